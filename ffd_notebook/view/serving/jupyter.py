"""Showing a plotter in Jupyter through trame: shared by the editor, the GP explorer and the cut viewer.

The view is an ``<iframe class="pyvista">`` (PyVista's trame Jupyter widget,
:class:`trame_pyvista.jupyter.Widget`) showing a page of the trame server that runs inside the
kernel; the page holds one :class:`~.remote_view.RemoteView` of the plotter. Server-side rendering
is what sphere widgets need: every mouse event reaches VTK in the kernel, the widget callback
changes the scene and the server streams the new image, paced by the renderer (see
:mod:`.remote_view` for why this view rather than PyVista's ``show_trame(mode="server")``).
The iframe's address honours ``pyvista.global_theme.trame.server_proxy_enabled`` /
``server_proxy_prefix`` (for jupyter-server-proxy), exactly like ``plotter.show()``.

The trame server is the package's own (not PyVista's shared one, which may already run unprotected):
it requires a fresh random token, which the iframe's ``src`` carries, and refuses WebSockets from
other sites' pages (:mod:`.web_security`). Behind jupyter-server-proxy the iframe comes from
Jupyter's origin, which Jupyter has checked; the token is still required.

With the ``"static"`` (or ``"none"``) Jupyter backend, e.g. when notebooks run headless in CI,
:func:`show_plotter` falls back to ``plotter.show()``. Changes made from code reach the browser
through the plotter's :class:`BrowserViews` (:func:`views_of`), the one place that pushes frames.
"""

from __future__ import annotations

import functools
import itertools
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import NDArray

__all__ = [
    "STATIC_BACKENDS",
    "BrowserViews",
    "aim_unset_cameras",
    "backend",
    "current_cell_id",
    "execution_count",
    "fit_to_output",
    "forget_shown",
    "in_kernel",
    "jupyter_server",
    "keep_while_shown",
    "png_bytes",
    "push_to_browser",
    "release_views",
    "serve_plotter",
    "show_changes",
    "show_plotter",
    "views_of",
]

STATIC_BACKENDS = ("static", "none")
#: the narrowest a view gets in a narrow notebook (pixels; see :func:`fit_to_output`)
MIN_VIEW_WIDTH = 320
SERVER_NAME = "ffd_notebook_views"  # the package's own trame server for its views (see jupyter_server)
_tokens: dict[str, str] = {}  # server name -> its session token
_pages = itertools.count(1)  # page (template) names of the served plotters


def execution_count() -> int | None:
    """The IPython shell's execution count (the cell being run), or None outside IPython."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with Jupyter
        return None
    shell = get_ipython()
    return None if shell is None else shell.execution_count


def backend() -> str:
    """PyVista's Jupyter backend, lower case (``"trame"`` when unset)."""
    backend = pv.global_theme.jupyter_backend
    return "trame" if backend is None else str(backend).lower()


def jupyter_server() -> Any:
    """The package's trame server for views in Jupyter, started (and protected) if needed.

    Does what :func:`trame_pyvista.jupyter.launch_server` does, but on a server of its own
    (:data:`SERVER_NAME`) that :func:`.web_security.protect` guards with a fresh token and Origin
    checks before it listens, and without initialising trame-vtklocal when it is installed: that
    module downloads a WebAssembly build of VTK from gitlab.kitware.com when a server starts, which
    this server-rendered view never uses (and which fails, noisily, without internet).
    """
    import asyncio
    import os

    from trame.widgets import html, rca, vuetify, vuetify3
    from trame.widgets import vtk as vtk_widgets
    from trame_pyvista.widgets import get_server

    from .web_security import AccessPolicy, new_token, protect

    server = get_server(SERVER_NAME)
    if server.running:
        return server
    # trame-rca before the start: its protocol (the views' images and events) is set up when the server starts
    for module in (html, vtk_widgets, rca, vuetify if server.client_type == "vue2" else vuetify3):
        module.initialize(server)
    if SERVER_NAME not in _tokens:  # not started yet by this process (a start in progress has its token)
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


