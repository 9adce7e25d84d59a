"""Organ models for solid textures: tetrahedra, their surface, and texture colours on it.

* :func:`tetrahedralize` fills a closed surface with tetrahedra: TetGen if it is installed (the
  paper's tool; AGPL, so an optional extra: ``pip install ffd_notebook[tetgen]``), otherwise a
  Delaunay tetrahedralisation of the surface points plus an interior grid, keeping the
  tetrahedra whose centroids lie inside the surface (no extra dependency).
* :func:`organ_surface` is the boundary of the tetrahedra (faces without a neighbour).
* :func:`texture_surface` colours a surface from a :class:`~ffd_notebook.solidtex.SolidTexture`
  by trilinear sampling at rest-frame positions, after linear subdivision so that detail smaller
  than a triangle is visible (dense sampling, as the paper did; VTK's 3D textures are not
  exposed by PyVista and are not shown by trame's client-side view).

Every mesh carries its rest-frame coordinates as point data ``"rest"``; deforming a mesh moves
its ``points`` only, so the colours (sampled at ``"rest"``) stay with the tissue.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from numpy.typing import NDArray
from scipy.spatial import Delaunay

from ..solidtex.sampling import SolidTexture, TextureSampler  # noqa: F401  (SolidTexture: the doctests)
from ..solidtex.tetra import boundary_faces

__all__ = ["auto_subdivisions", "organ_surface", "tetrahedralize", "texture_surface"]

REST = "rest"


def _tetgen_available() -> bool:
    try:
        import tetgen  # noqa: F401
    except ImportError:
        return False
    return True


def _tets_grid(points: NDArray[np.float64], tets: NDArray[np.int64], method: str) -> pv.UnstructuredGrid:
    points = np.asarray(points, dtype=np.float64)
    tets = np.array(tets, dtype=np.int64)
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    negative = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]  # VTK wants positive volumes
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: tets}, points)
    grid.point_data[REST] = grid.points.copy()
    grid.field_data["tetrahedralizer"] = np.array([method])
    return grid


def _tetgen(surface: pv.PolyData, max_volume: float | None, min_ratio: float) -> pv.UnstructuredGrid:
    import tetgen

    tg = tetgen.TetGen(surface.points, surface.regular_faces)
    points, elements, *_ = tg.tetrahedralize(
        order=1, quality=True, minratio=min_ratio, maxvolume=-1.0 if max_volume is None else max_volume
    )
    return _tets_grid(points, np.asarray(elements)[:, :4], "tetgen")


def _delaunay(surface: pv.PolyData, spacing: float | None) -> pv.UnstructuredGrid:
    pts = np.asarray(surface.points, dtype=np.float64)
    if spacing is None:
        # interior points about two surface edges apart: tetrahedra a little larger than the
        # surface triangles, as TetGen makes them
        edges = surface.extract_all_edges().compute_cell_sizes(length=True, area=False, volume=False)
        spacing = 2.0 * float(np.mean(edges.cell_data["Length"]))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    axes = [np.arange(a + spacing / 2, b, spacing) for a, b in zip(lo, hi, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    dist = _signed_distance(surface, grid)
    interior = grid[dist < -0.5 * spacing]  # not too close to the surface: no flat slivers there
    points = np.vstack([pts, interior])
    tets = Delaunay(points).simplices
    inside = _signed_distance(surface, points[tets].mean(axis=1)) < 0
    tets = tets[_close_pinches(tets, inside, len(points))]
    used = np.unique(tets)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return _tets_grid(points[used], remap[tets], "delaunay")


def _close_pinches(tets: NDArray[np.int64], keep: NDArray[np.bool_], n_points: int) -> NDArray[np.bool_]:
    """Add back tetrahedra around boundary edges shared by four or more boundary faces.

    Choosing tetrahedra by their centroid can leave two parts touching along an edge in narrow
    concavities; the boundary is then not a manifold. Filling the tetrahedra around such edges
    closes the pinch.
    """
    keep = keep.copy()
    pairs = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
    tet_edges = np.sort(tets[:, pairs], axis=2)
    tet_keys = tet_edges[..., 0] * n_points + tet_edges[..., 1]
    for _ in range(10):
        faces = boundary_faces(tets[keep])
        e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        keys, counts = np.unique(e[:, 0] * n_points + e[:, 1], return_counts=True)
        bad = keys[counts > 2]
        if len(bad) == 0:
            break
        keep |= np.isin(tet_keys, bad).any(axis=1)
    return keep


def _signed_distance(surface: pv.PolyData, points: NDArray[np.float64]) -> NDArray[np.float64]:
    probe = pv.PolyData(np.asarray(points, dtype=np.float64))
    return np.asarray(probe.compute_implicit_distance(surface)["implicit_distance"])


def tetrahedralize(
    surface: pv.PolyData,
    method: str = "auto",
    max_volume: float | None = None,
    min_ratio: float = 2.0,
    spacing: float | None = None,
) -> pv.UnstructuredGrid:
    """Fill a closed triangle surface with tetrahedra.

    Parameters
    ----------
    surface : pyvista.PolyData
        Closed, manifold triangle surface (e.g. :func:`ffd_notebook.datasets.frog_liver`).
    method : {"auto", "tetgen", "delaunay"}
        ``"tetgen"``: quality constrained Delaunay tetrahedralisation with TetGen (optional
        dependency, AGPL); the surface triangles are kept exactly. ``"delaunay"``: SciPy's
        Delaunay of the surface points plus an interior grid, keeping tetrahedra whose centroid
        is inside (no extra dependency; the boundary follows the surface points, in deep
        concavities a little less closely). ``"auto"``: TetGen if installed, else Delaunay.
    max_volume : float, optional
        TetGen only: largest tetrahedron volume.
    min_ratio : float
        TetGen only: radius-edge ratio bound (smaller gives rounder, more tetrahedra).
    spacing : float, optional
        Delaunay only: interior grid spacing (default: two mean surface edge lengths).

    Returns
    -------
    pyvista.UnstructuredGrid
        Linear tetrahedra; point data ``"rest"`` (copy of the points) and field data
        ``"tetrahedralizer"`` naming the method used.

    Examples
    --------
    >>> grid = tetrahedralize(pv.Sphere(theta_resolution=12, phi_resolution=12), method="delaunay")
    >>> str(grid.field_data["tetrahedralizer"][0]), grid.n_cells > 100
    ('delaunay', True)
    """
    if method not in ("auto", "tetgen", "delaunay"):
        raise ValueError(f"method must be 'auto', 'tetgen' or 'delaunay', got {method!r}")
    surface = surface.triangulate().clean()
    if surface.n_open_edges:
        raise ValueError(f"the surface must be closed; it has {surface.n_open_edges} open edges")
    if method == "tetgen" or (method == "auto" and _tetgen_available()):
        if not _tetgen_available():
            raise ImportError("method='tetgen' needs the optional tetgen package: pip install ffd_notebook[tetgen]")
        return _tetgen(surface, max_volume, min_ratio)
    return _delaunay(surface, spacing)


def organ_surface(grid: pv.UnstructuredGrid) -> pv.PolyData:
    """The outer surface of a tetrahedral mesh: the tetrahedra faces without a neighbour.

    Uses :func:`ffd_notebook.solidtex.boundary_faces` (oriented outwards). Only the points on
    the surface are kept; point data (``"rest"``) comes along, and ``"grid_point"`` gives each
    surface point's index in ``grid``.

    Examples
    --------
    >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
    >>> surf = organ_surface(grid)
    >>> surf.n_open_edges, bool(surf.volume > 0.4)
    (0, True)
    """
    tets = grid.cells_dict.get(pv.CellType.TETRA)
    if tets is None or len(tets) != grid.n_cells:
        raise ValueError("organ_surface needs a grid of linear tetrahedra only")
    faces = boundary_faces(tets, grid.points)
    used, inverse = np.unique(faces, return_inverse=True)
    surf = pv.PolyData.from_regular_faces(np.asarray(grid.points)[used], inverse.reshape(-1, 3))
    for name in grid.point_data.keys():
        surf.point_data[name] = np.asarray(grid.point_data[name])[used]
    surf.point_data["grid_point"] = used
    return surf


def auto_subdivisions(
    surface: pv.PolyData, texture: TextureSampler, samples_per_voxel: float = 1.0, *, quantile: float | None = None
) -> int:
    """How many linear subdivisions bring the edges down to the texture's voxel size.

    Each subdivision halves the edges (and multiplies the triangles by four); the answer is at
    most 4.

    Parameters
    ----------
    surface : pyvista.PolyData
        The triangles to subdivide.
    texture : SolidTexture or LazySolidTexture
        Anything with a ``spacing`` (the voxel size).
    samples_per_voxel : float
        Samples wanted per voxel along an edge.
    quantile : float, optional
        Which edges must come down: ``None`` (the default) the mean edge, which suits an even
        surface; a quantile such as 0.99 the long edges, for a section through tetrahedra, whose long
        thin triangles, sampled too sparsely, fan their corners' colours out as streaks.

    Returns
    -------
    int
        Subdivisions, 0 to 4.

    Examples
    --------
    >>> tex = SolidTexture(np.zeros((8, 8, 8, 3), np.uint8), spacing=0.05)
    >>> auto_subdivisions(pv.Sphere(theta_resolution=16, phi_resolution=16), tex)
    2
    >>> auto_subdivisions(pv.Sphere(theta_resolution=16, phi_resolution=16), tex, quantile=0.99)
    3
    """
    edges = surface.extract_all_edges().compute_cell_sizes(length=True, area=False, volume=False)
    lengths = np.asarray(edges.cell_data["Length"], dtype=float)
    edge = float(np.mean(lengths) if quantile is None else np.quantile(lengths, quantile))
    wanted = texture.spacing / samples_per_voxel
    return int(np.clip(np.ceil(np.log2(max(edge / wanted, 1.0))), 0, 4))


def texture_surface(surface: pv.PolyData, texture: TextureSampler, subdivisions: int | str = "auto") -> pv.PolyData:
    """Colour a surface from a solid texture, sampled at rest-frame positions.

    Parameters
    ----------
    surface : pyvista.PolyData
        Triangles; point data ``"rest"`` gives rest positions (the points themselves if absent).
    texture : SolidTexture or LazySolidTexture
        The volume texture, placed in the rest frame (anything with ``sample(points)`` and
        ``spacing``: a lazy texture synthesises the voxels the surface touches).
    subdivisions : int or "auto"
        Linear subdivisions before sampling (geometry unchanged, ``"rest"`` interpolated);
        ``"auto"`` uses :func:`auto_subdivisions` (about one sample per texture voxel).

    Returns
    -------
    pyvista.PolyData
        A new surface with point data ``"RGB"`` (uint8) and ``"rest"``.

    Examples
    --------
    >>> tex = SolidTexture(np.full((4, 4, 4, 3), 90, np.uint8), spacing=0.5, origin=(-1, -1, -1))
    >>> out = texture_surface(pv.Sphere(theta_resolution=8, phi_resolution=8), tex, subdivisions=1)
    >>> out.n_points > 100, out.point_data["RGB"].dtype.name, int(out.point_data["RGB"].max())
    (True, 'uint8', 90)
    """
    surf = surface.triangulate()
    if REST not in surf.point_data:
        surf = surf.copy()
        surf.point_data[REST] = np.asarray(surf.points, dtype=np.float64)
    n = auto_subdivisions(surf, texture) if subdivisions == "auto" else int(subdivisions)
    if n > 0:
        keep = pv.PolyData(surf.points, surf.faces)
        keep.point_data[REST] = surf.point_data[REST]
        surf = keep.subdivide(n, subfilter="linear")
    else:
        surf = surf.copy()
    surf.point_data["RGB"] = texture.sample(np.asarray(surf.point_data[REST]))
    surf.point_data.active_scalars_name = "RGB"
    return surf


def rest_points(mesh: pv.DataSet) -> NDArray[np.float64]:
    """The rest-frame positions of a mesh's points (point data ``"rest"``, else the points).

    Examples
    --------
    >>> mesh = pv.Sphere()
    >>> bool(np.array_equal(rest_points(mesh), mesh.points))
    True
    >>> mesh.point_data[REST] = mesh.points * 2
    >>> bool(np.allclose(rest_points(mesh), 2 * mesh.points))
    True
    """
    if REST in mesh.point_data:
        return np.asarray(mesh.point_data[REST], dtype=np.float64)
    return np.asarray(mesh.points, dtype=np.float64)
