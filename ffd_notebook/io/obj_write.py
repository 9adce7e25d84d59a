"""Write OBJ meshes with per-vertex colours (``v x y z r g b``, colours in [0, 1])."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np
import pyvista as pv

from ._atomic import atomic_open

__all__ = ["write_obj"]

_CHUNK = 20_000  # rows formatted at a time: bounded memory for big meshes


def _as_polydata(mesh) -> pv.PolyData:
    if isinstance(mesh, pv.PolyData):
        return mesh.triangulate() if mesh.n_strips else mesh  # OBJ has no triangle strips
    if isinstance(mesh, pv.DataSet):
        return mesh.extract_surface(pass_pointid=False, pass_cellid=False, algorithm="dataset_surface")
    raise TypeError(f"expected a PyVista mesh, got {type(mesh).__name__}")


def _colors01(mesh: pv.PolyData) -> np.ndarray | None:
    """Vertex colours in [0, 1] from point data "RGB" (or "RGBA"), or None."""
    name = "RGB" if "RGB" in mesh.point_data else "RGBA" if "RGBA" in mesh.point_data else None
    if name is None:
        return None
    stored = np.asarray(mesh.point_data[name])
    if stored.ndim != 2 or stored.shape[1] not in (3, 4):
        raise ValueError(f"point data {name!r} must have 3 or 4 components per point, got shape {stored.shape}")
    rgb = stored[:, :3].astype(np.float64)
    if not np.isfinite(rgb).all() or rgb.min() < 0 or rgb.max() > 255:
        raise ValueError(f"point data {name!r} must hold colours in [0, 1] (floats) or 0-255")
    if stored.dtype.kind == "f" and rgb.max() <= 1.0:
        return rgb
    return np.round(rgb / 255.0, 6)  # 6 decimals: rint(x * 255) recovers every uint8 value exactly


def _cells(cell_array) -> tuple[np.ndarray, np.ndarray]:
    offsets = np.asarray(pv.convert_array(cell_array.GetOffsetsArray()), dtype=np.int64)
    connectivity = np.asarray(pv.convert_array(cell_array.GetConnectivityArray()), dtype=np.int64)
    return offsets, connectivity


def _cell_lines(keyword: str, cell_array) -> Iterator[str]:
    offsets, connectivity = _cells(cell_array)
    if len(offsets) < 2:
        return
    sizes = np.diff(offsets)
    text = (connectivity + 1).astype(str)
    if np.all(sizes == sizes[0]):
        rows = text.reshape(-1, int(sizes[0]))
        for start in range(0, len(rows), _CHUNK):
            yield from (f"{keyword} " + " ".join(r) for r in rows[start : start + _CHUNK].tolist())
    else:
        for a, b in zip(offsets[:-1].tolist(), offsets[1:].tolist(), strict=True):
            yield f"{keyword} " + " ".join(text[a:b].tolist())


def _obj_lines(mesh: pv.PolyData) -> Iterator[str]:
    points = np.asarray(mesh.points)
    if not np.isfinite(points).all():
        raise ValueError("cannot write a mesh whose points contain NaN or infinite values")
    colors = _colors01(mesh)
    yield "# written by ffd_notebook: v x y z r g b (colours in [0, 1]), 1-based indices"
    for start in range(0, len(points), _CHUNK):
        block = points[start : start + _CHUNK].astype(str)  # shortest text that reads back exactly
        if colors is not None:
            block = np.concatenate([block, colors[start : start + _CHUNK].astype(str)], axis=1)
        yield from ("v " + " ".join(r) for r in block.tolist())
    yield from _cell_lines("f", mesh.GetPolys())
    yield from _cell_lines("l", mesh.GetLines())


def write_obj(path: str | os.PathLike[str], mesh: pv.DataSet) -> None:
    """Write a mesh as OBJ, atomically (a temporary file in the same folder, then rename).

    Parameters
    ----------
    path : str or path-like
        Destination; an existing file is replaced only once the new one is complete.
    mesh : pyvista.DataSet
        A PolyData (other datasets are written as their surface, triangle strips as triangles).
        Points are written with the shortest text that reads back bit-identical. If the mesh has
        point data ``"RGB"`` (or ``"RGBA"``; uint8 0-255, or floats in [0, 1]) every vertex gets
        ``v x y z r g b`` with colours in [0, 1]. Polygons become ``f`` and polylines ``l``
        statements, 1-based; vertex cells, normals and texture coordinates are not written.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np, pyvista as pv
    >>> from ffd_notebook.io import read_obj
    >>> mesh = pv.Plane(i_resolution=2, j_resolution=1)
    >>> mesh.point_data["RGB"] = np.arange(18, dtype=np.uint8).reshape(6, 3) * 10
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "plane.obj"
    >>> write_obj(path, mesh)
    >>> path.read_text().splitlines()[2]
    'v 0.0 -0.5 0.0 0.117647 0.156863 0.196078'
    >>> back = read_obj(path)
    >>> bool(np.array_equal(back.point_data["RGB"], mesh.point_data["RGB"]))
    True
    """
    polydata = _as_polydata(mesh)
    lines = _obj_lines(polydata)
    first = next(lines)  # validate (NaN points, bad colours) before creating any file
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write(first + "\n")
        for line in lines:
            f.write(line + "\n")
