"""Cubic B-spline and Bernstein basis functions, vectorised.

Both families are evaluated for arrays of parameters at once: the last axis of the
result runs over the basis functions.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.basis import bspline, bernstein
>>> bspline(np.array([0.0, 0.5])).round(4)
array([[0.1667, 0.6667, 0.1667, 0.    ],
       [0.0208, 0.4792, 0.4792, 0.0208]])
>>> bspline(np.linspace(0, 1, 5)).sum(axis=-1)
array([1., 1., 1., 1., 1.])
>>> bernstein(np.array([0.5]), degree=2)
array([[0.25, 0.5 , 0.25]])
"""

from __future__ import annotations

from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BASES",
    "BORDERS",
    "BSPLINE_MATRIX",
    "bernstein",
    "bernstein_derivative",
    "bspline",
    "bspline_cells",
    "bspline_derivative",
    "bspline_second_derivative",
    "bspline_support",
    "check_border",
]

#: The FFD bases, in the order user interfaces list them.
BASES = ("bspline", "bernstein")

#: What the B-spline FFD assumes beyond the lattice: ``"zero"`` (control points outside contribute
#: nothing: the FFD report's formula and SimpleITK's) or ``"clamp"`` (they are copies of the border
#: control points, as in Blender's lattice: the weights then sum to one everywhere).
BORDERS = ("zero", "clamp")

#: Power-basis coefficients of the uniform cubic B-spline pieces: ``bspline(t) ==
#: [1, t, t**2, t**3] @ BSPLINE_MATRIX`` (columns are B_0 .. B_3 of the FFD report).
BSPLINE_MATRIX = (
    np.array(
        [
            [1.0, 4.0, 1.0, 0.0],
            [-3.0, 0.0, 3.0, 0.0],
            [3.0, -6.0, 3.0, 0.0],
            [-1.0, 3.0, -3.0, 1.0],
        ]
    )
    / 6.0
)


def bspline(t: ArrayLike) -> NDArray[np.float64]:
    """Values of the four uniform cubic B-spline pieces at ``t`` in [0, 1].

    ``B_0 = (1-t)^3/6``, ``B_1 = (3t^3 - 6t^2 + 4)/6``, ``B_2 = (-3t^3 + 3t^2 + 3t + 1)/6``,
    ``B_3 = t^3/6`` (Rueckert et al. 1999; the FFD report's formula).

    Parameters
    ----------
    t : array_like
        Fractional positions inside a lattice cell, any shape.

    Returns
    -------
    numpy.ndarray
        Shape ``t.shape + (4,)``; the four values sum to one.

    Examples
    --------
    >>> bspline(0.0).tolist()
    [0.16666666666666666, 0.6666666666666666, 0.16666666666666666, 0.0]
    """
    t = np.asarray(t, dtype=np.float64)
    s = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    return np.stack(
        [s * s * s / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0],
        axis=-1,
    )


