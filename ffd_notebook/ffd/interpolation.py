"""Blender's lattice interpolations, one per axis: the weights of the four control points around a point.

Blender's lattice (``key_curve_position_weights`` in Blender's ``key.cc``) moves a point with
lattice coordinate ``u`` along an axis by the control points ``floor(u) - 1 .. floor(u) + 2``
with four weights that are cubic polynomials of ``t = u - floor(u)``:

- ``"linear"``: ``(0, 1 - t, t, 0)``, trilinear interpolation between the cell's corners;
- ``"cardinal"``: the cardinal spline of tension ``0.71`` (interpolating, not reproducing lines);
- ``"catmull-rom"``: the cardinal spline of tension ``0.5`` (interpolating, reproduces lines);
- ``"bspline"``: the uniform cubic B-spline (approximating; Blender's default since 2.81), the
  same weights as :func:`~ffd_notebook.basis.bspline`.

Each family is a 4x4 matrix of power-basis coefficients, ``weights(t) = [1, t, t^2, t^3] @ M``,
so that evaluators can treat all of them alike. The four weights sum to one for every ``t`` (so,
with indices clamped at the lattice's ends, Blender's border rule, a lattice that does not move
moves nothing, inside or outside it).

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.ffd.interpolation import interpolation_weights
>>> interpolation_weights([0.0, 0.5], "catmull-rom").tolist()
[[0.0, 1.0, 0.0, 0.0], [-0.0625, 0.5625, 0.5625, -0.0625]]
>>> interpolation_weights(np.linspace(0, 1, 7), "cardinal").sum(axis=-1).round(12).tolist()
[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
"""

from __future__ import annotations

from functools import partial
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .basis import BASES, BSPLINE, AxisBasis, BasisName, bspline_cells

__all__ = [
    "AXIS_BASES",
    "CARDINAL_TENSION",
    "CATMULL_ROM_TENSION",
    "INTERPOLATION_MATRICES",
    "LATTICE_INTERPOLATIONS",
    "axis_bases",
    "check_basis",
    "check_lattice_interpolation",
    "interpolation_derivative",
    "interpolation_second_derivative",
    "interpolation_weights",
]

#: Blender's interpolations of a lattice axis, in the order its interface lists them.
LATTICE_INTERPOLATIONS = ("linear", "cardinal", "catmull-rom", "bspline")

#: The tension ``fc`` of Blender's cardinal spline (``key.cc``).
CARDINAL_TENSION = 0.71
#: Catmull-Rom is the cardinal spline of tension 0.5.
CATMULL_ROM_TENSION = 0.5


def _cardinal_matrix(fc: float) -> NDArray[np.float64]:
    # rows: coefficients of 1, t, t^2, t^3; columns: the weights of points floor(u) - 1 .. floor(u) + 2
    return np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-fc, 0.0, fc, 0.0],
            [2.0 * fc, fc - 3.0, 3.0 - 2.0 * fc, -fc],
            [-fc, 2.0 - fc, fc - 2.0, fc],
        ]
    )


#: Power-basis coefficients of each interpolation: ``weights(t) == [1, t, t**2, t**3] @ M``.
INTERPOLATION_MATRICES: dict[str, NDArray[np.float64]] = {
    "linear": np.array([[0.0, 1.0, 0.0, 0.0], [0.0, -1.0, 1.0, 0.0], [0.0] * 4, [0.0] * 4]),
    "cardinal": _cardinal_matrix(CARDINAL_TENSION),
    "catmull-rom": _cardinal_matrix(CATMULL_ROM_TENSION),
    "bspline": np.array(
        [
            [1.0, 4.0, 1.0, 0.0],
            [-3.0, 0.0, 3.0, 0.0],
            [3.0, -6.0, 3.0, 0.0],
            [-1.0, 3.0, -3.0, 1.0],
        ]
    )
    / 6.0,
}
for _m in INTERPOLATION_MATRICES.values():
    _m.flags.writeable = False


def check_lattice_interpolation(kind: str) -> str:
    """``kind`` if it is one of :data:`LATTICE_INTERPOLATIONS`, else a ``ValueError`` naming them.

    Examples
    --------
    >>> check_lattice_interpolation("bspline")
    'bspline'
    >>> check_lattice_interpolation("cubic")
    Traceback (most recent call last):
    ...
    ValueError: interpolation must be one of ('linear', 'cardinal', 'catmull-rom', 'bspline'), got 'cubic'
    """
    if kind not in INTERPOLATION_MATRICES:
        raise ValueError(f"interpolation must be one of {LATTICE_INTERPOLATIONS}, got {kind!r}")
    return kind


