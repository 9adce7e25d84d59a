"""The editor in Jupyter: the scene's trame view next to an ipywidgets panel drawn from the session's controls."""

from __future__ import annotations

from .output import EditorOutput, editor_widget
from .panel import ControlPanel

__all__ = ["ControlPanel", "EditorOutput", "editor_widget"]
