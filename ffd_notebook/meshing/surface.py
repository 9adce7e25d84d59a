"""Surfaces for the views: any PyVista mesh as a checked surface, decimation that keeps per-vertex colors.

Mesh processing with PyVista, no rendering: the layer between the views and :mod:`ffd_notebook.io`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike

from ..io.mesh_checks import check_cells

__all__ = ["COLOR_ARRAYS", "as_surface", "color_array_name", "decimate_keeping_colors", "deformed_copy"]

#: point-data names read as per-vertex colors (uint8, 3 or 4 components), in order of preference
COLOR_ARRAYS = ("RGB", "RGBA", "Colors", "colors", "RGBColors")


def color_array_name(mesh: pv.DataSet) -> str | None:
    """Name of the mesh's per-vertex colour array (uint8, 3 or 4 components), or ``None``.

    Parameters
    ----------
    mesh : pyvista.DataSet
        The mesh.

    Returns
    -------
    str or None
        The array's name, or None when it has no colours.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> m = pv.Sphere()
    >>> color_array_name(m) is None
    True
    >>> m.point_data["RGB"] = np.zeros((m.n_points, 3), dtype=np.uint8)
    >>> color_array_name(m)
    'RGB'
    """
    for name in COLOR_ARRAYS:
        if name in mesh.point_data:
            arr = mesh.point_data[name]
            if arr.dtype == np.uint8 and arr.ndim == 2 and arr.shape[1] in (3, 4):
                return name
    return None


def as_surface(mesh: Any) -> pv.PolyData:
    """A deep copy of ``mesh`` as a :class:`pyvista.PolyData` surface (volumes give their outer surface).

    Cells that refer to missing points raise :class:`~ffd_notebook.errors.FileFormatError` (a
    ValueError) before any VTK filter sees them (:func:`ffd_notebook.io.mesh_checks.check_cells`).

    Parameters
    ----------
    mesh : pyvista.DataSet
        Any PyVista mesh (a volume mesh gives its outer surface).

    Returns
    -------
    pyvista.PolyData
        A new surface (the input is not changed).

    Examples
    --------
    >>> import pyvista as pv
    >>> as_surface(pv.ImageData(dimensions=(3, 3, 3))).n_cells
    24
    >>> as_surface(pv.PolyData([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[3, 0, 1, 7]))
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: the mesh: polygon 0 uses point 7: there are 3 points
    """
    if not isinstance(mesh, pv.DataSet):
        mesh = pv.wrap(mesh)
    if isinstance(mesh, pv.PolyData | pv.UnstructuredGrid):  # other grids' cells are implicit
        check_cells("the mesh", mesh)
    if not isinstance(mesh, pv.PolyData):
        mesh = mesh.extract_surface(algorithm="dataset_surface")
    if mesh.n_points == 0:
        raise ValueError("the mesh has no points")
    return mesh.copy(deep=True)


def decimate_keeping_colors(mesh: pv.PolyData, reduction: float, attribute_error: bool = False) -> pv.PolyData:
    """Quadric decimation that carries per-vertex colours (and all other point data) to the new vertices.

    VTK's ``vtkQuadricDecimation`` with ``MapPointData`` on: each remaining vertex gets the
    point data interpolated on the original surface where it lands. Colours (the arrays named
    in :data:`COLOR_ARRAYS`) are decimated as floats in [0, 1] (integers divided by their type's
    maximum) and given back in their own type and scale (integers rounded). With
    ``attribute_error=True`` the colours also enter the error metric (``AttributeErrorMetric`` +
    ``ScalarsAttribute``) and VTK then solves vertex colours from the quadrics instead; measured
    on the shared face scans (80 % reduction, mean ``|colour error|`` of the decimated surface
    against every original vertex, 0-255 scale): template 0.16 without vs 1.05 with, james 8.9
    vs 11.8, so mapping alone is the default.

    Parameters
    ----------
    mesh : pyvista.PolyData
        A surface (triangulated first if needed).
    reduction : float
        Fraction of triangles to remove, in ``[0, 1)``.
    attribute_error : bool
        Let colour differences steer the decimation too (see above).

    Returns
    -------
    pyvista.PolyData
        The decimated surface, with its colours.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> m = pv.Sphere(theta_resolution=40, phi_resolution=40)
    >>> m.point_data["RGB"] = np.where(m.points[:, 2:] > 0, [255, 0, 0], [0, 0, 255]).astype(np.uint8)
    >>> d = decimate_keeping_colors(m, 0.75)
    >>> d.n_cells < 0.3 * m.n_cells, d.point_data["RGB"].dtype.name
    (True, 'uint8')
    """
    from vtkmodules.vtkFiltersCore import vtkQuadricDecimation

    if not 0.0 <= reduction < 1.0:
        raise ValueError(f"reduction must be in [0, 1), got {reduction!r}")
    surf = mesh.triangulate() if not mesh.is_all_triangles else mesh.copy()
    color_names = [n for n in COLOR_ARRAYS if n in surf.point_data]
    kinds = {name: np.asarray(surf.point_data[name]).dtype for name in color_names}
    # interpolated as floats in [0, 1] (integers would be truncated; the error metric wants one scale)
    full = {name: float(np.iinfo(kind).max) if kind.kind in "ui" else 1.0 for name, kind in kinds.items()}
    for name in color_names:
        surf.point_data[name] = np.asarray(surf.point_data[name], dtype=np.float64) / full[name]
    alg = vtkQuadricDecimation()
    alg.SetInputData(surf)
    alg.SetTargetReduction(float(reduction))
    alg.SetVolumePreservation(True)
    alg.SetMapPointData(True)
    if attribute_error and color_names:
        surf.point_data.active_scalars_name = color_names[0]
        alg.SetAttributeErrorMetric(True)
        alg.SetScalarsAttribute(True)
    alg.Update()
    out = pv.wrap(alg.GetOutput())
    for name, kind in kinds.items():  # back to the array's own type and scale
        values = np.asarray(out.point_data[name], dtype=np.float64) * full[name]
        if kind.kind in "ui":
            values = np.clip(np.rint(values), np.iinfo(kind).min, np.iinfo(kind).max)
        out.point_data[name] = values.astype(kind)
    return out


def deformed_copy(mesh: pv.PolyData, points: ArrayLike) -> pv.PolyData:
    """A new mesh: ``points`` with the faces and point data of ``mesh``.

    Parameters
    ----------
    mesh : pyvista.PolyData
        The rest mesh.
    points : array_like
        ``(N, 3)`` new positions of its points.

    Returns
    -------
    pyvista.PolyData
        The copy.

    Examples
    --------
    >>> import pyvista as pv
    >>> m = pv.Sphere()
    >>> moved = deformed_copy(m, m.points + 1.0)
    >>> moved.n_cells == m.n_cells, float(moved.points.min() - m.points.min())
    (True, 1.0)
    """
    out = mesh.copy(deep=True)
    out.points = np.asarray(points, dtype=out.points.dtype).copy()
    return out
