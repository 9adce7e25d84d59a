"""The FFD editor: a PyVista plotter with a mesh inside a lattice of draggable control points.

Data flows one way: a sphere-widget move -> the lattice's offsets (model) -> the cached
:class:`~ffd_notebook.deform.Deformer` recomputes only the points the moved control point
influences -> the plotted mesh's points and the lattice line dataset are rewritten in place ->
the next render shows them. No actor is created or removed while dragging.

Undo: one drag is one undo step (consecutive moves of the same sphere merge until the mouse
releases it or another kind of edit happens); a typed displacement, a reset, a programmatic edit
picked up by :meth:`Editor.update`, a new lattice size, basis or a loaded .ffd file are one step
each. Loading a mesh starts a new history (the old steps belong to the old mesh).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ...deform import FFD, Deformer
from ...lattice import Lattice
from .display import EditorDisplayMixin
from .files import EditorFilesMixin
from .history import History, LatticeSwap, OffsetEdit
from .lattice_actor import LatticeActor
from .message_log import MessageLog

__all__ = ["Editor"]

TRACE_ENV = "FFD_NOTEBOOK_TRACE"


class Editor(EditorDisplayMixin, EditorFilesMixin):
    """Interactive FFD editor (see the module docstring and docs of each method).

    Parameters
    ----------
    mesh_or_path : pyvista.DataSet or path, optional
        The mesh to deform (its surface is used), or a file to read; the bundled sample mesh
        (:func:`ffd_notebook.datasets.sample_mesh`) if omitted.
    lattice : Lattice, optional
        The control lattice (used as is); fitted around the mesh with ``shape`` if omitted.
    shape : tuple of int
        Control points per axis of a fitted lattice.
    basis : {"bspline", "bernstein"}
        The FFD basis.
    window_size : tuple of int
        Render window size in pixels.
    off_screen : bool, optional
        Render off-screen (the default: images go to the notebook view, the app or screenshots).

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view import Editor
    >>> editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(200, 150))
    >>> editor.lattice.offsets[1, 1, 2] = (0.0, 0.0, 0.2)
    >>> editor.update()
    >>> float(editor.deformed_mesh.points[:, 2].max()) > float(editor.mesh.points[:, 2].max())
    True
    >>> editor.undo(); float(abs(editor.lattice.offsets).sum())
    True
    0.0
    >>> editor.close()
    """

    def __init__(
        self,
        mesh_or_path: Any = None,
        lattice: Lattice | None = None,
        shape: tuple[int, int, int] = (5, 5, 5),
        basis: str = "bspline",
        window_size: tuple[int, int] = (800, 600),
        off_screen: bool | None = None,
    ) -> None:
        self.messages = MessageLog()  # bounded: the newest MAX_MESSAGES, newest last
        self.history = History()
        self.last_callback_ms = 0.0
        self.n_callbacks = 0
        self._listeners: list[Callable[[str], None]] = []
        self._viewers: list[Any] = []
        self._selected: tuple[int, int, int] | None = None
        self._field: str | None = None
        self._colors_on = True
        self._lattice_actor: LatticeActor | None = None
        self.mesh_actor: Any = None
        trace = os.environ.get(TRACE_ENV)
        self._trace = open(trace, "a", buffering=1) if trace else None

        mesh = self._read_mesh_arg(mesh_or_path)
        if lattice is None:
            lattice = Lattice.around(mesh, shape, basis=basis)
            self._lattice_source = "fit"
        else:
            self._lattice_source = "given"
        ffd = FFD(lattice, basis)
        off_screen = True if off_screen is None else bool(off_screen)
        self.plotter = pv.Plotter(off_screen=off_screen, window_size=window_size)
        if off_screen and self.plotter.iren is not None:
            # Nobody looks at an off-screen window: the interactor need not render inside every
            # mouse event (trame renders when it sends the image; the editor renders after its own
            # changes). Saves a render per drag event and one per widget when widgets are removed.
            self.plotter.iren.interactor.EnableRenderOff()
        self._install_mesh(mesh, ffd)
        self._install_lattice(lattice, basis)
        self.frame()

    def frame(self) -> None:
        """Point the camera at the mesh: it fills the view, with the lattice's outer ring at the edges.

        The outer ring of a B-spline lattice lies a whole spacing outside the mesh; fitting the
        camera to all of it leaves the mesh small. This fits the lattice box shrunk by half a
        spacing on each side instead (rotate or zoom out to reach the corners). The view is from the
        front right, slightly above, with +y up: the convention of OBJ, PLY and STL meshes.
        """
        from ..camera import frame_camera

        lat = self.lattice
        inset = 0.5 if min(lat.shape) > 2 else 0.0
        corners = np.array(np.meshgrid(*[[inset, n - 1 - inset] for n in lat.shape], indexing="ij")).reshape(3, -1).T
        points = np.vstack([lat.to_world(corners), self.mesh.points])
        frame_camera(self.plotter, points, direction=(0.6, 0.45, 1.0), up=(0.0, 1.0, 0.0))

    # ------------------------------------------------------------------ model objects
    @property
    def lattice(self) -> Lattice:
        """The control lattice; edit ``lattice.offsets`` in place, then call :meth:`update`."""
        return self._ffd.lattice

    @lattice.setter
    def lattice(self, lattice: Lattice) -> None:
        self.set_lattice(lattice)

    @property
    def ffd(self) -> FFD:
        """The :class:`~ffd_notebook.deform.FFD` (lattice + basis) applied to the mesh."""
        return self._ffd

    @property
    def basis(self) -> str:
        """The FFD basis, ``"bspline"`` or ``"bernstein"``."""
        return self._ffd.basis

    @property
    def deformed_mesh(self) -> pv.PolyData:
        """A new mesh: the current deformed points with the rest mesh's faces and point data."""
        out = self.mesh.copy(deep=True)
        out.points = np.asarray(self._display_points, dtype=out.points.dtype).copy()
        return out

    @property
    def can_undo(self) -> bool:
        """Whether :meth:`undo` has a step to revert."""
        return self.history.can_undo

    @property
    def can_redo(self) -> bool:
        """Whether :meth:`redo` has a step to re-apply."""
        return self.history.can_redo

    @property
    def selected(self) -> tuple[int, int, int] | None:
        """The selected control point ``(i, j, k)`` (last dragged or :meth:`select`-ed), or None."""
        return self._selected

    # ------------------------------------------------------------------ the drag path
    def on_widget_moved(self, center: ArrayLike, index: int) -> None:
        """Sphere-widget callback: control point ``index`` (flat C order) was dragged to ``center``.

        Sets its offset to ``center - rest position``, updates the points it influences, the
        lattice lines and the field view in place. Errors are logged to :attr:`messages`
        (PyVista would turn them into warnings nobody sees).
        """
        t0 = time.perf_counter()
        try:
            index = int(index)
            ijk = tuple(int(v) for v in np.unravel_index(index, self.lattice.shape))
            before = self.lattice.offsets[ijk].copy()
            self.lattice.offsets[ijk] = np.asarray(center, dtype=np.float64) - self._rest_flat[index]
            self.history.record([ijk], [before], [self.lattice.offsets[ijk]], key=("drag", index), label="drag")
            self._refresh([ijk], widgets=False)
        except Exception as exc:  # a callback must never raise into VTK
            self._error(f"widget callback failed for control point {index}: {exc!r}")
            return
        self.last_callback_ms = (time.perf_counter() - t0) * 1000.0
        self.n_callbacks += 1
        if self._selected != ijk:
            self._set_selected(ijk)
        if self._trace is not None:
            self._write_trace(index, ijk, center)
        self._notify("drag")

    def _on_widget_start(self, index: int) -> None:
        self.history.close()
        self._set_selected(tuple(int(v) for v in np.unravel_index(index, self.lattice.shape)))

    def _on_widget_end(self, index: int) -> None:
        self.history.close()
        self._notify("offsets")

    # ------------------------------------------------------------------ programmatic edits
    def update(self, changed: Any = None) -> None:
        """Push the model to the view: mesh points, widget centres, lattice lines; then render.

        Call it after editing ``editor.lattice.offsets`` (or its placement) in place. Offsets that
        differ from what the view last showed become one undo step. ``changed`` (a list of
        ``(i, j, k)``) is a hint; points found to differ are always included.
        """
        self.history.close()
        lat = self.lattice
        if lat.shape != self._lattice_actor.shape:
            raise ValueError("the lattice's shape changed: assign a new lattice with editor.set_lattice(...)")
        self._rest_flat = lat.control_points().reshape(-1, 3)
        moved = np.argwhere(np.any(lat.offsets != self._synced, axis=-1))
        if len(moved):
            idx = tuple(moved.T)
            self.history.record(moved, self._synced[idx], lat.offsets[idx], label="code")
        hint = np.asarray(changed if changed is not None else np.empty((0, 3)), dtype=np.int64).reshape(-1, 3)
        todo = np.unique(np.vstack([moved, hint]), axis=0)
        self._refresh(None if changed is None and not len(todo) else [tuple(v) for v in todo], widgets=True)
        self._render()
        self._notify("offsets")

    def move_control_point(self, ijk: ArrayLike, displacement: ArrayLike) -> None:
        """Set the offset of control point ``ijk`` to ``displacement`` (world units; one undo step)."""
        ijk_t = self._check_ijk(ijk)
        value = np.asarray(displacement, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"displacement must be three finite numbers, got {displacement!r}")
        self._set_offsets([ijk_t], value[None, :], label="move")
        self._set_selected(ijk_t)

    def reset(self, ijk: ArrayLike | None = None) -> None:
        """Zero the offset of one control point, or of all of them (one undo step)."""
        if ijk is None:
            points = [tuple(v) for v in np.argwhere(np.any(self.lattice.offsets != 0, axis=-1))]
        else:
            points = [self._check_ijk(ijk)]
        if points:
            self._set_offsets(points, np.zeros((len(points), 3)), label="reset")

    def _set_offsets(self, points: list[tuple[int, int, int]], values: NDArray[np.float64], label: str) -> None:
        self.history.close()
        idx = tuple(np.array(points).T)
        before = self.lattice.offsets[idx].copy()
        self.lattice.offsets[idx] = values
        self.history.record(points, before, values, label=label)
        self._refresh(points, widgets=True)
        self._render()
        self._notify("offsets")

    # ------------------------------------------------------------------ selection
    def select(self, ijk: ArrayLike | None) -> None:
        """Select control point ``(i, j, k)`` (highlighted; the panel edits it), or None."""
        self._set_selected(None if ijk is None else self._check_ijk(ijk))
        self._render()

    def _set_selected(self, ijk: tuple[int, int, int] | None) -> None:
        self._selected = ijk
        flat = None if ijk is None else int(np.ravel_multi_index(ijk, self.lattice.shape))
        self._lattice_actor.highlight(flat)
        self._notify("select")

    def _check_ijk(self, ijk: ArrayLike) -> tuple[int, int, int]:
        arr = np.asarray(ijk)
        shape = self.lattice.shape
        if arr.shape != (3,) or not np.all(arr == np.round(arr)) or np.any(arr < 0) or np.any(arr >= shape):
            raise ValueError(f"control point index must be (i, j, k) within the lattice {shape}, got {ijk!r}")
        return tuple(int(v) for v in arr)  # type: ignore[return-value]

    # ------------------------------------------------------------------ undo / redo
    def undo(self) -> bool:
        """Revert the last step; False if there was none."""
        change = self.history.undo()
        if change is not None:
            self._apply_change(change, forward=False)
        return change is not None

    def redo(self) -> bool:
        """Re-apply the last undone step; False if there was none."""
        change = self.history.redo()
        if change is not None:
            self._apply_change(change, forward=True)
        return change is not None

    def _apply_change(self, change: OffsetEdit | LatticeSwap, forward: bool) -> None:
        if isinstance(change, LatticeSwap):
            lattice, basis, self._lattice_source = change.after if forward else change.before
            self._install_lattice(lattice.copy(), basis)
            self._notify("lattice")
        else:
            idx = tuple(change.ijk.T)
            self.lattice.offsets[idx] = change.after if forward else change.before
            self._refresh([tuple(v) for v in change.ijk], widgets=True)
            self._notify("offsets")
        self._render()

    # ------------------------------------------------------------------ lattice and basis
    def set_lattice(self, lattice: Lattice, basis: str | None = None, label: str = "lattice") -> None:
        """Replace the lattice (and optionally the basis); one undo step. Invalid input changes nothing.

        A lattice given this way stays where it is when another mesh is loaded (see
        :meth:`load_mesh`).
        """
        self._swap_lattice(lattice, basis, label, source="given")

    def _swap_lattice(self, lattice: Lattice, basis: str | None, label: str, source: str) -> None:
        """Install ``lattice`` as one undo step; ``source`` (how it was made: ``"fit"``, ``"given"``,
        ``"ffd-placed"``, ``"ffd-min"``) decides what :meth:`load_mesh` does with it, and is undone with it."""
        basis = self.basis if basis is None else basis
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        FFD(lattice, basis)  # validates (e.g. a B-spline lattice needs 4 points per axis) before any change
        self.history.close()
        before = (self.lattice.copy(), self.basis, self._lattice_source)
        self._install_lattice(lattice, basis)
        self._lattice_source = source
        self.history.record_lattice(before, (lattice.copy(), basis, source), label=label)
        self._render()
        self._notify("lattice")

    def set_shape(self, shape: ArrayLike) -> None:
        """Fit a new lattice with ``shape`` control points per axis around the mesh (undoable)."""
        try:
            lattice = Lattice.around(self.mesh, tuple(int(s) for s in np.ravel(shape)), basis=self.basis)
        except (ValueError, TypeError) as exc:
            self._error(f"cannot build a {shape!r} lattice: {exc}")
            raise
        self._swap_lattice(lattice, None, "shape", source="fit")
        self._info(f"new {'x'.join(map(str, lattice.shape))} lattice around the mesh")

    def set_basis(self, basis: str) -> None:
        """Switch the basis; refits the lattice around the mesh for it (offsets start at zero; undoable)."""
        if basis == self.basis:
            return
        try:
            lattice = Lattice.around(self.mesh, self.lattice.shape, basis=basis)
        except ValueError as exc:
            self._error(f"cannot switch to the {basis!r} basis: {exc}")
            raise
        self._swap_lattice(lattice, basis, "basis", source="fit")
        self._info(f"basis: {basis}")

    # ------------------------------------------------------------------ observers and messages
    def observe(self, callback: Callable[[str], None]) -> None:
        """Call ``callback(event)`` after changes (``"drag"``, ``"select"``, ``"offsets"``, ``"lattice"``,
        ``"mesh"``, ``"display"``, ``"message"``); used by the control panels."""
        self._listeners.append(callback)

    def _notify(self, event: str) -> None:
        for callback in list(self._listeners):
            try:
                callback(event)
            except Exception as exc:
                self.messages.append(f"Error: a view failed to follow the editor: {exc!r}")

    def attempt(self, action: Callable[..., Any], *args: Any) -> bool:
        """Run ``action(*args)`` for a user interface: a failure becomes a message, not an exception.

        The editor's own methods log what went wrong themselves; any other failure (e.g. a value
        typed in a panel that is not a number) is logged as ``"Error: <exception>"``. Both control
        panels (notebook and app) run every action through here.

        Returns
        -------
        bool
            Whether ``action`` succeeded.

        Examples
        --------
        >>> import pyvista as pv
        >>> editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(100, 80))
        >>> editor.attempt(editor.move_control_point, (9, 9, 9), (0.0, 0.0, 1.0))
        False
        >>> editor.messages[-1]
        'Error: control point index must be (i, j, k) within the lattice (4, 4, 4), got (9, 9, 9)'
        >>> editor.close()
        """
        n_messages = self.messages.n_added
        try:
            action(*args)
        except Exception as exc:
            if self.messages.n_added == n_messages:  # the editor did not explain it itself
                self._error(str(exc))
            return False
        return True

    def _info(self, text: str) -> None:
        self.messages.append(text)
        self._notify("message")

    def _error(self, text: str) -> None:
        self.messages.append(f"Error: {text}")
        self._notify("message")

    # ------------------------------------------------------------------ building the scene
    def _install_mesh(
        self, mesh: pv.PolyData, ffd: FFD, source: pv.PolyData | None = None, deformer: Deformer | None = None
    ) -> None:
        """Show ``mesh`` (rest shape) deformed by ``ffd``; replaces any previous mesh actor.

        ``source`` is the mesh as loaded (what :meth:`decimate` starts from); ``mesh`` itself if omitted.
        ``deformer``: ``ffd`` already bound to ``mesh.points`` (e.g. in a worker thread), to reuse.
        """
        deformer = ffd.bind(mesh.points) if deformer is None else deformer
        display = mesh.copy(deep=True)
        if self.mesh_actor is not None:
            self.plotter.remove_actor(self.mesh_actor, reset_camera=False, render=False)
        self.mesh = mesh
        self._source_mesh = mesh if source is None else source
        self._display = display
        self._deformer = deformer
        self._display_points = display.points  # NumPy view of the plotted VTK points: written in place
        self.mesh_actor = self.plotter.add_mesh(display, color="tan", smooth_shading=True, reset_camera=False)
        self._display_points[:] = deformer.update()
        self._update_field()
        self._apply_coloring()

    def _install_lattice(self, lattice: Lattice, basis: str, deformer: Deformer | None = None) -> None:
        """Use ``lattice`` with ``basis`` (rebinds the deformer, or uses ``deformer``, already bound to
        this lattice and the mesh's points; new widgets and lines)."""
        if deformer is None:
            deformer = FFD(lattice, basis).bind(self.mesh.points)
        ffd = deformer.ffd
        self._ffd, self._deformer = ffd, deformer
        if self._lattice_actor is not None:
            self._lattice_actor.remove()
        self._lattice_actor = LatticeActor(
            self.plotter, lattice, self.on_widget_moved, self._on_widget_start, self._on_widget_end
        )
        self._rest_flat = lattice.control_points().reshape(-1, 3)
        self._synced = lattice.offsets.copy()
        self._selected = None
        self._refresh(None, widgets=True)

    def _refresh(self, changed: list[tuple[int, int, int]] | None, widgets: bool) -> None:
        """Model -> view: deformed mesh points, lattice lines, (widget centres), field colours."""
        self._display_points[:] = self._deformer.update(changed)
        self._display.GetPoints().Modified()
        positions = self._rest_flat + self.lattice.offsets.reshape(-1, 3)
        self._lattice_actor.set_line_points(positions)
        if widgets:
            flat = None if changed is None else [np.ravel_multi_index(c, self.lattice.shape) for c in changed]
            self._lattice_actor.set_widget_centers(positions, flat)
        self._synced[...] = self.lattice.offsets
        if self._field is not None:
            self._update_field(changed)

    def _render(self) -> None:
        self.plotter.render_window.Render()
        for viewer in list(self._viewers):
            try:
                viewer.update()
            except Exception as exc:
                self.messages.append(f"Error: could not update a browser view: {exc!r}")

    def close(self) -> None:
        """Release the plotter, widgets and the trace file (the editor cannot be used afterwards)."""
        if self._trace is not None:
            self._trace.close()
            self._trace = None
        self._listeners.clear()
        self._viewers.clear()
        if self._lattice_actor is not None and self.plotter.render_window is not None:
            self._lattice_actor.remove()
        self.plotter.close()

    def __repr__(self) -> str:
        return (
            f"Editor(mesh={self.mesh.n_points} points, lattice={'x'.join(map(str, self.lattice.shape))}, "
            f"basis={self.basis!r}, history={len(self.history)})"
        )