def serve_plotter(plotter: pv.Plotter) -> Any:
    """An iframe widget showing ``plotter`` with server-side rendering (VTK widgets need it).

    The iframe shows a page of :func:`jupyter_server` holding a :class:`~.remote_view.RemoteView`
    that fills it; its address carries the server's session token (the trame client reads it from
    there). The view joins the plotter's :class:`BrowserViews`, so :func:`push_to_browser` reaches it.
    Cameras nobody has placed are aimed at the scene first (:func:`aim_unset_cameras`).
    """
    from trame.ui.html import DivLayout
    from trame_pyvista.jupyter import build_url

    from .remote_view import RemoteView
    from .web_security import url_with_token

    aim_unset_cameras(plotter)
    server = jupyter_server()
    page = f"ffd_view_{next(_pages)}"
    with DivLayout(server, template_name=page) as layout:
        layout.root.style = "width: 100vw; height: 100vh; margin: 0; padding: 0; overflow: hidden;"
        view = RemoteView(plotter, style="width: 100%; height: 100%;")
    src = url_with_token(build_url(server, ui=page), _tokens[SERVER_NAME])
    widget = _view_widget_class()(view, src)
    fit_to_output(widget, src, *plotter.window_size)
    views_of(plotter).add(view, on_close=functools.partial(_retire_page, server, page, weakref.ref(widget)))
    return widget


#: what a view shows once its plotter is released (its owner closed, or collected)
CLOSED_MESSAGE = (
    "This view is closed: what it showed was closed, or is no longer referenced by any variable or output "
    "(run its cell again to get a new one)."
)


def _retire_page(server: Any, page: str, widget: weakref.ref[Any]) -> None:
    """A released view's page and iframe show :data:`CLOSED_MESSAGE` instead of a picture nobody updates."""
    import html

    text = html.escape(CLOSED_MESSAGE)
    with server.state:
        server.state[f"trame__template_{page}"] = f'<div style="font: 14px sans-serif; padding: 1em;">{text}</div>'
    shown = widget()
    if shown is not None:
        shown.value = f'<div style="font-style: italic; color: #666; padding: 0.5em;">{text}</div>'


@functools.cache
def _view_widget_class() -> type:
    import ipywidgets as widgets

    class ViewWidget(widgets.HTML):
        """The iframe of a served view (like :class:`trame_pyvista.jupyter.Widget`, whose ``viewer`` is
        ``RemoteView``). ipywidgets keeps every widget until it is closed, so this one refers to its view
        weakly: ``viewer`` is None once the view is released."""

        def __init__(self, viewer: Any, src: str) -> None:
            super().__init__()
            self._viewer = weakref.ref(viewer)
            self.src = src

        @property
        def viewer(self) -> Any:
            """The :class:`~.remote_view.RemoteView` shown, or None once it is released."""
            return self._viewer()

    return ViewWidget


def aim_unset_cameras(plotter: pv.Plotter) -> None:
    """Aim every camera of ``plotter`` that nobody has placed at its scene, as ``plotter.show()`` does on its
    first render: PyVista's default view direction, reset to the visible actors.

    A plotter served through trame never goes through ``show()``: a GP explorer shown in a notebook without
    a camera position looked from VTK's default camera, at the origin, and showed no mesh at all.

    Examples
    --------
    >>> import pyvista as pv
    >>> pl = pv.Plotter(off_screen=True)
    >>> _ = pl.add_mesh(pv.Sphere(center=(100.0, 0.0, 0.0)))
    >>> aim_unset_cameras(pl)
    >>> [round(v) for v in pl.camera.focal_point], pl.renderer.camera_set
    ([100, 0, 0], True)
    >>> pl.camera_position = "xy"   # a camera placed by its maker is left where it is
    >>> before = pl.camera_position
    >>> aim_unset_cameras(pl); pl.camera_position == before
    True
    >>> pl.close()
    """
    for renderer in plotter.renderers:
        if not renderer.camera_set:
            renderer.camera_position = renderer.get_default_cam_pos()
            renderer.reset_camera(render=False)


def fit_to_output(widget: Any, src: str, width: int, height: int) -> None:
    """Make the view's iframe as wide as its row allows, up to ``width`` pixels (at least
    :data:`MIN_VIEW_WIDTH`), keeping the ``width : height`` proportions: a narrow notebook (JupyterLab
    with its file browser open on a laptop screen) shrinks the view instead of cutting off what is
    next to it. The server renders at the iframe's size, so the picture stays sharp and framed.

    Examples
    --------
    >>> import ipywidgets
    >>> widget = ipywidgets.HTML()
    >>> fit_to_output(widget, "http://127.0.0.1:1/index.html?ui=a&token=b", 800, 600)
    >>> "aspect-ratio: 802 / 602" in widget.value, "ui=a&amp;token=b" in widget.value, widget.layout.max_width
    (True, True, '802px')
    """
    import html

    import ipywidgets as widgets

    # border-box: at its widest the iframe's inside is exactly width x height (the window's size)
    border = "border: 1px solid rgb(221,221,221); box-sizing: border-box; display: block;"
    style = f"width: 100%; aspect-ratio: {width + 2} / {height + 2}; {border}"
    widget.value = f'<iframe src="{html.escape(src)}" class="pyvista" scrolling="no" style="{style}"></iframe>'
    narrowest = f"{min(width, MIN_VIEW_WIDTH) + 2}px"  # (+ the border)
    # grows from the narrowest: in a row with a panel, the panel keeps its width and the view takes the rest
    widget.layout = widgets.Layout(flex=f"1 1 {narrowest}", max_width=f"{width + 2}px", min_width=narrowest)


