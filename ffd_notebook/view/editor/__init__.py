"""The FFD editor: an editing session (no VTK), its VTK scene, and panels for Jupyter and the standalone app.

``from ffd_notebook.view.editor import Editor`` gives the editor; the panels and the app are imported
on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from .changes import Change
from .editor import Editor, edit
from .session import EditingSession, MeshIO

_LAZY = {
    "ControlPanel": "ffd_notebook.view.editor.notebook_panel",
    "EditorApp": "ffd_notebook.view.editor.app",
    "run_app": "ffd_notebook.view.editor.app",
}

__all__ = ["Change", "EditingSession", "Editor", "MeshIO", "edit", *sorted(_LAZY)]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ffd_notebook.view.editor' has no attribute {name!r}")
