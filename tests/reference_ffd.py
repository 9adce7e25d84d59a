"""Plain per-point FFD, written straight from the FFD report's formula.

It is the baseline of the engine benchmark and an independent reference in tests: one point at a
time, one control point at a time, no vectorisation.
"""

from __future__ import annotations

import math

import numpy as np


def report_bspline(t: float) -> tuple[float, float, float, float]:
    return ((1 - t) ** 3 / 6, (3 * t**3 - 6 * t**2 + 4) / 6, (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6, t**3 / 6)


def deform_loop(points, offsets, spacing, origin, rotation=None, affine=None):
    """``affine(x) + T_local(x)`` for each point with the report's triple loop over l, m, n."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation)
    affine = np.eye(4) if affine is None else np.asarray(affine)
    nx, ny, nz = offsets.shape[:3]
    out = np.empty((len(points), 3))
    for p, x in enumerate(points):
        u, v, w = rotation.T @ (x - origin) / spacing
        i, j, k = math.floor(u) - 1, math.floor(v) - 1, math.floor(w) - 1
        bu, bv, bw = (
            report_bspline(u - math.floor(u)),
            report_bspline(v - math.floor(v)),
            report_bspline(w - math.floor(w)),
        )
        d = [0.0, 0.0, 0.0]
        for l in range(4):
            for m in range(4):
                for n in range(4):
                    a, b, c = i + l, j + m, k + n
                    if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz:
                        wt = bu[l] * bv[m] * bw[n]
                        o = offsets[a, b, c]
                        d[0] += wt * o[0]
                        d[1] += wt * o[1]
                        d[2] += wt * o[2]
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