def bspline_cells(u: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Where lattice coordinates fall: first index of their four-point support and the fraction.

    A coordinate ``u`` (control point ``i`` at ``u = i``) is moved by control points
    ``first .. first + 3`` with weights ``bspline(t)``, where ``first = floor(u) - 1`` and
    ``t = u - floor(u)`` (the FFD report's convention, shared by the FFD engine and the
    B-spline GP kernel).

    Parameters
    ----------
    u : array_like
        Lattice coordinates, any shape.

    Returns
    -------
    first : numpy.ndarray
        ``floor(u) - 1`` as int64, the shape of ``u``.
    t : numpy.ndarray
        ``u - floor(u)`` in [0, 1), the shape of ``u``.

    Examples
    --------
    >>> first, t = bspline_cells([2.25, -0.5])
    >>> first.tolist(), t.tolist()
    ([1, -2], [0.25, 0.5])
    """
    u = np.asarray(u, dtype=np.float64)
    fl = np.floor(u)
    return fl.astype(np.int64) - 1, u - fl


def check_border(border: str) -> str:
    """``border`` if it is one of :data:`BORDERS`, else a ``ValueError``.

    Examples
    --------
    >>> check_border("clamp")
    'clamp'
    """
    if border not in BORDERS:
        raise ValueError(f"border must be one of {BORDERS}, got {border!r}")
    return border


def bspline_support(u: ArrayLike, n: int, border: str = "zero") -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Control-point indices and B-spline weights moving lattice coordinates ``u`` along one axis.

    The support of :func:`bspline_cells` (indices ``first .. first + 3``) made to fit a lattice of
    ``n`` control points: with ``border="zero"`` indices outside ``0 .. n-1`` get weight zero
    (and are clipped, so they stay valid indices); with ``"clamp"`` they are clipped to the
    border control point, which so receives their weight (an index may then repeat: add the
    weights of repeats, e.g. with ``numpy.add.at``).

    Parameters
    ----------
    u : array_like
        Lattice coordinates along the axis, any shape.
    n : int
        Control points along the axis.
    border : {"zero", "clamp"}
        What lies beyond the lattice (see :data:`BORDERS`).

    Returns
    -------
    index : numpy.ndarray
        ``u.shape + (4,)`` int64 indices in ``0 .. n-1``.
    weight : numpy.ndarray
        ``u.shape + (4,)`` weights; with ``"clamp"`` they sum to one for every ``u``.

    Examples
    --------
    >>> index, weight = bspline_support([0.0], n=5, border="clamp")
    >>> index.tolist(), weight.round(4).tolist()
    ([[0, 0, 1, 2]], [[0.1667, 0.6667, 0.1667, 0.0]])
    >>> bspline_support([0.0], n=5)[1].round(4).tolist()   # "zero": the point before 0 counts nothing
    [[0.0, 0.6667, 0.1667, 0.0]]
    """
    first, t = bspline_cells(u)
    index = first[..., None] + np.arange(4)
    weight = bspline(t)
    clipped = np.clip(index, 0, n - 1)
    if check_border(border) == "zero":
        weight = np.where(clipped == index, weight, 0.0)
    return clipped, weight


def bspline_derivative(t: ArrayLike) -> NDArray[np.float64]:
    """First derivatives ``dB_l/dt`` of the four cubic B-spline pieces.

    Examples
    --------
    >>> bspline_derivative(0.5).tolist()
    [-0.125, -0.625, 0.625, 0.125]
    >>> bool(abs(bspline_derivative(0.3).sum()) < 1e-15)  # partition of unity: derivatives sum to 0
    True
    """
    t = np.asarray(t, dtype=np.float64)
    s = 1.0 - t
    t2 = t * t
    return np.stack([-0.5 * s * s, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2], axis=-1)


def bspline_second_derivative(t: ArrayLike) -> NDArray[np.float64]:
    """Second derivatives of the four cubic B-spline pieces.

    Examples
    --------
    >>> bspline_second_derivative(0.0).tolist()
    [1.0, -2.0, 1.0, 0.0]
    """
    t = np.asarray(t, dtype=np.float64)
    return np.stack([1.0 - t, 3.0 * t - 2.0, -3.0 * t + 1.0, t], axis=-1)


def _check_degree(degree: int) -> int:
    if int(degree) != degree or degree < 0:
        raise ValueError(f"degree must be a non-negative integer, got {degree!r}")
    return int(degree)


def bernstein(t: ArrayLike, degree: int) -> NDArray[np.float64]:
    """Bernstein polynomials ``C(n, i) t^i (1-t)^(n-i)``, i = 0..n, of degree ``n``.

    Parameters
    ----------
    t : array_like
        Parameters in [0, 1], any shape.
    degree : int
        Polynomial degree n (a lattice with n + 1 control points along the axis).

    Returns
    -------
    numpy.ndarray
        Shape ``t.shape + (degree + 1,)``.

    Examples
    --------
    >>> bernstein([0.0, 1.0], degree=3).tolist()
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    """
    n = _check_degree(degree)
    t = np.asarray(t, dtype=np.float64)[..., None]
    i = np.arange(n + 1)
    coef = np.array([comb(n, k) for k in range(n + 1)], dtype=np.float64)
    return coef * t**i * (1.0 - t) ** (n - i)


def bernstein_derivative(t: ArrayLike, degree: int) -> NDArray[np.float64]:
    """Derivatives with respect to ``t`` of the Bernstein polynomials of ``degree``.

    Uses ``d/dt B_{i,n} = n (B_{i-1,n-1} - B_{i,n-1})``.

    Examples
    --------
    >>> bernstein_derivative(0.5, degree=2).tolist()
    [-1.0, 0.0, 1.0]
    """
    n = _check_degree(degree)
    t = np.asarray(t, dtype=np.float64)
    if n == 0:
        return np.zeros(t.shape + (1,))
    lower = bernstein(t, n - 1)
    pad = np.zeros(t.shape + (1,))
    return n * (np.concatenate([pad, lower], axis=-1) - np.concatenate([lower, pad], axis=-1))
