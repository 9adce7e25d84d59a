"""The editor in Jupyter: the plotter's trame view (server-side rendering) next to the control panel.

The view is PyVista's own trame Jupyter widget (:func:`trame_pyvista.jupyter.show_trame` with
``mode="server"``): an ``<iframe class="pyvista">`` served by the trame server that runs inside
the kernel. Server-side rendering is what sphere widgets need: every mouse event reaches VTK in
the kernel, the sphere-widget callback deforms the mesh and the server streams the new image.
The iframe's address honours ``pyvista.global_theme.trame.server_proxy_enabled`` /
``server_proxy_prefix`` (for jupyter-server-proxy), exactly like ``plotter.show()``.

The trame server is the package's own (not PyVista's shared one, which may already run unprotected):
it requires a fresh random token, which the iframe's ``src`` carries, and refuses WebSockets from
other sites' pages (:mod:`.web_security`). Behind jupyter-server-proxy the iframe comes from
Jupyter's origin, which Jupyter has checked; the token is still required.

With the ``"static"`` (or ``"none"``) Jupyter backend, e.g. when notebooks run headless in CI, the
view is a picture that the panel's actions refresh instead; either way the output also carries a
PNG of the scene so a saved notebook shows it where widgets cannot run.
"""

from __future__ import annotations

import base64
from typing import Any

import pyvista as pv

from .editor import Editor

__all__ = ["display_editor", "edit", "editor_widget", "push_to_browser", "show_plotter"]

STATIC_BACKENDS = ("static", "none")
SERVER_NAME = "ffd_notebook_views"  # the package's own trame server for its views (see _jupyter_server)
_tokens: dict[str, str] = {}  # server name -> its session token


def edit(
    mesh_or_path: Any = None,
    lattice: Any = None,
    shape: tuple[int, int, int] = (5, 5, 5),
    basis: str = "bspline",
    **kw: Any,
) -> Editor:
    """Open an FFD editor on a mesh in the notebook and return it.

    Parameters
    ----------
    mesh_or_path, lattice, shape, basis, **kw
        As for :class:`~ffd_notebook.view.editor.Editor` (``window_size``, ``off_screen``).

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
    editor = Editor(mesh_or_path, lattice=lattice, shape=shape, basis=basis, **kw)
    display_editor(editor)
    editor._displayed_in = _execution_count()
    return editor


def _execution_count() -> int | None:
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with Jupyter
        return None
    shell = get_ipython()
    return None if shell is None else shell.execution_count


def _backend() -> str:
    backend = pv.global_theme.jupyter_backend
    return "trame" if backend is None else str(backend).lower()


def _jupyter_server() -> Any:
    """The package's trame server for views in Jupyter, started (and protected) if needed.

    Does what :func:`trame_pyvista.jupyter.launch_server` does, but on a server of its own
    (:data:`SERVER_NAME`) that :func:`.web_security.protect` guards with a fresh token and Origin
    checks before it listens, and without initialising trame-vtklocal when it is installed: that
    module downloads a WebAssembly build of VTK from gitlab.kitware.com when a server starts, which
    this server-rendered view never uses (and which fails, noisily, without internet).
    """
    import asyncio
    import os

    from trame.widgets import html, vuetify, vuetify3
    from trame.widgets import vtk as vtk_widgets
    from trame_pyvista.widgets import get_server

    from .web_security import AccessPolicy, new_token, protect

    server = get_server(SERVER_NAME)
    if server.running:
        return server
    for module in (html, vtk_widgets, vuetify if server.client_type == "vue2" else vuetify3):
        module.initialize(server)
    if server._running_stage == 0:
        backend = "jupyter" if pv.global_theme.trame.jupyter_extension_enabled else "aiohttp"
        host = os.environ.get("TRAME_DEFAULT_HOST", "127.0.0.1")
        _tokens[SERVER_NAME] = new_token()
        proxied = lambda: bool(pv.global_theme.trame.server_proxy_enabled)  # noqa: E731 - asked per request
        protect(server, AccessPolicy(_tokens[SERVER_NAME], bind_host=host, behind_proxy=proxied))

        async def start() -> None:
            server.start(
                exec_mode="task",
                host=host,
                port=pv.global_theme.trame.jupyter_server_port,
                open_browser=False,
                show_connection_info=False,
                disable_logging=True,
                timeout=0,
                backend=backend,
            )
            await server.ready

        import nest_asyncio2  # what PyVista uses to start the server without `await` in a cell

        nest_asyncio2.apply()
        asyncio.run(start())
    return server


def _server_rendered(plotter: pv.Plotter) -> Any:
    """PyVista's trame iframe widget for a plotter, with server-side rendering (VTK widgets need it).

    The iframe's address carries the server's session token (the trame client reads it from there).
    """
    from trame_pyvista.jupyter import Widget, show_trame

    from .web_security import url_with_token

    server = _jupyter_server()
    token = _tokens[SERVER_NAME]

    def with_token(viewer: Any, src: str, iframe_attrs: dict[str, Any] | None = None, **kwargs: Any) -> Any:
        src = url_with_token(src, token)
        attrs = {**(iframe_attrs or {}), "src": src}
        return Widget(viewer, src, iframe_attrs=attrs, **kwargs)

    width, height = plotter.window_size
    widget = show_trame(plotter, mode="server", name=server.name, handler=with_token, collapse_menu=True,
                        width=f"{width}px", height=f"{height}px")  # fmt: skip
    plotter._ffd_notebook_viewer = widget.viewer  # for push_to_browser
    return widget


def _in_kernel() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with Jupyter
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def show_plotter(plotter: pv.Plotter, **kwargs: Any) -> Any:
    """Show a plotter whose VTK widgets (sliders, spheres, planes) must stay interactive.

    In a Jupyter kernel with an interactive backend this is the editor's own view: PyVista's
    trame iframe with server-side rendering, on a server started without trame-vtklocal (which
    downloads VTK's WebAssembly build at start-up). Elsewhere (a script, or the ``static`` backend
    of a headless notebook run) it is ``plotter.show(**kwargs)``.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.notebook import show_plotter
    >>> pl = pv.Plotter(off_screen=True, window_size=(120, 90))
    >>> _ = pl.add_mesh(pv.Sphere())
    >>> show_plotter(pl, screenshot=False) is None      # outside a kernel: plotter.show()
    True
    """
    if not _in_kernel() or _backend() in STATIC_BACKENDS:
        return plotter.show(**kwargs)
    return _server_rendered(plotter)


def push_to_browser(plotter: pv.Plotter) -> None:
    """Send a new image to the browser view of ``plotter`` after a change made from code.

    Does nothing for a plotter that :func:`show_plotter` has not served through trame.

    Examples
    --------
    >>> import pyvista as pv
    >>> pl = pv.Plotter(off_screen=True)
    >>> push_to_browser(pl)   # not shown in a browser: nothing to send
    >>> pl.close()
    """
    viewer = getattr(plotter, "_ffd_notebook_viewer", None)
    if viewer is not None:
        viewer.update()


def _trame_view(editor: Editor) -> Any:
    """The editor's trame view: server-side rendering, and the editor pushes frames after its changes."""
    from .web_security import test_hooks_enabled

    widget = _server_rendered(editor.plotter)
    editor.attach_viewer(widget.viewer)
    if test_hooks_enabled():  # internal state for browser tests only
        editor.register_triggers(widget.viewer.server)
    return widget


