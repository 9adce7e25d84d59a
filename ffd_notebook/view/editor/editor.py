"""The FFD editor: an editing session shown in a PyVista plotter, with a mesh inside a lattice of draggable spheres.

:class:`Editor` is a thin composition, the public face of three parts:

:class:`~.session.EditingSession` (``editor.session``)
    Lattice, basis, mesh, selection, undo history and the commands; NumPy and the model only.
:class:`~.scene.EditorScene` (``editor.scene``)
    The plotter and its VTK objects; follows the session.
the notebook widget (``editor.widget``)
    The scene's trame view next to a :class:`~.notebook_panel.ControlPanel`; follows the session too.

Data flows one way: a move of the drag handle -> :meth:`EditingSession.drag` (the lattice's offsets; the
cached :class:`~ffd_notebook.ffd.deformer.Deformer` recomputes only the points the moved control point
influences) -> one :class:`~.changes.Change` naming that control point -> the scene rewrites the
plotted points and the lattice lines in place -> the next render shows them.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ...ffd.deform import FFD
from ...ffd.lattice import Lattice
from ...io import write_mesh
from ...meshing import as_surface, color_array_name, decimate_keeping_colors, deformed_copy
from . import session_files
from .history import History
from .message_log import MessageLog
from .proxy import INTERACTIVE_CELLS
from .scene import EditorScene
from .session import EditingSession, MeshIO

__all__ = ["PYVISTA_MESH_IO", "Editor", "edit"]

Path = str | os.PathLike[str]


def read_surface(path: Path) -> pv.PolyData:
    """A mesh file's surface, checked (:func:`ffd_notebook.io.read_mesh` + :func:`ffd_notebook.meshing.as_surface`)."""
    from ...io import read_mesh

    return as_surface(read_mesh(path))


#: PyVista's mesh operations, for sessions of PyVista meshes
PYVISTA_MESH_IO = MeshIO(
    read=read_surface,
    write=write_mesh,
    decimate=decimate_keeping_colors,
    with_points=deformed_copy,
    color_array=color_array_name,
)


def _surface_of(mesh_or_path: Any) -> pv.PolyData:
    if mesh_or_path is None:
        from ...datasets import sample_mesh

        return as_surface(sample_mesh())
    if isinstance(mesh_or_path, (str, os.PathLike)):
        return read_surface(mesh_or_path)
    return as_surface(mesh_or_path)


