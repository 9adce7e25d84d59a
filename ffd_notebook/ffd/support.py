"""The border rule: which control points a point's support reads, and what lies beyond the lattice.

Every evaluator of the engine (one-shot, cached, fitting, Jacobian) asks this module, so the rule
is written once. It is built around a per-axis basis (:class:`~ffd_notebook.ffd.basis.AxisBasis`):
along each axis a coordinate ``u`` is moved by ``width`` consecutive control points starting at
``first``, with the basis's weights. The lattice has ``n`` control points on that axis; what the
support finds outside ``0 .. n-1`` is the border rule (:data:`BORDERS`):

- ``"zero"``: nothing (the FFD report's formula, SimpleITK's): those control points count zero.
- ``"clamp"``: copies of the border control point (Blender's lattice): their weight goes to it, so
  weights that sum to one inside the lattice sum to one everywhere.

Two equivalent forms serve the evaluators:

- per point, clipped indices and weights (:func:`axis_support`: the fit's sparse rows);
- per group of points, offsets padded by ``width`` layers (zeros, or copies of the border layer:
  :func:`pad_offsets`) read through a support whose start is clipped to ``-width .. n``
  (:func:`clip_starts`): a support wholly outside the lattice then reads padding only, which is
  what both rules ask for, with no mask and no special case. :class:`CellGroups` sorts points by
  that start, so each group's sum is one small matrix product.

A control point's share of a support (the slots it fills, :func:`support_slots`) and the domain of
``FFD(only_inside=True)`` (:func:`in_domain`) follow the same rule.

Examples
--------
>>> import numpy as np
>>> index, weight = axis_support([0.0], n=5, border="clamp")
>>> index.tolist(), weight.round(4).tolist()
([[0, 0, 1, 2]], [[0.1667, 0.6667, 0.1667, 0.0]])
>>> clip_starts(np.array([-9, 2, 9]), 5).tolist()    # outside: the support reads padding only
[-4, 2, 5]
"""

from __future__ import annotations

from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .basis import BSPLINE, AxisBasis

__all__ = [
    "BORDERS",
    "DOMAIN_RULES",
    "Border",
    "CellGroups",
    "axis_in_domain",
    "axis_support",
    "check_border",
    "check_only_inside",
    "clip_starts",
    "in_domain",
    "outer_uv",
    "pad_offsets",
    "support_slots",
]

#: What the B-spline FFD assumes beyond the lattice: ``"zero"`` (control points outside contribute
#: nothing: the FFD report's formula and SimpleITK's) or ``"clamp"`` (they are copies of the border
#: control points, as in Blender's lattice: the weights then sum to one everywhere).
BORDERS = ("zero", "clamp")

#: The type of a ``border`` argument: one of :data:`BORDERS`.
Border = Literal["zero", "clamp"]


def check_border(border: str) -> Border:
    """``border`` if it is one of :data:`BORDERS`, else a ``ValueError``.

    Examples
    --------
    >>> check_border("clamp")
    'clamp'
    """
    if border not in BORDERS:
        raise ValueError(f"border must be one of {BORDERS}, got {border!r}")
    return cast(Border, border)


