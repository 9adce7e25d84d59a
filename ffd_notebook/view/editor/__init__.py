"""The FFD editor: an editing session (no VTK), its VTK scene, and panels for Jupyter and the standalone app.

``from ffd_notebook.view.editor import Editor`` gives the editor; the panels and the app are imported
on first use.
"""

from __future__ import annotations

from ..._util.lazy import lazy_getattr
from .changes import Change
from .editor import Editor, edit
from .session import EditingSession, MeshIO

_LAZY = {
    "ControlPanel": "ffd_notebook.view.editor.notebook_panel",
    "EditorApp": "ffd_notebook.view.editor.app",
    "run_app": "ffd_notebook.view.editor.app",
}

__all__ = ["Change", "EditingSession", "Editor", "MeshIO", "edit", *sorted(_LAZY)]


__getattr__ = lazy_getattr(__name__, _LAZY)
