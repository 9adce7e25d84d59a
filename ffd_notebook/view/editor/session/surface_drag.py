"""Grabbing the mesh itself: pins and surface drags of an editing session (NumPy and the model only).

A surface drag takes a point of the rest mesh and moves its deformed position onto a target by
changing the lattice offsets the least (:meth:`ffd_notebook.ffd.deform.FFD.fit_points`), while pinned
points keep their deformed position. Every drag event solves again from the offsets the drag
started with, not from the previous event's: the result depends on where the mouse is, not on
the path it took, and the grabbed point lands exactly on the target each time.

Pins are stored as points of the REST mesh (``(Q, 3)`` world positions), not vertex ids: a click
lands inside a triangle (its barycentric rest position is exact), ``fit_points`` takes rest
positions as they are, and they stay meaningful when the mesh is decimated (vertex ids do not).
A new mesh (a loaded file) clears them. Pins are tool state, like the selection: adding or removing
one is not an undo step (an undo of a drag still moves the pinned points back with the mesh).

A :class:`SurfaceDrag` belongs to one :class:`~.session.EditingSession` (``session.surface``) and uses
its public lattice, history and notifications; :func:`ray_hit` is the scene's picking test.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ....ffd.fit import control_weights
from .script import SurfaceFit

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = ["MODES", "SurfaceDrag", "ray_hit"]

#: a drag of the mesh is refused where it would need offsets this many times the lattice's size (a strength near 0:
#: the least-norm fit divides by it), far past what the editor's float32 copy of the mesh holds
FAR_OFFSETS = 1e6
#: what a left-button drag on the view does: move the lattice's spheres, the mesh itself, or paint the
#: vertices' weights (:class:`~.weights.WeightPaint`)
MODES = ("control points", "surface", "paint weights")


@dataclass
class _Drag:
    """A surface drag in progress: the grabbed rest point and the offsets it started from."""

    point: NDArray[np.float64]  # (1, 3) rest position
    lattice: Any  # the lattice it started on (a swap of lattice ends it)
    idx: tuple[NDArray[np.intp], ...]  # the control points the grabbed point and the pins depend on
    flat: NDArray[np.intp]
    start: NDArray[np.float64]  # their offsets when the drag started
    key: object  # the undo step's merge key


class SurfaceDrag:
    """Pins, the interaction mode and surface drags of one :class:`~.session.EditingSession` (``session.surface``).

    It changes the session only through the session's public commands and state: the lattice's
    offsets and the undo history while a drag runs, :meth:`~.session.EditingSession.commit_rows`
    and :meth:`~.session.EditingSession.notify` to tell the views.

    Parameters
    ----------
    session : EditingSession
        The session whose mesh is grabbed (it makes its own: ``session.surface``).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> from ffd_notebook.view.editor.session import EditingSession
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(5, 5, 5))
    >>> session.surface.pin(0)
    0
    >>> session.surface.begin(10)
    >>> target = session.rest_points[10] + (0.0, 0.0, 0.1)
    >>> session.surface.move(target)
    >>> session.surface.end()
    >>> moved = session.ffd.deform(session.rest_points[[10, 0]])
    >>> bool(np.allclose(moved, [target, session.rest_points[0]], atol=1e-12)), len(session.history)
    (True, 1)
    """

    def __init__(self, session: EditingSession) -> None:
        self.session = session
        self.mode: str = MODES[0]
        self._pins: NDArray[np.float64] = np.empty((0, 3))
        self._drag: _Drag | None = None

    @property
    def pins(self) -> NDArray[np.float64]:
        """The pinned points, ``(Q, 3)`` positions on the rest mesh (a copy)."""
        return self._pins.copy()

    def pinned_points(self) -> NDArray[np.float64]:
        """Where the pinned points are now: ``(Q, 3)`` deformed positions."""
        return self.session.ffd.deform(self._pins) if len(self._pins) else np.empty((0, 3))

    @property
    def grabbed(self) -> NDArray[np.float64] | None:
        """The rest position of the point being dragged (``(3,)``), or None outside a surface drag."""
        return None if self._drag is None else self._drag.point[0].copy()

    # ------------------------------------------------------------------ mode and pins
    def set_mode(self, mode: str) -> None:
        """What a left-button drag in the view does: ``"control points"``, ``"surface"`` or ``"paint weights"``."""
        if mode not in MODES:
            raise ValueError(f"interaction mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        self.session.notify("display", None, "mode")

    def pin(self, vertex_or_point: Any) -> int:
        """Pin a point of the mesh (a vertex id, or a ``(3,)`` rest position); returns the pin's index."""
        point = self.rest_point(vertex_or_point)
        self._pins = np.vstack([self._pins, point[None, :]])
        self.session.notify("display", None, "pins")
        return len(self._pins) - 1

    def unpin(self, index: int) -> None:
        """Remove pin number ``index`` (of :attr:`pins`)."""
        if not isinstance(index, (int, np.integer)) or not 0 <= index < len(self._pins):
            raise ValueError(f"no pin {index!r}: there are {len(self._pins)} pins")
        self._pins = np.delete(self._pins, int(index), axis=0)
        self.session.notify("display", None, "pins")

    def clear_pins(self) -> None:
        """Remove every pin."""
        self.drop_pins()
        self.session.notify("display", None, "pins")

    def drop_pins(self) -> None:
        """Forget the pins without telling the views (a new mesh: the session tells them about the mesh)."""
        self._pins = np.empty((0, 3))

    def rest_point(self, vertex_or_point: Any) -> NDArray[np.float64]:
        """A vertex id or a ``(3,)`` position as a ``(3,)`` rest position; a ValueError otherwise.

        A position is taken as it is (a point on the rest surface, e.g. a picked one).
        """
        rest_points = self.session.rest_points
        if isinstance(vertex_or_point, (int, np.integer)):
            n = len(rest_points)
            if not 0 <= vertex_or_point < n:
                raise ValueError(f"vertex id must be in [0, {n}), got {vertex_or_point}")
            return rest_points[int(vertex_or_point)].copy()
        point = np.asarray(vertex_or_point, dtype=np.float64)
        if point.shape != (3,) or not np.isfinite(point).all():
            raise ValueError(f"a surface point must be a vertex id or three finite numbers, got {vertex_or_point!r}")
        return point

    # ------------------------------------------------------------------ the drag
    def begin(self, vertex_or_point: Any) -> None:
        """Grab a point of the mesh (a vertex id or a ``(3,)`` rest position); a new undo step starts.

        Raises a ValueError if no control point moves it (outside a "zero"-border lattice's reach).
        """
        session = self.session
        point = self.rest_point(vertex_or_point)[None, :]
        rows = np.vstack([point, self._pins])
        index, weight = control_weights(session.ffd, rows)
        if not np.any(weight[0] != 0):
            raise ValueError(f"no control point moves the point {point[0].tolist()}: it is outside the lattice")
        flat = np.unique(index[weight != 0])
        idx = np.unravel_index(flat, session.lattice.shape)
        session.history.close()
        self._drag = _Drag(point, session.lattice, idx, flat, session.lattice.offsets[idx].copy(), object())

    def move(self, target: ArrayLike, started: float | None = None) -> None:
        """Move the grabbed point's deformed position to ``target`` (``(3,)``), pins staying where they are.

        Solved from the offsets the drag started with (least-norm change, see the module
        docstring); one ``"drag"`` change naming the control points involved; the whole drag is one
        undo step.
        """
        session, drag = self.session, self._drag
        if drag is None or drag.lattice is not session.lattice:
            self._drag = None
            raise ValueError("no surface drag in progress: call surface.begin first")
        goal = np.asarray(target, dtype=np.float64)
        if goal.shape != (3,) or not np.isfinite(goal).all():
            raise ValueError(f"the drag target must be three finite numbers, got {target!r}")
        offsets = session.lattice.offsets
        previous = offsets[drag.idx].copy()
        offsets[drag.idx] = drag.start  # every event solves from the drag's start
        with np.errstate(all="ignore"):  # (judged just below)
            session.ffd.fit_points(drag.point, goal[None, :], pinned=self._pins if len(self._pins) else None)
        after = offsets[drag.idx]
        reach = FAR_OFFSETS * float(np.linalg.norm(session.lattice.spacing * session.lattice.shape))
        if not (np.all(np.isfinite(after)) and np.abs(after).max() <= reach):
            offsets[drag.idx] = previous  # as before this event
            raise ValueError("the mesh cannot be pulled there: the lattice hardly moves it (a strength near 0?)")
        ijk = np.column_stack(drag.idx)
        how = SurfaceFit(drag.point[0].copy(), goal.copy(), self._pins.copy())  # what the script does likewise
        session.history.record(ijk, drag.start, after, key=drag.key, label="surface drag", how=how)
        session.commit_rows(drag.idx, "surface drag", kind="drag", started=started)

    def end(self) -> None:
        """The mesh was released: the drag's undo step is closed (nothing happens outside a drag)."""
        drag, self._drag = self._drag, None
        if drag is None:
            return
        self.session.history.close()
        self.session.notify("offsets", drag.flat if drag.lattice is self.session.lattice else None, "surface drag")


