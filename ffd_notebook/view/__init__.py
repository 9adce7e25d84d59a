"""The view layer: everything that touches VTK, PyVista, trame or ipywidgets."""

from __future__ import annotations

from .rendering import configure_rendering, is_headless

configure_rendering()

__all__ = ["configure_rendering", "is_headless"]
