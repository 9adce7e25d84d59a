"""The standalone FFD editor: an :class:`~ffd_notebook.view.editor.Editor` in a trame web page.

The page is a Vuetify 3 layout: the plotter's :class:`trame_pyvista.PyVistaRemoteView` (server-side
rendering, which sphere widgets need) and a side panel with the notebook panel's features. The
panel only calls Editor methods; the editor tells the panel what changed through
:meth:`Editor.observe`, so edits made anywhere (drag, panel, undo) show up in both.

Paths typed into the panel are paths on the machine running the app (the server); a .ffd file can
also be uploaded from the browser. That is why the app listens on 127.0.0.1 unless told otherwise.

Run it with ``python -m ffd_notebook [MESH] [--ffd FILE] [--port N]`` (see :mod:`ffd_notebook.__main__`).
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .app_panel import build_layout
from .editor import Editor

__all__ = ["EditorApp", "run_app"]

FIELDS = ["none", "displacement", "jacobian"]
BASES = ["bspline", "bernstein"]
N_MESSAGES = 5
# while a sphere is dragged, the panel's X/Y/Z follow at most this often (each sync is a websocket message)
DRAG_SYNC_S = 0.25


def _number(value: Any, what: str, kind: type = float) -> Any:
    """``value`` from a text field as ``kind``; a ValueError naming the field otherwise."""
    try:
        number = float(value)
        if not np.isfinite(number) or (kind is int and number != int(number)):
            raise ValueError
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be {'a whole number' if kind is int else 'a number'}, got {value!r}") from None
    return kind(number)


def _triple(values: Any, what: str, kind: type = float) -> list[Any]:
    """Three numbers from three text fields (``what`` names them, e.g. ``"lattice size"``)."""
    values = list(values) if isinstance(values, (list, tuple)) else [values]
    if len(values) != 3:
        raise ValueError(f"{what} needs three values, got {values!r}")
    return [_number(v, f"{what} {axis}", kind) for v, axis in zip(values, "xyz", strict=True)]


def _upload_bytes(upload: Any) -> tuple[str, bytes] | None:
    """Name and content of a file from a Vuetify file input (a dict, or a list of one dict)."""
    if isinstance(upload, list):
        upload = upload[0] if upload else None
    if not isinstance(upload, dict) or upload.get("content") is None:
        return None
    content = upload["content"]
    if isinstance(content, list):  # large files arrive in chunks
        content = b"".join(content)
    return str(upload.get("name") or "upload.ffd"), bytes(content)


class EditorApp:
    """A trame server showing ``editor`` with a control panel.

    Parameters
    ----------
    editor : Editor
        The editor to serve (the app registers the ``ffd_widget_px`` / ``ffd_state`` triggers and
        attaches its view so programmatic changes reach the browser).
    server : trame server, optional
        A trame server (``client_type="vue3"``); a new one named ``name`` by default.
    name : str
        Name of the new trame server.

    Examples
    --------
    >>> from ffd_notebook.view.app import EditorApp
    >>> import pyvista as pv
    >>> from ffd_notebook.view import Editor
    >>> app = EditorApp(Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(200, 150)), name="doctest_app")
    >>> app.state.nx, app.state.basis, app.state.can_undo
    (4, 'bspline', False)
    >>> app.apply_offset([1, 2, 1, 0.0, 0.0, 0.25])
    >>> app.editor.lattice.offsets[1, 2, 1].tolist(), app.state.can_undo
    ([0.0, 0.0, 0.25], True)
    >>> app.editor.close()
    """

    def __init__(self, editor: Editor, server: Any = None, name: str = "ffd_notebook_app") -> None:
        from trame.app import get_server

        self.editor = editor
        self.server = server if server is not None else get_server(name, client_type="vue3")
        self.state = self.server.state
        self._last_drag_sync = 0.0
        self._upload_dir: str | None = None
        self.state.update(self._editor_values())
        self.state.update(
            trame__title="ffd_notebook editor",
            ffd_path="lattice.ffd",
            mesh_path="",
            mesh_save_path="deformed.obj",
            reduction=0.5,
            ffd_upload=None,
            field_items=FIELDS,
            basis_items=BASES,
        )
        self.layout, self.view = build_layout(self)
        editor.register_triggers(self.server)
        editor.attach_viewer(self.view)
        editor.observe(self._on_editor_event)
        self.state.change("sel_i", "sel_j", "sel_k")(self._on_selection_typed)
        self.state.change("basis")(self._on_basis_chosen)
        self.state.change("colors")(self._on_colors_switched)
        self.state.change("field")(self._on_field_chosen)
        self.state.change("ffd_upload")(self._on_upload)

    # ------------------------------------------------------------------ editor -> page
    def _editor_values(self) -> dict[str, Any]:
        ed = self.editor
        values: dict[str, Any] = {
            "nx": ed.lattice.shape[0],
            "ny": ed.lattice.shape[1],
            "nz": ed.lattice.shape[2],
            "max_i": ed.lattice.shape[0] - 1,
            "max_j": ed.lattice.shape[1] - 1,
            "max_k": ed.lattice.shape[2] - 1,
            "basis": ed.basis,
            "colors": ed.colors_shown,
            "has_colors": ed.has_colors,
            "field": ed.field or "none",
            "can_undo": ed.can_undo,
            "can_redo": ed.can_redo,
            "has_selection": ed.selected is not None,
            "mesh_info": f"{ed.mesh.n_points} vertices, {ed.mesh.n_cells} faces",
            "moved_points": int(np.any(ed.lattice.offsets != 0, axis=-1).sum()),
            "messages": [{"text": text, "error": text.startswith("Error")} for text in ed.messages[-N_MESSAGES:][::-1]],
        }
        if ed.selected is not None:
            offset = ed.lattice.offsets[ed.selected]
            values.update(zip(("sel_i", "sel_j", "sel_k"), ed.selected, strict=True))
            values.update(zip(("dx", "dy", "dz"), (float(f"{v:.6g}") for v in offset), strict=True))
        elif "sel_i" not in self.state:
            values.update(sel_i=0, sel_j=0, sel_k=0, dx=0.0, dy=0.0, dz=0.0)
        return values

    def sync(self) -> None:
        """Copy the editor's state (lattice size, selection, offsets, flags, messages) to the page."""
        with self.state:
            self.state.update(self._editor_values())

    def _on_editor_event(self, event: str) -> None:
        if event == "drag":  # every mouse move: keep the page cheap to update
            now = time.monotonic()
            if now - self._last_drag_sync < DRAG_SYNC_S:
                return
            self._last_drag_sync = now
        self.sync()

    # ------------------------------------------------------------------ page -> editor
    def _act(self, action: Callable[[], Any]) -> bool:
        """Run an editor action; a failure becomes a message on the page instead of a traceback."""
        ok = self.editor.attempt(action)
        self.sync()
        return ok

    def rebuild(self, shape: list[Any]) -> None:
        """Fit a new lattice with ``shape = [nx, ny, nz]`` control points (from the panel)."""
        self._act(lambda: self.editor.set_shape(_triple(shape, "lattice size", int)))

    def apply_offset(self, values: list[Any]) -> None:
        """``values = [i, j, k, dx, dy, dz]``: set control point (i, j, k)'s displacement."""

        def action() -> None:
            self.editor.move_control_point(_triple(values[:3], "index", int), _triple(values[3:], "displacement"))

        self._act(action)

    def reset_point(self, ijk: list[Any]) -> None:
        """Zero the displacement of control point ``ijk``."""
        self._act(lambda: self.editor.reset(_triple(ijk, "index", int)))

    def reset_all(self) -> None:
        """Zero every displacement."""
        self._act(self.editor.reset)

    def undo(self) -> None:
        """Undo the last edit."""
        self._act(self.editor.undo)

    def redo(self) -> None:
        """Redo the last undone edit."""
        self._act(self.editor.redo)

    def load_ffd(self, path: str) -> None:
        """Load a .ffd file from a path on the server."""
        self._act(lambda: self.editor.load_ffd(Path(str(path)).expanduser()))

    def save_ffd(self, path: str) -> None:
        """Save the lattice to a .ffd file at a path on the server."""
        self._act(lambda: self.editor.save_ffd(Path(str(path)).expanduser()))

    def load_mesh(self, path: str) -> None:
        """Load a mesh (OBJ, PLY, VTP, STL, ...) from a path on the server."""
        self._act(lambda: self.editor.load_mesh(Path(str(path)).expanduser()))

    def save_mesh(self, path: str) -> None:
        """Save the deformed mesh to a path on the server (format from the extension)."""
        self._act(lambda: self.editor.save_mesh(Path(str(path)).expanduser()))

    def decimate(self, reduction: Any) -> None:
        """Decimate the loaded mesh by a fraction of its faces (0 restores it)."""
        self._act(lambda: self.editor.decimate(_number(reduction, "the reduction")))

    def reset_camera(self) -> None:
        """Fit the camera to the scene."""
        self.editor.plotter.reset_camera()
        self.view.update()

    def _on_selection_typed(self, sel_i: Any, sel_j: Any, sel_k: Any, **_: Any) -> None:
        try:
            ijk = tuple(_triple((sel_i, sel_j, sel_k), "index", int))
        except ValueError:
            return  # half-typed number: wait for the rest
        if ijk != self.editor.selected:
            self._act(lambda: self.editor.select(ijk))

    def _on_basis_chosen(self, basis: str, **_: Any) -> None:
        if basis != self.editor.basis:
            self._act(lambda: self.editor.set_basis(basis))

    def _on_colors_switched(self, colors: Any, **_: Any) -> None:
        if bool(colors) != self.editor.colors_shown:
            self._act(lambda: self.editor.show_colors(bool(colors)))

    def _on_field_chosen(self, field: str, **_: Any) -> None:
        wanted = None if field in (None, "none") else field
        if wanted != self.editor.field:
            self._act(lambda: self.editor.set_field(wanted))

    def _on_upload(self, ffd_upload: Any, **_: Any) -> None:
        upload = _upload_bytes(ffd_upload)
        if upload is None:
            return
        name, content = upload
        if self._upload_dir is None:
            self._upload_dir = tempfile.mkdtemp(prefix="ffd_notebook_upload_")
        target = Path(self._upload_dir) / Path(name).name
        target.write_bytes(content)
        if self._act(lambda: self.editor.load_ffd(target)):
            self.editor.messages.append(f"(uploaded from the browser as {name})")
        self.state.ffd_upload = None
        self.sync()

    # ------------------------------------------------------------------ running
    def start(self, port: int = 8080, host: str = "127.0.0.1", **kwargs: Any) -> Any:
        """Serve the page (blocks until the server stops); prints the URL once it is listening."""
        self.server.controller.on_server_ready.add(
            lambda **_: print(f"ffd_notebook editor running at http://{host}:{self.server.port}/", flush=True)
        )
        kwargs.setdefault("open_browser", False)
        kwargs.setdefault("show_connection_info", False)
        kwargs.setdefault("timeout", 0)  # wslink would stop an idle server after 5 minutes
        return self.server.start(port=port, host=host, **kwargs)


def run_app(
    mesh: str | os.PathLike[str] | None = None,
    ffd: str | os.PathLike[str] | None = None,
    port: int = 8080,
    host: str = "127.0.0.1",
    shape: tuple[int, int, int] = (5, 5, 5),
    basis: str = "bspline",
) -> EditorApp:
    """Build the editor (``mesh`` path or the sample mesh, optional ``ffd`` lattice) and serve it (blocking)."""
    editor = Editor(mesh, shape=tuple(shape), basis=basis)
    if ffd is not None:
        editor.load_ffd(ffd)
    app = EditorApp(editor)
    app.start(port=port, host=host)
    return app