def in_kernel() -> bool:
    """Whether this runs in a Jupyter kernel."""
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
    >>> from ffd_notebook.view.serving.jupyter import show_plotter
    >>> pl = pv.Plotter(off_screen=True, window_size=(120, 90))
    >>> _ = pl.add_mesh(pv.Sphere())
    >>> show_plotter(pl, screenshot=False) is None      # outside a kernel: plotter.show()
    True
    """
    if not in_kernel() or backend() in STATIC_BACKENDS:
        return plotter.show(**kwargs)
    return serve_plotter(plotter)


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
    views_of(plotter).push()


def show_changes(plotter: pv.Plotter) -> None:
    """Show a change of ``plotter``'s scene: its browser views render it and send a new image, or, with
    none, ``plotter.render()`` (see :meth:`BrowserViews.show_changes`).

    Examples
    --------
    >>> import pyvista as pv
    >>> pl = pv.Plotter(off_screen=True)
    >>> show_changes(pl)   # not shown in a browser: renders (once the plotter has been shown)
    >>> pl.close()
    """
    views_of(plotter).show_changes(plotter.render)


class BrowserViews:
    """The trame viewers (objects with ``.update()``) showing one plotter in browsers.

    :meth:`push` sends each of them a new image: the single place where frames are pushed after
    changes made from code, for every product (editor, GP explorer, cut viewer, the app).

    Examples
    --------
    >>> class Viewer:
    ...     n = 0
    ...     def update(self):
    ...         self.n += 1
    >>> views, viewer = BrowserViews(), Viewer()
    >>> views.add(viewer); views.push(); viewer.n
    1
    >>> views.clear(); views.push(); viewer.n
    1
    """

    def __init__(self, on_error: Callable[[str], None] | None = None) -> None:
        self.viewers: list[Any] = []
        self.on_error = on_error
        self._on_close: list[Callable[[], Any]] = []

    def add(self, viewer: Any, *, on_close: Callable[[], Any] | None = None) -> None:
        """Let ``viewer`` receive a new image on every :meth:`push`; :meth:`close` closes it (if it has a
        ``close()``) and calls ``on_close()``."""
        self.viewers.append(viewer)
        if on_close is not None:
            self._on_close.append(on_close)

    def push(self) -> None:
        """Send a new image to every viewer; a failing viewer is reported to ``on_error`` (or raises)."""
        for viewer in list(self.viewers):
            try:
                viewer.update()
            except Exception as exc:
                if self.on_error is None:
                    raise
                self.on_error(f"could not update a browser view: {exc!r}")

    def show_changes(self, render: Callable[[], Any]) -> None:
        """Show a change of the scene: every viewer renders it and sends a new image (:meth:`push`); with no
        viewer, ``render()`` now.

        Rendering first and then pushing drew each change made from code twice in a browser (a viewer
        renders again to read the image back): ~40-50 ms of software rendering per change on a 53k-vertex mesh.

        Examples
        --------
        >>> views, renders = BrowserViews(), []
        >>> views.show_changes(lambda: renders.append("render"))  # no viewer: render now
        >>> class Viewer:
        ...     def update(self):
        ...         renders.append("viewer")
        >>> views.add(Viewer()); views.show_changes(lambda: renders.append("render"))
        >>> renders
        ['render', 'viewer']
        """
        if self.viewers:
            self.push()
        else:
            render()

    def clear(self) -> None:
        """Forget every viewer."""
        self.viewers.clear()

    def close(self) -> None:
        """Close every viewer and forget it (the plotter is being released).

        Examples
        --------
        >>> class Viewer:
        ...     closed = False
        ...     def update(self):
        ...         pass
        ...     def close(self):
        ...         self.closed = True
        >>> views, viewer, log = BrowserViews(), Viewer(), []
        >>> views.add(viewer, on_close=lambda: log.append("page retired")); views.close()
        >>> viewer.closed, log, views.viewers
        (True, ['page retired'], [])
        """
        viewers, self.viewers = self.viewers, []
        on_close, self._on_close = self._on_close, []
        for action in [*(v.close for v in viewers if hasattr(v, "close")), *on_close]:
            try:
                action()
            except Exception as exc:
                if self.on_error is None:
                    raise
                self.on_error(f"could not close a browser view: {exc!r}")


_views: weakref.WeakKeyDictionary[Any, BrowserViews] = weakref.WeakKeyDictionary()


def views_of(plotter: pv.Plotter) -> BrowserViews:
    """The :class:`BrowserViews` of ``plotter`` (made on first use; forgotten with the plotter).

    The views refer to no plotter (a value of this weak-keyed table that did would keep its key alive).
    """
    views = _views.get(plotter)
    if views is None:
        views = _views[plotter] = BrowserViews()
    return views


def release_views(plotter: pv.Plotter) -> None:
    """Close the browser views of ``plotter`` (:meth:`BrowserViews.close`): their pages and iframes say
    so, the server forgets them. Part of releasing a plotter; the shared server keeps running.

    Examples
    --------
    >>> import pyvista as pv
    >>> pl = pv.Plotter(off_screen=True)
    >>> release_views(pl)   # never served: nothing to close
    >>> pl.close()
    """
    views = _views.pop(plotter, None)
    if views is not None:
        views.close()


# ---------------------------------------------------------------------- what a notebook output keeps alive
#: cell id -> the owners (editors, explorers, viewers) its last run showed: an output keeps what it shows
#: alive until its cell runs again (the output is replaced)
_shown_by_cell: dict[str, list[Any]] = {}
_shown_forever: list[Any] = []  # shown by a front-end that sends no cell ids: nothing says when it goes


def current_cell_id() -> str | None:
    """The id of the notebook cell being run (JupyterLab, Notebook 7 and VS Code send it), or None."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with Jupyter
        return None
    kernel = getattr(get_ipython(), "kernel", None)
    if kernel is None:
        return None
    try:
        parent = kernel.get_parent()
    except Exception:  # an older kernel: no cell ids
        return None
    cell = (parent or {}).get("metadata", {}).get("cellId")
    return cell if isinstance(cell, str) and cell else None


