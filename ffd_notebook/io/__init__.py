"""Reading and writing files: .ffd lattices (more formats follow).

Every malformed file raises :class:`~ffd_notebook.errors.FileFormatError` naming the file and line;
every write is atomic.
"""

from __future__ import annotations

from .ffd_file import load_ffd, save_ffd
from .placement import place_at_mesh_minimum

__all__ = ["load_ffd", "place_at_mesh_minimum", "save_ffd"]
