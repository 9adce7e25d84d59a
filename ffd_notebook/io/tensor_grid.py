"""Cubic B-spline sums on regular grids aligned with a lattice, one axis at a time.

Where sample points form a full grid whose axes run along the lattice's, the B-spline weight of
control point ``(a, b, c)`` at voxel ``(i, j, k)`` is ``Bx[i, a] By[j, b] Bz[k, c]``: evaluating
(or fitting) the lattice on the grid is three small matrix products along the axes, never the
``N x n`` matrix. Used by :func:`~ffd_notebook.io.sample_displacement_field` (writing a field of
an FFD) and :func:`~ffd_notebook.io.fit_lattice`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..ffd.basis import bspline, bspline_cells

__all__ = ["apply_along", "axis_weights"]


def axis_weights(u: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """``(len(u), n)`` cubic B-spline weights of lattice coordinates ``u`` along one axis ("zero" border).

    Examples
    --------
    >>> axis_weights(np.array([1.0, 2.5]), 4).round(4).tolist()
    [[0.1667, 0.6667, 0.1667, 0.0], [0.0, 0.0208, 0.4792, 0.4792]]
    """
    first, t = bspline_cells(u)
    w = bspline(t)
    out = np.zeros((len(u), n))
    for k in range(4):
        j = first + k
        ok = (j >= 0) & (j < n)
        out[np.flatnonzero(ok), j[ok]] = w[ok, k]
    return out


def apply_along(matrix: NDArray[np.float64], data: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    """``matrix`` applied along one of the first three axes of ``data`` (``(n0, n1, n2, ...)``).

    Examples
    --------
    >>> apply_along(np.array([[1.0, 1.0]]), np.ones((3, 2, 4, 3)), 1).shape
    (3, 1, 4, 3)
    """
    moved = np.moveaxis(data, axis, 0)
    out = (matrix @ moved.reshape(moved.shape[0], -1)).reshape((matrix.shape[0],) + moved.shape[1:])
    return np.moveaxis(out, 0, axis)
