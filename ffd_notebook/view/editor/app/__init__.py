"""The standalone editor: a trame web page (its layout drawn from the session's controls) and its file handling."""

from __future__ import annotations

from .app import EditorApp, run_app

__all__ = ["EditorApp", "run_app"]
