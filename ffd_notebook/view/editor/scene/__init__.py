"""The editor's VTK scene: the plotter, the mesh and lattice actors, the interactive copy of a large mesh, the
colouring by a field, and picking on the mesh surface. It follows an editing session and computes no deformation.
"""

from __future__ import annotations

from .scene import EditorScene, PreparedDisplay, prepare_display

__all__ = ["EditorScene", "PreparedDisplay", "prepare_display"]
