"""The editor's VTK scene: a plotter showing the session's mesh inside its lattice of draggable control points.

The scene follows an :class:`~.session.EditingSession` (it subscribes to it) and never computes a
deformation: on a ``"drag"`` or ``"offsets"`` change it copies the session's deformed points into
the plotted mesh's points array in place and moves the lattice lines and control-point spheres
(and, for edits not made by dragging, the parked drag handle). No actor is created or removed while
dragging. A loaded mesh's plotted copy and normals may come ready-made from a worker thread
(:func:`prepare_display`, :meth:`EditorScene.offer_display`). While a mouse button is held, a large
mesh is drawn from a lighter copy (:mod:`.proxy`).
After every change except drag events and messages the scene asks its browser views
(:class:`~ffd_notebook.view.serving.jupyter.BrowserViews`) for a new frame, or renders itself when none is
attached; during a drag, the view renders when it sends the image.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ....meshing import color_array_name
from ...rendering.camera import frame_camera
from ...rendering.plotters import new_plotter
from ...serving.jupyter import release_views, views_of
from ..session.changes import Change
from ..session.session import EditingSession
from . import coloring
from .image_slices import ImageSlices
from .lattice_actor import LatticeActor
from .proxy import INTERACTIVE_CELLS, InteractiveProxy, point_normals, simplified
from .surface_picking import SurfacePicking

__all__ = ["EditorScene", "PreparedDisplay", "prepare_display"]

#: where the camera looks from (towards the mesh): the front (+z), a little right and above
FRONT = (0.3, 0.2, 1.0)
#: the opacity of an image's box drawn as the mesh (a lattice over the image alone): the slices are inside it
IMAGE_BOX_OPACITY = 0.35


class PreparedDisplay:
    """The plotted copy of a mesh, its point-normals filter and its interactive copy's geometry
    (:func:`~.proxy.simplified` with ``cells``), made by :func:`prepare_display`."""

    def __init__(self, source: Any, display: pv.PolyData, normals: Any, proxy: Any, cells: int | None) -> None:
        self.source, self.display, self.normals = source, display, normals
        self.proxy, self.cells = proxy, cells


def prepare_display(
    mesh: pv.PolyData, points: ArrayLike, interactive_cells: int | None = INTERACTIVE_CELLS
) -> PreparedDisplay:
    """What the scene plots for ``mesh`` at ``points``: a deep copy (its points written in place while
    dragging), a ``vtkPolyDataNormals`` filter on it, already run (:func:`~.proxy.point_normals`),
    and the vertices and faces of the lighter copy drawn while a button is held (None for a mesh
    under twice ``interactive_cells`` cells).

    Only new objects: safe in a worker thread, so the app's loads do the copy, the normals (0.1 s
    on a 500k-point mesh) and the clustering there and its event loop only swaps the actors.

    Examples
    --------
    >>> prepared = prepare_display(pv.Sphere(), pv.Sphere().points * 2)
    >>> prepared.normals.GetOutput().GetPointData().GetNormals().GetNumberOfTuples() == prepared.display.n_points
    True
    >>> prepared.proxy is None  # 1680 triangles: drawn as they are
    True
    """
    display = mesh.copy(deep=True)
    display.points[:] = points
    proxy = simplified(display, interactive_cells)
    return PreparedDisplay(mesh, display, point_normals(display), proxy, interactive_cells)


class EditorScene:
    """Plotter, mesh actor and lattice actor of one editing session.

    Parameters
    ----------
    session : EditingSession
        What to show; the scene subscribes to it.
    on_start, on_move, on_end : callable
        Sphere-widget callbacks: ``on_start(index)``, ``on_move(center, index)``, ``on_end(index)``.
    window_size : tuple of int
        Render window size in pixels.
    off_screen : bool
        Render off-screen.
    interactive_cells : int or None
        While a mouse button is held, a mesh with at least twice as many cells is drawn from a copy
        with about this many (:mod:`.proxy`); None always draws the full mesh.
    """

    def __init__(
        self,
        session: EditingSession,
        *,
        on_start: Callable[[int], None],
        on_move: Callable[[Any, int], None],
        on_end: Callable[[int], None],
        window_size: tuple[int, int] = (800, 600),
        off_screen: bool = True,
        interactive_cells: int | None = INTERACTIVE_CELLS,
    ) -> None:
        self.session = session
        #: whether the scene renders after each change (a recording renders each frame once, itself)
        self.auto_render = True
        self.interactive_cells = interactive_cells
        self._callbacks = (on_move, on_start, on_end)
        self.plotter = new_plotter(off_screen=off_screen, window_size=window_size)
        if off_screen and self.plotter.iren is not None:
            # Nobody looks at an off-screen window: the interactor need not render inside every
            # mouse event (trame renders when it sends the image; the scene renders after the
            # session's changes). Saves a render per drag event and one per widget when widgets are removed.
            self.plotter.iren.interactor.EnableRenderOff()
        self.views = views_of(self.plotter)
        self.views.on_error = lambda text: session.messages.append(f"Error: {text}")
        self.mesh_actor: Any = None
        self.proxy: InteractiveProxy | None = None
        self.interacting = False
        self._button_tags = self._watch_buttons()
        self.lattice_actor: LatticeActor | None = None
        self._offered: PreparedDisplay | None = None
        self._shown_lattice: Any = None
        self.image_slices: ImageSlices | None = None
        self._build_mesh()
        self._build_lattice()
        self._build_image()
        self.surface_picking = SurfacePicking(self)  # surface mode: the mouse on the mesh itself, pins
        self._unsubscribe = session.subscribe(self.follow)

    # ------------------------------------------------------------------ following the session
    def follow(self, change: Change) -> None:
        """Bring the scene up to date with one change of the session (see the module docstring)."""
        kind = change.kind
        if kind == "message":
            return
        if kind in ("drag", "offsets"):
            # a surface drag moves control points that no handle holds: their spheres follow too
            self._move_points(change.points, widgets=kind == "offsets" or change.label == "surface drag")
        elif kind == "lattice":
            self._build_lattice()
        elif kind == "mesh":
            self._build_mesh()
            if change.label == "load mesh":
                self.plotter.renderer.reset_camera(render=False)  # (the plotter's own renders anyway)
            elif change.label == "face from photo":  # a face looks along +z: see it from the front, fitted
                self.frame()  # (the session holds the new mesh and its lattice already)
            if self.session.lattice is not self._shown_lattice:
                return  # a "lattice" change follows (a lattice fitted to the new mesh): render once, then
        elif kind == "select":
            assert self.lattice_actor is not None  # built with the scene
            self.lattice_actor.highlight(self._selected_index())
        elif kind == "display" and change.label == "blend":  # the mesh and the spheres where t puts them
            assert self.lattice_actor is not None  # built with the scene
            self._move_points(None, widgets=True)
            self.lattice_actor.grabbable = self.session.blend == 1.0
        elif kind == "display" and change.label == "points":
            assert self.lattice_actor is not None  # built with the scene
            self.lattice_actor.show_points(self.session.points_shown, self._selected_index())
        elif kind == "display":
            self._write_field()
            self._recolor()
        elif kind == "image":
            if change.label == "load image":
                self._build_image()
            elif self.image_slices is not None:
                self.image_slices.update(rebuild=change.label == "slices")
        if kind in ("offsets", "lattice") and self.image_slices is not None:
            self.image_slices.update()  # (a drag's slices are updated just before the frame is rendered)
        self.surface_picking.follow(change)
        if kind != "drag" and change.label != "drag":
            self.render()

    def _selected_index(self) -> int | None:
        selected = self.session.selected
        return None if selected is None else self.session.flat_index(selected)

    def _move_points(self, points: NDArray[np.intp] | None, widgets: bool, only_if_changed: bool = False) -> None:
        """Session -> view: deformed mesh points, lattice lines, (the handle), field colors."""
        self._write_mesh_points(only_if_changed)
        positions = self.session.shown_control_points()
        assert self.lattice_actor is not None  # built with the scene
        self.lattice_actor.set_line_points(positions)
        if widgets:
            self.lattice_actor.set_widget_centers(positions, points)
        if self.session.field is not None:
            self._write_field()

    # ------------------------------------------------------------------ building
    def offer_display(self, prepared: PreparedDisplay) -> None:
        """Use ``prepared`` (from :func:`prepare_display`, e.g. in a worker thread) when the session's mesh
        becomes ``prepared.source``, instead of copying it and computing normals then."""
        self._offered = prepared

    def _build_mesh(self) -> None:
        """Show the session's mesh (a copy whose points are written in place); replaces any previous actor."""
        prepared, self._offered = self._offered, None
        if prepared is None or prepared.source is not self.session.mesh or prepared.cells != self.interactive_cells:
            prepared = prepare_display(self.session.mesh, self.session.shown_points(), self.interactive_cells)
        if self.proxy is not None:
            self.proxy.remove()
            self.proxy = None
        if self.mesh_actor is not None:
            self.plotter.remove_actor(self.mesh_actor, reset_camera=False, render=False)
        self.display = prepared.display
        self.display_points = prepared.display.points  # NumPy view of the plotted VTK points: written in place
        self.mesh_actor = self.plotter.add_mesh(
            prepared.normals, color="tan", interpolation="phong", reset_camera=False, render=False
        )
        if prepared.proxy is not None:
            self.proxy = InteractiveProxy(self.plotter, self.display, self.mesh_actor, prepared.proxy)
            self.proxy.interacting = self.interacting
        self._write_mesh_points(only_if_changed=True)
        self._write_field()
        self._recolor()
        if self.image_slices is not None:
            self._mesh_opacity()

    def _watch_buttons(self) -> list[int]:
        """Observe the interactor's button presses and releases: :attr:`interacting` while one is held."""
        iren = self.plotter.iren.interactor if self.plotter.iren is not None else None
        if iren is None:
            return []
        tags = []
        for button in ("Left", "Middle", "Right"):
            # before any widget or style observer (which may abort the event), without aborting it
            tags.append(iren.AddObserver(f"{button}ButtonPressEvent", lambda *_: self.set_interacting(True), 100.0))
            tags.append(iren.AddObserver(f"{button}ButtonReleaseEvent", lambda *_: self.set_interacting(False), 100.0))
        return tags

    def set_interacting(self, interacting: bool) -> None:
        """Whether a mouse button is held: renders draw the mesh's lighter copy (if it has one) until released."""
        self.interacting = bool(interacting)
        if self.proxy is not None:
            self.proxy.interacting = self.interacting

    def _build_lattice(self) -> None:
        """New glyphs, lines and handle for the session's lattice."""
        if self.lattice_actor is not None:
            self.lattice_actor.remove()
        self._shown_lattice = self.session.lattice
        self.lattice_actor = LatticeActor(
            self.plotter,
            self.session.lattice,
            *self._callbacks,
            points_shown=self.session.points_shown,
            selected=self._selected_index(),
            surface=self.ray_to_surface,
        )
        self.lattice_actor.grabbable = self.session.blend == 1.0
        self._move_points(None, widgets=True, only_if_changed=True)

    def ray_to_surface(self, x: float, y: float) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """The view ray through display position ``(x, y)`` and how far along it the plotted mesh is:
        :meth:`.surface_picking.SurfacePicking.ray_to_surface` (what a press can grab is in front of it).
        The see-through box of an image edited alone hides nothing: every sphere in it stays grabbable."""
        near, direction, distance = self.surface_picking.ray_to_surface(x, y)
        return near, direction, float("inf") if self._mesh_is_image_box() else distance

    def _build_image(self) -> None:
        """Slice planes for the session's image (none if it has none); replaces any previous ones."""
        if self.image_slices is not None:
            self.image_slices.remove()
            self.image_slices = None
        if self.session.image.loaded:
            self.image_slices = ImageSlices(self.plotter, self.session.image)
        self._mesh_opacity()

    def _mesh_opacity(self) -> None:
        """The image's box (the mesh of a lattice over an image alone) is see-through: the slices are inside it.
        A real mesh stays opaque (a see-through mesh of 100k triangles costs a render much more)."""
        self.mesh_actor.prop.opacity = IMAGE_BOX_OPACITY if self._mesh_is_image_box() else 1.0

    def _mesh_is_image_box(self) -> bool:
        """Whether the mesh is the box of an image edited alone (a lattice over the image, no mesh given)."""
        image = self.session.image
        return bool(image.loaded and image.box is not None and self.session.mesh is image.box)

    def _write_mesh_points(self, only_if_changed: bool = False) -> None:
        """The session's deformed points into the plotted mesh (and its normals, at the next render)."""
        deformed = self.session.shown_points()
        if only_if_changed and np.array_equal(self.display_points, deformed.astype(self.display_points.dtype)):
            return  # e.g. a new lattice, or a mesh prepared in a worker: the normals stay valid (0.1 s on 500k)
        self.display_points[:] = deformed
        self.display.GetPoints().Modified()

    # ------------------------------------------------------------------ coloring
    def _recolor(self) -> None:
        field = self.session.field
        name = color_array_name(self.display)
        if field is not None:
            vmax = self.display.point_data[coloring.DISPLACEMENT_ARRAY].max() if field == "displacement" else 1
            coloring.show_field(self.mesh_actor, field, vmax)
        elif self.session.colors_shown and name is not None:
            coloring.show_rgb(self.mesh_actor, name)
        else:
            coloring.show_plain(self.mesh_actor)

    def _write_field(self) -> None:
        """Copy the session's field values into the plotted mesh's point data."""
        values = self.session.field_values()
        if values is None:
            return
        shown = self.display.point_data
        if self.session.field == "displacement":
            shown[coloring.DISPLACEMENT_ARRAY] = values
            coloring.set_field_range(self.mesh_actor, float(values.max()) if len(values) else 1.0)
            return
        name = coloring.WEIGHTS_ARRAY if self.session.field == "weights" else coloring.FOLDING_ARRAY
        if name in shown:
            shown[name][...] = values  # a view of the VTK array: updated in place
            shown.GetArray(name).Modified()
        else:
            shown[name] = values

    # ------------------------------------------------------------------ camera, images
    def frame(self) -> None:
        """Point the camera at the mesh: it fills the view, with the lattice's outer ring at the edges.

        The outer ring of a "zero"-border B-spline lattice (a loaded file's) lies a whole spacing
        outside the mesh; fitting the camera to all of it leaves the mesh small. This fits the
        lattice box shrunk by half a spacing on each side, and the mesh, instead (rotate or zoom out
        to reach the corners; a fitted lattice hugs the mesh and is all in view). The view is from
        the front, a little to the right and above so the lattice's depth shows, with +y up: the
        convention of OBJ, PLY and STL meshes and of the default face, which looks along +z.
        """
        lat = self.session.lattice
        ffd = self.session.ffd
        outer_ring_outside = ffd.basis == "bspline" and ffd.border == "zero" and min(lat.shape) > 2
        inset = 0.5 if outer_ring_outside else 0.0
        corners = np.array(np.meshgrid(*[[inset, n - 1 - inset] for n in lat.shape], indexing="ij")).reshape(3, -1).T
        points = np.vstack([lat.to_world(corners), self.session.rest_points])
        frame_camera(self.plotter, points, direction=FRONT, up=(0.0, 1.0, 0.0))

    def render(self) -> None:
        """Show the change: the browser views render it and send a new image (each view's scheduler renders
        once for any number of changes); with no browser view, render now
        (:meth:`~ffd_notebook.view.serving.jupyter.BrowserViews.show_changes`); nothing if not :attr:`auto_render`."""
        if self.auto_render:
            self.views.show_changes(self.plotter.render_window.Render)

    def shown_points(self) -> NDArray[np.float64]:
        """Points of the plotted mesh (what the renderer draws), float64."""
        return np.asarray(self.display_points, dtype=np.float64)

    def screenshot(self, path: str | os.PathLike[str] | None = None) -> NDArray[np.uint8]:
        """Render and return the image ``(h, w, 3)`` uint8; also write a PNG if ``path`` is given."""
        self.plotter.render_window.Render()
        img = self.plotter.screenshot(return_img=True)
        if path is not None:
            from PIL import Image

            Image.fromarray(img).save(os.fspath(path))
        return img

    def close(self) -> None:
        """Stop following the session; release the widgets and the plotter."""
        self._unsubscribe()
        release_views(self.plotter)  # the browser views stop, their pages say so; the server forgets them
        if self.plotter.iren is not None:
            for tag in self._button_tags:
                self.plotter.iren.interactor.RemoveObserver(tag)
        if self.proxy is not None:
            self.proxy.remove()
        if self.image_slices is not None:
            self.image_slices.remove()
        self.surface_picking.remove()
        if self.lattice_actor is not None and self.plotter.render_window is not None:
            self.lattice_actor.remove()
        self.plotter.close()
