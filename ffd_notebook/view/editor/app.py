"""The standalone FFD editor: an :class:`~ffd_notebook.view.editor.Editor` in a trame web page.

The page is a Vuetify 3 layout: the plotter's :class:`trame_pyvista.PyVistaRemoteView` (server-side
rendering, which sphere widgets need) and a side panel with the notebook panel's features. The
panel only calls Editor methods; the editor tells the panel what changed through
:meth:`Editor.observe`, so edits made anywhere (drag, panel, undo) show up in both.

Safety (see :mod:`.web_security` and :mod:`.file_root`): the page's address carries a fresh random
token that the server requires, requests from other sites' pages are refused, paths typed into the
panel are confined to one root folder (``--root``, default: the current folder), and files can be
uploaded from and downloaded to the browser instead. The app listens on 127.0.0.1 unless told otherwise.

Run it with ``python -m ffd_notebook [MESH] [--ffd FILE] [--port N] [--root DIR]`` (see
:mod:`ffd_notebook.__main__`).
"""

from __future__ import annotations

import atexit
import os
import socket
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..file_root import DEFAULT_MAX_FILE_BYTES, FileRoot
from ..web_security import AccessPolicy, new_token, protect, url_with_token
from .app_files import MESH_FORMATS, AppFilesMixin
from .app_layout import build_layout
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


class EditorApp(AppFilesMixin):
    """A trame server showing ``editor`` with a control panel.

    Parameters
    ----------
    editor : Editor
        The editor to serve (the app attaches its view so programmatic changes reach the browser).
    server : trame server, optional
        A trame server (``client_type="vue3"``); a new one named ``name`` by default.
    name : str
        Name of the new trame server.
    root : path-like, optional
        The folder typed paths are confined to (default: the current folder).
    token : str, optional
        The session token the page must present (default: a fresh random one).
    max_file_bytes : int
        Largest file the app reads or accepts as an upload.

    Examples
    --------
    >>> from ffd_notebook.view.editor.app import EditorApp
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

    def __init__(
        self,
        editor: Editor,
        server: Any = None,
        name: str = "ffd_notebook_app",
        root: str | os.PathLike[str] | None = None,
        token: str | None = None,
        max_file_bytes: int = DEFAULT_MAX_FILE_BYTES,
    ) -> None:
        from trame.app import get_server

        self.editor = editor
        self.server = server if server is not None else get_server(name, client_type="vue3")
        self.state = self.server.state
        self.files = FileRoot(os.getcwd() if root is None else root, max_bytes=max_file_bytes)
        self.token = new_token() if token is None else token
        self.url: str | None = None
        self._last_drag_sync = 0.0
        self._scratch = None
        self._tasks: set[Any] = set()
        self.state.update(self._editor_values())
        self.state.update(
            trame__title="ffd_notebook editor",
            root_name=str(self.files.path),
            ffd_path="lattice.ffd",
            mesh_path="",
            mesh_save_path="deformed.obj",
            reduction=0.5,
            ffd_upload=None,
            mesh_upload=None,
            mesh_format=MESH_FORMATS[0],
            mesh_format_items=MESH_FORMATS,
            busy=False,
            busy_text="",
            field_items=FIELDS,
            basis_items=BASES,
        )
        for name_, method in (
            ("ffd_load_ffd", self.load_ffd),
            ("ffd_save_ffd", self.save_ffd),
            ("ffd_load_mesh", self.load_mesh),
            ("ffd_save_mesh", self.save_mesh),
            ("ffd_download_ffd", self.download_ffd),
            ("ffd_download_mesh", self.download_mesh),
        ):
            self.server.controller.trigger(name_)(method)
        self.layout, self.view = build_layout(self)
        editor.scene.views.add(self.view)
        editor.observe(self._on_editor_event)
        self.state.change("sel_i", "sel_j", "sel_k")(self._on_selection_typed)
        self.state.change("basis")(self._on_basis_chosen)
        self.state.change("colors")(self._on_colors_switched)
        self.state.change("field")(self._on_field_chosen)
        self.state.change("ffd_upload")(self.receive_ffd_upload)
        self.state.change("mesh_upload")(self.receive_mesh_upload)

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
            "messages": [{"text": t, "error": t.startswith("Error")} for t in list(ed.messages)[-N_MESSAGES:][::-1]],
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

    # ------------------------------------------------------------------ running
    def start(self, port: int = 8080, host: str = "127.0.0.1", **kwargs: Any) -> Any:
        """Serve the page (blocks until the server stops); prints the URL, with its token, once listening.

        The server requires the token and refuses other sites' pages (:func:`.web_security.protect`).
        """
        protect(self.server, AccessPolicy(self.token, bind_host=host))
        shown_host = socket.gethostname() if host in ("0.0.0.0", "::", "") else host
        if ":" in shown_host:
            shown_host = f"[{shown_host}]"

        def ready(**_: Any) -> None:
            self.url = url_with_token(f"http://{shown_host}:{self.server.port}/", self.token)
            print(f"ffd_notebook editor running at {self.url}", flush=True)

        self.server.controller.on_server_ready.add(ready)
        kwargs.setdefault("open_browser", False)
        kwargs.setdefault("show_connection_info", False)
        kwargs.setdefault("timeout", 0)  # wslink would stop an idle server after 5 minutes
        return self.server.start(port=port, host=host, **kwargs)

    def close(self) -> None:
        """Remove the uploads folder and close the editor."""
        self.cleanup_files()
        self.editor.close()


def run_app(
    mesh: str | os.PathLike[str] | None = None,
    ffd: str | os.PathLike[str] | None = None,
    port: int = 8080,
    host: str = "127.0.0.1",
    shape: tuple[int, int, int] = (5, 5, 5),
    basis: str = "bspline",
    root: str | os.PathLike[str] | None = None,
    max_file_bytes: int = DEFAULT_MAX_FILE_BYTES,
    setup: Callable[[EditorApp], None] | None = None,
) -> EditorApp:
    """Build the editor (``mesh`` path or the sample mesh, optional ``ffd`` lattice) and serve it (blocking).

    Typed paths are confined to ``root`` (default: the current folder); uploads are removed at exit.
    ``setup(app)`` runs before the server starts (a hook for code, e.g. tests' instrumentation).
    """
    editor = Editor(mesh, shape=tuple(shape), basis=basis)
    if ffd is not None:
        editor.load_ffd(ffd)
    app = EditorApp(editor, root=root, max_file_bytes=max_file_bytes)
    if setup is not None:
        setup(app)
    atexit.register(app.cleanup_files)  # also when the server ends by a signal or an error
    try:
        app.start(port=port, host=host)
    finally:
        app.cleanup_files()
    return app