def _powers(t: ArrayLike, derivative: int) -> NDArray[np.float64]:
    t = np.asarray(t, dtype=np.float64)
    one, zero = np.ones_like(t), np.zeros_like(t)
    if derivative == 0:
        return np.stack([one, t, t * t, t * t * t], axis=-1)
    if derivative == 1:
        return np.stack([zero, one, 2.0 * t, 3.0 * t * t], axis=-1)
    return np.stack([zero, zero, 2.0 * one, 6.0 * t], axis=-1)


def interpolation_weights(t: ArrayLike, kind: str) -> NDArray[np.float64]:
    """Weights of the control points ``floor(u) - 1 .. floor(u) + 2`` at fractions ``t = u - floor(u)``.

    Parameters
    ----------
    t : array_like
        Fractions in [0, 1), any shape.
    kind : {"linear", "cardinal", "catmull-rom", "bspline"}
        The interpolation (:data:`LATTICE_INTERPOLATIONS`).

    Returns
    -------
    numpy.ndarray
        Shape ``t.shape + (4,)``; the four weights sum to one.

    Examples
    --------
    >>> interpolation_weights(0.25, "linear").tolist()
    [0.0, 0.75, 0.25, 0.0]
    """
    return _powers(t, 0) @ INTERPOLATION_MATRICES[check_lattice_interpolation(kind)]


def interpolation_derivative(t: ArrayLike, kind: str) -> NDArray[np.float64]:
    """Derivatives ``d weights / dt`` (see :func:`interpolation_weights`); they sum to zero.

    Examples
    --------
    >>> interpolation_derivative(0.5, "linear").tolist()
    [0.0, -1.0, 1.0, 0.0]
    """
    return _powers(t, 1) @ INTERPOLATION_MATRICES[check_lattice_interpolation(kind)]


def interpolation_second_derivative(t: ArrayLike, kind: str) -> NDArray[np.float64]:
    """Second derivatives ``d^2 weights / dt^2`` (see :func:`interpolation_weights`).

    Examples
    --------
    >>> interpolation_second_derivative(0.0, "bspline").tolist()
    [1.0, -2.0, 1.0, 0.0]
    """
    return _powers(t, 2) @ INTERPOLATION_MATRICES[check_lattice_interpolation(kind)]


#: Each interpolation as a per-axis basis of the engine (:class:`~ffd_notebook.ffd.basis.AxisBasis`): the
#: same support as the B-spline's (``floor(u) - 1 .. floor(u) + 2``), so the border rule, the cell
#: grouping and the evaluators serve them all; ``"bspline"`` is the engine's own B-spline.
AXIS_BASES: dict[str, AxisBasis] = {
    kind: BSPLINE
    if kind == "bspline"
    else AxisBasis(
        kind,
        4,
        bspline_cells,
        partial(interpolation_weights, kind=kind),
        partial(interpolation_derivative, kind=kind),
    )
    for kind in LATTICE_INTERPOLATIONS
}


def check_basis(basis: Any) -> BasisName | tuple[str, str, str]:
    """An FFD's ``basis`` argument checked and in its one form.

    ``"bspline"`` and ``"bernstein"`` stay; one of Blender's interpolations alone means it on every
    axis; a tuple names one per axis, and three B-splines are ``"bspline"``.

    Examples
    --------
    >>> check_basis(("bspline", "catmull-rom", "linear"))
    ('bspline', 'catmull-rom', 'linear')
    >>> check_basis("linear"), check_basis(["bspline"] * 3)
    (('linear', 'linear', 'linear'), 'bspline')
    >>> check_basis(("bspline", "bernstein", "linear"))
    Traceback (most recent call last):
    ...
    ValueError: basis must be 'bspline', 'bernstein' or one interpolation per axis (three of ...), got ('bspline', ...)
    """
    if isinstance(basis, str):
        if basis in BASES:
            return cast(BasisName, basis)
        if basis in LATTICE_INTERPOLATIONS:
            basis = (basis,) * 3
    if not isinstance(basis, str) and isinstance(basis, (tuple, list)):
        kinds = tuple(basis)
        if len(kinds) == 3 and all(isinstance(k, str) and k in LATTICE_INTERPOLATIONS for k in kinds):
            return "bspline" if kinds == ("bspline",) * 3 else kinds
        basis = kinds
    raise ValueError(
        "basis must be 'bspline', 'bernstein' or one interpolation per axis (three of "
        f"{', '.join(repr(k) for k in LATTICE_INTERPOLATIONS)}), got {basis!r}"
    )


def axis_bases(basis: str | tuple[str, ...]) -> tuple[AxisBasis, AxisBasis, AxisBasis]:
    """The per-axis bases of a checked local ``basis`` (see :func:`check_basis`; not ``"bernstein"``).

    Examples
    --------
    >>> [b.name for b in axis_bases(("linear", "bspline", "cardinal"))]
    ['linear', 'bspline', 'cardinal']
    """
    kinds = ("bspline",) * 3 if basis == "bspline" else basis
    return tuple(AXIS_BASES[k] for k in kinds)  # type: ignore[return-value]
