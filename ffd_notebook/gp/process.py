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
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from .kernels import Kernel, as_points
from .linalg import as_generator, cholesky

__all__ = ["GaussianProcess", "PosteriorKernel", "noise_variances"]

MeanFunction = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def noise_variances(noise: ArrayLike, n_landmarks: int) -> NDArray[np.float64]:
    """Observation noise variances as an ``(L, 3)`` array.

    ``noise`` is one variance for all, one per landmark ``(L,)``, or one per landmark and
    component ``(L, 3)``.
    """
    arr = np.asarray(noise, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == n_landmarks:
        arr = arr[:, None]
    try:
        out = np.broadcast_to(arr, (n_landmarks, 3)).copy()
    except ValueError:
        raise ValueError(f"noise must be a variance, (L,) or (L, 3) variances for L={n_landmarks}") from None
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise ValueError("noise variances must be finite and non-negative")
    return out


@dataclass(frozen=True)
class _Group:
    """Output components that share one kernel component and one noise column (one factorisation)."""

    outputs: tuple[int, ...]  # displacement components 0..2 solved together
    kernel_index: int  # which of the prior kernel's components
    factor: NDArray[np.float64]  # lower Cholesky factor of K(X, X) + noise


def _factor_groups(kernel: Kernel, landmarks: NDArray[np.float64], noise: NDArray[np.float64]) -> list[_Group]:
    comps = kernel.components(landmarks, landmarks)
    shared = kernel.n_components == 1 and np.all(noise == noise[:, :1])
    if shared:
        return [_Group((0, 1, 2), 0, cholesky(comps[0] + np.diag(noise[:, 0])))]
    return [
        _Group((a,), a if kernel.n_components == 3 else 0, cholesky(comps[a % len(comps)] + np.diag(noise[:, a])))
        for a in range(3)
    ]


class PosteriorKernel(Kernel):
    """``k(x, y) - k(x, X) (K(X, X) + noise)^-1 k(X, y)``: the covariance after observing at ``X``.

    Built by :meth:`GaussianProcess.posterior`; it is a kernel like any other (a posterior can
    be conditioned again).
    """

    def __init__(self, prior: Kernel, landmarks: ArrayLike, noise: ArrayLike = 0.0) -> None:
        self.prior = prior
        self.landmarks = as_points(landmarks, "landmarks")
        self.noise = noise_variances(noise, len(self.landmarks))
        self.groups = _factor_groups(prior, self.landmarks, self.noise)
        self.n_components = len(self.groups)

    def _whitened(self, x: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """``L_g^-1 K(X, x)`` per group, each ``(L, N)``."""
        kx = self.prior.components(self.landmarks, x)
        return [sla.solve_triangular(g.factor, kx[g.kernel_index], lower=True, check_finite=False) for g in self.groups]

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        x, y = as_points(x, "x"), as_points(y, "y")
        prior = self.prior.components(x, y)
        vx = self._whitened(x)
        vy = vx if y is x else self._whitened(y)
        return np.stack([prior[g.kernel_index] - a.T @ b for g, a, b in zip(self.groups, vx, vy, strict=True)])

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        x = as_points(x)
        prior = self.prior.diagonal(x)
        out = [
            prior[g.kernel_index] - np.einsum("ln,ln->n", v, v)
            for g, v in zip(self.groups, self._whitened(x), strict=True)
        ]
        return np.maximum(np.stack(out), 0.0)

    def __repr__(self) -> str:
        return f"PosteriorKernel({self.prior!r}, {len(self.landmarks)} landmarks)"


class _PosteriorMean:
    """``m(x) + k(x, X) alpha`` with ``alpha = (K + noise)^-1 (y - m(X))`` per group."""

    def __init__(self, process: GaussianProcess, kernel: PosteriorKernel, residual: NDArray[np.float64]) -> None:
        self.prior_mean = process.mean
        self.kernel = kernel
        self.alpha = [
            sla.cho_solve((g.factor, True), residual[:, g.outputs], check_finite=False) for g in kernel.groups
        ]

    def __call__(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        out = self.prior_mean(points)
        kx = self.kernel.prior.components(points, self.kernel.landmarks)
        for g, alpha in zip(self.kernel.groups, self.alpha, strict=True):
            out[:, g.outputs] += kx[g.kernel_index] @ alpha
        return out


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
        """Mean displacement at each point, ``(N, 3)``."""
        pts = as_points(points)
        if self._mean is None:
            return np.zeros_like(pts)
        out = np.array(self._mean(pts), dtype=np.float64)
        if out.shape != pts.shape:
            raise ValueError(f"the mean function returned shape {out.shape}, expected {pts.shape}")
        return out

    def variance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Pointwise marginal variance of each displacement component, ``(N, 3)``."""
        diag = self.kernel.diagonal(as_points(points))
        return np.broadcast_to(diag, (3, diag.shape[1])).T.copy()

    def covariance(self, x: ArrayLike, y: ArrayLike | None = None) -> NDArray[np.float64]:
        """The ``(3N, 3M)`` covariance matrix between the displacements at ``x`` and ``y``."""
        return self.kernel.matrix(x, y)

    def sample(
        self, points: ArrayLike, n: int = 1, rng: int | np.random.Generator | None = None
    ) -> NDArray[np.float64]:
        """Draw ``n`` displacement fields jointly at the points, ``(n, N, 3)``.

        Exact, see :meth:`Kernel.sample <ffd_notebook.gp.kernels.Kernel.sample>`: most kernels
        factorise the ``N x N`` kernel matrix, so keep ``N`` to a few thousand and use a
        :class:`~ffd_notebook.gp.LowRankGP` for whole meshes; the B-spline kernel samples a
        random FFD directly at any size.
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
        noise : float or (L,) or (L, 3) array_like
            Observation noise variance (0: interpolate exactly, up to the jitter needed to
            factorise a singular kernel matrix).

        Returns
        -------
        GaussianProcess
            Mean ``m(x) + k(x, X) (K + noise)^-1 (y - m(X))`` and kernel :class:`PosteriorKernel`.
        """
        lms = as_points(landmarks, "landmarks")
        obs = as_points(displacements, "displacements")
        if len(obs) != len(lms):
            raise ValueError(f"got {len(lms)} landmarks but {len(obs)} displacements")
        kernel = PosteriorKernel(self.kernel, lms, noise)
        return GaussianProcess(kernel, _PosteriorMean(self, kernel, obs - self.mean(lms)))

    def __repr__(self) -> str:
        return f"GaussianProcess({self.kernel!r}, mean={'zero' if self._mean is None else 'given'})"
