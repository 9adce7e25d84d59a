"""How :class:`~ffd_notebook.gp.LowRankGP` models are made: from kernels, from examples, from basis matrices.

The constructors live in a base class of their own so that ``lowrank.py`` holds what a model
does and this module how one is made (each under the project's module size).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from . import lowrank_ops as ops
from .approximation import choose_rank, nystrom_basis, pivoted_cholesky_basis, select
from .linalg import as_generator
from .process import GaussianProcess
from .space import example_space, kernel_space, matrix_space

if TYPE_CHECKING:
    from .lowrank import LowRankGP

__all__ = ["LowRankBuilders"]


def _kernel_of(process: GaussianProcess):
    if not process.kernel.is_diagonal:
        raise TypeError("a low-rank model needs a diagonal kernel; condition the low-rank model instead")
    return process.kernel


def _points_of(shape: ArrayLike | object, name: str) -> NDArray[np.float64]:
    """Points of an ``(N, 3)`` array or of anything with ``.points`` (a PyVista mesh)."""
    return as_points(getattr(shape, "points", shape), name)


def _triangles_of(mesh: object) -> NDArray[np.int64] | None:
    """``(M, 3)`` triangles of a mesh with PyVista-style ``faces`` ([3, i, j, k, ...]), if all are triangles."""
    faces = np.asarray(getattr(mesh, "faces", np.empty(0)), dtype=np.int64)
    if faces.size == 0 or faces.size % 4 or not np.all(faces.reshape(-1, 4)[:, 0] == 3):
        return None
    return faces.reshape(-1, 4)[:, 1:].copy()


class LowRankBuilders:
    """The constructors of :class:`~ffd_notebook.gp.LowRankGP` (which derives from this class)."""

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
        """
        pts = as_points(points)
        kernel = _kernel_of(process)
        gen = as_generator(rng)
        inducing = pts[np.sort(gen.choice(len(pts), size=min(n_inducing, len(pts)), replace=False))]
        bases = [nystrom_basis(kernel, c, pts, inducing, progress) for c in range(kernel.n_components)]
        return cls._from_bases(process, pts, bases, rank, variance)

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
        pts = as_points(points)
        if not 0 <= tolerance < 1:
            raise ValueError(f"tolerance must be in [0, 1), got {tolerance}")
        if not absolute_tolerance >= 0:
            raise ValueError(f"absolute_tolerance must be non-negative, got {absolute_tolerance}")
        kernel = _kernel_of(process)
        bases = [
            pivoted_cholesky_basis(kernel, c, pts, tolerance, max_rank, progress, absolute_tolerance)
            for c in range(kernel.n_components)
        ]
        return cls._from_bases(process, pts, bases, rank, variance)

    @classmethod
    def _from_bases(cls, process, pts, bases, rank, variance) -> LowRankGP:
        kernel = process.kernel
        total = float(np.broadcast_to(kernel.diagonal(pts), (3, len(pts))).sum())
        eig, axes, which = select(bases, kernel.n_components)
        r = choose_rank(eig, total, rank, variance)
        eig, axes, which = eig[:r], axes[:r], which[:r]
        space, column_of = kernel_space(kernel, process.mean, pts, bases, which, total)
        factor = np.zeros((3, len(space.vectors_t), r))
        rows = [column_of[(int(b), int(j))] for b, j in which]
        factor[axes, rows, np.arange(r)] = np.sqrt(eig)
        return cls(space, factor, variances=eig)

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
        ref = _points_of(reference, "reference")
        examples = [_points_of(m, f"meshes[{i}]") for i, m in enumerate(meshes)]
        if len(examples) < 2:
            raise ValueError(f"a model from examples needs at least 2 meshes, got {len(examples)}")
        for i, ex in enumerate(examples):
            if ex.shape != ref.shape:
                raise ValueError(f"meshes[{i}] has {len(ex)} points, the reference {len(ref)}: not in correspondence")
        space, factor = example_space(ref, np.stack(examples) - ref)
        space.cells = _triangles_of(reference)
        return cls._truncated(space, factor, None, rank, variance)

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
        """
        ref = as_points(reference, "reference")
        mean = np.asarray(mean, dtype=np.float64).reshape(ref.shape)
        basis = np.asarray(basis, dtype=np.float64)
        variances = np.asarray(variances, dtype=np.float64)
        if basis.ndim != 2 or basis.shape[0] != 3 * len(ref) or variances.shape != (basis.shape[1],):
            raise ValueError(f"basis must be (3N, r) = ({3 * len(ref)}, r) and variances (r,)")
        if np.any(variances < 0):
            raise ValueError("variances must be non-negative")
        space, factor = matrix_space(ref, mean, basis, variances)
        space.cells = None if cells is None else np.asarray(cells, dtype=np.int64)
        return cls(space, factor, variances=variances)

    @classmethod
    def _truncated(cls, space, factor, mean_shift, rank, variance) -> LowRankGP:
        """The model in eigen form without its zero-variance directions (and truncated if asked)."""
        basis, eig = ops.eigen_form(factor, space.gram)
        keep = int(np.count_nonzero(eig > ops.RELATIVE_FLOOR * max(eig[0], 0.0))) if len(eig) else 0
        keep = min(keep, choose_rank(eig[:keep], space.total_variance, rank, variance)) if keep else 0
        return cls(space, np.ascontiguousarray(basis[:, :, :keep]), mean_shift, variances=eig[:keep])
