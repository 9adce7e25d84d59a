"""The view layer: everything that touches VTK, PyVista, trame or ipywidgets.

Importing it changes no global setting; the plotters it makes get the headless rendering settings
where they help (see :func:`~ffd_notebook.view.rendering.plotters.new_plotter`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._util.lazy import lazy_getattr
from .rendering import is_headless, new_plotter

if TYPE_CHECKING:  # the lazy names below, declared for type checkers and IDEs
    from .editor import EditingSession as EditingSession
    from .editor import Editor as Editor
    from .editor import animate as animate
    from .editor import edit as edit
    from .editor.notebook import ControlPanel as ControlPanel
    from .gp import GPExplorer as GPExplorer
    from .rendering import frame_camera as frame_camera
    from .rendering import view_direction as view_direction
    from .solidtex import CutViewer as CutViewer
    from .solidtex import TexturedOrgan as TexturedOrgan
    from .solidtex import add_cut as add_cut

_LAZY = {
    "Editor": "ffd_notebook.view.editor",
    "edit": "ffd_notebook.view.editor",
    "EditingSession": "ffd_notebook.view.editor",
    "animate": "ffd_notebook.view.editor",
    "ControlPanel": "ffd_notebook.view.editor.notebook",
    "GPExplorer": "ffd_notebook.view.gp",
    "TexturedOrgan": "ffd_notebook.view.solidtex",
    "CutViewer": "ffd_notebook.view.solidtex",
    "add_cut": "ffd_notebook.view.solidtex",
    "frame_camera": "ffd_notebook.view.rendering",
    "view_direction": "ffd_notebook.view.rendering",
}

__all__ = ["is_headless", "new_plotter", *sorted(_LAZY)]


__getattr__ = lazy_getattr(__name__, _LAZY)