def keep_while_shown(owner: Any) -> None:
    """Keep ``owner`` alive while the output of the cell being run shows it, i.e. until that cell runs
    again: the one strong reference a notebook output holds (the widgets in ipywidgets' registry refer
    to their owner weakly). Without a cell id (a front-end that sends none) it is kept for the kernel's
    life, since nothing tells when its output goes. Outside a kernel, nothing is kept.

    Examples
    --------
    >>> keep_while_shown(object())   # not in a kernel: nothing to keep
    >>> _shown_by_cell, _shown_forever
    ({}, [])
    """
    if not in_kernel():
        return
    cell = current_cell_id()
    if cell is None:
        _shown_forever.append(owner)
        return
    _forget_replaced_outputs()
    _shown_by_cell.setdefault(cell, []).append(owner)


def forget_shown(owner: Any) -> None:
    """Stop keeping ``owner`` for the outputs showing it (it was closed)."""
    for owners in [*_shown_by_cell.values(), _shown_forever]:
        owners[:] = [o for o in owners if o is not owner]


_hooked: list[Any] = []  # the IPython shell whose "pre_run_cell" event forgets replaced outputs


def _forget_replaced_outputs() -> None:
    from IPython import get_ipython

    shell = get_ipython()
    if shell is None or any(s is shell for s in _hooked):
        return

    def cell_runs(info: Any) -> None:  # its old output is replaced: what only that output kept may go
        cell_id = getattr(info, "cell_id", None)
        if cell_id is not None:  # no id: nothing was kept under one
            _shown_by_cell.pop(cell_id, None)

    shell.events.register("pre_run_cell", cell_runs)
    _hooked.append(shell)


def png_bytes(image: NDArray[np.uint8]) -> bytes:
    """An ``(h, w, 3)`` uint8 image as PNG bytes.

    Examples
    --------
    >>> import numpy as np
    >>> png_bytes(np.zeros((2, 3, 3), dtype=np.uint8))[:4]
    b'\\x89PNG'
    """
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    return buf.getvalue()