def _png(editor: Editor) -> bytes:
    """The editor's scene, rendered now, as PNG bytes."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(editor.screenshot()).save(buf, format="PNG")
    return buf.getvalue()


def _static_view(editor: Editor) -> Any:
    """A PNG of the scene that follows the editor's changes (no dragging without a trame view)."""
    import ipywidgets as widgets

    view = widgets.Image(value=_png(editor), format="png")

    def follow(event: str) -> None:
        if event in ("offsets", "lattice", "mesh", "display", "select"):
            view.value = _png(editor)

    editor.observe(follow)
    return view


def editor_widget(editor: Editor) -> Any:
    """The editor's notebook widget: ``ipywidgets.HBox([view, ControlPanel(editor)])`` (made once per editor)."""
    box = getattr(editor, "_notebook_widget", None)
    if box is None:
        import ipywidgets as widgets

        from .panel import ControlPanel

        view = _static_view(editor) if _backend() in STATIC_BACKENDS else _trame_view(editor)
        box = widgets.HBox([view, ControlPanel(editor)])
        editor._notebook_widget = box
    return box


class _EditorOutput:
    """Display bundle: the live widget plus a PNG of the scene for viewers without a kernel."""

    def __init__(self, editor: Editor) -> None:
        self.editor = editor

    def _repr_mimebundle_(self, include: Any = None, exclude: Any = None) -> dict[str, Any]:
        bundle = dict(editor_widget(self.editor)._repr_mimebundle_(include=include, exclude=exclude) or {})
        bundle["image/png"] = base64.b64encode(_png(self.editor)).decode("ascii")
        bundle["text/plain"] = repr(self.editor)
        return bundle


def display_editor(editor: Editor) -> None:
    """Show the editor in the notebook (once per cell: see :func:`edit`)."""
    from IPython.display import display

    if getattr(editor, "_displayed_in", None) is not None and editor._displayed_in == _execution_count():
        return
    display(_EditorOutput(editor))
