"""ffd_notebook: interactive 3D free-form deformation in Jupyter.

The model (:class:`Lattice`, :class:`FFD`) is plain NumPy. File readers, the editor and the
other systems are imported lazily on first use, so ``import ffd_notebook`` stays fast and does
not load VTK.

Examples
--------
>>> import numpy as np
>>> import ffd_notebook as fn
>>> pts = np.random.default_rng(0).random((100, 3))
>>> lat = fn.Lattice.around(pts, shape=(5, 5, 5))
>>> lat.offsets[...] = (0.0, 0.0, 1.0)          # move every control point up by 1
>>> moved = fn.FFD(lat).deform(pts)
>>> bool(np.allclose(moved - pts, (0, 0, 1)))
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._util.lazy import lazy_getattr
from .errors import FileFormatError
from .ffd import FFD, Deformer, Lattice

# the lazy names below, declared for type checkers and IDEs (tests/test_typing.py keeps both in step)
if TYPE_CHECKING:
    from .errors import NoFaceError as NoFaceError
    from .face import face_from_photo as face_from_photo
    from .images import warp_image as warp_image
    from .io import DisplacementField as DisplacementField
    from .io import ElastixTransform as ElastixTransform
    from .io import fit_lattice as fit_lattice
    from .io import load_deformation as load_deformation
    from .io import load_displacement_field as load_displacement_field
    from .io import load_elastix as load_elastix
    from .io import load_ffd as load_ffd
    from .io import load_prm as load_prm
    from .io import load_transform as load_transform
    from .io import place_at_mesh_minimum as place_at_mesh_minimum
    from .io import read_mesh as read_mesh
    from .io import read_obj as read_obj
    from .io import sample_displacement_field as sample_displacement_field
    from .io import save_deformation as save_deformation
    from .io import save_displacement_field as save_displacement_field
    from .io import save_elastix as save_elastix
    from .io import save_ffd as save_ffd
    from .io import save_prm as save_prm
    from .io import save_transform as save_transform
    from .io import write_mesh as write_mesh
    from .io import write_obj as write_obj
    from .view import Editor as Editor
    from .view import animate as animate
    from .view import edit as edit

__version__ = "0.1.0"

# public name -> module that defines it (imported on first access)
_LAZY = {
    "load_ffd": "ffd_notebook.io",
    "save_ffd": "ffd_notebook.io",
    "read_obj": "ffd_notebook.io",
    "write_obj": "ffd_notebook.io",
    "read_mesh": "ffd_notebook.io",
    "write_mesh": "ffd_notebook.io",
    "place_at_mesh_minimum": "ffd_notebook.io",
    "load_transform": "ffd_notebook.io",
    "save_transform": "ffd_notebook.io",
    "load_prm": "ffd_notebook.io",
    "save_prm": "ffd_notebook.io",
    "load_deformation": "ffd_notebook.io",
    "save_deformation": "ffd_notebook.io",
    "load_elastix": "ffd_notebook.io",
    "save_elastix": "ffd_notebook.io",
    "ElastixTransform": "ffd_notebook.io",
    "DisplacementField": "ffd_notebook.io",
    "load_displacement_field": "ffd_notebook.io",
    "save_displacement_field": "ffd_notebook.io",
    "sample_displacement_field": "ffd_notebook.io",
    "fit_lattice": "ffd_notebook.io",
    "face_from_photo": "ffd_notebook.face",
    "NoFaceError": "ffd_notebook.errors",
    "warp_image": "ffd_notebook.images",
    "edit": "ffd_notebook.view",
    "Editor": "ffd_notebook.view",
    "animate": "ffd_notebook.view",
}

__all__ = ["FFD", "Deformer", "FileFormatError", "Lattice", "__version__", *sorted(_LAZY)]


__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(__all__)
