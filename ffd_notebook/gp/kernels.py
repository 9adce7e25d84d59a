"""Matrix-valued kernels for Gaussian processes over displacement fields ``u: R^3 -> R^3``.

Every kernel here is *diagonal*: ``k(x, y) = diag(k_x(x, y), k_y(x, y), k_z(x, y))``, each
output component an independent scalar process. Most are *isotropic in the output*
(``k(x, y) = k_s(x, y) I3``, one scalar kernel for all three components). A kernel reports
which through :attr:`Kernel.n_components` (1 or 3) and :meth:`Kernel.components`, so the
processes solve one scalar ``N x N`` problem for all three components (or three of them)
instead of a ``3N x 3N`` one. :meth:`Kernel.matrix` gives the full block matrix when needed.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel
>>> k = GaussianKernel(sigma=2.0, scale=3.0)
>>> x = np.zeros((1, 3)); y = np.array([[2.0, 0.0, 0.0]])
>>> k(x, y)[0, 0].round(4)            # 9 * exp(-4 / 4) * I3
array([[3.3109, 0.    , 0.    ],
       [0.    , 3.3109, 0.    ],
       [0.    , 0.    , 3.3109]])
>>> (2 * k + GaussianKernel(sigma=10.0)).matrix(x, y).shape
(3, 3)
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.distance import cdist

from .._util.points import as_points
from ..ffd.deform import FFD
from ..ffd.fit import control_weights
from ..ffd.lattice import Lattice
from .combine import Kernel, per_axis
from .linalg import as_generator

__all__ = [
    "BSplineKernel",
    "ExponentialKernel",
    "GaussianKernel",
    "Kernel",
    "bspline_weights",
]


class _StationaryKernel(Kernel):
    """``scale^2 * profile(distance)`` with per-axis length scales and per-component scales."""

    def __init__(self, sigma: ArrayLike = 1.0, scale: ArrayLike = 1.0) -> None:
        self.sigma = per_axis(sigma, "sigma")
        self.scale = per_axis(scale, "scale")
        self.n_components = 1 if self.scale.ndim == 0 else 3

    @abstractmethod
    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Unscaled kernel values ``(N, M)``, equal to 1 at zero distance."""

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        base = self._profile(as_points(x, "x"), as_points(y, "y"))
        return base[None] * np.reshape(self.scale**2, (-1, 1, 1))

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        n = len(as_points(x))
        return np.ones((self.n_components, n)) * np.reshape(self.scale**2, (-1, 1))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(sigma={self.sigma.tolist()}, scale={self.scale.tolist()})"


class GaussianKernel(_StationaryKernel):
    """``k(x, y) = scale^2 exp(-|x - y|^2 / sigma^2) I3`` (Scalismo's convention).

    Note the missing factor 2: scikit-learn's ``RBF(length_scale=l)`` is this kernel with
    ``sigma = sqrt(2) l``.

    Parameters
    ----------
    sigma : float or (3,) array_like
        Kernel width (world units); a 3-vector gives one width per input axis (anisotropic:
        ``exp(-sum_i (x_i - y_i)^2 / sigma_i^2)``).
    scale : float or (3,) array_like
        Standard deviation of each displacement component; a 3-vector gives one per output
        component (a diagonal, non-isotropic kernel).

    Examples
    --------
    >>> import numpy as np
    >>> k = GaussianKernel(sigma=[1.0, 2.0, 4.0], scale=[1.0, 1.0, 0.5])
    >>> k.n_components, k.components(np.zeros((1, 3)), [[0.0, 2.0, 0.0]]).ravel().round(4).tolist()
    (3, [0.3679, 0.3679, 0.092])
    """

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        d2 = cdist(x / self.sigma, y / self.sigma, "sqeuclidean")
        return np.exp(-d2, out=d2)


