"""Reading and writing files: .ffd lattices, OBJ meshes with per-vertex colours, other mesh formats.

The .ffd and OBJ parsers are written here (see :mod:`.ffd_file` and :mod:`.obj` for why); every
other mesh format goes through PyVista's readers and writers. Every malformed file raises
:class:`~ffd_notebook.errors.FileFormatError` naming the file and line; every write is atomic.
"""

from __future__ import annotations

from .ffd_file import load_ffd, save_ffd
from .mesh import read_mesh, write_mesh
from .obj import read_obj, write_obj
from .placement import place_at_mesh_minimum

__all__ = ["load_ffd", "place_at_mesh_minimum", "read_mesh", "read_obj", "save_ffd", "write_mesh", "write_obj"]
