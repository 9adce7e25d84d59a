"""Mesh processing with PyVista, without rendering: surfaces, decimation, organ meshes.

Imports the model, :mod:`ffd_notebook.io` and PyVista, never trame or ipywidgets; the views build on it.
"""

from __future__ import annotations

from .surface import COLOR_ARRAYS, as_surface, color_array_name, decimate_keeping_colors, deformed_copy

__all__ = ["COLOR_ARRAYS", "as_surface", "color_array_name", "decimate_keeping_colors", "deformed_copy"]
