"""The view layer: everything that touches VTK, PyVista, trame or ipywidgets.

Importing it changes no global setting; the plotters it makes get the headless rendering settings
where they help (see :func:`~ffd_notebook.view.rendering.new_plotter`).
"""

from __future__ import annotations

from .._util.lazy import lazy_getattr
from .rendering import is_headless, new_plotter

_LAZY = {
    "Editor": "ffd_notebook.view.editor",
    "edit": "ffd_notebook.view.editor",
    "EditingSession": "ffd_notebook.view.editor",
    "ControlPanel": "ffd_notebook.view.editor.notebook",
    "GPExplorer": "ffd_notebook.view.gp",
    "TexturedOrgan": "ffd_notebook.view.solidtex",
    "CutViewer": "ffd_notebook.view.solidtex",
    "add_cut": "ffd_notebook.view.solidtex",
    "frame_camera": "ffd_notebook.view.camera",
    "view_direction": "ffd_notebook.view.camera",
}

__all__ = ["is_headless", "new_plotter", *sorted(_LAZY)]


__getattr__ = lazy_getattr(__name__, _LAZY)