class ExponentialKernel(_StationaryKernel):
    """``k(x, y) = scale^2 exp(-|x - y| / sigma^2) I3`` (the convention of the blog post).

    Rougher than :class:`GaussianKernel`: samples are continuous but not differentiable.
    A 3-vector ``sigma`` divides each axis by ``sigma_i^2`` before taking the distance.

    Parameters
    ----------
    sigma : float or array_like
        Length scale (a number, or one per axis).
    scale : float or array_like
        Standard deviation of the displacement (a number, or one per component).

    Examples
    --------
    >>> import numpy as np
    >>> k = ExponentialKernel(sigma=2.0)
    >>> float(k.components(np.zeros((1, 3)), [[4.0, 0.0, 0.0]])[0, 0, 0].round(6))   # exp(-4/4)
    0.367879
    """

    def _profile(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        s2 = self.sigma**2
        d = cdist(x / s2, y / s2, "euclidean")
        return np.exp(-d, out=d)


def bspline_weights(lattice: Lattice, points: ArrayLike) -> sp.csr_matrix:
    """Cubic B-spline weights of every lattice control point at each point, sparse ``(N, n_ctrl)``.

    Row ``i`` holds the 64 tensor-product weights ``B_l(t_u) B_m(t_v) B_n(t_w)`` of the
    4x4x4 control points around point ``i``: the FFD engine's
    (:func:`~ffd_notebook.ffd.fit.control_weights`) with the lattice's
    :attr:`~ffd_notebook.Lattice.border` rule, so control points beyond a "zero" lattice are
    dropped and beyond a "clamp" one their weight goes to the border one. Columns are flat
    control-point indices in C order, like ``lattice.offsets.reshape(-1, 3)``, so
    ``W @ offsets.reshape(-1, 3)`` is ``FFD(lattice).displacement(points)``.

    Parameters
    ----------
    lattice : Lattice
        The lattice.
    points : array_like
        ``(N, 3)`` points.

    Returns
    -------
    scipy.sparse.csr_matrix
        ``(N, nx * ny * nz)``: row ``n`` holds the weights of the control points that reach point ``n``.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
    >>> W = bspline_weights(lat, [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])
    >>> W.shape, W.sum(axis=1).round(12).ravel().tolist()
    ((2, 64), [1.0, 1.0])
    """
    index, weight = control_weights(FFD(lattice), points)  # the engine's weights and border rule
    n = len(index)
    # 64 entries a row; the clamp rule repeats a border control point in a row (its weights add up)
    w = sp.csr_matrix((weight.ravel(), index.ravel(), np.arange(0, index.size + 1, index.shape[1])),
                      shape=(n, lattice.n_points))  # fmt: skip
    w.sum_duplicates()
    w.eliminate_zeros()
    return w


class BSplineKernel(Kernel):
    """``k(x, y) = scale^2 sum_c w_c(x) w_c(y) I3`` with the FFD engine's B-spline weights ``w_c``.

    The covariance of the displacement ``FFD(lattice).displacement(x)`` when every control
    point's offset is drawn i.i.d. from ``N(0, scale^2)`` per component: a sample of this
    process *is* a random FFD on ``lattice`` (the lattice's own offsets are ignored).

    Parameters
    ----------
    lattice : Lattice
        The lattice whose control points' offsets are random.
    scale : float or array_like
        Standard deviation of each offset component (a number or a 3-vector).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> k = BSplineKernel(Lattice((5, 5, 5), 1.0, origin=(-2, -2, -2)), scale=2.0)
    >>> float(k.components([[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]])[0, 0, 0].round(6))  # 4 * (1/36 + 16/36 + 1/36)^3
    0.5
    """

    def __init__(self, lattice: Lattice, scale: ArrayLike = 1.0) -> None:
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        FFD(lattice)  # the engine's checks (at least 4 control points per axis with the "zero" border)
        self.lattice = lattice.copy()
        self.scale = per_axis(scale, "scale")
        self.n_components = 1 if self.scale.ndim == 0 else 3

    def weights(self, points: ArrayLike) -> sp.csr_matrix:
        """Sparse ``(N, n_ctrl)`` control-point weights (see :func:`bspline_weights`).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        scipy.sparse.csr_matrix
            ``(N, nx * ny * nz)`` weights.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice
        >>> k = BSplineKernel(Lattice((5, 5, 5), 1.0, origin=(-2, -2, -2)), scale=2.0)
        >>> w = k.weights(np.zeros((1, 3)))
        >>> w.shape, round(float(w.sum()), 6)
        ((1, 125), 1.0)
        """
        return bspline_weights(self.lattice, points)

    def random_offsets(self, n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """``n`` sets of i.i.d. ``N(0, scale^2)`` control-point offsets, ``(n, nx, ny, nz, 3)``.

        Parameters
        ----------
        n : int
            How many sets.
        rng : numpy.random.Generator
            The random source.

        Returns
        -------
        numpy.ndarray
            ``(n, nx, ny, nz, 3)`` offsets.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice
        >>> k = BSplineKernel(Lattice((5, 5, 5), 1.0, origin=(-2, -2, -2)), scale=2.0)
        >>> k.random_offsets(2, np.random.default_rng(0)).shape
        (2, 5, 5, 5, 3)
        """
        return rng.standard_normal((n, *self.lattice.shape, 3)) * self.scale

    def random_lattice(self, rng: int | np.random.Generator | None = None) -> Lattice:
        """A copy of the lattice with random offsets: the FFD of one sample of this process.

        Uses the same draws as ``sample(points, 1, rng)``, so for the same seed
        ``FFD(kernel.random_lattice(seed)).displacement(points)`` equals
        ``GaussianProcess(kernel).sample(points, 1, seed)[0]``.

        Parameters
        ----------
        rng : int or numpy.random.Generator, optional
            The random source.

        Returns
        -------
        Lattice
            A copy of the kernel's lattice with random offsets.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice
        >>> k = BSplineKernel(Lattice((5, 5, 5), 1.0, origin=(-2, -2, -2)), scale=2.0)
        >>> from ffd_notebook import FFD
        >>> from ffd_notebook.gp import GaussianProcess
        >>> pts = np.zeros((1, 3))
        >>> a = FFD(k.random_lattice(3)).displacement(pts)
        >>> bool(np.allclose(a, GaussianProcess(k).sample(pts, 1, 3)[0]))
        True
        """
        lattice = self.lattice.copy()
        lattice.offsets[...] = self.random_offsets(1, as_generator(rng))[0]
        return lattice

    def sample(self, points: NDArray[np.float64], n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """Random FFDs evaluated at the points (weight space: exact, no factorisation, any ``N``).

        Parameters
        ----------
        points : numpy.ndarray
            ``(N, 3)`` points.
        n : int
            How many fields.
        rng : numpy.random.Generator
            The random source.

        Returns
        -------
        numpy.ndarray
            ``(n, N, 3)`` fields.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice
        >>> k = BSplineKernel(Lattice((5, 5, 5), 1.0, origin=(-2, -2, -2)), scale=2.0)
        >>> k.sample(np.zeros((4, 3)), 2, np.random.default_rng(0)).shape
        (2, 4, 3)
        """
        offsets = self.random_offsets(n, rng).reshape(n, -1, 3)
        weights = self.weights(points)
        return np.stack([weights @ o for o in offsets])

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        base = (self.weights(x) @ self.weights(y).T).toarray()
        return base[None] * np.reshape(self.scale**2, (-1, 1, 1))

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        w = self.weights(x)
        return np.asarray(w.multiply(w).sum(axis=1)).T * np.reshape(self.scale**2, (-1, 1))

    def __repr__(self) -> str:
        return f"BSplineKernel({self.lattice!r}, scale={self.scale.tolist()})"
