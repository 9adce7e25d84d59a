"""Solid textures on organ meshes, cut open interactively (PyVista); meshing: :mod:`ffd_notebook.meshing.organ`."""

from __future__ import annotations

from .cut_viewer import CutViewer, TexturedOrgan, add_cut

__all__ = ["CutViewer", "TexturedOrgan", "add_cut"]
