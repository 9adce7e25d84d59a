"""Sample meshes that work offline: a face scan bundled with the package (the editor's default), organs built
from PyVista's data."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # PyVista is imported only when a mesh is built
    import pyvista as pv

__all__ = ["face", "frog_liver", "sample_mesh"]

FACE_FILE = Path(__file__).parent / "data" / "face.ply"


def _frog_label_surface(label: int = 10, sigma: float = 2.0) -> pv.PolyData:
    """Smooth closed surface of one label of PyVista's bundled frog tissue volume (in its world units).

    The label mask is blurred (``sigma`` world units) before contouring at 0.5, which removes the
    voxel staircase; x and y are sampled every second voxel (z already has 1.5x spacing).
    """
    import pyvista as pv
    from pyvista import examples
    from scipy import ndimage

    volume = examples.load_frog_tissues()
    labels = np.asarray(volume.active_scalars).reshape(volume.dimensions[::-1])  # (z, y, x)
    mask = labels == label
    found = np.argwhere(mask)
    lo = np.maximum(found.min(axis=0) - 4, 0)
    hi = found.max(axis=0) + 5
    spacing_zyx = np.array(volume.spacing)[::-1]
    blurred = ndimage.gaussian_filter(
        mask[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].astype(np.float32), sigma / spacing_zyx
    )
    step = np.array([1, 2, 2])
    blurred = blurred[:: step[0], :: step[1], :: step[2]]
    image = pv.ImageData(
        dimensions=blurred.shape[::-1],
        spacing=tuple((spacing_zyx * step)[::-1]),
        origin=tuple(np.array(volume.origin) + lo[::-1] * np.array(volume.spacing)),
    )
    image.point_data["mask"] = blurred.ravel()
    return image.contour([0.5], scalars="mask").clean().connectivity("largest")


def face() -> pv.PolyData:
    """A real face scan with per-vertex colours (bundled, offline): 6,393 vertices, 12,228 triangles.

    The "james" scan of menpo3d 0.8.6 (BSD-3 licence: ``ffd_notebook/data/LICENSE-menpo3d.txt``)
    with its texture baked into per-vertex colours, the kind of mesh the FFD platform's face
    reconstruction produced. Millimetres, +y up, looking along +z.

    Returns
    -------
    pyvista.PolyData
        Triangles, point data ``"RGB"`` (uint8, ``(N, 3)``).

    Examples
    --------
    >>> mesh = face()
    >>> mesh.n_points, mesh.n_cells, mesh.point_data["RGB"].dtype.name
    (6393, 12228, 'uint8')
    >>> [round(float(v)) for v in mesh.bounds[2:4]]          # about 32 cm from chin to crown
    [-171, 150]
    """
    from .io import read_mesh

    return read_mesh(FACE_FILE)


def sample_mesh() -> pv.PolyData:
    """The editor's default mesh: the bundled coloured face scan, :func:`face` (offline).

    Organ tools and notebooks that want the frog's liver call :func:`frog_liver` explicitly.

    Returns
    -------
    pyvista.PolyData
        Triangles, point data ``"RGB"`` (uint8, ``(N, 3)``); +y up, the face looking along +z.

    Examples
    --------
    >>> mesh = sample_mesh()
    >>> mesh.n_points, mesh.point_data["RGB"].dtype.name
    (6393, 'uint8')
    """
    return face()


@lru_cache(maxsize=4)
def _frog_liver(n_points: int) -> pv.PolyData:
    surface = _frog_label_surface(10)
    if n_points < surface.n_points:
        # quadric decimation keeps this surface closed and manifold; a light Taubin pass (no
        # shrinkage) evens out the triangles the decimation leaves
        surface = surface.decimate(1.0 - n_points / surface.n_points).clean()
        surface = surface.smooth_taubin(n_iter=10, pass_band=0.1)
    surface = surface.compute_normals(auto_orient_normals=True, split_vertices=False)
    return surface


def frog_liver(n_points: int = 12000) -> pv.PolyData:
    """A closed, smooth surface of a frog's liver (offline): label 10 of PyVista's frog tissues.

    Label 10 of :func:`pyvista.examples.load_frog_tissues` (a 500x470x136 label volume bundled
    with PyVista, spacing 1 x 1 x 1.5) is very likely the liver in VTK's frog tissue list: a
    lobed organ about 120 x 140 x 140 units. Its mask is blurred and contoured (no voxel
    staircase), the largest piece kept, and the surface decimated to about ``n_points`` points.
    The result is cached in memory; every call returns a new copy.

    Parameters
    ----------
    n_points : int
        Approximate number of points (at most the ~20k of the undecimated contour). Around 3000
        is right for tetrahedralisation, 10-20k for display.

    Returns
    -------
    pyvista.PolyData
        Closed, manifold triangle surface with outward point normals.

    Examples
    --------
    >>> liver = frog_liver(5000)
    >>> 4500 < liver.n_points < 5500, liver.n_open_edges, liver.is_manifold
    (True, 0, True)
    >>> liver.points[0, 0] = 0.0                       # a copy: the cached surface is untouched
    >>> bool(frog_liver(5000).points[0, 0] != 0.0)
    True
    """
    if n_points < 100:
        raise ValueError(f"n_points must be at least 100, got {n_points}")
    return _frog_liver(int(n_points)).copy()