def axis_support(
    u: ArrayLike, n: int, border: str = "zero", basis: AxisBasis = BSPLINE
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Control-point indices and weights moving lattice coordinates ``u`` along one axis.

    The basis's support (indices ``first .. first + width - 1``) made to fit a lattice of ``n``
    control points: with ``border="zero"`` indices outside ``0 .. n-1`` get weight zero (and are
    clipped, so they stay valid indices); with ``"clamp"`` they are clipped to the border control
    point, which so receives their weight (an index may then repeat: add the weights of repeats,
    e.g. with ``numpy.add.at``).

    Parameters
    ----------
    u : array_like
        Lattice coordinates along the axis, any shape.
    n : int
        Control points along the axis.
    border : {"zero", "clamp"}
        What lies beyond the lattice (see :data:`BORDERS`).
    basis : AxisBasis
        The per-axis basis (the cubic B-spline by default).

    Returns
    -------
    index : numpy.ndarray
        ``u.shape + (width,)`` int64 indices in ``0 .. n-1``.
    weight : numpy.ndarray
        ``u.shape + (width,)`` weights; with ``"clamp"`` they sum to one for every ``u``.

    Examples
    --------
    >>> axis_support([0.0], n=5)[1].round(4).tolist()   # "zero": the point before 0 counts nothing
    [[0.0, 0.6667, 0.1667, 0.0]]
    """
    first, weight = basis.support(u)
    index = first[..., None] + np.arange(basis.width)
    clipped = np.clip(index, 0, n - 1)
    if check_border(border) == "zero":
        weight = np.where(clipped == index, weight, 0.0)
    return clipped, weight


def clip_starts(first: NDArray[Any], dims: ArrayLike, width: int = BSPLINE.width, out: Any = None) -> NDArray[Any]:
    """Support starts clipped to ``-width .. n``: beyond that a support reads the padding only.

    ``dims`` (control points per axis) broadcasts against ``first``: ``(3,)`` for ``(N, 3)``
    starts, ``(3, 1)`` for rows ``(3, N)``; integer or float starts. A start clipped to ``-width``
    or ``n`` reads ``width`` padding layers (:func:`pad_offsets`): zeros for "zero", the border
    control point for "clamp", which is what the unclipped start would have read.

    Examples
    --------
    >>> clip_starts(np.array([[-7.0, 3.0]]), [[4]]).tolist()
    [[-4.0, 3.0]]
    """
    return np.clip(first, -width, dims, out=out)


def pad_offsets(
    offsets: NDArray[np.float64], border: str = "zero", width: int = BSPLINE.width, dtype: Any = None
) -> NDArray[Any]:
    """Offsets with ``width`` layers around, zeros (``"zero"``) or copies of the border (``"clamp"``).

    Copying the border layer outward is the same as clamping the support's indices (the clamp
    rule); a support whose start is clipped by :func:`clip_starts` stays inside the padded array.

    Examples
    --------
    >>> pad_offsets(np.ones((2, 2, 2, 3)), "clamp").shape
    (10, 10, 10, 3)
    >>> float(pad_offsets(np.ones((2, 2, 2, 3)))[0, 0, 0, 0])
    0.0
    """
    mode: Literal["constant", "edge"] = "constant" if check_border(border) == "zero" else "edge"
    padded = np.pad(offsets, [(width, width)] * 3 + [(0, 0)], mode=mode)
    return padded if dtype is None else padded.astype(dtype, copy=False)


def support_slots(
    ijk: NDArray[np.int64],
    first: NDArray[np.int64],
    shape: tuple[int, int, int],
    border: str,
    width: int = BSPLINE.width,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Slots ``lo..hi`` (per axis, ``0 .. width-1``) control point ``ijk`` fills in supports starting at ``first``.

    With "zero" a control point fills one slot, ``ijk - first``; with "clamp" a border control
    point also fills every slot beyond the lattice on its side. Empty where ``lo > hi``.

    Examples
    --------
    >>> lo, hi = support_slots(np.array([0, 2, 2]), np.array([[-4, 0, 1]]), (5, 5, 5), "clamp")
    >>> lo.tolist(), hi.tolist()
    ([[0, 2, 1]], [[3, 2, 1]])
    """
    rel = ijk - first
    lo, hi = rel.copy(), rel.copy()
    if border == "clamp":
        dims = np.asarray(shape)
        lo[:, ijk == 0] = 0
        hi[:, ijk == dims - 1] = width - 1
    return np.maximum(lo, 0), np.minimum(hi, width - 1)


#: The values of ``FFD(only_inside=...)`` beyond ``False``: ``True``, the closed domain (ITK's
#: ``BSplineTransform`` and PyGeM include every face), and ``"half-open"``, elastix's valid region
#: (``AdvancedBSplineDeformableTransform``), which includes the faces at its first control points and
#: excludes those at its last (a point exactly on such a face does not move).
DOMAIN_RULES = (True, "half-open")


def check_only_inside(only_inside: Any) -> bool | str:
    """An ``only_inside`` option checked: ``False``, ``True`` or ``"half-open"`` (:data:`DOMAIN_RULES`).

    Examples
    --------
    >>> check_only_inside(1), check_only_inside("half-open")
    (True, 'half-open')
    >>> check_only_inside("open")
    Traceback (most recent call last):
    ...
    ValueError: only_inside must be False, True (the closed domain) or 'half-open' (elastix's), got 'open'
    """
    if isinstance(only_inside, str):
        if only_inside == "half-open":
            return only_inside
    elif isinstance(only_inside, bool | int | np.bool_) and int(only_inside) in (0, 1):
        return bool(only_inside)
    raise ValueError(
        f"only_inside must be False, True (the closed domain) or 'half-open' (elastix's), got {only_inside!r}"
    )


def axis_in_domain(basis: str, n: int, u: NDArray[np.float64], only_inside: bool | str = True) -> NDArray[np.bool_]:
    """Which lattice coordinates ``u`` along one axis of ``n`` control points lie in the domain (see :func:`in_domain`).

    ``basis`` is ``"bernstein"`` or the name of a local basis (all local bases share the B-spline's
    support, so its domain). NaN lies outside.

    Examples
    --------
    >>> axis_in_domain("bspline", 5, np.array([0.5, 1.0, 3.0, 3.5])).tolist()
    [False, True, True, False]
    >>> axis_in_domain("bspline", 5, np.array([1.0, 3.0]), "half-open").tolist()
    [True, False]
    """
    lo, hi = (0.0, n - 1.0) if basis == "bernstein" else (1.0, n - 2.0)
    below = u < hi if only_inside == "half-open" else u <= hi
    return (u >= lo) & below


