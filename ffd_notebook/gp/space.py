"""The vector spaces low-rank models live in: scalar vectors over a point set and how to extend them.

A :class:`~ffd_notebook.gp.LowRankGP` writes each displacement component ``a`` as
``mean[:, a] + U F_a alpha``: ``U`` holds ``q`` scalar vectors over the ``N`` points (stored
transposed, ``vectors_t (q, N)``, because products with a few columns, ``W^T U^T``, run several
times faster that way in OpenBLAS) and ``F (3, q, r)`` is the model's small factor. A
:class:`Space` is the part shared by a model and its posteriors: ``U``, its Gram matrix, the
base mean and how the vectors extend to points that are not vertices.

Spaces come from a kernel's eigenvectors (:func:`kernel_space`), from example deformations
(:func:`example_space`), from a basis matrix read from a file (:func:`matrix_space`) and from
two spaces side by side (:func:`joined_space`).

``gram`` need only be *effective*: ``F_a^T gram F_a == F_a^T U U^T F_a`` for every factor the
space is used with. Kernel spaces keep each axis's factor inside one orthonormal block, so the
identity serves, as the per-axis blocks do for example spaces; posteriors multiply factors on
the right and keep that property.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from .approximation import ScalarBasis
from .kernels import Kernel

__all__ = ["Space", "example_space", "joined_space", "kernel_space", "matrix_space"]

Extension = Callable[[NDArray[np.float64]], NDArray[np.float64]]  # points (M, 3) -> vectors (M, q)


@dataclass(eq=False)
class Space:
    """Scalar vectors over a point set, their (effective) Gram matrix, extension and base mean."""

    points: NDArray[np.float64]
    vectors_t: NDArray[np.float64]  # (q, N)
    gram: NDArray[np.float64]  # (q, q), see the module docstring
    extend: Extension  # the vectors at any points, (M, q)
    base_mean: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    base_values: NDArray[np.float64]  # base_mean(points), (N, 3)
    total_variance: float
    kernel: Kernel | None = None
    cells: NDArray[np.int64] | None = None

    def vectors_at(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """The scalar vectors at points, ``(M, q)``."""
        return self.extend(points)


def nearest_vertex(space_points: NDArray[np.float64], values_t: NDArray[np.float64]) -> Callable:
    """Extension by the nearest vertex (Scalismo's ``NearestNeighborInterpolator``): ``(q, N)`` values."""
    holder: dict[str, cKDTree] = {}

    def extend(points: NDArray[np.float64]) -> NDArray[np.float64]:
        if "tree" not in holder:
            holder["tree"] = cKDTree(space_points)
        _, idx = holder["tree"].query(points)
        return values_t[:, idx].T

    return extend


def kernel_space(kernel, mean, points, bases: list[ScalarBasis], which, total) -> tuple[Space, dict]:
    """The space of the eigenvectors of ``bases`` that ``which`` uses, and where each sits in it."""
    vectors, parts, column_of, start = [], [], {}, 0
    for b, basis in enumerate(bases):
        used = np.unique(which[which[:, 0] == b, 1])
        u, ext = basis.vectors(used)
        vectors.append(u)
        parts.append((basis.kernel_index, basis.inducing, ext, slice(start, start + len(used))))
        column_of.update({(b, int(j)): start + i for i, j in enumerate(used)})
        start += len(used)
    u_t = np.vstack(vectors)

    def extend(pts: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty((len(pts), start))
        for index, inducing, ext, cols in parts:
            out[:, cols] = kernel.components(pts, inducing)[index] @ ext
        return out

    space = Space(points, u_t, np.eye(start), extend, mean, mean(points), total, kernel=kernel)
    return space, column_of


def _mean_extension(points, values):
    ext = nearest_vertex(points, values.T)
    return lambda pts: ext(pts).copy()


def example_space(points: NDArray[np.float64], displacements: NDArray[np.float64]) -> tuple[Space, NDArray]:
    """Space of ``n`` example displacement fields ``(n, N, 3)`` and the factor of their sample covariance.

    ``U`` holds the centred examples' components (rows ``a n + i``) and ``F_a`` is
    ``I / sqrt(n - 1)`` on block ``a``: ``U F F^T U^T`` is the sample covariance (divided by
    ``n - 1``, as Scalismo's PCA).
    """
    n = len(displacements)
    mean = displacements.mean(axis=0)
    centred = displacements - mean
    u_t = np.concatenate([centred[:, :, a] for a in range(3)])  # (3n, N)
    gram = np.zeros((3 * n, 3 * n))
    for a in range(3):
        block = slice(a * n, (a + 1) * n)
        gram[block, block] = u_t[block] @ u_t[block].T
    factor = np.zeros((3, 3 * n, n))
    for a in range(3):
        factor[a, a * n : (a + 1) * n] = np.eye(n) / np.sqrt(n - 1)
    total = float(np.trace(gram)) / (n - 1)
    space = Space(points, u_t, gram, nearest_vertex(points, u_t), _mean_extension(points, mean), mean, total)
    return space, factor


def matrix_space(
    points: NDArray[np.float64], mean: NDArray[np.float64], basis: NDArray[np.float64], variances: NDArray[np.float64]
) -> tuple[Space, NDArray]:
    """Space of a basis matrix ``(3N, r)`` (rows ``3 i + a``) with variances ``(r,)``, kept exactly as given.

    ``U`` holds each column's three components (rows ``a r + k``), ``F_a`` is
    ``diag(sqrt(variances))`` on block ``a``: instance ``c`` is ``mean + basis @ (sqrt(variances) * c)``
    whether or not the basis is orthonormal.
    """
    r = basis.shape[1]
    per_axis = basis.reshape(len(points), 3, r)
    u_t = np.concatenate([per_axis[:, a, :].T for a in range(3)])  # (3r, N)
    gram = np.zeros((3 * r, 3 * r))
    factor = np.zeros((3, 3 * r, r))
    for a in range(3):
        block = slice(a * r, (a + 1) * r)
        gram[block, block] = u_t[block] @ u_t[block].T
        factor[a, block] = np.diag(np.sqrt(variances))
    total = float(np.einsum("akq,qp,apk->", factor.transpose(0, 2, 1), gram, factor))
    space = Space(points, u_t, gram, nearest_vertex(points, u_t), _mean_extension(points, mean), mean, total)
    return space, factor


def joined_space(first: Space, second: Space) -> Space:
    """Both spaces' vectors side by side (the sum of two independent models on the same points)."""
    if first.points.shape != second.points.shape or not np.allclose(first.points, second.points):
        raise ValueError("the two models must be defined on the same points")
    u_t = np.vstack([first.vectors_t, second.vectors_t])
    cross = first.vectors_t @ second.vectors_t.T
    gram = np.block([[first.gram, cross], [cross.T, second.gram]])

    def extend(pts: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.hstack([first.extend(pts), second.extend(pts)])

    def mean(pts: NDArray[np.float64]) -> NDArray[np.float64]:
        return first.base_mean(pts) + second.base_mean(pts)

    values = first.base_values + second.base_values
    space = Space(first.points, u_t, gram, extend, mean, values, first.total_variance + second.total_variance)
    space.cells = first.cells if first.cells is not None else second.cells
    return space
