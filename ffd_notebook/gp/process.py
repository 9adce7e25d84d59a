"""Gaussian processes over displacement fields, exact (dense) inference.

A :class:`GaussianProcess` is a mean function and a :class:`~ffd_notebook.gp.kernels.Kernel`.
It evaluates anywhere: :meth:`GaussianProcess.mean`, :meth:`GaussianProcess.variance` and
:meth:`GaussianProcess.sample` take any ``(N, 3)`` points. :meth:`GaussianProcess.posterior`
conditions on observed displacements at landmarks and returns another process (its kernel a
:class:`PosteriorKernel`), solved by Cholesky factorisation, never an explicit inverse.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
>>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=0.5))
>>> landmarks = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
>>> observed = np.array([[0.0, 0.0, 0.2], [0.0, 0.0, -0.2]])
>>> post = gp.posterior(landmarks, observed, noise=1e-8)
>>> post.mean(landmarks).round(6).tolist()
[[0.0, 0.0, 0.2], [0.0, 0.0, -0.2]]
>>> post.sample(np.zeros((5, 3)), n=2, rng=0).shape
(2, 5, 3)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .kernels import Kernel
from .linalg import as_generator
from .noise import noise_variances
from .posterior import PosteriorKernel, PosteriorMean

__all__ = ["GaussianProcess", "PosteriorKernel", "noise_variances"]

MeanFunction = Callable[[NDArray[np.float64]], NDArray[np.float64]]


class GaussianProcess:
    """A Gaussian process over displacement fields ``u: R^3 -> R^3``.

    Parameters
    ----------
    kernel : Kernel
        The covariance ``k(x, y)`` (3x3 blocks).
    mean : callable, optional
        ``mean(points) -> (N, 3)`` displacements; zero if omitted.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel
    >>> gp = GaussianProcess(GaussianKernel(sigma=2.0, scale=1.0))
    >>> pts = np.random.default_rng(0).random((100, 3))
    >>> u = gp.sample(pts, n=1, rng=42)[0]          # one smooth random displacement field
    >>> u.shape, gp.variance(pts[:1]).tolist()
    ((100, 3), [[1.0, 1.0, 1.0]])
    """

    def __init__(self, kernel: Kernel, mean: MeanFunction | None = None) -> None:
        if not isinstance(kernel, Kernel):
            raise TypeError(f"kernel must be a Kernel, got {type(kernel).__name__}")
        self.kernel = kernel
        self._mean = mean

    def mean(self, points: ArrayLike) -> NDArray[np.float64]:
        """Mean displacement at each point, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
        >>> pts = np.random.default_rng(0).random((4, 3))
        >>> gp.mean(pts).tolist()[0]
        [0.0, 0.0, 0.0]
        """
        pts = as_points(points)
        if self._mean is None:
            return np.zeros_like(pts)
        out = np.array(self._mean(pts), dtype=np.float64)
        if out.shape != pts.shape:
            raise ValueError(f"the mean function returned shape {out.shape}, expected {pts.shape}")
        return out

    def variance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pointwise marginal variance of each displacement component, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64 variances.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
        >>> pts = np.random.default_rng(0).random((4, 3))
        >>> gp.variance(pts).round(6).tolist()[0]
        [4.0, 4.0, 4.0]
        """
        diag = self.kernel.diagonal(as_points(points))
        return np.broadcast_to(diag, (3, diag.shape[1])).T.copy()

    def covariance(self, x: ArrayLike, y: ArrayLike | None = None) -> NDArray[np.float64]:
        """The ``(3N, 3M)`` covariance matrix between the displacements at ``x`` and ``y``.

        Parameters
        ----------
        x : array_like
            ``(N, 3)`` points.
        y : array_like, optional
            ``(M, 3)`` points; ``x`` again by default.

        Returns
        -------
        numpy.ndarray
            ``(3N, 3M)``; row ``3 i + a`` is point ``i``, component ``a``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
        >>> pts = np.random.default_rng(0).random((4, 3))
        >>> gp.covariance(pts).shape
        (12, 12)
        """
        return self.kernel.matrix(x, y)

    def sample(
        self, points: ArrayLike, n: int = 1, rng: int | np.random.Generator | None = None
    ) -> NDArray[np.float64]:
        """Draw ``n`` displacement fields jointly at the points, ``(n, N, 3)``.

        Exact, see :meth:`Kernel.sample <ffd_notebook.gp.kernels.Kernel.sample>`: most kernels
        factorise the ``N x N`` kernel matrix, so keep ``N`` to a few thousand and use a
        :class:`~ffd_notebook.gp.LowRankGP` for whole meshes; the B-spline kernel samples a
        random FFD directly at any size.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.
        n : int
            How many fields.
        rng : int or numpy.random.Generator, optional
            The random source (a seed or a generator).

        Returns
        -------
        numpy.ndarray
            ``(n, N, 3)`` displacement fields.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
        >>> pts = np.random.default_rng(0).random((4, 3))
        >>> gp.sample(pts, n=2, rng=0).shape
        (2, 4, 3)
        """
        pts = as_points(points)
        out = self.kernel.sample(pts, n, as_generator(rng))
        return out + self.mean(pts)[None]

    def posterior(self, landmarks: ArrayLike, displacements: ArrayLike, noise: ArrayLike = 0.0) -> GaussianProcess:
        """The process conditioned on displacements observed at landmarks.

        Parameters
        ----------
        landmarks : (L, 3) array_like
            Points where the displacement was observed.
        displacements : (L, 3) array_like
            The observed displacements.
        noise : float or (L,) or (L, 3) or (L, 3, 3) array_like
            Observation noise: one variance, one per landmark, one per landmark and component,
            or one 3x3 covariance per landmark (0: interpolate exactly, up to the jitter needed
            to factorise a singular kernel matrix). Covariances with off-diagonal entries give a
            non-diagonal posterior kernel.

        Returns
        -------
        GaussianProcess
            Mean ``m(x) + k(x, X) (K + noise)^-1 (y - m(X))`` and kernel :class:`PosteriorKernel`.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
        >>> pts = np.random.default_rng(0).random((4, 3))
        >>> post = gp.posterior(pts[:1], [[1.0, 0.0, 0.0]])
        >>> post.mean(pts[:1]).round(6).tolist()
        [[1.0, 0.0, 0.0]]
        """
        lms = as_points(landmarks, "landmarks")
        obs = as_points(displacements, "displacements")
        if len(obs) != len(lms):
            raise ValueError(f"got {len(lms)} landmarks but {len(obs)} displacements")
        kernel = PosteriorKernel(self.kernel, lms, noise)
        return GaussianProcess(kernel, PosteriorMean(self.mean, kernel, obs - self.mean(lms)))

    def log_marginal_likelihood(self, points: ArrayLike, displacements: ArrayLike, noise: ArrayLike = 0.0) -> float:
        """``log p(displacements | points)``: the density of the observations under the process plus noise.

        ``log N(y - m(X); 0, K(X, X) + noise)`` over the ``3L`` observed values; ``noise`` as in
        :meth:`posterior`. With a kernel isotropic in the output and scalar or per-landmark
        noise this is scikit-learn's ``GaussianProcessRegressor.log_marginal_likelihood`` with the
        three components as independent target columns.

        Parameters
        ----------
        points : array_like
            ``(L, 3)`` observed points.
        displacements : array_like
            ``(L, 3)`` observed displacements.
        noise : array_like
            Observation noise: a variance, variances per landmark (``(L,)`` or ``(L, 3)``) or ``(L, 3, 3)``
            covariances.

        Returns
        -------
        float
            The log density.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> gp = GaussianProcess(GaussianKernel(sigma=1.0))
        >>> x = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])      # far apart: independent
        >>> y = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        >>> lml = gp.log_marginal_likelihood(x, y, noise=1.0)
        >>> bool(np.isclose(lml, -0.5 * 1.0 / 2.0 - 3 * np.log(2.0) - 3 * np.log(2 * np.pi)))
        True
        """
        lms = as_points(points, "points")
        obs = as_points(displacements, "displacements")
        if len(obs) != len(lms):
            raise ValueError(f"got {len(lms)} points but {len(obs)} displacements")
        return PosteriorKernel(self.kernel, lms, noise).log_likelihood(obs - self.mean(lms))

    def __repr__(self) -> str:
        return f"GaussianProcess({self.kernel!r}, mean={'zero' if self._mean is None else 'given'})"
