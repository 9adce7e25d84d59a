"""Reading and writing files: .ffd lattices, ITK transforms, PyGeM .prm files, OBJ meshes, other meshes.

The .ffd and OBJ parsers are written here (see :mod:`.ffd_file` and :mod:`.obj` for why); every
other mesh format goes through PyVista's readers and writers. Every malformed file raises
:class:`~ffd_notebook.errors.FileFormatError` naming the file and line; every write is atomic.
"""

from __future__ import annotations

from .deformation_files import load_deformation, save_deformation
from .ffd_file import load_ffd, save_ffd
from .itk import load_transform, save_transform
from .mesh import read_mesh, write_mesh
from .obj import read_obj, write_obj
from .placement import place_at_mesh_minimum
from .prm import load_prm, save_prm

__all__ = [
    "load_deformation",
    "load_ffd",
    "load_prm",
    "load_transform",
    "place_at_mesh_minimum",
    "read_mesh",
    "read_obj",
    "save_deformation",
    "save_ffd",
    "save_prm",
    "save_transform",
    "write_mesh",
    "write_obj",
]
