"""Kernel algebra: sums, products, scalings, one kernel per axis and left-right mirror symmetry.

Every combination of positive semi-definite diagonal kernels here is again one: a sum is the
covariance of the sum of independent processes, a product (Schur product, component by
component) that of their product, and the mirrored kernel that of ``(u(x) + M u(M x)) / sqrt 2``.
Operators build them: ``k1 + k2``, ``k1 * k2``, ``2.0 * k``, ``[1, 1, 0.1] * k``.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import ExponentialKernel, GaussianKernel, MirroredKernel
>>> k = MirroredKernel(GaussianKernel(2.0) * ExponentialKernel(3.0) + 0.5 * GaussianKernel(10.0), axis=0)
>>> x = np.random.default_rng(0).normal(size=(6, 3))
>>> K = k.matrix(x)
>>> bool(np.linalg.eigvalsh(K).min() >= -1e-9 * np.abs(K).max())
True
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .linalg import cholesky

__all__ = [
    "DiagonalKernel",
    "Kernel",
    "MirroredKernel",
    "ProductKernel",
    "ScaledKernel",
    "SumKernel",
    "per_axis",
]

_CHUNK = 1024  # points per block when a diagonal needs cross terms


def per_axis(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A positive scalar or 3-vector as a float array (shape () or (3,))."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape not in ((), (3,)) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be a positive number or three positive numbers, got {value!r}")
    return arr


class Kernel(ABC):
    """A diagonal matrix-valued positive-definite kernel on R^3.

    Subclasses implement :meth:`components` (and :meth:`diagonal` when it has a cheap form).
    Kernels add (``k1 + k2``), multiply (``k1 * k2``) and scale by a positive number or a
    per-component 3-vector (``2.0 * k``, ``[1, 1, 0.1] * k``); see below.

    A few kernels are not diagonal (a posterior after noise with 3x3 covariances): they set
    :attr:`is_diagonal` to False, override :meth:`__call__` and have no :meth:`components`.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel
    >>> k = GaussianKernel(sigma=1.0, scale=2.0)
    >>> x = np.zeros((1, 3)); y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    >>> (k + k).matrix(x).tolist() == (2.0 * k).matrix(x).tolist()
    True
    """

    #: 1 if the same scalar kernel drives all three output components (``k_s I3``), else 3.
    n_components: int = 1
    #: False for kernels whose 3x3 blocks have off-diagonal entries.
    is_diagonal: bool = True

    @abstractmethod
    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Scalar kernel matrices of the output components, shape ``(n_components, N, M)``.

        Parameters
        ----------
        x : array_like
            ``(N, 3)`` points.
        y : array_like
            ``(M, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(n_components, N, M)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = GaussianKernel(sigma=1.0, scale=2.0)
        >>> x = np.zeros((1, 3)); y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        >>> k.components(x, y).round(4).tolist()
        [[[4.0, 1.4715]]]
        """

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        """``k(x_i, x_i)`` per component, shape ``(n_components, N)`` (the prior variance).

        Parameters
        ----------
        x : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(n_components, N)`` float64 variances.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = GaussianKernel(sigma=1.0, scale=2.0)
        >>> x = np.zeros((1, 3)); y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        >>> k.diagonal(y).tolist()
        [[4.0, 4.0]]
        """
        x = as_points(x)
        return np.stack([np.diagonal(c) for c in self.components(x, x)])

    def component_matrices(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """The three scalar kernel matrices, shape ``(3, N, M)`` (repeated if isotropic).

        Parameters
        ----------
        x : array_like
            ``(N, 3)`` points.
        y : array_like
            ``(M, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(3, N, M)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = GaussianKernel(sigma=1.0, scale=2.0)
        >>> x = np.zeros((1, 3)); y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        >>> k.component_matrices(x, y).shape
        (3, 1, 2)
        """
        comps = self.components(x, y)
        return np.broadcast_to(comps, (3, *comps.shape[1:]))

    def sample(self, points: NDArray[np.float64], n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """``n`` zero-mean fields drawn jointly at the points, ``(n, N, 3)``.

        Cholesky factor of each distinct component's ``N x N`` matrix times standard normals
        (``rng.standard_normal((N, n, 3))``).

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
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = GaussianKernel(sigma=1.0, scale=2.0)
        >>> x = np.zeros((1, 3)); y = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
        >>> k.sample(y, 3, np.random.default_rng(0)).shape
        (3, 2, 3)
        """
        comps = self.components(points, points)
        z = rng.standard_normal((len(points), n, 3))
        out = np.empty((n, len(points), 3))
        if len(comps) == 1:
            flat = cholesky(comps[0]) @ z.reshape(len(points), 3 * n)
            out[...] = flat.reshape(len(points), n, 3).transpose(1, 0, 2)
        else:
            for a in range(3):
                out[:, :, a] = (cholesky(comps[a]) @ z[:, :, a]).T
        return out

    def __call__(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """The 3x3 blocks ``k(x_i, y_j)``, shape ``(N, M, 3, 3)``."""
        comps = self.component_matrices(x, y)
        out = np.zeros((*comps.shape[1:], 3, 3))
        for a in range(3):
            out[:, :, a, a] = comps[a]
        return out

    def matrix(self, x: ArrayLike, y: ArrayLike | None = None) -> NDArray[np.float64]:
        """The ``(3N, 3M)`` kernel matrix; row ``3 i + a`` is point ``i``, component ``a``.

        Parameters
        ----------
        x : array_like
            ``(N, 3)`` points.
        y : array_like, optional
            ``(M, 3)`` points; ``x`` by default.

        Returns
        -------
        numpy.ndarray
            ``(3N, 3M)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = GaussianKernel(sigma=1.0)
        >>> x = np.random.default_rng(0).random((4, 3))
        >>> K = k.matrix(x)
        >>> K.shape, bool(np.allclose(K, K.T)), bool(np.linalg.eigvalsh(K).min() > -1e-12)
        ((12, 12), True, True)
        """
        y = x if y is None else y
        blocks = self(x, y)
        n, m = blocks.shape[:2]
        return blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * m)

    def __add__(self, other: Kernel) -> Kernel:
        if not isinstance(other, Kernel):
            return NotImplemented
        return SumKernel(self, other)

    def __mul__(self, other: ArrayLike | Kernel) -> Kernel:
        return ProductKernel(self, other) if isinstance(other, Kernel) else ScaledKernel(self, other)

    __rmul__ = __mul__


def _diagonal_only(*kernels: Kernel) -> None:
    for k in kernels:
        if not isinstance(k, Kernel):
            raise TypeError(f"expected a Kernel, got {type(k).__name__}")
        if not k.is_diagonal:
            raise TypeError(f"{type(k).__name__} is not a diagonal kernel; only diagonal kernels combine")


class SumKernel(Kernel):
    """``k1 + k2``: the displacement is the sum of two independent processes.

    Parameters
    ----------
    first : Kernel
        The first kernel.
    second : Kernel
        The second kernel.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import ExponentialKernel, GaussianKernel
    >>> k = GaussianKernel(1.0) + ExponentialKernel(1.0)
    >>> float(k.components(np.zeros((1, 3)), np.zeros((1, 3)))[0, 0, 0])
    2.0
    """

    def __init__(self, first: Kernel, second: Kernel) -> None:
        _diagonal_only(first, second)
        self.terms = (first, second)
        self.n_components = max(first.n_components, second.n_components)

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return self.terms[0].components(x, y) + self.terms[1].components(x, y)

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        return self.terms[0].diagonal(x) + self.terms[1].diagonal(x)

    def __repr__(self) -> str:
        return f"({self.terms[0]!r} + {self.terms[1]!r})"


class ProductKernel(Kernel):
    """``k1 * k2`` component by component: the covariance of the product of independent processes.

    Parameters
    ----------
    first : Kernel
        The first kernel.
    second : Kernel
        The second kernel.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import ExponentialKernel, GaussianKernel
    >>> k = GaussianKernel(1.0, scale=2.0) * ExponentialKernel(1.0)
    >>> float(k.components(np.zeros((1, 3)), [[1.0, 0, 0]])[0, 0, 0].round(6))   # 4 e^-1 * e^-1
    0.541341
    """

    def __init__(self, first: Kernel, second: Kernel) -> None:
        _diagonal_only(first, second)
        self.terms = (first, second)
        self.n_components = max(first.n_components, second.n_components)

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return self.terms[0].components(x, y) * self.terms[1].components(x, y)

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        return self.terms[0].diagonal(x) * self.terms[1].diagonal(x)

    def __repr__(self) -> str:
        return f"({self.terms[0]!r} * {self.terms[1]!r})"


class ScaledKernel(Kernel):
    """``factor * k``: the covariance multiplied by a positive number or a per-component 3-vector.

    Parameters
    ----------
    kernel : Kernel
        The kernel scaled.
    factor : float or array_like
        A positive number, or a positive 3-vector (one factor per output component).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel
    >>> k = [1.0, 1.0, 0.25] * GaussianKernel(1.0)
    >>> k.diagonal(np.zeros((1, 3))).ravel().tolist()
    [1.0, 1.0, 0.25]
    """

    def __init__(self, kernel: Kernel, factor: ArrayLike) -> None:
        _diagonal_only(kernel)
        self.kernel = kernel
        self.factor = per_axis(factor, "factor")
        self.n_components = 3 if self.factor.ndim == 1 else kernel.n_components

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return self.kernel.components(x, y) * np.reshape(self.factor, (-1, 1, 1))

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        return self.kernel.diagonal(x) * np.reshape(self.factor, (-1, 1))

    def __repr__(self) -> str:
        return f"{self.factor.tolist()} * {self.kernel!r}"


class DiagonalKernel(Kernel):
    """A kernel per axis: ``diag(k_x, k_y, k_z)``, each output component its own process.

    Parameters
    ----------
    kx, ky, kz : Kernel
        Output-isotropic kernels of the x, y and z components.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import ExponentialKernel, GaussianKernel
    >>> k = DiagonalKernel(GaussianKernel(1.0), GaussianKernel(1.0), ExponentialKernel(1.0))
    >>> k.n_components, k(np.zeros((1, 3)), [[1.0, 0, 0]])[0, 0].diagonal().round(4).tolist()
    (3, [0.3679, 0.3679, 0.3679])
    """

    def __init__(self, kx: Kernel, ky: Kernel, kz: Kernel) -> None:
        for k in (kx, ky, kz):
            if not isinstance(k, Kernel) or not k.is_diagonal or k.n_components != 1:
                raise ValueError("DiagonalKernel needs three output-isotropic kernels (n_components == 1)")
        self.kernels = (kx, ky, kz)
        self.n_components = 3

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        return np.concatenate([k.components(x, y) for k in self.kernels])

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        return np.concatenate([k.diagonal(x) for k in self.kernels])

    def __repr__(self) -> str:
        return f"DiagonalKernel{self.kernels!r}"


class MirroredKernel(Kernel):
    """Left-right symmetric deformations: ``k_sym(x, y) = k(x, y) + k(x, M y) M``.

    ``M`` reflects across the plane ``x[axis] = center`` (for a face, the mid-sagittal plane).
    Written in the form that stays positive semi-definite for any diagonal ``k``,
    ``(k(x, y) + k(Mx, My) + (k(x, My) + k(Mx, y)) M) / 2``, the covariance of
    ``(u(x) + M u(M x)) / sqrt 2``; for a mirror-invariant ``k`` (stationary kernels:
    ``k(Mx, My) = k(x, y)``) it is the formula above. Its samples satisfy ``u(M x) = M u(x)``.

    Parameters
    ----------
    kernel : Kernel
        A diagonal kernel.
    axis : int
        The coordinate the mirror flips (0, 1 or 2).
    center : float
        Position of the mirror plane along ``axis``.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
    >>> gp = GaussianProcess(MirroredKernel(GaussianKernel(1.0), axis=0))
    >>> u = gp.sample([[0.5, 0.2, 0.0], [-0.5, 0.2, 0.0]], rng=0)[0]
    >>> bool(np.allclose(u[1], u[0] * [-1, 1, 1], atol=1e-12))
    True
    """

    def __init__(self, kernel: Kernel, axis: int = 0, center: float = 0.0) -> None:
        _diagonal_only(kernel)
        if axis not in (0, 1, 2):
            raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
        self.kernel, self.axis, self.center = kernel, int(axis), float(center)
        self.signs = np.ones(3)
        self.signs[self.axis] = -1.0
        self.n_components = 3

    def mirror(self, points: ArrayLike) -> NDArray[np.float64]:
        """The points reflected across the mirror plane, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` reflected points.

        Examples
        --------
        >>> from ffd_notebook.gp import GaussianKernel
        >>> MirroredKernel(GaussianKernel(1.0), axis=0, center=1.0).mirror([[3.0, 2.0, 0.0]]).tolist()
        [[-1.0, 2.0, 0.0]]
        """
        out = as_points(points).copy()
        out[:, self.axis] = 2.0 * self.center - out[:, self.axis]
        return out

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        x, y = as_points(x, "x"), as_points(y, "y")
        mx, my = self.mirror(x), self.mirror(y)
        k = self.kernel.component_matrices
        cross = (k(x, my) + k(mx, y)) * self.signs[:, None, None]
        return 0.5 * (k(x, y) + k(mx, my) + cross)

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        x = as_points(x)
        out = np.empty((3, len(x)))
        for s in range(0, len(x), _CHUNK):  # k(x_i, M x_i) has no cheap form: diagonal of small blocks
            block = self.components(x[s : s + _CHUNK], x[s : s + _CHUNK])
            out[:, s : s + _CHUNK] = np.diagonal(block, axis1=1, axis2=2)
        return out

    def sample(self, points: NDArray[np.float64], n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """``(u(x) + M u(M x)) / sqrt 2`` from one joint draw of ``u``: exactly symmetric, not up to jitter.

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
            ``(n, N, 3)`` left-right symmetric fields.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel
        >>> k = MirroredKernel(GaussianKernel(1.0), axis=0)
        >>> u = k.sample(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]), 1, np.random.default_rng(0))[0]
        >>> bool(np.allclose(u[0], u[1] * [-1, 1, 1]))   # the mirror image's displacement, x flipped
        True
        """
        both = np.vstack([points, self.mirror(points)])
        # points that are mirror images of each other must share one draw of u: merge them up to rounding
        extent = float(np.ptp(both, axis=0).max()) or 1.0
        keys = np.round(both / (1e-10 * extent))
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        u = self.kernel.sample(both[first], n, rng)[:, inverse.reshape(-1)]
        return (u[:, : len(points)] + u[:, len(points) :] * self.signs) / np.sqrt(2.0)

    def __repr__(self) -> str:
        return f"MirroredKernel({self.kernel!r}, axis={self.axis}, center={self.center})"
