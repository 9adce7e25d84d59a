"""The mouse on the mesh itself (surface mode): pick a point, drag it, click to pin; pins drawn in red.

In the session's ``"surface"`` interaction mode this object takes the left button before anything
else: its interactor observers have a higher priority (:data:`PRIORITY`) than the lattice actor's
(10) and the sphere widgets', and it sets the command's abort flag on every event it takes, so no
sphere handle and no camera style sees it.

- Press on the mesh: the point under the cursor is picked (:func:`.surface_drag.ray_hit` on the
  plotted, deformed mesh; its rest position is the triangle's rest corners at the hit's barycentric
  coordinates). Moving more than :data:`CLICK_PX` pixels starts a surface drag in the plane through
  the grabbed point parallel to the view plane; release ends it (one undo step).
- A click without movement toggles a pin: on a pin (within :data:`PIN_PX`) it removes it,
  elsewhere on the mesh it pins the point under the cursor.
- Press off the mesh (and off every pin) rotates the camera as usual: the press is handed to the
  interactor style directly, so the sphere widgets never see it.

In ``"paint weights"`` mode a press on the mesh starts a brush stroke and every move over the mesh
paints at the point under the cursor (:class:`~..session.weights.WeightPaint`); release ends the
stroke (one undo step); a press off the mesh rotates the camera. In ``"control points"`` mode it does
nothing. The pins are one point actor (drawn as red spheres)
whose points follow the session's changes.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
import pyvista as pv
from numpy.typing import NDArray

from ..session.changes import Change
from ..session.surface_drag import ray_hit

if TYPE_CHECKING:
    from .scene import EditorScene

__all__ = ["CLICK_PX", "PIN_COLOR", "PIN_DEPTH", "PIN_PX", "PRIORITY", "SurfacePicking"]

PRIORITY = 20.0  # above the lattice actor's observers (10) and every widget's
CLICK_PX = 3.0  # a press and release closer than this (pixels) is a click
PIN_PX = 8.0  # a click this close to a pin (pixels) removes it
PIN_COLOR = "red"
PIN_DEPTH = 0.02  # a pin this far (a fraction of the mesh's size) behind the surface under the cursor is hidden


class SurfacePicking:
    """Surface picking, dragging and pins of one :class:`~.scene.EditorScene` (see the module docstring).

    Parameters
    ----------
    scene : EditorScene
        Its plotter, plotted mesh (``scene.display``) and session.
    """

    def __init__(self, scene: EditorScene) -> None:
        self.scene = scene
        self.session = scene.session
        self.plotter = scene.plotter
        self._triangles: tuple[Any, NDArray[np.int64]] | None = None  # (the mesh they belong to, (T, 3))
        self._press: dict[str, Any] | None = None  # the press being handled (None: not ours)
        self.pin_cloud = pv.PolyData(np.zeros((1, 3)))  # never empty (PyVista does not plot empty meshes)
        self.pin_actor = self.plotter.add_mesh(
            self.pin_cloud,
            color=PIN_COLOR,
            point_size=12,
            render_points_as_spheres=True,
            pickable=False,
            reset_camera=False,
            render=False,
        )
        self.update_pins()
        iren = self.plotter.iren.interactor if self.plotter.iren is not None else None
        self._iren = iren
        self._tags: dict[str, int] = {}
        if iren is not None:
            for event, method in (
                ("LeftButtonPressEvent", self._on_press),
                ("MouseMoveEvent", self._on_move),
                ("LeftButtonReleaseEvent", self._on_release),
            ):
                self._tags[event] = iren.AddObserver(event, method, PRIORITY)

    # ------------------------------------------------------------------ following the session
    def follow(self, change: Change) -> None:
        """Keep the pins on the deformed mesh (called by the scene before it renders)."""
        if change.kind in ("drag", "offsets", "lattice", "mesh", "display"):
            self.update_pins()

    def update_pins(self) -> None:
        """Write the pins' deformed positions into the pin actor (points in place while their number holds)."""
        shown = self.session.surface.pinned_points()
        if len(shown) == 0:
            self.pin_actor.VisibilityOff()
            return
        if self.pin_cloud.n_points == len(shown):
            self.pin_cloud.points[:] = shown
            self.pin_cloud.GetPoints().Modified()
        else:
            self.pin_cloud.points = shown
            self.pin_cloud.verts = np.column_stack([np.ones(len(shown), dtype=np.int64), np.arange(len(shown))])
        self.pin_actor.VisibilityOn()

    # ------------------------------------------------------------------ geometry
    def triangles(self) -> NDArray[np.int64]:
        """The plotted mesh's faces as ``(T, 3)`` vertex ids (triangulated once per mesh)."""
        mesh = self.scene.display
        if self._triangles is None or self._triangles[0] is not mesh:
            surface = mesh if mesh.is_all_triangles else mesh.triangulate()
            self._triangles = (mesh, np.asarray(surface.faces, dtype=np.int64).reshape(-1, 4)[:, 1:])
        return self._triangles[1]

    def display_to_world(self, x: float, y: float, z: float) -> NDArray[np.float64]:
        """World point at display position ``(x, y)`` (pixels, origin bottom-left) and depth ``z`` in [0, 1]."""
        ren = self.plotter.renderer
        ren.SetDisplayPoint(x, y, z)
        ren.DisplayToWorld()
        w = np.array(ren.GetWorldPoint())
        return w[:3] / w[3]

    def world_to_display(self, points: Any) -> NDArray[np.float64]:
        """``(N, 3)`` world points -> ``(N, 3)`` display positions (x, y pixels; z depth)."""
        ren = self.plotter.renderer
        out = []
        for p in np.asarray(points, dtype=np.float64).reshape(-1, 3):
            ren.SetWorldPoint(*p, 1.0)
            ren.WorldToDisplay()
            out.append(ren.GetDisplayPoint())
        return np.array(out, dtype=np.float64).reshape(-1, 3)

    def pick(self, x: float, y: float) -> NDArray[np.float64] | None:
        """The rest position of the mesh point under display position ``(x, y)``, or None (off the mesh)."""
        near, far = self.display_to_world(x, y, 0.0), self.display_to_world(x, y, 1.0)
        triangles = self.triangles()
        found = ray_hit(self.scene.display_points, triangles, near, far - near)
        if found is None:
            return None
        cell, bary = found
        return bary @ self.session.rest_points[triangles[cell]]

    def ray_to_surface(self, x: float, y: float) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """The view ray through display position ``(x, y)``: its origin (on the near clipping plane), its unit
        direction, and the distance along it to the first hit on the plotted mesh (``inf`` off the mesh).
        The NumPy ray test (:func:`ray_hit`, a few ms on a 53k-vertex mesh), on the deformed mesh as drawn."""
        near, far = self.display_to_world(x, y, 0.0), self.display_to_world(x, y, 1.0)
        direction = (far - near) / np.linalg.norm(far - near)
        triangles = self.triangles()
        found = ray_hit(self.scene.display_points, triangles, near, direction)
        if found is None:
            return near, direction, float("inf")
        cell, bary = found
        hit = bary @ np.asarray(self.scene.display_points, dtype=np.float64)[triangles[cell]]
        return near, direction, float((hit - near) @ direction)

    def pin_at(self, x: float, y: float, *, behind: bool = False) -> int | None:
        """Index of the pin nearest to display position ``(x, y)`` within :data:`PIN_PX` pixels, or None.

        Pins are on the mesh: one the mesh hides (further along the view ray than the surface under the
        cursor, by more than :data:`PIN_DEPTH` of the mesh's size) counts only with ``behind`` (the
        lattice's :data:`~.lattice_actor.BEHIND_KEY` held), the same rule as for control points.
        """
        shown = self.session.surface.pinned_points()
        if not len(shown):
            return None
        dist = np.hypot(*(self.world_to_display(shown)[:, :2] - (x, y)).T)
        near = dist <= PIN_PX
        if not behind and near.any():
            origin, direction, surface = self.ray_to_surface(x, y)
            size = float(np.linalg.norm(np.ptp(self.scene.display_points, axis=0)))
            near &= (shown - origin) @ direction <= surface + PIN_DEPTH * size
        if not near.any():
            return None
        return int(np.flatnonzero(near)[np.argmin(dist[near])])

    # ------------------------------------------------------------------ mouse events
    def _take(self, event: str) -> None:
        """This event is ours: lower-priority observers (spheres, lattice actor, camera style) skip it."""
        assert self._iren is not None  # events only come through the interactor
        self._iren.GetCommand(self._tags[event]).SetAbortFlag(1)

    def _on_press(self, iren: Any, event: str) -> None:
        if self.session.blend != 1.0:  # part of the deformation shown (the blend slider): the press turns the camera
            return
        mode = self.session.surface.mode
        if mode == "paint weights":
            self._take(event)
            x, y = iren.GetEventPosition()
            point = self.pick(x, y)
            if point is None:
                self._rotate(iren)
                return
            self._press = {"paint": True}
            self.session.attempt(self.session.paint.begin)
            self.session.attempt(self.session.paint.stroke, point)
            return
        if mode != "surface":
            return
        self._take(event)
        x, y = iren.GetEventPosition()
        pin, point = self.pin_at(x, y, behind=bool(iren.GetAltKey())), self.pick(x, y)
        if pin is None and point is None:
            self._rotate(iren)
            return
        self._press = {"xy": (x, y), "point": point, "pin": pin, "dragging": False, "depth": 0.0}

    @staticmethod
    def _rotate(iren: Any) -> None:
        """A press off the mesh: rotate the camera as usual, without the sphere widgets seeing the press."""
        style = iren.GetInteractorStyle()
        if style is not None:
            style.OnLeftButtonDown()

    def _on_move(self, iren: Any, event: str) -> None:
        press = self._press
        if press is None:
            return
        self._take(event)
        x, y = iren.GetEventPosition()
        if press.get("paint"):
            started = time.perf_counter()
            point = self.pick(x, y)
            if point is not None:
                self.session.attempt(lambda: self.session.paint.stroke(point, started=started))
            return
        if not press["dragging"]:
            if np.hypot(x - press["xy"][0], y - press["xy"][1]) < CLICK_PX or press["point"] is None:
                return
            if not self.session.attempt(self.session.surface.begin, press["point"]):
                self._press = None
                return
            press["dragging"] = True
            # the drag plane: through the grabbed point, parallel to the view plane (constant display depth)
            press["depth"] = self.world_to_display(self.session.ffd.deform(press["point"][None, :]))[0, 2]
        started = time.perf_counter()
        target = self.display_to_world(x, y, press["depth"])
        self.session.attempt(self.session.surface.move, target, started)

    def _on_release(self, iren: Any, event: str) -> None:
        press, self._press = self._press, None
        if press is None:
            return
        self._take(event)
        if press.get("paint"):
            self.session.attempt(self.session.paint.end)
        elif press["dragging"]:
            self.session.attempt(self.session.surface.end)
        elif press["pin"] is not None:
            self.session.attempt(self.session.surface.unpin, press["pin"])
        elif press["point"] is not None:
            self.session.attempt(self.session.surface.pin, press["point"])

    def remove(self) -> None:
        """Stop listening to the mouse and remove the pin actor."""
        if self._iren is not None:
            for tag in self._tags.values():
                self._iren.RemoveObserver(tag)
        self._tags = {}
        self.plotter.remove_actor(self.pin_actor, reset_camera=False, render=False)