class Editor:
    """Interactive FFD editor (see the module docstring).

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
    interactive_cells : int or None
        While a mouse button is held (a drag, a camera turn), a mesh with at least twice as many
        cells is drawn from a copy with about this many, at the view's reduced drag size; the
        release brings back the full mesh. None always draws the full mesh.

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
        *,
        lattice: Lattice | None = None,
        shape: tuple[int, int, int] = (5, 5, 5),
        basis: str = "bspline",
        window_size: tuple[int, int] = (800, 600),
        off_screen: bool | None = None,
        interactive_cells: int | None = INTERACTIVE_CELLS,
    ) -> None:
        self.session = EditingSession(
            _surface_of(mesh_or_path), mesh_io=PYVISTA_MESH_IO, lattice=lattice, shape=shape, basis=basis
        )
        self.scene = EditorScene(
            self.session,
            on_start=self.session.begin_drag,
            on_move=self.on_widget_moved,
            on_end=lambda _index: self.session.end_drag(),
            window_size=window_size,
            off_screen=True if off_screen is None else bool(off_screen),
            interactive_cells=interactive_cells,
        )
        self.last_callback_ms = 0.0
        self._widget: Any = None
        self._shown_in_cell: int | None = None
        self.scene.frame()

    # ------------------------------------------------------------------ the parts' state
    @property
    def plotter(self) -> pv.Plotter:
        """The PyVista plotter (``editor.scene.plotter``)."""
        return self.scene.plotter

    @property
    def mesh_actor(self) -> Any:
        """The actor of the plotted mesh."""
        return self.scene.mesh_actor

    @property
    def mesh(self) -> pv.PolyData:
        """The rest mesh (undeformed surface)."""
        return self.session.mesh

    @property
    def lattice(self) -> Lattice:
        """The control lattice; edit ``lattice.offsets`` in place, then call :meth:`update`."""
        return self.session.lattice

    @lattice.setter
    def lattice(self, lattice: Lattice) -> None:
        self.session.set_lattice(lattice)

    @property
    def ffd(self) -> FFD:
        """The :class:`~ffd_notebook.ffd.deform.FFD` applied to the mesh (lattice, basis, border, affine part)."""
        return self.session.ffd

    @property
    def basis(self) -> str:
        """The FFD basis, ``"bspline"`` or ``"bernstein"``."""
        return self.session.basis

    @property
    def deformed_mesh(self) -> pv.PolyData:
        """A new mesh: the current deformed points with the rest mesh's faces and point data."""
        return self.session.deformed_mesh

    @property
    def history(self) -> History:
        """The undo history."""
        return self.session.history

    @property
    def messages(self) -> MessageLog:
        """The editor's messages, newest last (bounded)."""
        return self.session.messages

    @property
    def selected(self) -> tuple[int, int, int] | None:
        """The selected control point ``(i, j, k)`` (last dragged or :meth:`select`-ed), or None."""
        return self.session.selected

    @property
    def can_undo(self) -> bool:
        """Whether :meth:`undo` has a step to revert."""
        return self.session.can_undo

    @property
    def can_redo(self) -> bool:
        """Whether :meth:`redo` has a step to re-apply."""
        return self.session.can_redo

    @property
    def field(self) -> str | None:
        """The deformation field shown on the mesh: None, ``"displacement"`` or ``"jacobian"``."""
        return self.session.field

    @property
    def points_shown(self) -> str:
        """Which control points are drawn: ``"all"``, ``"near"`` (the selection's) or ``"hull"``."""
        return self.session.points_shown

    @property
    def colors_shown(self) -> bool:
        """Whether per-vertex colors are shown (when the mesh has them and no field is shown)."""
        return self.session.colors_shown

    @property
    def has_colors(self) -> bool:
        """Whether the mesh has per-vertex colors."""
        return self.session.has_colors

    # ------------------------------------------------------------------ the drag path
    def on_widget_moved(self, center: ArrayLike, index: int) -> None:
        """Drag-handle callback: control point ``index`` (flat C order) was dragged to ``center``.

        Errors are logged to :attr:`messages` (PyVista would turn them into warnings nobody sees).
        """
        t0 = time.perf_counter()
        try:
            self.session.drag(index, center, started=t0)
        except Exception as exc:  # a callback must never raise into VTK
            self.session.error(f"widget callback failed for control point {index}: {exc!r}")
            return
        self.last_callback_ms = (time.perf_counter() - t0) * 1000.0

    # ------------------------------------------------------------------ commands (the session's)
    def update(self, changed: Any = None) -> None:
        """Push in-place edits of ``editor.lattice.offsets`` to the view: :meth:`EditingSession.update`."""
        self.session.update(changed)

    def move_control_point(self, ijk: ArrayLike, displacement: ArrayLike) -> None:
        """Set control point ``ijk``'s offset: :meth:`EditingSession.move_control_point`."""
        self.session.move_control_point(ijk, displacement)

    def reset(self, ijk: ArrayLike | None = None) -> None:
        """Zero one offset or all: :meth:`EditingSession.reset`."""
        self.session.reset(ijk)

    def select(self, ijk: ArrayLike | None) -> None:
        """Select a control point: :meth:`EditingSession.select`."""
        self.session.select(ijk)

    def undo(self) -> bool:
        """Revert the last step: :meth:`EditingSession.undo`."""
        return self.session.undo()

    def redo(self) -> bool:
        """Re-apply the last undone step: :meth:`EditingSession.redo`."""
        return self.session.redo()

    def set_lattice(self, lattice: Lattice, basis: str | None = None, *, label: str = "lattice") -> None:
        """Replace the lattice: :meth:`EditingSession.set_lattice`."""
        self.session.set_lattice(lattice, basis, label=label)

    def set_shape(self, shape: ArrayLike) -> None:
        """Fit a lattice of another size: :meth:`EditingSession.set_shape`."""
        self.session.set_shape(shape)

    def set_basis(self, basis: str) -> None:
        """Switch the basis: :meth:`EditingSession.set_basis`."""
        self.session.set_basis(basis)

    def set_field(self, field: str | None) -> None:
        """Color the mesh by a field: :meth:`EditingSession.set_field`."""
        self.session.set_field(field)

    def show_colors(self, show: bool = True) -> None:
        """Show per-vertex colors: :meth:`EditingSession.show_colors`."""
        self.session.show_colors(show)

    def set_interaction_mode(self, mode: str) -> None:
        """What a mouse drag moves (spheres or the mesh): :meth:`EditingSession.set_interaction_mode`."""
        self.session.set_interaction_mode(mode)

    def clear_pins(self) -> None:
        """Unpin every pinned mesh point: :meth:`EditingSession.clear_pins`."""
        self.session.clear_pins()

    def show_points(self, which: str) -> None:
        """Draw all control points, those near the selection, or the hull: :meth:`EditingSession.show_points`."""
        self.session.show_points(which)

    def attempt(self, action: Callable[..., Any], *args: Any) -> bool:
        """Run an action for a user interface, failures as messages: :meth:`EditingSession.attempt`.

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
        return self.session.attempt(action, *args)

    def observe(self, callback: Callable[[str], None]) -> None:
        """Call ``callback(kind)`` after changes (``"drag"``, ``"select"``, ``"offsets"``, ``"lattice"``,
        ``"mesh"``, ``"display"``, ``"message"``); :meth:`EditingSession.subscribe` gives the whole change."""
        self.session.subscribe(lambda change: callback(change.kind))

    # ------------------------------------------------------------------ files (session_files)
    def read_ffd_file(self, path: Path) -> tuple[FFD, str]:
        """Read a lattice file without changing anything: :func:`.session_files.read_ffd_file`."""
        return session_files.read_ffd_file(self.session, path)

    def use_ffd(self, ffd: FFD, source: str, name: str) -> None:
        """Install an FFD read by :meth:`read_ffd_file`: :func:`.session_files.use_ffd`."""
        session_files.use_ffd(self.session, ffd, source, name)

    def load_ffd(self, path: Path) -> Lattice:
        """Load a lattice file (.ffd, ITK .tfm/.txt/.h5/.hdf5, PyGeM .prm): :func:`.session_files.load_ffd`."""
        return session_files.load_ffd(self.session, path)

    def save_ffd(self, path: Path) -> None:
        """Save the FFD to a lattice file (format by extension): :func:`.session_files.save_ffd`."""
        session_files.save_ffd(self.session, path)

    def read_mesh_file(self, path: Path) -> tuple[pv.PolyData, Any]:
        """Read a mesh without changing anything: :func:`.session_files.read_mesh_file`."""
        return session_files.read_mesh_file(self.session, path)

    def use_mesh(self, mesh: pv.PolyData, deformer: Any, name: str) -> None:
        """Use a mesh read by :meth:`read_mesh_file`: :func:`.session_files.use_mesh`."""
        session_files.use_mesh(self.session, mesh, deformer, name)

    def load_mesh(self, path: Path) -> pv.PolyData:
        """Load a mesh (a new undo history): :func:`.session_files.load_mesh`."""
        return session_files.load_mesh(self.session, path)

    def save_mesh(self, path: Path) -> None:
        """Save the deformed mesh: :func:`.session_files.save_mesh`."""
        session_files.save_mesh(self.session, path)

    def decimate(self, reduction: float) -> pv.PolyData:
        """Decimate the loaded mesh: :func:`.session_files.decimate`."""
        return session_files.decimate(self.session, reduction)

    # ------------------------------------------------------------------ the scene's
    def frame(self) -> None:
        """Point the camera at the mesh: :meth:`EditorScene.frame`."""
        self.scene.frame()

    def screenshot(self, path: Path | None = None) -> NDArray[np.uint8]:
        """Render and return the image ``(h, w, 3)`` uint8; also write a PNG if ``path`` is given."""
        return self.scene.screenshot(path)

    # ------------------------------------------------------------------ Jupyter
    @property
    def widget(self) -> Any:
        """The editor's notebook widget: its view next to a control panel (made once)."""
        if self._widget is None:
            from .notebook import editor_widget

            self._widget = editor_widget(self)
        return self._widget

    def display(self) -> None:
        """Show the editor in the notebook, once per cell (showing it again in the same cell does nothing)."""
        from IPython.display import display

        from ..jupyter import execution_count
        from .notebook import EditorOutput

        cell = execution_count()
        if cell is not None and cell == self._shown_in_cell:
            return
        display(EditorOutput(self))
        self._shown_in_cell = cell

    def _ipython_display_(self) -> None:
        self.display()

    def close(self) -> None:
        """Release the plotter and widgets (the editor cannot be used afterwards)."""
        self.scene.close()
        self.session.close()

    def __repr__(self) -> str:
        return (
            f"Editor(mesh={self.mesh.n_points} points, lattice={'x'.join(map(str, self.lattice.shape))}, "
            f"basis={self.basis!r}, history={len(self.history)})"
        )


def edit(mesh_or_path: Any = None, **kw: Any) -> Editor:
    """Open an FFD editor on a mesh in the notebook and return it.

    Parameters
    ----------
    mesh_or_path, **kw
        As for :class:`Editor` (``lattice``, ``shape``, ``basis``, ``window_size``, ``off_screen``).

    Returns
    -------
    Editor
        Keep it to work with the result: ``editor.deformed_mesh``, ``editor.lattice``,
        ``editor.save_ffd(...)``. Showing the returned editor again in the same cell does not
        draw a second copy.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view import edit
    >>> editor = edit(pv.Sphere(), shape=(4, 4, 4), window_size=(300, 200))  # doctest: +SKIP
    """
    editor = Editor(mesh_or_path, **kw)
    editor.display()
    return editor