def ray_hit(
    points: ArrayLike, triangles: ArrayLike, origin: ArrayLike, direction: ArrayLike
) -> tuple[int, NDArray[np.float64]] | None:
    """The first triangle a ray hits, and the hit's barycentric coordinates; None if it hits none.

    Hand-written so the view can pick on the deformed mesh without a locator that would have to
    be rebuilt after every drag. Seen along the ray, a triangle it crosses has vertices on both
    sides of two perpendicular lines through it; one pass over the vertices (their side codes,
    OR-ed per triangle) keeps only those, and the Moller-Trumbore test runs on them alone: a few
    ms on the 53k-vertex face, where testing every triangle takes ~70 ms (``vtkCellPicker`` ~45 ms).

    Parameters
    ----------
    points : array_like
        ``(N, 3)`` vertex positions.
    triangles : array_like
        ``(T, 3)`` vertex ids.
    origin, direction : array_like
        The ray ``origin + t * direction``, ``t >= 0``.

    Returns
    -------
    (int, numpy.ndarray) or None
        The triangle nearest to ``origin`` along the ray and the ``(3,)`` weights of its vertices
        at the hit point.

    Examples
    --------
    >>> tri = np.array([[0, 1, 2]])
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> cell, bary = ray_hit(pts, tri, (0.25, 0.25, 1.0), (0.0, 0.0, -1.0))
    >>> cell, bary.tolist()
    (0, [0.5, 0.25, 0.25])
    >>> ray_hit(pts, tri, (2.0, 2.0, 1.0), (0.0, 0.0, -1.0)) is None
    True
    """
    pts = np.asarray(points)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    # two unit vectors across the ray: each vertex's side of the two lines through it, as 4 bits
    side = np.linalg.svd(d[None, :])[2][1:]  # (2, 3), orthonormal, perpendicular to d
    across = (pts - o) @ side.T  # (N, 2)
    code = (across <= 0) @ np.array([1, 4], dtype=np.uint8) + (across >= 0) @ np.array([2, 8], dtype=np.uint8)
    code = code.astype(np.uint8)
    cand = np.flatnonzero((code[tri[:, 0]] | code[tri[:, 1]] | code[tri[:, 2]]) == 15)
    if not len(cand):
        return None
    corners = pts[tri[cand]].astype(np.float64)
    a, b, c = (corners[:, k] for k in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - a
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
    if not hit.any():
        return None
    best = np.flatnonzero(hit)[np.argmin(t[hit])]
    return int(cand[best]), np.array([1.0 - u[best] - v[best], u[best], v[best]])
