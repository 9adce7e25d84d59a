"""One-shot evaluation of ``T_local``: deform a point set once, with no cache kept.

:class:`~ffd_notebook.Deformer` pays for a cache (grouping of the points by cell, weights) that
repeated updates amortise; ``FFD.deform`` on a fresh point set should not. Everything here runs
along the points (arrays ``(rows, N)``): NumPy is several times faster along a long contiguous
axis than broadcasting over a short last one.

- Bernstein: the per-point weights are a tensor product of three per-axis basis matrices, so the
  sum over all ``nx * ny * nz`` control points is done as successive contractions: a row-wise
  outer product of the x and y weights, ``(nx*ny, block)``, times the offsets as an
  ``(nz*3, nx*ny)`` matrix (one BLAS product, the binomial factors folded into it), then the z
  weights. The ``(N, nx*ny*nz)`` weight matrix is never formed, and points go in blocks whose
  intermediates stay in cache, in buffers reused from block to block.
- B-spline: points are grouped by the cell whose 4x4x4 support moves them with a radix sort of
  16-bit cell numbers (NumPy's stable sort is a radix sort for small integer types); each cell's
  points get one ``(12, 16) @ (16, m)`` product (x and y contracted), and the z contraction is
  one pass over all points, in chunks of sorted points whose buffers stay in cache. The border
  rule is :mod:`~ffd_notebook.ffd.support`'s: offsets padded by :func:`~ffd_notebook.ffd.support.pad_offsets`,
  support starts clipped by :func:`~ffd_notebook.ffd.support.clip_starts`.

Both keep float64 throughout.

Examples
--------
>>> import numpy as np
>>> offsets = np.zeros((4, 4, 4, 3)); offsets[..., 2] = 1.0
>>> uvw = np.array([[1.5, 1.5, 1.5], [9.0, 9.0, 9.0]])
>>> displacement("bspline", offsets, uvw.T).T.round(12).tolist()   # lattice coordinates in rows
[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
>>> displacement("bspline", offsets, uvw.T, border="clamp").T.round(12).tolist()
[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
"""

from __future__ import annotations

from math import comb
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .interpolation import INTERPOLATION_MATRICES
from .support import clip_starts, pad_offsets

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .lattice import Lattice

__all__ = ["bernstein_displacement", "bspline_displacement", "displacement", "lattice_rows"]

_BLOCK_VALUES = 2**17  # Bernstein x-y weights per block, (nx*ny, block): 1 MB, about one core's L2 cache
_CHUNK = 8192  # points per B-spline chunk (sorted order; a multiple of _RUN): its intermediates fill ~2.5 MB
# OpenBLAS threads a product above 4 * 65536 multiply-adds. On the loaded 2-core machine a second
# BLAS thread waiting for a busy core made these products 10-50x slower (the Bernstein 11^3 one-shot
# 0.3-1.4 s instead of 28 ms), so they are cut below that size and run on the calling thread; that
# costs ~12% at 11^3 with one thread, and gives up a speed-up only two idle cores would have given.
SERIAL_MADDS = 4 * 65536
_RUN = 1024  # B-spline points per (12, 16) @ (16, m) product at most (12 * 16 * 1024 multiply-adds)
_MIN_COLUMNS = 32  # Bernstein products are cut only if each piece keeps this many points (<= 13^3)
_WIDTH = 4  # control points per axis in a cubic B-spline support (the 12 x 16 blocks below)


