"""How :class:`~ffd_notebook.gp.LowRankGP` models are made: from kernels, from examples, from basis matrices.

Functions that compute a model's parts (:class:`ModelParts`: the shared vectors, the factor, the
mean shift, the variances); :class:`~ffd_notebook.gp.LowRankGP`'s constructors (``nystrom``,
``from_examples``...) build the model from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from . import lowrank_ops as ops
from .approximation import choose_rank, nystrom_basis, pivoted_cholesky_basis, select
from .linalg import as_generator
from .process import GaussianProcess
from .space import Space, example_space, kernel_space, matrix_space

__all__ = ["ModelParts", "example_parts", "matrix_parts", "nystrom_parts", "pivoted_cholesky_parts"]


class ModelParts(NamedTuple):
    """What a :class:`~ffd_notebook.gp.LowRankGP` is made of: ``LowRankGP(*parts)``."""

    space: Space
    factor: NDArray[np.float64]
    mean_shift: NDArray[np.float64] | None
    variances: NDArray[np.float64] | None


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


def nystrom_parts(
    process: GaussianProcess,
    points: ArrayLike,
    n_inducing: int = 500,
    rank: int | None = None,
    variance: float | None = None,
    rng: int | np.random.Generator | None = None,
    progress: bool = False,
) -> ModelParts:
    """The parts of :meth:`LowRankGP.nystrom <ffd_notebook.gp.LowRankGP.nystrom>`."""
    pts = as_points(points)
    kernel = _kernel_of(process)
    gen = as_generator(rng)
    inducing = pts[np.sort(gen.choice(len(pts), size=min(n_inducing, len(pts)), replace=False))]
    bases = [nystrom_basis(kernel, c, pts, inducing, progress) for c in range(kernel.n_components)]
    return _kernel_parts(process, pts, bases, rank, variance)


def pivoted_cholesky_parts(
    process: GaussianProcess,
    points: ArrayLike,
    tolerance: float = 1e-2,
    max_rank: int = 1000,
    rank: int | None = None,
    variance: float | None = None,
    progress: bool = False,
    absolute_tolerance: float = 0.0,
) -> ModelParts:
    """The parts of :meth:`LowRankGP.pivoted_cholesky <ffd_notebook.gp.LowRankGP.pivoted_cholesky>`."""
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
    return _kernel_parts(process, pts, bases, rank, variance)


def example_parts(
    reference: ArrayLike | object,
    meshes: Sequence[ArrayLike | object],
    rank: int | None = None,
    variance: float | None = None,
) -> ModelParts:
    """The parts of :meth:`LowRankGP.from_examples <ffd_notebook.gp.LowRankGP.from_examples>`."""
    ref = _points_of(reference, "reference")
    examples = [_points_of(m, f"meshes[{i}]") for i, m in enumerate(meshes)]
    if len(examples) < 2:
        raise ValueError(f"a model from examples needs at least 2 meshes, got {len(examples)}")
    for i, ex in enumerate(examples):
        if ex.shape != ref.shape:
            raise ValueError(f"meshes[{i}] has {len(ex)} points, the reference {len(ref)}: not in correspondence")
    space, factor = example_space(ref, np.stack(examples) - ref)
    space.cells = _triangles_of(reference)
    return _truncated_parts(space, factor, None, rank, variance)


def matrix_parts(
    reference: ArrayLike,
    mean: ArrayLike,
    basis: ArrayLike,
    variances: ArrayLike,
    cells: ArrayLike | None = None,
) -> ModelParts:
    """The parts of :meth:`LowRankGP.from_basis_matrix <ffd_notebook.gp.LowRankGP.from_basis_matrix>`."""
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
    return ModelParts(space, factor, None, variances)


def _kernel_parts(process, pts, bases, rank, variance) -> ModelParts:
    kernel = process.kernel
    total = float(np.broadcast_to(kernel.diagonal(pts), (3, len(pts))).sum())
    eig, axes, which = select(bases, kernel.n_components)
    r = choose_rank(eig, total, rank, variance)
    eig, axes, which = eig[:r], axes[:r], which[:r]
    space, column_of = kernel_space(kernel, process.mean, pts, bases, which, total)
    factor = np.zeros((3, len(space.vectors_t), r))
    rows = [column_of[(int(b), int(j))] for b, j in which]
    factor[axes, rows, np.arange(r)] = np.sqrt(eig)
    return ModelParts(space, factor, None, eig)


def _truncated_parts(space, factor, mean_shift, rank, variance) -> ModelParts:
    """The model in eigen form without its zero-variance directions (and truncated if asked)."""
    basis, eig = ops.eigen_form(factor, space.gram)
    keep = int(np.count_nonzero(eig > ops.RELATIVE_FLOOR * max(eig[0], 0.0))) if len(eig) else 0
    keep = min(keep, choose_rank(eig[:keep], space.total_variance, rank, variance)) if keep else 0
    return ModelParts(space, np.ascontiguousarray(basis[:, :, :keep]), mean_shift, eig[:keep])
