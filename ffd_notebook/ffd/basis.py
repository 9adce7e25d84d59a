"""Cubic B-spline and Bernstein basis functions, vectorised.

Both families are evaluated for arrays of parameters at once: the last axis of the
result runs over the basis functions.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.ffd.basis import bspline, bernstein
>>> bspline(np.array([0.0, 0.5])).round(4)
array([[0.1667, 0.6667, 0.1667, 0.    ],
       [0.0208, 0.4792, 0.4792, 0.0208]])
>>> bspline(np.linspace(0, 1, 5)).sum(axis=-1)
array([1., 1., 1., 1., 1.])
>>> bernstein(np.array([0.5]), degree=2)
array([[0.25, 0.5 , 0.25]])
"""

from __future__ import annotations

from collections.abc import Callable
from math import comb
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BASES",
    "BSPLINE",
    "BSPLINE_MATRIX",
    "AxisBasis",
    "BasisName",
    "bernstein",
    "bernstein_derivative",
    "bernstein_values",
    "bspline",
    "bspline_cells",
    "bspline_derivative",
    "bspline_second_derivative",
]

#: The FFD bases, in the order user interfaces list them.
BASES = ("bspline", "bernstein")

#: The type of a ``basis`` argument: one of :data:`BASES`.
BasisName = Literal["bspline", "bernstein"]

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


class AxisBasis(NamedTuple):
    """A per-axis basis with local support: along one axis, ``width`` control points move a coordinate.

    :mod:`~ffd_notebook.ffd.support` applies the border rule to any such basis; the evaluators
    take the weights from here.

    Attributes
    ----------
    name : str
        The basis's name.
    width : int
        Control points that touch a coordinate (its support), ``first .. first + width - 1``.
    locate : callable
        ``u -> (first, t)``: the support's first control index (int64) and the fraction of the
        cell, both shaped like ``u`` (lattice coordinates, control point ``i`` at ``u = i``).
    weights, derivative : callable
        ``t -> t.shape + (width,)``: the weights of the support's control points, and their
        derivatives with respect to ``u``.

    Examples
    --------
    >>> first, weight = BSPLINE.support([1.5])
    >>> first.tolist(), weight.round(4).tolist()
    ([0], [[0.0208, 0.4792, 0.4792, 0.0208]])
    """

    name: str
    width: int
    locate: Callable[[ArrayLike], tuple[NDArray[np.int64], NDArray[np.float64]]]
    weights: Callable[[ArrayLike], NDArray[np.float64]]
    derivative: Callable[[ArrayLike], NDArray[np.float64]]

    def support(self, u: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """``(first, weights)`` of lattice coordinates ``u``: where the support starts and its weights."""
        first, t = self.locate(u)
        return first, self.weights(t)


#: The uniform cubic B-spline as a per-axis basis (the FFD report's, ITK's order 3).
BSPLINE = AxisBasis("bspline", 4, bspline_cells, bspline, bspline_derivative)
