"""The standalone FFD editor: an :class:`~ffd_notebook.view.editor.Editor` in a trame web page.

The page is a Vuetify 3 layout: the plotter's :class:`~ffd_notebook.view.serving.remote_view.RemoteView` (server-side
rendering, which the drag handle needs) and a side panel drawn from the same list of controls as the
notebook panel. The panel only calls session commands (:func:`..session.controls.run`); the session
tells the page what changed (:meth:`EditingSession.subscribe <..session.EditingSession.subscribe>`), so
edits made anywhere (drag, panel, undo, code) show up everywhere. File actions go through the app's
:class:`~.files.AppFiles` (``app.files``): paths confined to a root folder, uploads, worker threads.

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
from collections.abc import Callable
from typing import Any

from ....ffd.basis import BasisName
from ...serving.file_root import DEFAULT_MAX_FILE_BYTES, FileRoot
from ...serving.web_security import AccessPolicy, new_token, protect, url_with_token
from ..editor import Editor
from ..session import controls as panel_controls
from ..session.changes import Change, DragSync
from ..session.controls import by_key, run, session_state
from .files import MESH_FORMATS, AppFiles
from .layout import build_layout

__all__ = ["EditorApp", "run_app"]


class EditorApp:
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
    >>> app.run("apply", [1, 2, 1, 0.0, 0.0, 0.25])
    True
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
        root_folder = FileRoot(os.getcwd() if root is None else root, max_bytes=max_file_bytes)
        self.files = AppFiles(editor, self.state, root_folder, sync=self.sync)  # typed paths, uploads, downloads
        self.token = new_token() if token is None else token
        self.url: str | None = None
        self._drag_sync = DragSync()
        self.controls = [c for c in panel_controls.CONTROLS if "app" in c.panels]
        self.state.update(self._editor_values())
        self.state.update({c.key: c.default for c in self.controls if c.default is not None})
        self.state.update({f"{c.key}_items": [{"value": v, "title": t} for v, t in c.choices] for c in self.controls})
        self.state.update(
            trame__title="ffd_notebook editor",
            root_name=str(root_folder.path),
            ffd_upload=None,
            mesh_upload=None,
            mesh_format=MESH_FORMATS[0],
            mesh_format_items=MESH_FORMATS,
            busy=False,
            busy_text="",
            code_text="",
            code_open=False,
            recording=False,
            record_progress=0,
        )
        for name_, method in (
            ("ffd_load_ffd", self.files.load_deformation_in_background),
            ("ffd_save_ffd", self.files.save_deformation_in_background),
            ("ffd_load_mesh", self.files.load_mesh_in_background),
            ("ffd_load_face", self.files.load_face_in_background),
            ("ffd_save_mesh", self.files.save_mesh_in_background),
            ("ffd_download_ffd", self.files.download_ffd),
            ("ffd_download_mesh", self.files.download_mesh),
            ("ffd_rebuild", self.files.rebuild),
            ("ffd_undo", self.files.undo),
            ("ffd_redo", self.files.redo),
            ("ffd_basis", self.files.set_basis),
            ("ffd_decimate", self.files.decimate),
            ("ffd_load_image", self.files.load_image_in_background),
            ("ffd_save_image", self.files.save_image_in_background),
            ("ffd_show_code", self.files.show_code),
            ("ffd_download_code", self.files.download_code),
            ("ffd_record", self.files.record),
        ):
            self.server.controller.trigger(name_)(method)
        self.layout, self.view = build_layout(self)
        editor.scene.views.add(self.view)
        editor.session.subscribe(self._on_editor_change)
        for control in self.controls:
            if control.command is not None and control.kind != "button":  # inputs act when their value changes
                self.state.change(*control.state)(self._input_handler(control))
        self.state.change("ffd_upload")(self.files.receive_ffd_upload)
        self.state.change("mesh_upload")(self.files.receive_mesh_upload)

    # ------------------------------------------------------------------ editor -> page
    def _editor_values(self) -> dict[str, Any]:
        values = session_state(self.editor.session)
        if "sel_i" not in values and "sel_i" not in self.state:
            values.update(sel_i=0, sel_j=0, sel_k=0, dx=0.0, dy=0.0, dz=0.0)
        return values

    def sync(self) -> None:
        """Copy the editor's state (:func:`..session.controls.session_state`) to the page.

        Examples
        --------
        A value typed on the page but not applied goes back to the editor's:

        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> app = EditorApp(Editor(sphere, shape=(4, 4, 4), window_size=(64, 48)), name="doctest_app_sync")
        >>> app.state.nx = 7
        >>> app.sync()
        >>> app.state.nx
        4
        >>> app.close()
        """
        with self.state:
            self.state.update(self._editor_values())

    def _on_editor_change(self, change: Change) -> None:
        if self._drag_sync.wanted(change):  # drags: at most every DRAG_SYNC_S (each sync is a websocket message)
            self.sync()

    # ------------------------------------------------------------------ page -> editor
    def _input_handler(self, control: Any) -> Any:
        return lambda **values: self.run(control.key, [values[k] for k in control.state])

    def run(self, key: str, values: list[Any] | None = None) -> bool:
        """Run the panel control ``key`` (see :data:`..session.controls.CONTROLS`) with the page's ``values``.

        A failure becomes a message on the page instead of a traceback. File actions go through the
        app's root folder and a worker thread (their named triggers) instead of the editor's own.

        Parameters
        ----------
        key : str
            The control's key (``"apply"``, ``"undo"``, ``"reset_all"``...).
        values : list, optional
            The values of the control's page fields, in order (e.g. ``[i, j, k, dx, dy, dz]`` for ``"apply"``).

        Returns
        -------
        bool
            Whether the command succeeded (True for a file action handed to its worker).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> app = EditorApp(Editor(sphere, shape=(4, 4, 4), window_size=(64, 48)), name="doctest_app_run")
        >>> app.run("apply", [1, 2, 1, 0.0, 0.0, 0.25]), app.editor.lattice.offsets[1, 2, 1].tolist()
        (True, [0.0, 0.0, 0.25])
        >>> app.run("apply", [9, 2, 1, 0.0, 0.0, 0.25]), app.state.messages[-1]["error"]
        (False, True)
        >>> app.close()
        """
        control = by_key(key, self.controls)
        if control.app_trigger is not None:
            self.server.controller.trigger_fn(control.app_trigger)(*(values or []))
            return True
        ok = run(self.editor.session, control, values or [])
        self.sync()
        return ok

    def reset_camera(self) -> None:
        """Fit the camera to the scene.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> app = EditorApp(Editor(sphere, shape=(4, 4, 4), window_size=(64, 48)), name="doctest_app_camera")
        >>> app.editor.plotter.camera.position = (10.0, 10.0, 10.0)
        >>> app.reset_camera()
        >>> bool(max(abs(v) for v in app.editor.plotter.camera.position) < 10.0)
        True
        >>> app.close()
        """
        self.editor.plotter.reset_camera()
        self.view.update()

    # ------------------------------------------------------------------ running
    def start(self, port: int = 8080, host: str = "127.0.0.1", **kwargs: Any) -> Any:
        """Serve the page (blocks until the server stops); prints the URL, with its token, once listening.

        The server requires the token and refuses other sites' pages (:func:`.web_security.protect`).

        Parameters
        ----------
        port : int, default 8080
            The port to listen on (0: any free port).
        host : str, default "127.0.0.1"
            The interface to listen on (``"0.0.0.0"`` for every one: the printed URL then names this machine).
        **kwargs
            Passed to trame's ``server.start`` (by default no browser is opened, no connection banner
            printed, and an idle server is not stopped).

        Returns
        -------
        object
            What trame's ``server.start`` returns once the server has stopped (None when it ran in the main loop).

        Examples
        --------
        A server that fetches its own page once listening, then stops:

        >>> import asyncio
        >>> import aiohttp
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> app = EditorApp(Editor(sphere, shape=(4, 4, 4), window_size=(64, 48)), name="doctest_app_start")
        >>> statuses = []
        >>> async def visit():
        ...     async with aiohttp.ClientSession() as http, http.get(app.url) as page:
        ...         statuses.append(page.status)
        ...     await app.server.stop()
        >>> app.server.controller.on_server_ready.add(lambda **_: asyncio.ensure_future(visit()))
        >>> app.start(port=0)  # doctest: +ELLIPSIS
        ffd_notebook editor running at http://127.0.0.1:.../?secret=...
        >>> statuses
        [200]
        >>> app.close()
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
        """Remove the uploads folder and close the editor.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> app = EditorApp(Editor(sphere, shape=(4, 4, 4), window_size=(64, 48)), name="doctest_app_close")
        >>> app.close()
        >>> app.editor.lifetime.alive
        False
        """
        self.files.cleanup()
        self.editor.close()