def in_domain(
    basis: str | tuple[str, ...], shape: tuple[int, int, int], uvw: NDArray[np.float64], only_inside: bool | str = True
) -> NDArray[np.bool_]:
    """Which points lie in the lattice's domain (see ``FFD(only_inside=True)``).

    Bernstein: the box ``0 <= u <= n - 1`` (PyGeM's unit cube). B-spline: ``1 <= u <= n - 2``,
    where every support lies in the lattice (ITK's ``BSplineTransform::InsideValidRegion``).
    With ``only_inside="half-open"`` the far faces are left out (``u < n - 2``: elastix's valid region).

    Examples
    --------
    >>> in_domain("bernstein", (4, 4, 4), np.array([[0.0, 3.0, 1.0], [0.0, 3.1, 1.0]])).tolist()
    [True, False]
    >>> in_domain("bspline", (4, 4, 4), np.array([[1.0, 2.0, 1.5], [0.5, 2.0, 1.5]])).tolist()
    [True, False]
    >>> in_domain("bspline", (4, 4, 4), np.array([[1.0, 2.0, 1.5]]), "half-open").tolist()
    [False]
    """
    kind = "bernstein" if basis == "bernstein" else "local"
    inside = np.ones(len(uvw), dtype=bool)
    for axis, n in enumerate(shape):
        inside &= axis_in_domain(kind, n, uvw[:, axis], only_inside)
    return inside


def outer_uv(bu: NDArray[Any], bv: NDArray[Any]) -> NDArray[Any]:
    """Row-wise outer product of the u and v weights, ``(N, 16)`` with index ``4 * l + m``."""
    return (bu[:, :, None] * bv[:, None, :]).reshape(len(bu), -1)


class CellGroups:
    """Points grouped by the start of their B-spline support (the lattice cell that moves them).

    Points are sorted by support start so that each start's points form one contiguous run; a
    sum over a run is then one small matrix product with the 64 offsets it reads. Starts are
    clipped by :func:`clip_starts`, so points beyond the lattice read the padding of
    :func:`pad_offsets` (zeros, or the border control points).

    Examples
    --------
    >>> import numpy as np
    >>> cells = CellGroups(np.array([[1.5, 1.5, 1.5], [0.2, 0.2, 0.2], [1.7, 1.2, 1.9]]), (4, 4, 4))
    >>> cells.order.tolist(), cells.runs.tolist(), cells.run_first.tolist()
    ([1, 0, 2], [[0, 1], [1, 3]], [[-1, -1, -1], [0, 0, 0]])
    """

    def __init__(self, uvw: NDArray[np.float64], shape: tuple[int, int, int], border: str = "zero") -> None:
        n = len(uvw)
        first, t = BSPLINE.locate(uvw)
        width = BSPLINE.width
        dims = np.array(shape)
        self.border = check_border(border)
        first = clip_starts(first, dims, width)
        grid = tuple(dims + width + 1)
        cell = np.ravel_multi_index(tuple((first + width).T), grid)
        order = np.argsort(cell, kind="stable")
        cells, starts = np.unique(cell[order], return_index=True)
        self.order = order.astype(np.int32 if n < 2**31 else np.int64)
        self.t: NDArray[np.float64] | None = t[order]  # None once the weights are computed
        self.runs = np.column_stack([starts, np.r_[starts[1:], n]])
        self.run_first = np.column_stack(np.unravel_index(cells, grid)) - width

    def pad(self, offsets: NDArray[np.float64], dtype: Any = np.float64) -> NDArray[Any]:
        """Offsets padded by this grouping's border rule (see :func:`pad_offsets`)."""
        return pad_offsets(offsets, self.border, BSPLINE.width, dtype)

    def sum(self, padded: NDArray[Any], buv: NDArray[Any], bw: NDArray[Any]) -> NDArray[Any]:
        """``sum_lmn buv[4l+m] bw[n] offsets[first + (l, m, n)]`` per point, in sorted order."""
        w = BSPLINE.width
        out = np.empty((len(buv), 3), dtype=np.result_type(buv, padded))
        for (s, e), (i, j, k) in zip(self.runs, self.run_first + w, strict=True):
            # (l m) x (n d): contract the 16 (l, m) weights by BLAS, then the 4 n weights
            x = (buv[s:e] @ padded[i : i + w, j : j + w, k : k + w].reshape(w * w, w * 3)).reshape(-1, w, 3)
            np.einsum("pnd,pn->pd", x, bw[s:e], out=out[s:e])
        return out

    def unsort(self, values: NDArray[Any]) -> NDArray[Any]:
        """Values given in sorted order, returned in the points' original order."""
        out = np.empty_like(values)
        out[self.order] = values
        return out
