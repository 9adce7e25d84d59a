"""The editor in Jupyter: the plotter's trame view (server-side rendering) next to the control panel.

How the view is served (token, Origin checks, proxies) is :mod:`ffd_notebook.view.jupyter`'s business,
shared with the other products. With the ``"static"`` (or ``"none"``) Jupyter backend, e.g. when
notebooks run headless in CI, the view is a picture that the panel's actions refresh instead; either
way the output also carries a PNG of the scene so a saved notebook shows it where widgets cannot run.
"""

from __future__ import annotations

import base64
from typing import Any

from ..jupyter import STATIC_BACKENDS, backend, execution_count, png_bytes, serve_plotter
from .editor import Editor

__all__ = ["display_editor", "edit", "editor_widget"]


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
    editor._displayed_in = execution_count()
    return editor


def _trame_view(editor: Editor) -> Any:
    """The editor's trame view: server-side rendering, and the editor pushes frames after its changes."""
    from ..web_security import test_hooks_enabled

    widget = serve_plotter(editor.plotter)
    editor.attach_viewer(widget.viewer)
    if test_hooks_enabled():  # internal state for browser tests only
        editor.register_triggers(widget.viewer.server)
    return widget


def _png(editor: Editor) -> bytes:
    """The editor's scene, rendered now, as PNG bytes."""
    return png_bytes(editor.screenshot())


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

        from .notebook_panel import ControlPanel

        view = _static_view(editor) if backend() in STATIC_BACKENDS else _trame_view(editor)
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

    if getattr(editor, "_displayed_in", None) is not None and editor._displayed_in == execution_count():
        return
    display(_EditorOutput(editor))