def lattice_rows(lattice: Lattice, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lattice coordinates of ``(N, 3)`` points as rows ``(3, N)``: ``Lattice.to_lattice(points).T``.

    One ``(3, 3) @ (3, N)`` product and a shift along the rows: ``to_lattice``'s
    ``((p - origin) @ rotation_inverse.T) / spacing`` broadcasts over the short last axis, several times
    slower. The two differ by rounding only (about ``1e-16 * |p| / spacing``).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> lat = Lattice((3, 3, 3), 2.0, origin=(1, 1, 1))
    >>> lattice_rows(lat, np.array([[3.0, 2.0, 1.0]])).tolist()
    [[1.0], [0.5], [0.0]]
    """
    to_rows = lattice.rotation_inverse / lattice.spacing[:, None]
    rows = to_rows @ points.T
    rows -= (to_rows @ lattice.origin)[:, None]
    return rows


def displacement(
    basis: str | tuple[str, ...], offsets: NDArray[np.float64], rows: NDArray[np.float64], border: str = "zero"
) -> NDArray[np.float64]:
    """``T_local`` as rows ``(3, N)`` at lattice coordinates ``rows`` ``(3, N)`` for ``offsets`` ``(nx, ny, nz, 3)``.

    ``basis``: ``"bernstein"``, ``"bspline"`` or one of Blender's interpolations per axis (a tuple).
    """
    if basis == "bernstein":
        return bernstein_displacement(offsets, rows)
    if basis == "bspline":
        return bspline_displacement(offsets, rows, border)
    return bspline_displacement(offsets, rows, border, matrices=[INTERPOLATION_MATRICES[k] for k in basis])


def _bernstein_rows(s: NDArray[np.float64], degrees: tuple[int, ...], up: NDArray[np.float64]) -> list:
    """Per axis ``a``, ``s[a]**i * (1 - s[a])**(degrees[a] - i)`` for ``i = 0..degrees[a]``, ``(degree + 1, m)``.

    ``s`` is ``(3, m)``; the powers of all three axes are made together (one pass per power, on
    ``3 m`` values), in ``up`` ``(max degree + 1, 3, m)``. The binomial factors are left out (the
    caller folds them into the offsets).
    """
    n = max(degrees)
    down = np.empty_like(up)
    up[0] = 1.0
    down[0] = 1.0
    r = 1.0 - s
    for i in range(1, n + 1):
        np.multiply(up[i - 1], s, out=up[i])
        np.multiply(down[i - 1], r, out=down[i])
    return [up[: k + 1, a] * down[k::-1, a] for a, k in enumerate(degrees)]


def _binomials(n: int) -> NDArray[np.float64]:
    return np.array([comb(n - 1, i) for i in range(n)], dtype=np.float64)


def bernstein_displacement(offsets: NDArray[np.float64], rows: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bernstein ``T_local`` (rows ``(3, N)``) over the lattice box (parameter ``u / (n - 1)`` per axis).

    Examples
    --------
    >>> import numpy as np
    >>> offsets = np.zeros((2, 3, 2, 3)); offsets[1, :, :, 0] = 1.0   # the x = 1 face moves by 1 in x
    >>> bernstein_displacement(offsets, np.array([[0.25], [1.0], [0.5]])).tolist()
    [[0.25], [0.0], [0.0]]
    """
    nx, ny, nz, _ = offsets.shape
    n = rows.shape[1]
    cx, cy, cz = (_binomials(k) for k in (nx, ny, nz))
    scaled = offsets * (cx[:, None, None, None] * cy[None, :, None, None] * cz[None, None, :, None])
    table = np.ascontiguousarray(scaled.reshape(nx * ny, nz * 3).T)  # (nz*3, nx*ny)
    s_all = rows / (np.array([nx, ny, nz], dtype=np.float64) - 1.0)[:, None]
    out = np.empty((3, n))
    b = min(n, max(1024, min(8192, _BLOCK_VALUES // (nx * ny))))
    up, wxy, x = np.empty((max(nx, ny, nz), 3, b)), np.empty((nx, ny, b)), np.empty((nz * 3, b))
    piece = SERIAL_MADDS // table.size  # points per product that stays on one BLAS thread
    piece = piece if piece >= _MIN_COLUMNS else b  # a big lattice: one product per block, threads welcome
    for start in range(0, n, b):
        m = min(b, n - start)
        px, py, pz = _bernstein_rows(s_all[:, start : start + m], (nx - 1, ny - 1, nz - 1), up[:, :, :m])
        w = np.multiply(px[:, None, :], py[None, :, :], out=wxy[:, :, :m])
        w, xm = w.reshape(nx * ny, m), x[:, :m]
        for p in range(0, m, piece):
            np.matmul(table, w[:, p : p + piece], out=xm[:, p : p + piece])
        xz = xm.reshape(nz, 3, m)
        xz *= pz[:, None, :]
        xz.sum(axis=0, out=out[:, start : start + m])
    return out


def _bspline_rows(t: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Six times the cubic B-spline weights ``B_0 .. B_3`` of ``t``, into ``w`` ``(4,) + t.shape``.

    ``6 B_0 = (1 - t)^3``, ``6 B_1 = (3t - 6) t^2 + 4`` (the report's ``3t^3 - 6t^2 + 4``),
    ``6 B_3 = t^3`` and ``6 B_2 = 6 - 6 B_0 - 6 B_1 - 6 B_3``: twelve passes. The caller divides
    the offsets by ``6^3`` instead.
    """
    t2 = t * t
    np.multiply(t2, t, out=w[3])  # t^3
    np.subtract(1.0, t, out=w[2])
    np.multiply(w[2], w[2], out=w[0])
    w[0] *= w[2]  # (1 - t)^3
    np.multiply(t, 3.0, out=w[1])
    w[1] -= 6.0
    w[1] *= t2
    w[1] += 4.0
    np.subtract(6.0, w[0], out=w[2])
    w[2] -= w[1]
    w[2] -= w[3]
    return w


def bspline_displacement(
    offsets: NDArray[np.float64],
    rows: NDArray[np.float64],
    border: str = "zero",
    matrices: Sequence[NDArray[np.float64]] | None = None,
) -> NDArray[np.float64]:
    """Cubic B-spline ``T_local`` (rows ``(3, N)``; the FFD report's formula), ``border`` "zero" or "clamp".

    ``matrices``: another four-point basis per axis, by its power-basis coefficients (Blender's
    interpolations, :data:`~ffd_notebook.ffd.interpolation.INTERPOLATION_MATRICES`, on the
    B-spline's support); their weights replace the B-spline's, the rest is the same.

    Examples
    --------
    >>> import numpy as np
    >>> offsets = np.zeros((4, 4, 4, 3)); offsets[1, 1, 1] = (0.0, 0.0, 6.0)
    >>> bspline_displacement(offsets, np.array([[1.0], [1.0], [1.0]])).round(6).tolist()
    [[0.0], [0.0], [1.777778]]
    """
    n = rows.shape[1]
    dims = np.array(offsets.shape[:3])
    first = np.floor(rows)
    t = rows - first
    first -= 1.0  # the support starts at floor - 1 (basis.bspline_cells), as floats: exact small integers
    clip_starts(first, dims[:, None], _WIDTH, out=first)
    grid = dims + _WIDTH + 1  # possible support starts per axis
    stride = np.array([grid[1] * grid[2], grid[2], 1], dtype=np.float64)
    cell: NDArray[Any] = stride @ first  # exact: small integers in float64
    cell += _WIDTH * stride.sum()
    small = np.uint16 if grid.prod() < 2**16 else np.uint32 if grid.prod() < 2**32 else np.uint64
    cell = cell.astype(small)
    order = np.argsort(cell, kind="stable")
    cell = cell[order]
    # runs of equal cells, also cut every _RUN points (chunk boundaries among them)
    cuts = np.union1d(np.flatnonzero(cell[1:] != cell[:-1]) + 1, np.arange(0, n, _RUN))
    bounds = np.r_[cuts, n].tolist()
    padded = pad_offsets(offsets / 216.0, border, _WIDTH)
    # each run's 64 offsets as a (12, 16) matrix, (z slot, component) x (x slot, y slot), gathered at once
    windows = np.lib.stride_tricks.sliding_window_view(padded, (4, 4, 4), axis=(0, 1, 2))  # (.., 3, l, m, n)
    blocks = windows[np.unravel_index(cell[cuts], tuple(grid))].transpose(0, 4, 1, 2, 3).reshape(-1, 12, 16)
    c = min(_CHUNK, n)
    tt, weights, buv = np.empty((3, c)), np.empty((4, 3, c)), np.empty((4, 4, c))
    if matrices is not None:  # weights = (6 M)^T @ [1, t, t^2, t^3]: six times them, as _bspline_rows gives
        scaled = [np.ascontiguousarray(6.0 * m.T) for m in matrices]
        powers, axis_rows = np.ones((4, c)), np.empty((4, c))
    x, local = np.empty((12, c)), np.empty((3, c))
    out = np.empty((3, n))
    run = 0
    for start in range(0, n, c):
        m = min(c, n - start)
        idx = order[start : start + m]
        np.take(t, idx, axis=1, out=tt[:, :m], mode="clip")  # "clip": no checks, no buffering
        if matrices is None:
            w = _bspline_rows(tt[:, :m], weights[:, :, :m])  # (4, 3, m)
        else:
            w = weights[:, :, :m]
            for a in range(3):
                powers[1, :m] = tt[a, :m]
                np.multiply(tt[a, :m], tt[a, :m], out=powers[2, :m])
                np.multiply(powers[2, :m], tt[a, :m], out=powers[3, :m])
                np.matmul(scaled[a], powers[:, :m], out=axis_rows[:, :m])
                w[:, a, :] = axis_rows[:, :m]
        np.multiply(w[:, None, 0, :], w[None, :, 1, :], out=buv[:, :, :m])
        wuv = buv.reshape(16, c)
        while run < len(blocks) and bounds[run] < start + m:
            s, e = bounds[run] - start, bounds[run + 1] - start
            np.matmul(blocks[run], wuv[:, s:e], out=x[:, s:e])
            run += 1
        xz = x[:, :m].reshape(4, 3, m)
        xz *= w[:, None, 2, :]
        xz.sum(axis=0, out=local[:, :m])
        for d in range(3):  # 1-D scatters, several times faster than one of (m, 3) rows
            out[d, idx] = local[d, :m]
    return out
