"""Checks around VTK's readers for the formats still read by VTK (STL, legacy .vtk, .vtp, .vtu).

Those readers run in a child process (:mod:`._vtk_child`: VTK's legacy reader itself crashes on
bad cell counts). Before the child starts, header counts are checked against the file size (a
200-byte file cannot hold a billion points; this keeps VTK from allocating gigabytes); after, every
cell of what it read is checked (:func:`check_cells`) before anything in this process uses the
mesh: VTK filters (normals, surface extraction) crash on cells that index past the points or
have fewer points than their type needs.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pyvista as pv

from ..errors import FileFormatError

__all__ = ["check_cells", "check_header_counts"]

# legacy .vtk keywords followed by counts; FIELD arrays: "name ncomp ntuples type"
_LEGACY_COUNTS = re.compile(
    rb"^[ \t]*(POINTS|CELLS|POLYGONS|LINES|VERTICES|TRIANGLE_STRIPS|CELL_TYPES|POINT_DATA|CELL_DATA|OFFSETS|"
    rb"CONNECTIVITY|METADATA|FIELD [^ \t\r\n]+|[^ \t\r\n]+(?=[ \t]+[0-9]+[ \t]+[0-9]+[ \t]+(?:bit|unsigned_char|char|"
    rb"unsigned_short|short|unsigned_int|int|unsigned_long|long|float|double|vtkIdType|vtktypeint64)))"
    rb"((?:[ \t]+[0-9]+)+)",
    re.M,
)
_LEGACY_DATASET = re.compile(rb"^[ \t]*DATASET[ \t]+([A-Za-z_]+)", re.M)
_XML_COUNTS = re.compile(rb"\bNumberOf(?:Points|Cells|Verts|Lines|Strips|Polys|Tuples|Components)=\"([0-9]+)\"")
# an XML file may hold compressed data: allow this many values per byte of file (LZMA reaches ~7000)
_XML_RATIO = 10_000

# VTK cell types accepted in an unstructured grid, with their number of points (0: any >= 1)
_CELL_POINTS = {1: 1, 2: 0, 3: 2, 4: 0, 5: 3, 6: 0, 7: 0, 8: 4, 9: 4, 10: 4, 11: 8, 12: 8, 13: 6, 14: 5,
                21: 3, 22: 6, 23: 8, 24: 10, 25: 20}  # fmt: skip
_LEAST_POINTS = {2: 1, 4: 2, 6: 3, 7: 3}
_NEED = np.array([_CELL_POINTS.get(t, 0) for t in range(26)], dtype=np.int64)  # by cell type
_LEAST = np.array([_LEAST_POINTS.get(t, 1) for t in range(26)], dtype=np.int64)


def check_header_counts(path: str | os.PathLike[str], data: bytes, size: int, suffix: str) -> None:
    """Refuse a file whose header announces more items than its ``size`` in bytes can hold.

    ``data`` is the start of the file (all of it for legacy .vtk); ``suffix`` the lower-case extension.

    Examples
    --------
    >>> check_header_counts("big.stl", bytes(80) + (10**9).to_bytes(4, "little") + bytes(50), 134, ".stl")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: big.stl: the binary STL header says 1000000000 triangles ...
    """
    if suffix == ".stl":
        if not data.lstrip()[:5].lower() == b"solid" and size >= 84:
            n = int.from_bytes(data[80:84], "little")
            if 84 + 50 * n > size:
                raise FileFormatError(path, None, f"the binary STL header says {n} triangles ({84 + 50 * n} bytes), "
                                      f"the file has {size} bytes")  # fmt: skip
        return
    if suffix == ".vtk":
        dataset = _LEGACY_DATASET.search(data)
        if dataset is None or dataset.group(1) not in (b"POLYDATA", b"UNSTRUCTURED_GRID"):
            kind = dataset.group(1).decode("ascii", "replace") if dataset else "none"
            raise FileFormatError(path, None, f"expected a legacy VTK file with DATASET POLYDATA or "
                                  f"UNSTRUCTURED_GRID, got {kind[:40]!r}")  # fmt: skip
        for match in _LEGACY_COUNTS.finditer(data):
            _check_count(path, data, match, [int(v) for v in match.group(2).split()], size, size)
        return
    for match in _XML_COUNTS.finditer(data):
        _check_count(path, data, match, [int(match.group(1))], _XML_RATIO * size, size)


def _check_count(path, data: bytes, match: re.Match, counts: list[int], limit: int, size: int) -> None:
    if max(counts) > limit:
        line = data.count(b"\n", 0, match.start()) + 1
        what = match.group(0).strip()[:60].decode("ascii", "replace")
        raise FileFormatError(path, line, f"{what!r}: {max(counts)} items cannot fit in a file of {size} bytes")


def check_cells(path: str | os.PathLike[str], mesh: pv.DataSet) -> None:
    """Refuse a mesh whose cells index outside its points or are malformed, or whose points are not finite.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> mesh = pv.PolyData(np.zeros((3, 3)), faces=[3, 0, 1, 5])
    >>> check_cells("bad.vtk", mesh)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: bad.vtk: polygon 0 uses point 5: there are 3 points
    """
    points = np.asarray(mesh.points)
    if not np.isfinite(points).all():
        bad = int(np.flatnonzero(~np.isfinite(points).all(axis=1))[0])
        raise FileFormatError(path, None, f"point {bad} has a coordinate that is not a finite number")
    n = mesh.n_points
    if isinstance(mesh, pv.PolyData):
        kinds = (("vertex", mesh.GetVerts(), 1), ("line", mesh.GetLines(), 2), ("polygon", mesh.GetPolys(), 3),
                 ("triangle strip", mesh.GetStrips(), 3))  # fmt: skip
        for kind, cells, least in kinds:
            sizes = _check_array(path, kind, cells, n)
            if len(sizes) and sizes.min() < least:
                bad = int(np.argmax(sizes < least))
                raise FileFormatError(path, None, f"{kind} {bad} has {sizes[bad]} points, expected at least {least}")
    elif isinstance(mesh, pv.UnstructuredGrid):
        sizes = _check_array(path, "cell", mesh.GetCells(), n)
        types = np.asarray(mesh.celltypes).astype(np.int64)
        if len(types) != len(sizes):
            raise FileFormatError(path, None, f"{len(sizes)} cells but {len(types)} cell types")
        known = np.isin(types, list(_CELL_POINTS))
        if not known.all():
            bad = int(np.argmax(~known))
            raise FileFormatError(path, None, f"cell {bad} has cell type {types[bad]}, not supported")
        need, least_points = _NEED[types], _LEAST[types]
        wrong = np.where(need > 0, sizes != need, sizes < least_points)
        if wrong.any():
            bad = int(np.argmax(wrong))
            raise FileFormatError(path, None, f"cell {bad} of type {types[bad]} has {sizes[bad]} points")
    else:
        raise FileFormatError(path, None, f"expected a surface or unstructured mesh, got a {type(mesh).__name__}")


def _check_array(path, kind: str, cells, n_points: int) -> np.ndarray:
    """Sizes of the cells of a ``vtkCellArray`` after checking offsets and indices."""
    offsets = np.asarray(pv.convert_array(cells.GetOffsetsArray()), dtype=np.int64)
    connectivity = np.asarray(pv.convert_array(cells.GetConnectivityArray()), dtype=np.int64)
    if len(offsets) == 0:
        return np.zeros(0, np.int64)
    sizes = np.diff(offsets)
    if offsets[0] != 0 or offsets[-1] != len(connectivity) or (sizes < 0).any():
        raise FileFormatError(path, None, f"the {kind} cells are inconsistent (offsets do not match the indices)")
    bad = (connectivity < 0) | (connectivity >= n_points)
    if bad.any():
        first = int(np.argmax(bad))
        cell = int(np.searchsorted(offsets, first, side="right")) - 1
        raise FileFormatError(path, None, f"{kind} {cell} uses point {connectivity[first]}: there are {n_points} "
                              "points")  # fmt: skip
    return sizes
