"""Reading and writing files: .ffd lattices, ITK and ANTs transforms, elastix parameter files, NiftyReg and FSL FNIRT
files, PyGeM .prm files, displacement fields, meshes.

The .ffd, OBJ and PLY parsers are written here (see :mod:`.ffd_file`, :mod:`.obj` and :mod:`.ply`
for why); STL and VTK formats go through VTK's readers in a child process (see :mod:`.mesh`).
Every malformed file raises :class:`~ffd_notebook.errors.FileFormatError` naming the file and line;
special files and files over :data:`MAX_FILE_BYTES` are refused before reading
(:func:`check_regular_file`); every write is atomic.

The mesh functions return PyVista meshes, so they are imported on first use (PEP 562): reading a
.ffd file (:func:`load_ffd`) does not load VTK.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._util.lazy import lazy_getattr
from ._safety import MAX_FILE_BYTES, check_regular_file
from .deformation_files import load_deformation, save_deformation
from .displacement_field import (
    DisplacementField,
    load_displacement_field,
    sample_displacement_field,
    save_displacement_field,
)
from .elastix import ElastixTransform, load_elastix, save_elastix
from .ffd_file import load_ffd, save_ffd
from .fnirt import load_fnirt, save_fnirt
from .itk import load_transform, save_transform
from .lattice_fitting import fit_lattice
from .niftyreg import load_niftyreg, save_niftyreg
from .placement import place_at_mesh_minimum
from .prm import load_prm, save_prm
from .transform_chain import AffineTransform, TransformChain

if TYPE_CHECKING:  # the lazy names below, declared for type checkers and IDEs
    from .mesh import read_mesh as read_mesh
    from .mesh import write_mesh as write_mesh
    from .obj import read_obj as read_obj
    from .obj import write_obj as write_obj

#: Mesh file extensions :func:`read_mesh` and :func:`write_mesh` handle (here, not in the mesh
#: module, so that code checking a name loads no VTK).
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".vtk", ".vtp", ".vtu")

# mesh functions (PyVista, hence VTK) -> the module that defines them
_LAZY = {
    "read_mesh": "ffd_notebook.io.mesh",
    "write_mesh": "ffd_notebook.io.mesh",
    "read_obj": "ffd_notebook.io.obj",
    "write_obj": "ffd_notebook.io.obj",
}

__all__ = [
    "MAX_FILE_BYTES",
    "MESH_SUFFIXES",
    "AffineTransform",
    "DisplacementField",
    "ElastixTransform",
    "TransformChain",
    "check_regular_file",
    "fit_lattice",
    "load_deformation",
    "load_displacement_field",
    "load_elastix",
    "load_ffd",
    "load_fnirt",
    "load_niftyreg",
    "load_prm",
    "load_transform",
    "place_at_mesh_minimum",
    "read_mesh",
    "read_obj",
    "sample_displacement_field",
    "save_deformation",
    "save_displacement_field",
    "save_elastix",
    "save_ffd",
    "save_fnirt",
    "save_niftyreg",
    "save_prm",
    "save_transform",
    "write_mesh",
    "write_obj",
]


__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(__all__)