def run_app(
    mesh: str | os.PathLike[str] | None = None,
    ffd: str | os.PathLike[str] | None = None,
    port: int = 8080,
    host: str = "127.0.0.1",
    shape: tuple[int, ...] = (5, 5, 5),
    basis: BasisName = "bspline",
    root: str | os.PathLike[str] | None = None,
    max_file_bytes: int = DEFAULT_MAX_FILE_BYTES,
    setup: Callable[[EditorApp], None] | None = None,
    image: str | os.PathLike[str] | None = None,
) -> EditorApp:
    """Build the editor and serve it (blocking) until the server stops.

    The editor shows the ``mesh`` file (or the sample mesh), with an optional ``ffd`` deformation
    file and an optional ``image`` shown as warped slices (an image without a mesh gets a lattice
    fitted to its box). Typed paths are confined to ``root`` (default: the current folder); uploads
    are removed at exit. ``setup(app)`` runs before the server starts (a hook for code, e.g. tests'
    instrumentation).

    Parameters
    ----------
    mesh : str or os.PathLike, optional
        A mesh file; the sample mesh if omitted.
    ffd : str or os.PathLike, optional
        A deformation file loaded onto it (:meth:`Editor.load_deformation`).
    port : int, default 8080
        The port to listen on (0: any free port).
    host : str, default "127.0.0.1"
        The interface to listen on.
    shape : tuple of int, default (5, 5, 5)
        Control points per axis of the fitted lattice.
    basis : {"bspline", "bernstein"}, default "bspline"
        The FFD basis.
    root : str or os.PathLike, optional
        The folder typed paths are confined to.
    max_file_bytes : int
        Largest file the app reads or accepts as an upload.
    setup : callable, optional
        ``setup(app)``, called with the :class:`EditorApp` before the server starts.
    image : str or os.PathLike, optional
        An image file shown as three slices warped by the lattice.

    Returns
    -------
    EditorApp
        The app, once its server has stopped.

    Examples
    --------
    A server on a sphere that fetches its own page once listening, then stops:

    >>> import asyncio, os, tempfile
    >>> import aiohttp
    >>> import pyvista as pv
    >>> path = os.path.join(tempfile.mkdtemp(), "ball.ply")
    >>> pv.Sphere(theta_resolution=8, phi_resolution=8).save(path)
    >>> statuses = []
    >>> def visit_then_stop(app):
    ...     async def visit():
    ...         async with aiohttp.ClientSession() as http, http.get(app.url) as page:
    ...             statuses.append(page.status)
    ...         await app.server.stop()
    ...     app.server.controller.on_server_ready.add(lambda **_: asyncio.ensure_future(visit()))
    >>> app = run_app(path, port=0, shape=(4, 4, 4), root=os.path.dirname(path), setup=visit_then_stop)
    ... # doctest: +ELLIPSIS
    ffd_notebook editor running at http://127.0.0.1:.../?secret=...
    >>> statuses, app.editor.mesh.n_points, app.editor.lattice.shape
    ([200], 50, (4, 4, 4))
    >>> app.editor.close()
    """
    editor = Editor(mesh, shape=tuple(shape), basis=basis, image=image)
    if ffd is not None:
        editor.load_deformation(ffd)
    app = EditorApp(editor, root=root, max_file_bytes=max_file_bytes)
    if setup is not None:
        setup(app)
    atexit.register(app.files.cleanup)  # also when the server ends by a signal or an error
    try:
        app.start(port=port, host=host)
    finally:
        app.files.cleanup()
    return app
