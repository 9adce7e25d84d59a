"""The lattice on screen: one line dataset, one glyph actor for all control points, and ONE drag handle.

Every control point is drawn by a single actor: a :class:`pyvista.PolyData` of the shown control
points, drawn as shaded sphere sprites (``render_points_as_spheres``), coloured per point (the
selected one in :data:`SELECTED_COLOR`). Sprites have a size in pixels; before every render the
scene's renderer sets it from the spheres' world radius (:func:`widget_radius`) seen at the shown
points' median depth, so the spheres keep their size in the world when the camera zooms and match
the drag handle. The lattice edges are one line dataset. Moving control points rewrites both points
arrays in place, so neither a drag nor a new lattice creates an actor per control point.

Measured on the 53k-face sample at 800x600 (software rendering, frame medians; the mesh alone
costs 8-11 ms): sprites 6-7 ms at 5^3 and 13-20 ms at 20^3; ``vtkGlyph3DMapper`` with an 8x5 sphere
12 ms and 90 ms (a 12x8 sphere: 33 and 276 ms); ``vtkPointGaussianMapper`` spheres 7 ms and 15-20 ms,
but with Mesa's software renderer a later render of another actor crashed (SIGSEGV in
``swrast_dri.so`` inside ``vtkOpenGLPolyDataMapper::RenderPieceDraw``) once editors had been opened
and closed in the same process (``tests/view/editor/test_app.py`` then ``test_display.py``), so
sprites it is.

Dragging goes through one ``vtkSphereWidget``, the *handle*, so a drag feels like before (VTK moves
the grabbed sphere in the view plane): an interactor observer with a higher priority than the
widget's sees each left-button press first, finds the control point under the cursor
(:meth:`LatticeActor.index_at`: the shown points projected with the camera's composite matrix in
NumPy, the hit nearest to the camera within each sphere's on-screen radius) and moves the handle
there, at the glyph's radius, before the widget picks. Between drags the handle is parked (a
vanishing radius at its control point), so a press on no sphere starts no drag: the camera turns.
The callbacks get the control point's flat C-order index ``(i * ny + j) * nz + k``, like
``lattice.offsets.reshape(-1, 3)``.

Dense lattices can show all control points, only those near the selection, or only the hull
(:data:`POINTS_SHOWN`); the lines follow the same subset (the edges between shown points), since a
line to a hidden point leads nowhere one can grab and costs as much to draw as the points.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ....ffd.lattice import Lattice
from ..session.session import POINTS_SHOWN

__all__ = [
    "AUTO_ALL_UP_TO",
    "BEHIND_KEY",
    "NEAR_RINGS",
    "XRAY_OPACITY",
    "LatticeActor",
    "shown_indices",
    "widget_radius",
]

WIDGET_COLOR = "royalblue"
SELECTED_COLOR = "gold"
LINE_COLOR = "dimgray"
#: "near" shows the control points at most this many index steps (along every axis) from the selection
NEAR_RINGS = 2
#: the parked handle's radius, as a fraction of the glyph radius: nothing to see or to grab
_PARKED = 1e-6
#: lattices with more control points than this draw 1-px lines: wide lines cost fill (software rendering)
#: and a dense lattice's wide lines cover the mesh
THIN_LINES_ABOVE = 1000
#: display "auto" shows every control point of lattices up to this size, the hull of denser ones
AUTO_ALL_UP_TO = 1000
#: the handle is a polygon sphere: a little larger than the true sphere so it covers every pixel the glyph does
#: the modifier key that grabs a control point hidden behind the mesh (Alt, Option on a Mac: VTK's camera takes
#: Shift, pan, and Ctrl, spin; and on a Mac a Ctrl-click is a right click)
BEHIND_KEY = "Alt"
#: opacity of the faint copies of the spheres drawn through the mesh (the X-ray look)
XRAY_OPACITY = 0.3
_HANDLE_SCALE = 1.04


def widget_radius(lattice: Lattice, fraction: float = 0.07) -> float:
    """Control-point sphere radius for a lattice: a fraction of its smallest spacing.

    Examples
    --------
    >>> round(widget_radius(Lattice((4, 4, 4), spacing=(10.0, 20.0, 5.0))), 6)
    0.35
    """
    return float(fraction * np.min(lattice.spacing))


def shown_indices(shape: tuple[int, int, int], mode: str, selected: int | None = None) -> NDArray[np.int64]:
    """Flat indices of the control points drawn in display ``mode`` (see :data:`POINTS_SHOWN`).

    ``"near"`` shows the points within :data:`NEAR_RINGS` index steps of ``selected`` (the hull
    while nothing is selected: somewhere to start); ``"hull"`` the boundary points; ``"auto"`` all
    of them up to :data:`AUTO_ALL_UP_TO` control points, the hull of a denser lattice (whose inner
    spheres and lines would hide the mesh and cost a third more per frame at 20^3). The selected
    point is always shown.

    Examples
    --------
    >>> len(shown_indices((5, 5, 5), "all")), len(shown_indices((5, 5, 5), "hull"))
    (125, 98)
    >>> len(shown_indices((10, 10, 10), "auto")), len(shown_indices((11, 10, 10), "auto"))
    (1000, 524)
    >>> len(shown_indices((20, 20, 20), "near", selected=0)), len(shown_indices((20, 20, 20), "near", 4210))
    (27, 125)
    >>> shown_indices((3, 3, 3), "hull", selected=13)[13 - 1 : 13 + 1].tolist()  # the centre, selected
    [12, 13]
    """
    if mode not in POINTS_SHOWN:
        raise ValueError(f"points shown must be one of {POINTS_SHOWN}, got {mode!r}")
    n = int(np.prod(shape))
    if mode == "auto":
        mode = "all" if n <= AUTO_ALL_UP_TO else "hull"
    if mode == "all":
        return np.arange(n, dtype=np.int64)
    ijk = np.indices(shape).reshape(3, -1).T
    if mode == "near" and selected is not None:
        keep = np.all(np.abs(ijk - np.unravel_index(int(selected), shape)) <= NEAR_RINGS, axis=1)
    else:
        keep = np.any((ijk == 0) | (ijk == np.asarray(shape) - 1), axis=1)
    if selected is not None:
        keep[int(selected)] = True
    return np.flatnonzero(keep).astype(np.int64)


def _line_cells(edges: NDArray[np.int64]) -> NDArray[np.int64]:
    return np.column_stack([np.full(len(edges), 2), edges]).ravel()


def _matrix(vtk_matrix: Any) -> NDArray[np.float64]:
    return np.array([[vtk_matrix.GetElement(i, j) for j in range(4)] for i in range(4)])


class LatticeActor:
    """Lattice lines, control-point glyphs and the drag handle of one lattice in one plotter.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Where to draw; the handle attaches to its interactor.
    lattice : Lattice
        The lattice shown (its deformed control points).
    on_move : callable
        ``on_move(center, index)``, called on every move of the handle while it is dragged.
    on_start, on_end : callable, optional
        ``f(index)``, called when the mouse grabs / releases a control point.
    points_shown : str
        One of :data:`POINTS_SHOWN`.
    selected : int, optional
        The selected control point's flat index (highlighted; the centre of ``"near"``).
    """

    def __init__(
        self,
        plotter: pv.Plotter,
        lattice: Lattice,
        on_move: Callable[[Any, int], None],
        on_start: Callable[[int], None] | None = None,
        on_end: Callable[[int], None] | None = None,
        *,
        points_shown: str = "all",
        selected: int | None = None,
        surface: Callable[[float, float], tuple[Any, Any, float]] | None = None,
    ) -> None:
        self.plotter = plotter
        self.surface = surface
        self.shape = lattice.shape
        self.radius = widget_radius(lattice)
        self._edges = lattice.edges()
        positions = lattice.control_points(deformed=True).reshape(-1, 3)
        self.lines = pv.PolyData(positions.copy(), lines=_line_cells(self._edges))
        self._positions = self.lines.points  # a NumPy view of the VTK points: written in place
        self.line_actor = plotter.add_mesh(
            self.lines,
            color=LINE_COLOR,
            line_width=1 if len(positions) > THIN_LINES_ABOVE else 2,
            pickable=False,
            reset_camera=False,
            render=False,
        )
        self.glyphs = pv.PolyData(positions.copy())
        self.glyphs.point_data["rgb"] = np.zeros((len(positions), 3), dtype=np.uint8)
        self.glyph_actor = plotter.add_mesh(
            self.glyphs,
            scalars="rgb",
            rgb=True,
            style="points",
            render_points_as_spheres=True,
            pickable=False,
            reset_camera=False,
            render=False,
        )
        self.xray = self._add_xray()
        self.points_shown = "all"
        self.shown = np.arange(len(positions), dtype=np.int64)
        self._selected = selected
        self._callbacks = (on_move, on_start, on_end)
        self.handle_index = 0 if selected is None else int(selected)
        self.handle = self._make_handle()
        self._dragging = False
        #: whether a press grabs a sphere (not while the editor shows part of the deformation: its blend)
        self.grabbable = True
        self._tags: list[int] = []
        self._size_tag = plotter.renderer.AddObserver("StartEvent", lambda *_: self._before_render())
        iren = self._interactor()
        if iren is not None:
            # before the handle sees a press (it has priority 0.5), put it on the control point under the cursor
            self._tags.append(iren.AddObserver("LeftButtonPressEvent", self._grab, 10.0))
        self.show_points(points_shown, selected)

    # ------------------------------------------------------------------ the handle
    def _interactor(self) -> Any:
        return self.plotter.iren.interactor if self.plotter.iren is not None else None

    def _make_handle(self) -> Any:
        from vtkmodules.vtkInteractionWidgets import vtkSphereWidget

        handle = vtkSphereWidget()
        handle.SetRepresentationToSurface()
        handle.ScaleOff()  # the right button would resize it
        handle.SetThetaResolution(16)
        handle.SetPhiResolution(12)
        for prop in (handle.GetSphereProperty(), handle.GetSelectedSphereProperty()):
            prop.SetColor(pv.Color(SELECTED_COLOR).float_rgb)
        handle.SetCenter(*self._positions[self.handle_index])
        handle.SetRadius(self.radius * _PARKED)
        iren = self._interactor()
        if iren is not None:
            handle.SetInteractor(iren)
            handle.SetCurrentRenderer(self.plotter.renderer)
            handle.On()
        handle.AddObserver("StartInteractionEvent", self._started)
        handle.AddObserver("InteractionEvent", self._moved)
        handle.AddObserver("EndInteractionEvent", self._ended)
        return handle

    def _grab(self, iren: Any, _event: str) -> None:
        """Left-button press: the handle onto the control point under the cursor (or stay parked); with
        :data:`BEHIND_KEY` held, onto one behind the mesh (:meth:`index_at`)."""
        if not self.grabbable:
            return
        index = self.index_at(*iren.GetEventPosition(), behind=bool(iren.GetAltKey()))
        if index is not None:
            self.place_handle(index)

    def place_handle(self, index: int) -> None:
        """Put the handle, at the glyphs' radius, on control point ``index`` (flat): the next press there drags it."""
        self.handle_index = int(index)
        self.handle.SetCenter(*self._positions[self.handle_index])
        self.handle.SetRadius(self.radius * _HANDLE_SCALE)

    def park_handle(self) -> None:
        """Shrink the handle to nothing at its control point: no press grabs it until :meth:`place_handle`."""
        self.handle.SetRadius(self.radius * _PARKED)
        self.handle.SetCenter(*self._positions[self.handle_index])

    def _started(self, *_: Any) -> None:
        self._dragging = True
        on_start = self._callbacks[1]
        if on_start is not None:
            on_start(self.handle_index)

    def _moved(self, *_: Any) -> None:
        self._callbacks[0](self.handle.GetCenter(), self.handle_index)

    def _ended(self, *_: Any) -> None:
        self._dragging = False
        self.park_handle()
        on_end = self._callbacks[2]
        if on_end is not None:
            on_end(self.handle_index)

    # ------------------------------------------------------------------ picking
    def display_positions(self) -> NDArray[np.float64]:
        """Every control point on screen: ``(N, 4)`` display ``x, y`` (pixels, origin bottom-left), depth
        ``z`` in [0, 1] (as ``vtkRenderer.WorldToDisplay``) and the sphere's radius in pixels.

        One matrix product: the camera's composite projection matrix (world -> clip coordinates).
        """
        ren = self.plotter.renderer
        width, height = ren.GetSize()
        x0, y0 = ren.GetOrigin()
        camera = ren.GetActiveCamera()
        aspect = ren.GetTiledAspectRatio()
        composite = _matrix(camera.GetCompositeProjectionTransformMatrix(aspect, -1.0, 1.0))
        projection = _matrix(camera.GetProjectionTransformMatrix(aspect, -1.0, 1.0))
        points = np.asarray(self._positions, dtype=np.float64)
        clip = points @ composite[:3, :3].T + composite[:3, 3]
        w = points @ composite[3, :3] + composite[3, 3]
        ndc = clip / w[:, None]
        out = np.empty((len(points), 4))
        out[:, 0] = x0 + (ndc[:, 0] + 1.0) * width / 2.0
        out[:, 1] = y0 + (ndc[:, 1] + 1.0) * height / 2.0
        out[:, 2] = (ndc[:, 2] + 1.0) / 2.0
        out[:, 3] = self.radius * abs(projection[1, 1]) * height / 2.0 / np.abs(w)
        return out

    def _before_render(self) -> None:
        layer, main = self.xray[0], self.plotter.renderer
        if layer.GetActiveCamera() is not main.GetActiveCamera():  # (a camera replaced, not moved)
            layer.SetActiveCamera(main.GetActiveCamera())
        self.fit_point_size()

    def fit_point_size(self) -> float:
        """Set the sprites' size (pixels) to the spheres' on-screen diameter at the shown points' median depth.

        Called before every render of the plotter's renderer; returns the size set.
        """
        radii = self.display_positions()[self.shown, 3] if len(self.shown) else np.ones(1)
        size = float(max(2.0, 2.0 * np.median(radii)))
        for prop in (self.glyph_actor.GetProperty(), self.xray[1].GetProperty()):
            if prop.GetPointSize() != size:
                prop.SetPointSize(size)
        return size

    def index_at(self, x: float, y: float, *, behind: bool = False) -> int | None:
        """Flat index of the shown control point under display position ``(x, y)`` (pixels, origin
        bottom-left) that a press there grabs, or None (the camera turns).

        A sphere is grabbed only if it begins in front of the mesh surface under the cursor (:attr:`surface`:
        the distance along the view ray to the mesh, found by the NumPy ray test): the nearest such sphere.
        A sphere hidden by the mesh is grabbed only with ``behind`` (:data:`BEHIND_KEY` held): the nearest
        hidden one, else the nearest in front.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> editor = Editor(pv.Sphere(), shape=(3, 3, 3), window_size=(200, 150))
        >>> actor = editor.scene.lattice_actor
        >>> x, y, depth, radius = actor.display_positions()[26]
        >>> actor.index_at(x, y), actor.index_at(x + 1.5 * radius, y) in (None, 26)
        (26, False)
        >>> editor.close()
        """
        screen = self.display_positions()[self.shown]
        hit = np.hypot(screen[:, 0] - x, screen[:, 1] - y) <= screen[:, 3]
        hit &= (screen[:, 2] >= 0.0) & (screen[:, 2] <= 1.0)  # in front of the camera, within the clipping range
        if not hit.any():
            return None
        candidates = np.flatnonzero(hit)
        candidates = candidates[np.argsort(screen[candidates, 2], kind="stable")]  # the nearest first
        if self.surface is None:
            return int(self.shown[candidates[0]])
        visible = self.in_front(self.shown[candidates], x, y)
        if behind and not visible.all():
            return int(self.shown[candidates[np.argmin(visible)]])
        return int(self.shown[candidates[np.argmax(visible)]]) if visible.any() else None

    def in_front(self, indices: ArrayLike, x: float, y: float) -> NDArray[np.bool_]:
        """Whether each control point of ``indices`` (flat) begins in front of the mesh along the view ray
        through display position ``(x, y)``: its sphere's nearest point on the ray (centre minus radius) comes
        before the ray's first hit on the mesh (all True off the mesh, or without :attr:`surface`)."""
        indices = np.asarray(indices, dtype=np.int64)
        if self.surface is None:
            return np.ones(len(indices), dtype=bool)
        origin, direction, distance = self.surface(x, y)
        begins = (np.asarray(self._positions, dtype=np.float64)[indices] - origin) @ direction - self.radius
        return begins <= distance

    # ------------------------------------------------------------------ the X-ray look
    def _add_xray(self) -> tuple[Any, Any]:
        """The spheres again, faint (:data:`XRAY_OPACITY`), in a renderer layer drawn over the scene: those the
        mesh hides show through it, so the user knows they are there (and that :data:`BEHIND_KEY` reaches them).
        Over a visible sphere the faint copy is the same colour: nothing changes there. Returns
        ``(renderer, actor)``."""
        from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer

        main = self.plotter.renderer
        window = self.plotter.render_window
        layer = vtkRenderer()
        layer.SetLayer(max(1, window.GetNumberOfLayers()))
        window.SetNumberOfLayers(layer.GetLayer() + 1)
        layer.InteractiveOff()  # mouse events go to the scene's renderer
        layer.SetViewport(main.GetViewport())
        layer.SetActiveCamera(main.GetActiveCamera())
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(self.glyphs)
        mapper.SetScalarModeToUsePointFieldData()
        mapper.SelectColorArray("rgb")
        mapper.SetColorModeToDirectScalars()
        actor = vtkActor()
        actor.SetMapper(mapper)
        actor.PickableOff()
        prop = actor.GetProperty()
        prop.SetRepresentationToPoints()
        prop.RenderPointsAsSpheresOn()
        prop.SetOpacity(XRAY_OPACITY)
        prop.LightingOff()
        layer.AddActor(actor)
        window.AddRenderer(layer)
        return layer, actor

    # ------------------------------------------------------------------ what is shown
    def show_points(self, mode: str, selected: int | None = None) -> None:
        """Draw the control points (and the lines between them) of display ``mode`` (:data:`POINTS_SHOWN`),
        with ``selected`` (a flat index, or None) highlighted."""
        shown = shown_indices(self.shape, mode, selected)
        self.points_shown, self._selected = mode, selected
        if not np.array_equal(shown, self.shown) or self.glyphs.n_points != len(shown):
            self.shown = shown
            mask = np.zeros(len(self._positions), dtype=bool)
            mask[shown] = True
            edges = self._edges if len(shown) == len(mask) else self._edges[mask[self._edges].all(axis=1)]
            self.lines.lines = _line_cells(edges)
            glyphs = pv.PolyData(np.asarray(self._positions)[shown])
            glyphs.point_data["rgb"] = np.zeros((len(shown), 3), dtype=np.uint8)
            self.glyphs.copy_from(glyphs)  # the same dataset (the actor's input), new size
        self._color_glyphs()
        if not self._dragging and self.handle_index not in set(shown.tolist()):
            self.handle_index = int(shown[0]) if len(shown) else 0
            self.park_handle()

    def _color_glyphs(self) -> None:
        rgb = self.glyphs.point_data["rgb"]
        rgb[:] = pv.Color(WIDGET_COLOR).int_rgb
        if self._selected is not None:
            rgb[self.shown == self._selected] = pv.Color(SELECTED_COLOR).int_rgb
        self.glyphs.point_data.GetArray("rgb").Modified()

    def highlight(self, index: int | None) -> None:
        """Draw control point ``index`` (flat) in the selection colour, the others normally; in ``"near"``
        mode the shown points follow it."""
        if self.points_shown == "near" or (self.points_shown in ("hull", "auto") and index is not None):
            self.show_points(self.points_shown, index)
        else:
            self._selected = index
            self._color_glyphs()

    def set_visible(self, visible: bool) -> None:
        """Draw the lattice (lines and spheres), or not (an animation without it)."""
        for actor in (self.line_actor, self.glyph_actor, self.xray[1]):
            actor.SetVisibility(bool(visible))

    # ------------------------------------------------------------------ moving
    def set_line_points(self, positions: ArrayLike) -> None:
        """Write all ``(N, 3)`` control-point positions into the lines and the glyphs, in place."""
        self._positions[:] = positions
        self.lines.GetPoints().Modified()
        self.glyphs.points[:] = self._positions[self.shown]
        self.glyphs.GetPoints().Modified()

    def set_widget_centers(self, positions: ArrayLike, indices: ArrayLike | None = None) -> None:
        """Control points moved by an edit other than a drag: keep the (parked) handle on its point."""
        if not self._dragging:
            self.handle.SetCenter(*np.asarray(positions, dtype=np.float64).reshape(-1, 3)[self.handle_index])

    def remove(self) -> None:
        """Remove the handle, the glyphs and the line actor from the plotter."""
        iren = self._interactor()
        for tag in self._tags:
            iren.RemoveObserver(tag)
        self._tags = []
        self.handle.RemoveAllObservers()
        if iren is not None:
            enabled = iren.GetEnableRender()
            iren.EnableRenderOff()  # Off() would render
            try:
                self.handle.Off()
            finally:
                iren.SetEnableRender(enabled)
        self.handle.SetInteractor(None)
        self.plotter.renderer.RemoveObserver(self._size_tag)
        self.plotter.remove_actor([self.line_actor, self.glyph_actor], reset_camera=False, render=False)
        layer, actor = self.xray
        layer.RemoveActor(actor)
        if self.plotter.render_window is not None:
            self.plotter.render_window.RemoveRenderer(layer)
