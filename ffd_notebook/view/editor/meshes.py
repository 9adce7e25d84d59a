"""The meshes an editor edits: PyVista's mesh operations for its session, and what a mesh, a file, a photo or an
image becomes (its surface). The editor and its recordings (:mod:`.animation`) both start from them."""

from __future__ import annotations

import os
from typing import Any

import pyvista as pv

from ..._util.paths import StrPath
from ...io import write_mesh
from ...meshing import as_surface, color_array_name, decimate_keeping_colors, deformed_copy
from .session.session import MeshIO

__all__ = ["PYVISTA_MESH_IO", "face_surface", "image_box", "read_surface", "surface_of"]


def read_surface(path: StrPath) -> pv.PolyData:
    """A mesh file's surface, checked (:func:`ffd_notebook.io.read_mesh` + :func:`ffd_notebook.meshing.as_surface`)."""
    from ...io import read_mesh

    return as_surface(read_mesh(path))


def face_surface(photo: Any) -> pv.PolyData:
    """The coloured face in a photo (path, array or ``face.Photo``): :func:`ffd_notebook.face_from_photo`."""
    from ...face import face_from_photo

    return face_from_photo(photo)


#: PyVista's mesh operations, for sessions of PyVista meshes
PYVISTA_MESH_IO = MeshIO(
    read=read_surface,
    write=write_mesh,
    decimate=decimate_keeping_colors,
    with_points=deformed_copy,
    color_array=color_array_name,
    face=face_surface,
)


def image_box(image: Any) -> pv.PolyData:
    """The box of an image's voxel centres as a surface (subdivided so it bends with the lattice), in physical
    space; a flat rectangle for a 2D image. The editor's mesh when it edits a lattice over an image alone."""
    from ...images.pixels import as_pixels

    if isinstance(image, tuple):
        _, grid, _ = as_pixels(image[0], **image[1])
    else:
        _, grid, _ = as_pixels(image)
    size = list(grid.size) + [1] * (3 - grid.dim)
    if grid.dim == 3:
        box = pv.Box(bounds=(0, size[0] - 1, 0, size[1] - 1, 0, size[2] - 1), level=8, quads=False)
    else:
        centre = ((size[0] - 1) / 2, (size[1] - 1) / 2, 0.0)
        box = pv.Plane(center=centre, i_size=size[0] - 1, j_size=size[1] - 1, i_resolution=16, j_resolution=16)
        box = box.triangulate()
    to_physical = grid.index_to_physical()
    box.points = box.points @ to_physical[:3, :3].T + to_physical[:3, 3]
    return box


def surface_of(mesh_or_path: Any, image: Any = None) -> pv.PolyData:
    """The surface an editor edits: of a mesh, a mesh file, the face in a photo, an image's box, or the sample.

    Examples
    --------
    >>> surface_of(pv.Sphere(theta_resolution=8, phi_resolution=8)).n_points
    50
    """
    from ...face import is_photo

    if mesh_or_path is None and image is not None:
        return image_box(image)
    if mesh_or_path is None:
        from ...datasets import sample_mesh

        return as_surface(sample_mesh())
    if is_photo(mesh_or_path):  # a photo path (.jpg, .png...) or an (H, W, 3) uint8 array: the face in it
        return face_surface(mesh_or_path)
    if isinstance(mesh_or_path, (str, os.PathLike)):
        return read_surface(mesh_or_path)
    return as_surface(mesh_or_path)
