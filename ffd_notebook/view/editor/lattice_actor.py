"""The lattice on screen: one line dataset for all lattice edges and one sphere widget per control point.

The lines are a single :class:`pyvista.PolyData` (points = control points, one line cell per
lattice edge) drawn by one actor; moving control points rewrites its points array in place, so
a drag never creates or removes an actor. The sphere widgets are VTK ``vtkSphereWidget``\\ s made
by :meth:`pyvista.Plotter.add_sphere_widget`; their flat index is the control point's C-order
index ``(i * ny + j) * nz + k``, like ``lattice.offsets.reshape(-1, 3)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ...lattice import Lattice

__all__ = ["LatticeActor", "widget_radius"]

WIDGET_COLOR = "royalblue"
SELECTED_COLOR = "gold"
LINE_COLOR = "dimgray"


def widget_radius(lattice: Lattice, fraction: float = 0.07) -> float:
    """Sphere-widget radius for a lattice: a fraction of its smallest spacing.

    Examples
    --------
    >>> round(widget_radius(Lattice((4, 4, 4), spacing=(10.0, 20.0, 5.0))), 6)
    0.35
    """
    return float(fraction * np.min(lattice.spacing))


def _line_cells(lattice: Lattice) -> NDArray[np.int64]:
    edges = lattice.edges()
    return np.column_stack([np.full(len(edges), 2), edges]).ravel()


class LatticeActor:
    """Lattice lines and control-point widgets of one lattice in one plotter.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Where to draw; the sphere widgets attach to its interactor.
    lattice : Lattice
        The lattice shown (its deformed control points).
    on_move : callable
        ``on_move(center, index)``, called on every widget move (``interaction_event="always"``).
    on_start, on_end : callable, optional
        ``f(index)``, called when the mouse grabs / releases a widget.
    """

    def __init__(
        self,
        plotter: pv.Plotter,
        lattice: Lattice,
        on_move: Callable[[Any, int], None],
        on_start: Callable[[int], None] | None = None,
        on_end: Callable[[int], None] | None = None,
    ) -> None:
        self.plotter = plotter
        self.shape = lattice.shape
        positions = lattice.control_points(deformed=True).reshape(-1, 3)
        self.lines = pv.PolyData(positions.copy(), lines=_line_cells(lattice))
        self.line_actor = plotter.add_mesh(
            self.lines, color=LINE_COLOR, line_width=2, pickable=False, reset_camera=False, render=False
        )
        self._line_points = self.lines.points  # a NumPy view of the VTK points: written in place
        self.radius = widget_radius(lattice)
        # coarser spheres for big lattices (an 11x12x11 .ffd has 1452): they are drawn every frame
        theta, phi = (16, 12) if len(positions) <= 500 else (10, 8)
        widgets = plotter.add_sphere_widget(
            on_move,
            center=positions,
            radius=self.radius,
            color=[WIDGET_COLOR] * len(positions),
            selected_color=SELECTED_COLOR,
            interaction_event="always",
            test_callback=False,
            theta_resolution=theta,
            phi_resolution=phi,
        )
        self.widgets: list[Any] = list(widgets)
        for index, widget in enumerate(self.widgets):
            widget.AddObserver("StartInteractionEvent", lambda *_: self._restore_pickable())
            if on_start is not None:
                widget.AddObserver("StartInteractionEvent", lambda *_, i=index: on_start(i))
            if on_end is not None:
                widget.AddObserver("EndInteractionEvent", lambda *_, i=index: on_end(i))
        self._highlighted: int | None = None
        self._restricted = False  # only the sphere under the last click is pickable
        self._sphere_actors = self._find_sphere_actors()
        self._actor_index = {a.__this__: i for i, a in enumerate(self._sphere_actors) if a is not None}
        self._picker: Any = None
        # before the widgets see a click (higher priority), make only the nearest sphere under it pickable
        iren = plotter.iren.interactor if plotter.iren is not None else None
        self._tags = []
        if iren is not None:
            self._tags.append(iren.AddObserver("LeftButtonPressEvent", self._grab_nearest, 10.0))
            self._tags.append(iren.AddObserver("LeftButtonReleaseEvent", lambda *_: self._restore_pickable(), 10.0))

    def _find_sphere_actors(self) -> list[Any]:
        """Each widget's sphere actor (VTK does not expose it; it is the actor drawn with the widget's property)."""
        by_property = {}
        for actor in self.plotter.renderer.GetActors():
            by_property[actor.GetProperty().__this__] = actor
        return [by_property.get(w.GetSphereProperty().__this__) for w in self.widgets]

    def nearest_widget_at(self, x: float, y: float) -> int | None:
        """Index of the nearest sphere under display position ``(x, y)`` (pixels, origin bottom-left), or None.

        Uses a ``vtkCellPicker`` over the sphere actors only, the geometry the widgets pick with
        themselves, and takes the hit nearest to the camera.
        """
        from vtkmodules.vtkRenderingCore import vtkCellPicker

        if self._picker is None:
            self._picker = vtkCellPicker()
            self._picker.SetTolerance(0.0005)
            self._picker.PickFromListOn()
            for actor in self._sphere_actors:
                if actor is not None:
                    self._picker.AddPickList(actor)
        if not self._picker.Pick(x, y, 0.0, self.plotter.renderer):
            return None
        return self._actor_index.get(self._picker.GetActor().__this__)

    def _grab_nearest(self, iren: Any, _event: str) -> None:
        """VTK hands a click to the first widget (in creation order) whose sphere is under the cursor, even
        one hidden behind another; leaving only the nearest sphere pickable makes the visible one move."""
        nearest = self.nearest_widget_at(*iren.GetEventPosition())
        if nearest is None:
            return
        for index, actor in enumerate(self._sphere_actors):
            if actor is not None:
                actor.SetPickable(index == nearest)
        self._restricted = True

    def _restore_pickable(self) -> None:
        """Every sphere pickable again (once the press has been handed to a widget, or the button released)."""
        if self._restricted:
            for actor in self._sphere_actors:
                if actor is not None:
                    actor.PickableOn()
            self._restricted = False

    def set_line_points(self, positions: ArrayLike) -> None:
        """Write all ``(N, 3)`` control-point positions into the line dataset, in place."""
        self._line_points[:] = positions
        self.lines.GetPoints().Modified()

    def set_widget_centers(self, positions: ArrayLike, indices: ArrayLike | None = None) -> None:
        """Move widgets (all, or those of the flat ``indices``) to ``positions`` (``(N, 3)`` for all)."""
        pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        which = range(len(self.widgets)) if indices is None else np.asarray(indices, dtype=np.int64).ravel()
        for i in which:
            self.widgets[int(i)].SetCenter(*pos[int(i)])

    def highlight(self, index: int | None) -> None:
        """Draw widget ``index`` in the selection colour (and the previous one normally again)."""
        if self._highlighted is not None and self._highlighted < len(self.widgets):
            self.widgets[self._highlighted].GetSphereProperty().SetColor(pv.Color(WIDGET_COLOR).float_rgb)
        if index is not None:
            self.widgets[index].GetSphereProperty().SetColor(pv.Color(SELECTED_COLOR).float_rgb)
        self._highlighted = index

    def remove(self) -> None:
        """Remove the widgets and the line actor from the plotter."""
        for widget in self.widgets:
            widget.RemoveAllObservers()
        for tag in self._tags:
            self.plotter.iren.interactor.RemoveObserver(tag)
        self._tags = []
        # each widget's Off() asks the interactor to render: N renders for N widgets unless disabled
        iren = self.plotter.iren.interactor if self.plotter.iren is not None else None
        enabled = iren.GetEnableRender() if iren is not None else None
        if iren is not None:
            iren.EnableRenderOff()
        try:
            self.plotter.widgets.clear_sphere_widgets()
        finally:
            if iren is not None:
                iren.SetEnableRender(enabled)
        self.widgets = []
        self.plotter.remove_actor(self.line_actor, reset_camera=False, render=False)
