"""Plain per-point FFD, written straight from the FFD report's formula.

It is the baseline of the engine benchmark and an independent reference in tests: one point at a
time, one control point at a time, no vectorisation.
"""

from __future__ import annotations

import math

import numpy as np


def report_bspline(t: float) -> tuple[float, float, float, float]:
    return ((1 - t) ** 3 / 6, (3 * t**3 - 6 * t**2 + 4) / 6, (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6, t**3 / 6)


def report_basis(l: int, t: float) -> float:
    """B_l(t) of the FFD report."""
    if l == 0:
        return (1 - t) ** 3 / 6
    if l == 1:
        return (3 * t**3 - 6 * t**2 + 4) / 6
    if l == 2:
        return (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6
    return t**3 / 6


def deform_loop(points, offsets, spacing, origin, rotation=None, affine=None, border="zero"):
    """``affine(x) + T_local(x)`` for each point, the report's formula as written.

    For each point: its lattice coordinates, ``i = floor(u) - 1`` (likewise j, k), then
    ``T_local = sum_lmn B_l(u - floor u) B_m(v - floor v) B_n(w - floor w) offsets[i+l, j+m, k+n]``
    with control points outside the lattice contributing nothing (``border="zero"``) or, with
    ``border="clamp"``, read at the index clamped into the lattice (Blender's lattice loop).
    """
    rotation = np.eye(3) if rotation is None else np.asarray(rotation)
    affine = np.eye(4) if affine is None else np.asarray(affine)
    nx, ny, nz = offsets.shape[:3]
    out = np.empty((len(points), 3))
    for p, x in enumerate(points):
        u, v, w = rotation.T @ (x - origin) / spacing
        i, j, k = math.floor(u) - 1, math.floor(v) - 1, math.floor(w) - 1
        tu, tv, tw = u - math.floor(u), v - math.floor(v), w - math.floor(w)
        d = np.zeros(3)
        for l in range(4):
            for m in range(4):
                for n in range(4):
                    a, b, c = i + l, j + m, k + n
                    if border == "clamp":
                        a, b, c = min(max(a, 0), nx - 1), min(max(b, 0), ny - 1), min(max(c, 0), nz - 1)
                    if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz:
                        weight = report_basis(l, tu) * report_basis(m, tv) * report_basis(n, tw)
                        d += weight * offsets[a, b, c]
        out[p] = affine[:3, :3] @ x + affine[:3, 3] + d
    return out


def bernstein_loop(points, offsets, spacing, origin, rotation=None):
    """Sederberg-Parry: ``x + sum_ijk B_i(s) B_j(t) B_k(u) offsets[i, j, k]`` over the lattice box."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation)
    nx, ny, nz = offsets.shape[:3]
    out = np.empty((len(points), 3))
    for p, x in enumerate(points):
        s, t, u = rotation.T @ (x - origin) / spacing / (np.array([nx, ny, nz]) - 1)
        d = np.zeros(3)
        for i in range(nx):
            for j in range(ny):
                for k in range(nz):
                    b = (
                        math.comb(nx - 1, i)
                        * s**i
                        * (1 - s) ** (nx - 1 - i)
                        * math.comb(ny - 1, j)
                        * t**j
                        * (1 - t) ** (ny - 1 - j)
                        * math.comb(nz - 1, k)
                        * u**k
                        * (1 - u) ** (nz - 1 - k)
                    )
                    d += b * offsets[i, j, k]
        out[p] = x + d
    return out
