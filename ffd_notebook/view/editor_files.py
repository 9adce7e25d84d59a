"""Deprecated location of :func:`ffd_notebook.meshing.as_surface`; kept so older imports keep working."""

from __future__ import annotations

from ..meshing import as_surface, decimate_keeping_colors

__all__ = ["as_surface", "decimate_keeping_colors"]
