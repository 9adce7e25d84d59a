"""Low-rank Gaussian processes on a point set (a mesh's vertices): from kernels and from examples.

A model is ``u = mean + sum_k sqrt(lambda_k) c_k phi_k`` with ``c_k ~ N(0, 1)``, basis
functions ``phi_k`` over the point set and variances ``lambda_k`` (Scalismo's
``DiscreteLowRankGaussianProcess``). Ways to build one:

- :meth:`LowRankGP.nystrom`, :meth:`LowRankGP.pivoted_cholesky`: the leading eigenfunctions of
  a kernel without forming the ``N x N`` matrix (random inducing points, or greedy pivots until
  a rank or a trace tolerance).
- :meth:`LowRankGP.from_examples`: the mean and principal components of example meshes in
  correspondence (a statistical shape model, Scalismo's PCA model).
- :meth:`LowRankGP.augment`: a data model plus an analytic one (Scalismo's ``augmentModel``).
- :func:`~ffd_notebook.gp.load_model`: a Statismo/Scalismo HDF5 file.

Kernel models extend to any point through the inducing points (landmarks need not be
vertices); data models extend by the nearest vertex. The factor algebra lives in
:mod:`~ffd_notebook.gp.space` (the shared vectors) and :mod:`~ffd_notebook.gp.lowrank_ops`.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP
>>> pts = np.random.default_rng(0).random((2000, 3))
>>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(0.5)), pts, n_inducing=100, rank=30, rng=0)
>>> model.rank, bool(np.all(np.diff(model.eigenvalues) <= 0))
(30, True)
>>> model.sample(n=2, rng=1).shape
(2, 2000, 3)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from . import lowrank_build as build
from . import lowrank_ops as ops
from .linalg import as_generator
from .space import Space, joined_space

if TYPE_CHECKING:
    from .process import GaussianProcess

__all__ = ["LowRankGP"]

_LOG_2PI = float(np.log(2.0 * np.pi))


class LowRankGP:
    """A Gaussian process on a point set, held by a few basis functions.

    Coefficients index the basis functions (decreasing :attr:`eigenvalues` for every model the
    package builds; a model read from a file keeps the file's order and basis). Internally the
    displacement is ``mean + U F alpha`` with scalar vectors ``U`` over the points and a small
    factor ``F`` (see :mod:`~ffd_notebook.gp.space`); a posterior only changes ``F`` and the mean
    (cheap), and is put back in eigen form only when eigenvalues or coefficients are asked for.

    Made by the class methods (:meth:`nystrom`, :meth:`pivoted_cholesky`, :meth:`from_examples`,
    :meth:`from_basis_matrix`) or read from a file, rarely directly.

    Parameters
    ----------
    space : Space
        The scalar vectors ``U`` over the points, their Gram matrix, extension and base mean.
    factor : (3, q, rank) ndarray
        The factor ``F``: component ``d`` of the displacement is ``mean + U @ factor[d] @ alpha``.
    mean_shift : (q, 3) ndarray, optional
        ``M``: the mean is the space's base mean plus ``U M`` (zero by default).
    variances : (rank,) ndarray, optional
        The eigenvalues, when ``factor`` is already in eigen form (kept as given).

    Attributes
    ----------
    points : (N, 3) ndarray
        The point set (the reference shape's vertices).
    total_variance : float
        Trace of the covariance being approximated, over the points and components (the
        kernel's ``trace(K)``; for a data model its own total variance).
    metadata : dict
        What a Statismo file held besides the model (kept so it saves back unchanged).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
    >>> pts = np.random.default_rng(0).random((200, 3))
    >>> model = LowRankGP.pivoted_cholesky(GaussianProcess(GaussianKernel(0.5)), pts, rank=20)
    >>> model.rank, model.points.shape, model.total_variance, model.sample(3, rng=0).shape
    (20, (200, 3), 600.0, (3, 200, 3))
    """

    def __init__(
        self,
        space: Space,
        factor: NDArray[np.float64],
        mean_shift: NDArray[np.float64] | None = None,
        variances: NDArray[np.float64] | None = None,
    ) -> None:
        self._space = space
        self.points = space.points
        self.total_variance = space.total_variance
        self._factor = factor  # F (3, q, rank)
        q = space.vectors_t.shape[0]
        self._mean_shift = np.zeros((q, 3)) if mean_shift is None else mean_shift  # M (q, 3): mean = base + U M
        self._mean_values = space.base_values + (self._mean_shift.T @ space.vectors_t).T
        self._basis = None if variances is None else (factor, np.asarray(variances, dtype=np.float64))
        self.metadata: dict = {}

    # ------------------------------------------------------------------ making one (parts: lowrank_build)
    @classmethod
    def nystrom(
        cls,
        process: GaussianProcess,
        points: ArrayLike,
        n_inducing: int = 500,
        rank: int | None = None,
        variance: float | None = None,
        rng: int | np.random.Generator | None = None,
        progress: bool = False,
    ) -> LowRankGP:
        """Nystrom approximation from ``n_inducing`` points drawn at random from ``points``.

        Parameters
        ----------
        process : GaussianProcess
            The process to approximate (its kernel and mean).
        points : (N, 3) array_like
            The point set (a mesh's vertices).
        n_inducing : int
            Inducing points ``m``; the rank is at most ``3 m``.
        rank, variance : optional
            Keep ``rank`` basis functions, or the fewest that capture the fraction ``variance``
            of the total variance; by default all numerically non-zero ones.
        rng : int or Generator, optional
            Chooses the inducing points.
        progress : bool
            Show a progress bar while the kernel matrix is evaluated.

        Returns
        -------
        LowRankGP
            The model in eigen form on ``points``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((200, 3))
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(0.5)), pts, n_inducing=50, rank=10, rng=0)
        >>> model.rank
        10
        """
        return cls(*build.nystrom_parts(process, points, n_inducing, rank, variance, rng, progress))

    @classmethod
    def pivoted_cholesky(
        cls,
        process: GaussianProcess,
        points: ArrayLike,
        tolerance: float = 1e-2,
        max_rank: int = 1000,
        rank: int | None = None,
        variance: float | None = None,
        progress: bool = False,
        absolute_tolerance: float = 0.0,
    ) -> LowRankGP:
        """Pivoted Cholesky approximation, stopped at a rank or at a trace tolerance.

        Pivots are added greedily (largest remaining variance first) until the trace of the
        residual ``K - L L^T`` is at most ``tolerance * trace(K)`` (relative) or at most
        ``absolute_tolerance`` (world units squared, per scalar component), or ``max_rank``
        pivots are taken. Costs ``O(N r^2)`` for ``r`` pivots. ``rank`` and ``variance`` then
        truncate the eigenbasis as in :meth:`nystrom`. The variance kept is reported by
        :attr:`kept_variance` and :attr:`captured_variance`.

        Parameters
        ----------
        process : GaussianProcess
            The process to approximate.
        points : array_like
            ``(N, 3)`` points.
        tolerance : float
            Stop when the remaining trace is below this fraction of the total.
        max_rank : int
            The largest rank tried.
        rank : int, optional
            Keep this many components.
        variance : float, optional
            Keep the fewest components holding this fraction of the variance.
        progress : bool
            Show a progress bar.
        absolute_tolerance : float
            Stop when the remaining trace is below this value.

        Returns
        -------
        LowRankGP
            The model in eigen form on ``points``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP
        >>> pts = np.random.default_rng(0).random((500, 3))
        >>> gp = GaussianProcess(GaussianKernel(0.5))
        >>> model = LowRankGP.pivoted_cholesky(gp, pts, tolerance=0.0, absolute_tolerance=1.0)
        >>> bool(model.total_variance - model.kept_variance <= 3 * 1.0)     # three components
        True
        >>> LowRankGP.pivoted_cholesky(gp, pts, tolerance=0.0, max_rank=4).rank   # 4 pivots, x y z each
        12
        """
        return cls(
            *build.pivoted_cholesky_parts(
                process, points, tolerance, max_rank, rank, variance, progress, absolute_tolerance
            )
        )

    @classmethod
    def from_examples(
        cls,
        reference: ArrayLike | object,
        meshes: Sequence[ArrayLike | object],
        rank: int | None = None,
        variance: float | None = None,
    ) -> LowRankGP:
        """A statistical shape model: the mean and principal components of meshes in correspondence.

        Vertex ``i`` of every mesh corresponds to vertex ``i`` of the reference; the model is of
        the displacements ``mesh - reference``, with the sample covariance divided by ``n - 1``
        (Scalismo's ``PointDistributionModel.createUsingPCA``). Only the components with a
        non-zero variance are kept (at most ``n - 1``), or ``rank`` / a ``variance`` fraction.

        Parameters
        ----------
        reference : (N, 3) array_like or mesh
            The reference shape; a mesh's triangles become the model's :attr:`cells`.
        meshes : sequence of (N, 3) array_like or meshes
            At least two examples.
        rank : int, optional
            Keep this many principal components.
        variance : float, optional
            Keep the fewest components holding this fraction of the variance.

        Returns
        -------
        LowRankGP
            Mean and principal components (rank at most ``len(meshes) - 1``).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> ref = np.random.default_rng(0).random((100, 3))
        >>> shapes = [ref + [t, 0.0, 0.0] for t in (-1.0, 0.0, 1.0)]       # one mode: a shift in x
        >>> model = LowRankGP.from_examples(ref, shapes)
        >>> model.rank, model.eigenvalues.round(6).tolist()
        (1, [100.0])
        """
        return cls(*build.example_parts(reference, meshes, rank, variance))

    @classmethod
    def from_basis_matrix(
        cls,
        reference: ArrayLike,
        mean: ArrayLike,
        basis: ArrayLike,
        variances: ArrayLike,
        cells: ArrayLike | None = None,
    ) -> LowRankGP:
        """A model given as Statismo stores one: instance ``c`` is ``mean + basis @ (sqrt(variances) * c)``.

        ``mean`` is the mean displacement ``(N, 3)``, ``basis`` ``(3N, r)`` with rows
        ``3 i + a`` (point ``i``, component ``a``), ``variances`` ``(r,)``. The basis is kept as
        given (it need not be orthonormal), so coefficients mean what they meant in the file.

        Parameters
        ----------
        reference : array_like
            ``(N, 3)`` reference points.
        mean : array_like
            ``(N, 3)`` mean displacement.
        basis : array_like
            ``(3N, r)`` basis vectors in the columns.
        variances : array_like
            ``(r,)`` non-negative variances.
        cells : array_like, optional
            ``(M, 3)`` triangles of the reference mesh, kept for Statismo files.

        Returns
        -------
        LowRankGP
            The model, its basis kept as given.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> again = LowRankGP.from_basis_matrix(ref, model.mean(), model.basis_matrix(), model.eigenvalues)
        >>> bool(np.allclose(again.instance([1.0, 0, 0, 0]), model.instance([1.0, 0, 0, 0])))
        True
        """
        return cls(*build.matrix_parts(reference, mean, basis, variances, cells))

    # ------------------------------------------------------------------ basis
    def _basis_form(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The factor whose columns are the basis functions times ``sqrt(lambda)``, and ``lambda``."""
        if self._basis is None:
            self._basis = ops.eigen_form(self._factor, self._space.gram)
        return self._basis

    @property
    def eigenvalues(self) -> NDArray[np.float64]:
        """Variances of the basis functions (descending for the package's models), ``(rank,)``."""
        return self._basis_form()[1]

    @property
    def axes(self) -> NDArray[np.int64]:
        """The displacement component (0, 1, 2) each basis function moves most, ``(rank,)``."""
        factor, _ = self._basis_form()
        energy = np.einsum("aqk,qp,apk->ak", factor, self._space.gram, factor)
        return np.argmax(energy, axis=0)

    @property
    def rank(self) -> int:
        """Number of basis functions."""
        return self._factor.shape[2]

    @property
    def kept_variance(self) -> float:
        """The variance the model holds: the trace of its covariance over the points (sum of the
        :attr:`eigenvalues` when the basis is orthonormal, as for every model the package builds)."""
        return float(np.einsum("aqk,qp,apk->", self._factor, self._space.gram, self._factor))

    @property
    def captured_variance(self) -> float:
        """Fraction of :attr:`total_variance` the basis functions hold."""
        return self.kept_variance / self.total_variance if self.total_variance > 0 else 1.0

    @property
    def cells(self) -> NDArray[np.int64] | None:
        """The reference mesh's triangles ``(M, 3)``, if the model has them (from examples or a file)."""
        return self._space.cells

    # ------------------------------------------------------------------ fields
    def _fields(self, weights: NDArray[np.float64] | None, points: ArrayLike | None) -> NDArray[np.float64]:
        """``mean + U W`` for weights ``W (q, 3)`` at the point set or at other points."""
        space = self._space
        if points is None:
            return self._mean_values.copy() if weights is None else self._mean_values + (weights.T @ space.vectors_t).T
        pts = as_points(points)
        shift = self._mean_shift if weights is None else self._mean_shift + weights
        return space.base_mean(pts) + space.vectors_at(pts) @ shift

    def mean(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """Mean displacement ``(N, 3)`` at the point set (default) or at other points.

        Parameters
        ----------
        points : array_like, optional
            ``(M, 3)`` other points; the model's point set by default.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> model.mean().shape
        (30, 3)
        """
        return self._fields(None, points)

    def instance(self, coefficients: ArrayLike, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """The displacement field ``mean + sum_k sqrt(lambda_k) c_k phi_k``, ``(N, 3)``.

        Parameters
        ----------
        coefficients : array_like
            ``(rank,)`` coefficients.
        points : array_like, optional
            ``(M, 3)`` other points; the model's point set by default.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` displacements.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((300, 3))
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), pts, n_inducing=50, rank=10, rng=0)
        >>> c = np.zeros(10); c[0] = 1.0
        >>> u = model.instance(c)
        >>> bool(np.isclose(np.sum(u**2), model.eigenvalues[0]))       # sqrt(lambda_0) * unit vector
        True
        """
        coef = np.asarray(coefficients, dtype=np.float64)
        if coef.shape != (self.rank,):
            raise ValueError(f"expected {self.rank} coefficients, got shape {coef.shape}")
        return self._fields(ops.weights(self._basis_form()[0], coef), points)

    def sample(
        self, n: int = 1, rng: int | np.random.Generator | None = None, points: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Draw ``n`` random displacement fields, ``(n, N, 3)``, at the point set or other points.

        Parameters
        ----------
        n : int
            How many fields.
        rng : int or numpy.random.Generator, optional
            The random source.
        points : array_like, optional
            ``(M, 3)`` other points; the model's point set by default.

        Returns
        -------
        numpy.ndarray
            ``(n, N, 3)`` fields.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> model.sample(3, rng=0).shape
        (3, 30, 3)
        """
        coefs = as_generator(rng).standard_normal((n, self.rank))
        # any factor of the covariance gives the same distribution: no need for the eigen form
        return np.stack([self._fields(ops.weights(self._factor, c), points) for c in coefs])

    def _vectors_t(self, points: ArrayLike | None) -> NDArray[np.float64]:
        return self._space.vectors_t if points is None else self._space.vectors_at(as_points(points)).T

    def variance(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """Pointwise variance of each displacement component held by the model, ``(N, 3)``.

        Parameters
        ----------
        points : array_like, optional
            ``(M, 3)`` other points; the model's point set by default.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> bool(np.all(model.variance() >= 0))
        True
        """
        return ops.pointwise_variance(self._factor, self._vectors_t(points))

    def covariance(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """The model's ``(3M, 3M)`` covariance matrix at points (row ``3 i + a``), like a dense process's.

        Parameters
        ----------
        points : array_like, optional
            ``(M, 3)`` other points; the model's point set by default.

        Returns
        -------
        numpy.ndarray
            ``(3M, 3M)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((50, 3))
        >>> gp = GaussianProcess(GaussianKernel(1.0))
        >>> model = LowRankGP.nystrom(gp, pts, n_inducing=50, rng=0)      # full rank: exact
        >>> bool(np.allclose(model.covariance(pts[:5]), gp.covariance(pts[:5]), atol=1e-8))
        True
        """
        u_t = self._vectors_t(points)
        tu = [self._factor[a].T @ u_t for a in range(3)]
        out = np.empty((3 * u_t.shape[1], 3 * u_t.shape[1]))
        for a in range(3):
            for b in range(3):
                out[a::3, b::3] = tu[a].T @ tu[b]
        return out

    def basis_function(self, k: int) -> NDArray[np.float64]:
        """Basis function ``phi_k`` over the point set, ``(N, 3)`` (unit norm for the package's models).

        Parameters
        ----------
        k : int
            Which basis function (0 has the largest variance).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> model.basis_function(0).shape
        (30, 3)
        """
        factor, eig = self._basis_form()
        scale = 1.0 / np.sqrt(eig[k]) if eig[k] > 0 else 0.0
        return (np.einsum("aq,qn->na", factor[:, :, k], self._space.vectors_t)) * scale

    def basis_matrix(self) -> NDArray[np.float64]:
        """All basis functions as Statismo's ``pcaBasis``: ``(3N, rank)``, row ``3 i + a``.

        Returns
        -------
        numpy.ndarray
            ``(3N, rank)`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> model.basis_matrix().shape
        (90, 4)
        """
        factor, eig = self._basis_form()
        scale = np.divide(1.0, np.sqrt(eig), out=np.zeros_like(eig), where=eig > 0)
        per_axis = [(factor[a].T @ self._space.vectors_t).T * scale for a in range(3)]  # (N, r) each
        return np.stack(per_axis, axis=1).reshape(3 * len(self.points), self.rank)

    def coefficients(self, displacements: ArrayLike, noise: float = 0.0) -> NDArray[np.float64]:
        """Coefficients of the model instance closest to a displacement field on the point set.

        Minimises ``|instance(c) - d|^2 + noise * |c|^2`` (``noise > 0`` pulls towards the mean).

        Parameters
        ----------
        displacements : array_like
            ``(N, 3)`` displacements at the point set.
        noise : float
            Observation noise variance (0: the orthogonal projection).

        Returns
        -------
        numpy.ndarray
            ``(rank,)`` coefficients.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> c = np.array([1.0, -0.5, 0.0, 0.0])
        >>> (model.coefficients(model.instance(c)).round(6) + 0.0).tolist()
        [1.0, -0.5, 0.0, 0.0]
        """
        d = np.asarray(displacements, dtype=np.float64)
        if d.shape != self.points.shape:
            raise ValueError(f"displacements must have shape {self.points.shape}, got {d.shape}")
        factor, _ = self._basis_form()
        return ops.least_squares(factor, self._space, d - self._mean_values, noise)

    def project(self, displacements: ArrayLike, noise: float = 0.0) -> NDArray[np.float64]:
        """The model instance closest to a displacement field, ``(N, 3)``.

        Parameters
        ----------
        displacements : array_like
            ``(N, 3)`` displacements at the point set.
        noise : float
            Observation noise variance.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)``: the instance of :meth:`coefficients`.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> field = model.instance([0.5, 0.0, 0.0, 0.0])
        >>> bool(np.allclose(model.project(field), field))
        True
        """
        return self.instance(self.coefficients(displacements, noise))

    # ------------------------------------------------------------------ densities
    def logpdf(self, coefficients: ArrayLike) -> float:
        """Log density of coefficients: ``log N(c; 0, I)`` (Scalismo's ``logpdf``).

        Parameters
        ----------
        coefficients : array_like
            ``(rank,)`` coefficients.

        Returns
        -------
        float
            The log density.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), np.eye(3), n_inducing=3)
        >>> bool(np.isclose(model.logpdf(np.zeros(model.rank)), -model.rank / 2 * np.log(2 * np.pi)))
        True
        """
        coef = np.asarray(coefficients, dtype=np.float64)
        if coef.shape != (self.rank,):
            raise ValueError(f"expected {self.rank} coefficients, got shape {coef.shape}")
        return float(-0.5 * coef @ coef - 0.5 * self.rank * _LOG_2PI)

    def logpdf_of(self, displacements: ArrayLike) -> float:
        """Log density of a displacement field under the model, ``(N, 3)`` at the point set.

        The model is a Gaussian on the ``3N`` values concentrated on a ``rank``-dimensional
        affine subspace; this is its density there (pseudo-determinant, as
        ``scipy.stats.multivariate_normal(mean, cov, allow_singular=True)``), evaluated at the
        field's projection onto the subspace (the closest instance). Directions without variance
        are left out.

        Parameters
        ----------
        displacements : array_like
            ``(N, 3)`` displacements at the point set.

        Returns
        -------
        float
            The log density of its coefficients.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import LowRankGP
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.random((30, 3))
        >>> model = LowRankGP.from_examples(ref, [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)])
        >>> bool(model.logpdf_of(model.mean()) > model.logpdf_of(model.instance([3.0, 0.0, 0.0, 0.0])))
        True
        """
        d = np.asarray(displacements, dtype=np.float64)
        if d.shape != self.points.shape:
            raise ValueError(f"displacements must have shape {self.points.shape}, got {d.shape}")
        return ops.subspace_logpdf(self._factor, self._space, d - self._mean_values)

    # ------------------------------------------------------------------ conditioning
    def posterior(self, landmarks: ArrayLike, displacements: ArrayLike, noise: ArrayLike = 0.0) -> LowRankGP:
        """The model conditioned on displacements observed at landmarks (any points).

        With ``Q`` the covariance factor at the landmarks and ``A = Q Q^T + noise``, the
        coefficients' posterior is ``N(Q^T A^-1 r, I - Q^T A^-1 Q)`` (``r`` the observed minus
        the mean displacement; Scalismo's low-rank regression). ``noise`` is a variance, one per
        landmark ``(L,)`` or per landmark and component ``(L, 3)``, or one 3x3 covariance per
        landmark ``(L, 3, 3)`` (Scalismo's ``MultivariateNormalDistribution`` per point). Only
        ``3L x 3L`` and ``3L x rank`` systems are solved; the result has the same basis and rank.

        Parameters
        ----------
        landmarks : array_like
            ``(L, 3)`` points (any, not only the point set's).
        displacements : array_like
            ``(L, 3)`` observed displacements.
        noise : array_like
            A variance, variances per landmark, or ``(L, 3, 3)`` covariances.

        Returns
        -------
        LowRankGP
            The posterior model.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((500, 3))
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), pts, n_inducing=60, rng=0)
        >>> post = model.posterior(pts[:2], [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]], noise=1e-8)
        >>> post.mean(pts[:2]).round(4).tolist()
        [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]]
        >>> cov = np.broadcast_to(np.diag([1e-8, 1e-8, 1e-2]), (2, 3, 3))   # z barely observed
        >>> model.posterior(pts[:2], [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]], noise=cov).mean(pts[:1]).shape
        (1, 3)
        """
        lms = as_points(landmarks, "landmarks")
        obs = as_points(displacements, "displacements")
        if len(obs) != len(lms):
            raise ValueError(f"got {len(lms)} landmarks but {len(obs)} displacements")
        u_l = self._space.vectors_at(lms)
        residual = obs - self._space.base_mean(lms) - u_l @ self._mean_shift
        factor, step = ops.condition(self._factor, u_l, residual, noise)
        return LowRankGP(self._space, factor, self._mean_shift + step)

    def augment(self, other: LowRankGP) -> LowRankGP:
        """This model plus an independent one on the same points (Scalismo's ``augmentModel``).

        The sum of the two processes: means add, covariances add. Typically ``self`` is a data
        model and ``other`` an analytic bias model (``LowRankGP.pivoted_cholesky`` of a kernel
        on ``self.points``) that adds the flexibility the few examples lack. Exact: the result
        is put in eigen form over both bases together (rank up to the sum of the ranks).

        Parameters
        ----------
        other : LowRankGP
            A model on the same point set.

        Returns
        -------
        LowRankGP
            The sum of the two processes, in eigen form.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP
        >>> ref = np.random.default_rng(0).random((200, 3))
        >>> data = LowRankGP.from_examples(ref, [ref, ref + [0.1, 0, 0], ref - [0.1, 0, 0]])
        >>> bias = LowRankGP.pivoted_cholesky(GaussianProcess(GaussianKernel(0.5, 0.01)), ref, max_rank=10)
        >>> both = data.augment(bias)
        >>> both.rank, bool(np.allclose(both.variance(), data.variance() + bias.variance()))
        (31, True)
        """
        if not isinstance(other, LowRankGP):
            raise TypeError(f"can only augment with a LowRankGP, got {type(other).__name__}")
        space = joined_space(self._space, other._space)
        q1, r1 = self._factor.shape[1:]
        q2, r2 = other._factor.shape[1:]
        factor = np.zeros((3, q1 + q2, r1 + r2))
        factor[:, :q1, :r1], factor[:, q1:, r1:] = self._factor, other._factor
        shift = np.vstack([self._mean_shift, other._mean_shift])
        basis, eig = ops.eigen_form(factor, space.gram)
        return type(self)(space, basis, shift, variances=eig)

    def __repr__(self) -> str:
        return (
            f"LowRankGP({len(self.points)} points, rank={self.rank}, "
            f"captured variance={self.captured_variance:.4f}, kernel={self._space.kernel!r})"
        )
