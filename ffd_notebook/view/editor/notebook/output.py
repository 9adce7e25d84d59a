"""The editor in Jupyter: the plotter's trame view (server-side rendering) next to the control panel.

How the view is served (token, Origin checks, proxies) is :mod:`ffd_notebook.view.serving.jupyter`'s business,
shared with the other products. With the ``"static"`` (or ``"none"``) Jupyter backend, e.g. when
notebooks run headless in CI, the view is a picture that the panel's actions refresh instead; either
way the output also carries a PNG of the scene so a saved notebook shows it where widgets cannot run.
"""

from __future__ import annotations

import base64
from typing import TYPE_CHECKING, Any

from ...serving.jupyter import STATIC_BACKENDS, backend, png_bytes, serve_plotter
from ...serving.lifetime import weak_call
from ..session.changes import Change

if TYPE_CHECKING:
    from ..editor import Editor

__all__ = ["EditorOutput", "close_editor_widget", "editor_widget"]

#: the changes after which the static picture is redrawn
REDRAWN_AFTER = ("offsets", "lattice", "mesh", "display", "select")


def _static_view(editor: Editor) -> Any:
    """A PNG of the scene that follows the editor's changes (no dragging without a trame view)."""
    import ipywidgets as widgets

    view = widgets.Image(value=png_bytes(editor.screenshot()), format="png")

    def follow(editor: Editor, change: Change) -> None:
        if change.kind in REDRAWN_AFTER:
            view.value = png_bytes(editor.screenshot())

    editor.session.subscribe(weak_call(editor, follow))  # the session must not keep its editor alive
    return view


def editor_widget(editor: Editor) -> Any:
    """A new notebook widget for ``editor``: ``ipywidgets.HBox([view, ControlPanel(editor)])``.

    The trame view joins the scene's browser views (:func:`~ffd_notebook.view.serving.jupyter.serve_plotter`),
    so the scene pushes a frame to it after every change made from code or the panel.
    Use :attr:`Editor.widget <ffd_notebook.view.editor.editor.Editor.widget>`: it makes one per editor.
    """
    import ipywidgets as widgets

    from .panel import ControlPanel

    view = _static_view(editor) if backend() in STATIC_BACKENDS else serve_plotter(editor.plotter)
    # the view shrinks to leave the panel its width; in a notebook narrower than both, the panel goes below
    return widgets.HBox([view, ControlPanel(editor)], layout=widgets.Layout(flex_flow="row wrap"))


def close_editor_widget(box: Any) -> None:
    """Close the panel of an editor's widget (made by :func:`editor_widget`): ipywidgets keeps every widget,
    and its callbacks, until it is closed. The view stays: a served view's iframe says it is closed, a static
    picture stays as it was."""
    view, *panels = box.children
    box.children = (view,)
    for panel in panels:
        _close_tree(panel)


def _close_tree(widget: Any) -> None:
    """Close ``widget``, its children and their layout and style widgets (each is a widget of its own, with a
    comm, that closing its owner leaves open)."""
    for child in getattr(widget, "children", ()):
        _close_tree(child)
    for part in (getattr(widget, "layout", None), getattr(widget, "style", None)):
        if part is not None and hasattr(part, "close"):
            part.close()
    widget.close()


class EditorOutput:
    """Display bundle: the live widget plus a PNG of the scene for viewers without a kernel."""

    def __init__(self, editor: Editor) -> None:
        self.editor = editor

    def _repr_mimebundle_(self, include: Any = None, exclude: Any = None) -> dict[str, Any]:
        bundle = dict(self.editor.widget._repr_mimebundle_(include=include, exclude=exclude) or {})
        bundle["image/png"] = base64.b64encode(png_bytes(self.editor.screenshot())).decode("ascii")
        bundle["text/plain"] = repr(self.editor)
        return bundle
