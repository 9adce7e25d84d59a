"""Deprecated location: :mod:`ffd_notebook.view.jupyter` (showing plotters) and
:mod:`ffd_notebook.view.editor.notebook` (the editor in Jupyter). Kept so older imports keep working."""

from __future__ import annotations

from .jupyter import push_to_browser, show_plotter

__all__ = ["push_to_browser", "show_plotter"]
