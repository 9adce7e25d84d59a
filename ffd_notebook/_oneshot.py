"""One-shot evaluation of ``T_local``: deform a point set once, with no cache kept.

:class:`~ffd_notebook.Deformer` pays for a cache (grouping of the points by cell, weights) that
repeated updates amortise; ``FFD.deform`` on a fresh point set should not. Here:

- Bernstein: the per-point weights are a tensor product of three per-axis basis matrices, so the
  sum over all ``nx * ny * nz`` control points is done as successive contractions: a row-wise
  outer product of the x and y weights, ``(N, nx*ny)``, times the offsets as an
  ``(nx*ny, nz*3)`` matrix (one BLAS product), then the z weights. The ``(N, nx*ny*nz)`` weight
  matrix is never formed, and points go in blocks so the intermediates stay in cache.
- B-spline: points are grouped by the cell whose 4x4x4 support moves them with a radix sort of
  16-bit cell numbers (NumPy's stable sort is a radix sort for small integer types), and each
  cell's points are summed with one small matrix product.

Both keep float64 throughout.

Examples
--------
>>> import numpy as np
>>> offsets = np.zeros((4, 4, 4, 3)); offsets[..., 2] = 1.0
>>> displacement("bspline", offsets, np.array([[1.5, 1.5, 1.5], [9.0, 9.0, 9.0]])).round(12).tolist()
[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
>>> in_domain("bernstein", (4, 4, 4), np.array([[0.0, 3.0, 1.0], [0.0, 3.1, 1.0]])).tolist()
[True, False]
"""

from __future__ import annotations

from math import comb

import numpy as np
from numpy.typing import NDArray

from .basis import BSPLINE_MATRIX

__all__ = ["bernstein_displacement", "bspline_displacement", "displacement", "in_domain"]

_BLOCK = 8192  # points per block: the Bernstein intermediates (block x nx*ny) stay in cache


