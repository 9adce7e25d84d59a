"""Showing a plotter in Jupyter through trame: shared by the editor, the GP explorer and the cut viewer.

The view is an ``<iframe class="pyvista">`` (PyVista's trame Jupyter widget,
:class:`trame_pyvista.jupyter.Widget`) showing a page of the trame server that runs inside the
kernel; the page holds one :class:`~.remote_view.RemoteView` of the plotter. Server-side rendering
is what sphere widgets need: every mouse event reaches VTK in the kernel, the widget callback
changes the scene and the server streams the new image, paced by the renderer (see
:mod:`.remote_view` for why this view rather than PyVista's ``show_trame(mode="server")``).

Where the iframe loads the page from is decided in the browser, so that the view works however the
notebook is reached (:func:`view_iframe_html`). The server listens on the kernel's machine, on a port
of its own; a browser elsewhere (an SSH tunnel to a lab machine, Docker's ``-p 8888:8888``, VS Code's
port forwarding, a hub) reaches only Jupyter's port. So the iframe first asks Jupyter's own
jupyter-server-proxy for the page (``<base_url>proxy/<port>/``, the base URL read from the notebook
page) and uses that address if *this* server answers there (:data:`.web_security.SERVER_ID_HEADER`);
otherwise (no jupyter-server-proxy in the Jupyter server, a front-end that is not Jupyter's) it opens
the server's own address, ``http://localhost:<port>/``. The proxied address is tried first because it
is the safe one: the probe goes to the notebook's own origin, which the user has already trusted and
logged into, and the token is sent only once the answer proves to come from this server; opening the
direct address first would hand the token to whatever listens on that port of the *browser's*
machine, which is not the kernel's one in every case above, and the browser cannot check who
answers there without being allowed to by the answer itself. The price of going through Jupyter is
small: the first image came no later (medians of 0.6-1.2 s on either route, on a loaded 2-core
machine) and a drag's frames 1-6 % later (``tests/benchmarks/bench_first_image.py``). When PyVista's
``pyvista.global_theme.trame.server_proxy_enabled`` is set (JupyterHub's environment sets it), the
iframe opens its ``server_proxy_prefix`` address directly, as ``plotter.show()`` does.

The trame server is the package's own (not PyVista's shared one, which may already run unprotected):
it requires a fresh random token, which the iframe's address carries, and refuses WebSockets from
other sites' pages (:mod:`.web_security`). Behind jupyter-server-proxy the iframe comes from
Jupyter's origin, which Jupyter has checked (see :mod:`.web_security`); the token is still required.

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
    "view_iframe_html",
    "views_of",
]

STATIC_BACKENDS = ("static", "none")
#: the narrowest a view gets in a narrow notebook (pixels; see :func:`fit_to_output`)
MIN_VIEW_WIDTH = 320
SERVER_NAME = "ffd_notebook_views"  # the package's own trame server for its views (see jupyter_server)
_policies: dict[str, Any] = {}  # server name -> its AccessPolicy (session token, public id)
#: how long the view waits for Jupyter's proxy to answer before it opens the server's own address
PROXY_PROBE_TIMEOUT_S = 10.0
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
    if SERVER_NAME not in _policies:  # not started yet by this process (a start in progress has its token)
        backend = "jupyter" if pv.global_theme.trame.jupyter_extension_enabled else "aiohttp"
        host = os.environ.get("TRAME_DEFAULT_HOST", "127.0.0.1")
        proxied = lambda: bool(pv.global_theme.trame.server_proxy_enabled)  # noqa: E731 - asked per request
        _policies[SERVER_NAME] = AccessPolicy(new_token(), bind_host=host, behind_proxy=proxied, forwarded=True)
        protect(server, _policies[SERVER_NAME])

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
    there) and is found by the browser (:func:`view_iframe_html`); the widget's ``src`` is the
    server's own address (or the configured proxied one). The view joins the plotter's
    :class:`BrowserViews`, so :func:`push_to_browser` reaches it.
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
    policy = _policies[SERVER_NAME]
    src = url_with_token(build_url(server, ui=page), policy.token)
    widget = _view_widget_class()(view, src)
    if pv.global_theme.trame.server_proxy_enabled:  # the address is configured (a hub): open it
        iframe = view_iframe_html(src)
    else:  # the browser finds its way (see the module docstring)
        direct = url_with_token(build_url(server, ui=page, server_proxy_enabled=False), policy.token)
        proxied = build_url(server, ui=page, server_proxy_enabled=True, server_proxy_prefix="proxy/")
        iframe = view_iframe_html(direct, proxied=proxied, token=policy.token, server_id=policy.server_id)
    fit_to_output(widget, iframe, *plotter.window_size)
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


def view_iframe_html(src: str, *, proxied: str | None = None, token: str = "", server_id: str = "") -> str:
    """The view's ``<iframe class="pyvista">`` (without a style; :func:`fit_to_output` adds it).

    With only ``src``, the iframe opens ``src``. With ``proxied`` (the page's address relative to
    Jupyter's base URL, ``proxy/<port>/index.html?...``, without the token), the iframe holds a small
    page (``srcdoc``, which has the notebook page's origin) that reads Jupyter's base URL from the
    notebook page, asks Jupyter for ``<base_url><proxied>`` and, if the answer carries
    :data:`.web_security.SERVER_ID_HEADER` equal to ``server_id``, opens that address with ``token``
    added; otherwise (no Jupyter page around, no jupyter-server-proxy, another server answering, no
    answer within :data:`PROXY_PROBE_TIMEOUT_S`) it opens ``src``. See the module docstring for why
    in this order.

    Examples
    --------
    >>> view_iframe_html("http://localhost:1/index.html?ui=a&secret=b")
    '<iframe src="http://localhost:1/index.html?ui=a&amp;secret=b" class="pyvista" scrolling="no"></iframe>'
    >>> html = view_iframe_html("http://localhost:1/index.html?ui=a&secret=b", proxied="proxy/1/index.html?ui=a",
    ...                         token="b", server_id="c0ffee")
    >>> html.startswith('<iframe srcdoc="'), "proxy/1/index.html?ui=a" in html, "src=" in html
    (True, True, False)
    """
    import html
    import json

    from .web_security import SERVER_ID_HEADER, url_with_token

    if proxied is None:
        return f'<iframe src="{html.escape(src)}" class="pyvista" scrolling="no"></iframe>'
    view = {
        "direct": src,
        "probe": proxied,
        "proxied": url_with_token(proxied, token),
        "header": SERVER_ID_HEADER,
        "id": server_id,
        "timeout_ms": round(PROXY_PROBE_TIMEOUT_S * 1000),
    }
    page = _FIND_THE_VIEW.replace("__VIEW__", json.dumps(view).replace("</", "<\\/"))
    return f'<iframe srcdoc="{html.escape(page)}" class="pyvista" scrolling="no"></iframe>'


#: the iframe's first page (see view_iframe_html): it runs with the notebook page's origin (a srcdoc)
_FIND_THE_VIEW = """<!doctype html><meta charset="utf-8">
<body style="margin: 0; padding: 0.5em; font: 13px sans-serif; color: #888;">Opening the view&hellip;
<script>
(async () => {
  const view = __VIEW__;
  let base = null;
  try {  // the notebook's page: JupyterLab and Notebook 7 publish their base URL, the classic notebook too
    const page = window.parent.document;
    const config = page.getElementById("jupyter-config-data");
    base = config ? JSON.parse(config.textContent).baseUrl : page.body.dataset.baseUrl || null;
  } catch (error) {}  // not a Jupyter page, or another origin's: only the direct address is left
  if (base) {
    base = base.endsWith("/") ? base : base + "/";
    try {  // Jupyter's proxy, without the token: is it this server that answers there?
      const answer = await fetch(base + view.probe, {
        credentials: "same-origin", cache: "no-store", signal: AbortSignal.timeout(view.timeout_ms),
      });
      if (answer.ok && answer.headers.get(view.header) === view.id) {
        window.location.replace(base + view.proxied);
        return;
      }
    } catch (error) {}
  }
  window.location.replace(view.direct);
})();
</script>"""


def fit_to_output(widget: Any, iframe: str, width: int, height: int) -> None:
    """Show ``iframe`` (:func:`view_iframe_html`) in ``widget``, as wide as its row allows, up to ``width``
    pixels (at least :data:`MIN_VIEW_WIDTH`), keeping the ``width : height`` proportions: a narrow notebook
    (JupyterLab with its file browser open on a laptop screen) shrinks the view instead of cutting off what
    is next to it. The server renders at the iframe's size, so the picture stays sharp and framed.

    Examples
    --------
    >>> import ipywidgets
    >>> widget = ipywidgets.HTML()
    >>> fit_to_output(widget, view_iframe_html("http://127.0.0.1:1/index.html?ui=a&token=b"), 800, 600)
    >>> "aspect-ratio: 802 / 602" in widget.value, "ui=a&amp;token=b" in widget.value, widget.layout.max_width
    (True, True, '802px')
    """
    import ipywidgets as widgets

    # border-box: at its widest the iframe's inside is exactly width x height (the window's size)
    border = "border: 1px solid rgb(221,221,221); box-sizing: border-box; display: block;"
    style = f"width: 100%; aspect-ratio: {width + 2} / {height + 2}; {border}"
    widget.value = iframe.replace("<iframe ", f'<iframe style="{style}" ', 1)
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
