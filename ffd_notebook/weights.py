"""The weight machinery shared by :class:`~ffd_notebook.deform.FFD`, the :class:`~ffd_notebook.deformer.Deformer`
and :mod:`~ffd_notebook.fit`: points grouped by B-spline cell, padded offsets by border rule, Bernstein values
over the lattice box, and the chain rule from lattice coordinates to world coordinates.

It lives apart from :mod:`~ffd_notebook.deform` so that the deformer and the fit can use it without importing
the FFD class (which itself builds deformers): the import graph stays a tree.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .basis import bernstein, bernstein_derivative, bspline, bspline_cells, bspline_derivative
from .lattice import Lattice

__all__ = [
    "CellGroups",
    "bernstein_values",
    "bspline_lattice_jacobian",
    "det3",
    "jacobian_to_world",
    "outer_uv",
    "pad_offsets",
]


def bernstein_values(
    shape: tuple[int, int, int], uvw: NDArray[np.float64], derivative: bool = False
) -> list[NDArray[np.float64]]:
    """Per-axis Bernstein values (or d/du) over the lattice box: parameter ``u / (n - 1)``.

    Examples
    --------
    >>> import numpy as np
    >>> [v.sum(axis=1).round(12).tolist() for v in bernstein_values((3, 4, 5), np.array([[1.0, 1.5, 2.0]]))]
    [[1.0], [1.0], [1.0]]
    """
    out = []
    for axis, n in enumerate(shape):
        s = uvw[:, axis] / (n - 1)
        if derivative:
            out.append(bernstein_derivative(s, n - 1) / (n - 1))
        else:
            out.append(bernstein(s, n - 1))
    return out


def jacobian_to_world(lattice: Lattice, affine: NDArray[np.float64], d_uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """Whole Jacobian from ``d T_local / d(u, v, w)``: ``A + d_uvw @ (R^T / spacing)``.

    Examples
    --------
    >>> import numpy as np
    >>> jacobian_to_world(Lattice((4, 4, 4), 2.0), np.eye(4), np.zeros((1, 3, 3))).tolist() == [np.eye(3).tolist()]
    True
    """
    # one (3N x 3) @ (3 x 3) product: a batched matmul of N tiny matrices is 3x slower
    local = (d_uvw.reshape(-1, 3) @ (lattice.rotation.T / lattice.spacing[:, None])).reshape(-1, 3, 3)
    return affine[:3, :3] + local


def pad_offsets(offsets: NDArray[np.float64], dtype: Any = np.float64, border: str = "zero") -> NDArray[Any]:
    """Offsets with three layers around, zeros or copies of the border (the border rule).

    Supports reaching outside the lattice read these layers: copying the border layer there is
    the same as clamping the support's indices, the clamp rule.
    """
    mode = "constant" if border == "zero" else "edge"
    return np.pad(offsets, ((3, 3), (3, 3), (3, 3), (0, 0)), mode=mode).astype(dtype, copy=False)


def outer_uv(bu: NDArray[Any], bv: NDArray[Any]) -> NDArray[Any]:
    """Row-wise outer product of the u and v weights, ``(N, 16)`` with index ``4 * l + m``."""
    return (bu[:, :, None] * bv[:, None, :]).reshape(len(bu), 16)


def det3(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Determinants of ``(N, 3, 3)`` matrices by the explicit formula (far faster than batched LU)."""
    return (
        m[:, 0, 0] * (m[:, 1, 1] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 1])
        - m[:, 0, 1] * (m[:, 1, 0] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 0])
        + m[:, 0, 2] * (m[:, 1, 0] * m[:, 2, 1] - m[:, 1, 1] * m[:, 2, 0])
    )


def bspline_lattice_jacobian(cells: CellGroups, offsets: NDArray[np.float64], t: NDArray[np.float64]):
    """``d T_local / d(u, v, w)`` in sorted order, ``(N, 3 components, 3 lattice axes)``."""
    padded = cells.pad(offsets)
    vals = [bspline(t[:, a]) for a in range(3)]
    ders = [bspline_derivative(t[:, a]) for a in range(3)]
    d_uvw = np.empty((len(t), 3, 3))
    for axis in range(3):
        bu, bv, bw = (ders[a] if a == axis else vals[a] for a in range(3))
        d_uvw[:, :, axis] = cells.sum(padded, outer_uv(bu, bv), cells.masked(bw))
    return d_uvw


class CellGroups:
    """Points grouped by the lattice cell whose 4x4x4 support moves them.

    Points are sorted by cell so that each cell's points form one contiguous run; a sum over a
    run is then one small matrix product with that cell's 64 offsets. With the "zero" border,
    points whose support lies wholly outside the lattice are put in a run with zero weights;
    with "clamp" their support is moved to the nearest one reaching the lattice, whose indices
    all clamp to the same border control points.
    """

    def __init__(self, uvw: NDArray[np.float64], shape: tuple[int, int, int], border: str = "zero") -> None:
        n = len(uvw)
        first, t = bspline_cells(uvw)
        dims = np.array(shape)
        self.border = border
        if border == "clamp":
            first = np.clip(first, -3, dims - 1)
        self.inside = np.all((first >= -3) & (first <= dims - 1), axis=1)
        first = np.where(self.inside[:, None], first, 0)
        grid = tuple(dims + 3)
        cell = np.ravel_multi_index(tuple((first + 3).T), grid)
        order = np.argsort(cell, kind="stable")
        cells, starts = np.unique(cell[order], return_index=True)
        self.order = order.astype(np.int32 if n < 2**31 else np.int64)
        self.inside = self.inside[order]
        self.t = t[order]
        self.runs = np.column_stack([starts, np.r_[starts[1:], n]])
        self.run_first = np.column_stack(np.unravel_index(cells, grid)) - 3

    def pad(self, offsets: NDArray[np.float64], dtype: Any = np.float64) -> NDArray[Any]:
        """Offsets padded by this grouping's border rule (see :func:`pad_offsets`)."""
        return pad_offsets(offsets, dtype, self.border)

    def masked(self, bw: NDArray[Any]) -> NDArray[Any]:
        """Zero the weights of points outside every support (applied to one factor only)."""
        bw[~self.inside] = 0.0
        return bw

    def sum(self, padded: NDArray[Any], buv: NDArray[Any], bw: NDArray[Any]) -> NDArray[Any]:
        """``sum_lmn buv[4l+m] bw[n] offsets[first + (l, m, n)]`` per point, in sorted order."""
        out = np.empty((len(buv), 3), dtype=np.result_type(buv, padded))
        for (s, e), (i, j, k) in zip(self.runs, self.run_first + 3, strict=True):
            # (l m) x (n d): contract the 16 (l, m) weights by BLAS, then the 4 n weights
            x = (buv[s:e] @ padded[i : i + 4, j : j + 4, k : k + 4].reshape(16, 12)).reshape(-1, 4, 3)
            np.einsum("pnd,pn->pd", x, bw[s:e], out=out[s:e])
        return out

    def unsort(self, values: NDArray[Any]) -> NDArray[Any]:
        """Values given in sorted order, returned in the points' original order."""
        out = np.empty_like(values)
        out[self.order] = values
        return out