def displacement(basis: str, offsets: NDArray[np.float64], uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """``T_local`` at lattice coordinates ``uvw`` ``(N, 3)`` for ``offsets`` ``(nx, ny, nz, 3)``."""
    if basis == "bernstein":
        return bernstein_displacement(offsets, uvw)
    return bspline_displacement(offsets, uvw)


def in_domain(basis: str, shape: tuple[int, int, int], uvw: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which points lie in the lattice's domain (see ``FFD(only_inside=True)``).

    Bernstein: the box ``0 <= u <= n - 1`` (PyGeM's unit cube). B-spline: ``1 <= u <= n - 2``,
    where every support lies in the lattice (ITK's ``BSplineTransform::InsideValidRegion``).
    """
    dims = np.asarray(shape, dtype=np.float64)
    lo, hi = (0.0, dims - 1.0) if basis == "bernstein" else (1.0, dims - 2.0)
    return np.all((uvw >= lo) & (uvw <= hi), axis=1)


def _bernstein_rows(s: NDArray[np.float64], degree: int) -> NDArray[np.float64]:
    """``(degree + 1, N)`` Bernstein values, powers by repeated products (no ``pow`` calls).

    Rows, not columns: every operation here and in the contractions below runs along the points,
    the long axis, which is several times faster than broadcasting over a short last axis.
    """
    n = degree
    up = np.empty((n + 1, len(s)))
    down = np.empty((n + 1, len(s)))
    up[0] = 1.0
    down[n] = 1.0
    r = 1.0 - s
    for i in range(1, n + 1):
        np.multiply(up[i - 1], s, out=up[i])
        np.multiply(down[n - i + 1], r, out=down[n - i])
    up *= down
    up *= np.array([comb(n, i) for i in range(n + 1)], dtype=np.float64)[:, None]
    return up


def bernstein_displacement(offsets: NDArray[np.float64], uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bernstein ``T_local`` over the lattice box (parameter ``u / (n - 1)`` per axis).

    Examples
    --------
    >>> import numpy as np
    >>> offsets = np.zeros((2, 3, 2, 3)); offsets[1, :, :, 0] = 1.0   # the x = 1 face moves by 1 in x
    >>> bernstein_displacement(offsets, np.array([[0.25, 1.0, 0.5]])).tolist()
    [[0.25, 0.0, 0.0]]
    """
    nx, ny, nz, _ = offsets.shape
    table = np.ascontiguousarray(offsets.reshape(nx * ny, nz * 3).T)  # (nz*3, nx*ny)
    s_all = (uvw / (np.array([nx, ny, nz], dtype=np.float64) - 1.0)).T
    out = np.empty((3, len(uvw)))
    for start in range(0, len(uvw), _BLOCK):
        s = s_all[:, start : start + _BLOCK]
        bx = _bernstein_rows(s[0], nx - 1)
        by = _bernstein_rows(s[1], ny - 1)
        bz = _bernstein_rows(s[2], nz - 1)
        wxy = (bx[:, None, :] * by[None, :, :]).reshape(nx * ny, -1)
        x = (table @ wxy).reshape(nz, 3, -1)
        np.einsum("kdp,kp->dp", x, bz, out=out[:, start : start + _BLOCK])
    return out.T


def _bspline_rows(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(4, 3, N)`` cubic B-spline weights of ``t`` ``(3, N)`` by one power-basis product."""
    flat = t.reshape(-1)
    powers = np.empty((4, len(flat)))
    powers[0] = 1.0
    powers[1] = flat
    np.multiply(flat, flat, out=powers[2])
    np.multiply(powers[2], flat, out=powers[3])
    return (BSPLINE_MATRIX.T @ powers).reshape((4,) + t.shape)


def bspline_displacement(offsets: NDArray[np.float64], uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cubic B-spline ``T_local`` (the FFD report's formula; supports outside the lattice read zero).

    Examples
    --------
    >>> import numpy as np
    >>> offsets = np.zeros((4, 4, 4, 3)); offsets[1, 1, 1] = (0.0, 0.0, 6.0)
    >>> bspline_displacement(offsets, np.array([[1.0, 1.0, 1.0]])).round(6).tolist()
    [[0.0, 0.0, 1.777778]]
    """
    n = len(uvw)
    dims = np.array(offsets.shape[:3])
    floor = np.floor(uvw)
    t = (uvw - floor).T  # (3, N): the weights are computed along the points
    # floor(u) - 1, shifted by the 3 zero layers of padding; clipped first so far points cast safely
    first = np.clip(floor, -3.0, dims + 1.0).astype(np.int64) + 2
    # one unsigned comparison checks 0 <= first <= dims + 2 (negative numbers wrap to huge ones)
    inside = np.all(first.view(np.uint64) <= (dims + 2).astype(np.uint64), axis=1)
    first[~inside] = 0
    grid = dims + 3
    cell = (first[:, 0] * grid[1] + first[:, 1]) * grid[2] + first[:, 2]
    small = np.uint16 if grid.prod() < 2**16 else np.uint32 if grid.prod() < 2**32 else np.uint64
    order = np.argsort(cell.astype(small), kind="stable")
    cell = cell[order]
    bounds = np.r_[0, np.flatnonzero(np.diff(cell)) + 1, n]
    weights = _bspline_rows(np.take(t, order, axis=1))
    weights[:, 2, ~inside[order]] = 0.0  # supports wholly outside the lattice contribute nothing
    buv = (weights[:, 0, None, :] * weights[:, 1][None, :, :]).reshape(16, n)
    bw = weights[:, 2]
    padded = np.pad(offsets, ((3, 3), (3, 3), (3, 3), (0, 0)))
    firsts = first[order[bounds[:-1]]]
    local = np.empty((n, 3))
    for s, e, (i, j, k) in zip(bounds[:-1], bounds[1:], firsts, strict=True):
        block = padded[i : i + 4, j : j + 4, k : k + 4].reshape(16, 12).T  # (n d) x (l m)
        x = (block @ buv[:, s:e]).reshape(4, 3, -1)
        np.einsum("ndp,np->pd", x, bw[:, s:e], out=local[s:e])
    out = np.empty_like(local)
    out[order] = local
    return out
