"""Read PLY meshes with NumPy, checking every size and index before anything is built.

Why a hand-written reader (chosen over the alternatives, all tried with hostile files):

* VTK's ``vtkPLYReader`` (what ``pyvista.read`` uses, VTK 9.7) trusts the header: a 200-byte
  binary PLY announcing billions of vertices kills the process (SIGSEGV), and faces whose indices
  are past the vertex count load silently and crash VTK filters later (normals).
* ``plyfile`` is well kept and strict, but GPL-3: this package is MIT and would have to become GPL.
* ``meshio`` (MIT) reads ``uchar`` colours as signed ``int8``, reads only ``vertex`` and ``face``
  elements, and walks ``face`` counts from the header without checking them against the file.

The format is small (an ASCII header, then fixed-size rows or one line per row), so this reader
checks the element counts against the file size, reads rows with ``numpy.frombuffer`` (binary) or
``numpy`` text parsing (ASCII), and checks that face indices are within the vertices. Anything
malformed raises :class:`~ffd_notebook.errors.FileFormatError` (with the line for ASCII files).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pyvista as pv

from ..errors import FileFormatError
from ._safety import MAX_FILE_BYTES, read_bytes
from ._text import parse_int, split_fields
from .obj import padded_cells

__all__ = ["read_ply"]

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2", "ushort": "u2",
    "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4",
    "double": "f8", "float64": "f8",
}  # fmt: skip
_ByteOrder = Literal["<", ">"]
_FORMATS: dict[str, _ByteOrder | None] = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_MAX_HEADER = 1 << 16
_ASCII_NUMBERS = re.compile(r"[^0-9eE+\-. \t]")


@dataclass
class _Property:
    name: str
    dtype: np.dtype  # of the value (of the items for a list)
    count_dtype: np.dtype | None = None  # of the item count, for a list


@dataclass
class _Element:
    name: str
    count: int
    line: int  # of its header line
    properties: list[_Property]


def _header(path, data: bytes) -> tuple[_ByteOrder | None, list[_Element], int, int]:
    """(byte order or None for ASCII, elements, offset of the body, line number of ``end_header``)."""
    end = re.search(rb"end_header[ \t]*\r?\n", data[:_MAX_HEADER])
    if not data.startswith((b"ply\n", b"ply\r\n")) or end is None:
        raise FileFormatError(path, 1, "not a PLY file: expected 'ply' on line 1 and 'end_header' in the first 64 KiB")
    try:
        lines = data[: end.start()].decode("ascii").split("\n")
    except UnicodeDecodeError:
        raise FileFormatError(path, None, "the PLY header is not ASCII text") from None
    order: _ByteOrder | None = None
    has_format = False
    elements: list[_Element] = []
    for number, text in enumerate(lines[1:], start=2):
        fields = split_fields(text.rstrip("\r"))
        if not fields or fields[0] in ("comment", "obj_info"):
            continue
        if fields[0] == "format" and len(fields) == 3 and fields[1] in _FORMATS and fields[2] == "1.0":
            order, has_format = _FORMATS[fields[1]], True
        elif fields[0] == "element" and len(fields) == 3:
            count = parse_int(path, number, fields[2], f"the number of {fields[1]!r} elements")
            if count < 0:
                raise FileFormatError(path, number, f"negative element count {count}")
            elements.append(_Element(fields[1], count, number, []))
        elif fields[0] == "property" and elements:
            elements[-1].properties.append(_property(path, number, fields))
        else:
            raise FileFormatError(path, number, f"expected a PLY header line (format, element, property, comment), "
                                  f"got {text[:40]!r}")  # fmt: skip
    if not has_format:
        raise FileFormatError(path, 2, "missing 'format ascii 1.0' (or binary_little_endian / binary_big_endian)")
    return order, elements, end.end(), len(lines)  # the last header line is 'end_header'


def _property(path, number: int, fields: list[str]) -> _Property:
    if len(fields) == 3 and fields[1] in _TYPES:
        return _Property(fields[2], np.dtype(_TYPES[fields[1]]))
    if len(fields) == 5 and fields[1] == "list" and fields[2] in _TYPES and fields[3] in _TYPES:
        if np.dtype(_TYPES[fields[2]]).kind == "f":
            raise FileFormatError(path, number, f"a list count must be an integer type, got {fields[2]!r}")
        return _Property(fields[4], np.dtype(_TYPES[fields[3]]), np.dtype(_TYPES[fields[2]]))
    raise FileFormatError(path, number, f"expected 'property TYPE NAME' or 'property list TYPE TYPE NAME' with "
                          f"TYPE one of {', '.join(sorted(set(_TYPES)))}, got {' '.join(fields)[:60]!r}")  # fmt: skip


# ---------------------------------------------------------------------------------------- binary
def _read_binary(path, data: bytes, at: int, element: _Element, order: _ByteOrder) -> tuple[dict[str, np.ndarray], int]:
    """Columns of one element (a list property gives a list of arrays) and the offset after it."""
    props = element.properties
    least = sum((p.count_dtype or p.dtype).itemsize for p in props)
    if element.count and least * element.count > len(data) - at:
        raise FileFormatError(path, element.line, f"{element.count} {element.name!r} elements need at least "
                              f"{least * element.count} bytes, the file has {len(data) - at} left")  # fmt: skip
    if all(p.count_dtype is None for p in props):
        dtype = np.dtype([(f"p{i}", p.dtype.newbyteorder(order)) for i, p in enumerate(props)])
        rows = np.frombuffer(data, dtype, element.count, at)
        return {p.name: rows[f"p{i}"] for i, p in enumerate(props)}, at + dtype.itemsize * element.count
    sizes = _uniform_list_sizes(data, at, element, order)
    if sizes is None:
        return _read_binary_rows(path, data, at, element, order)
    fields: list[tuple[Any, ...]] = []
    for i, (p, size) in enumerate(zip(props, sizes, strict=True)):
        if p.count_dtype is None:
            fields.append((f"p{i}", p.dtype.newbyteorder(order)))
        else:
            fields += [(f"n{i}", p.count_dtype.newbyteorder(order)), (f"p{i}", p.dtype.newbyteorder(order), (size,))]
    dtype = np.dtype(fields)
    if dtype.itemsize * element.count > len(data) - at:
        return _read_binary_rows(path, data, at, element, order)  # reports where it ends
    rows = np.frombuffer(data, dtype, element.count, at)
    columns = {}
    for i, (p, size) in enumerate(zip(props, sizes, strict=True)):
        if p.count_dtype is not None and np.any(rows[f"n{i}"] != size):
            return _read_binary_rows(path, data, at, element, order)  # lists of several sizes
        columns[p.name] = rows[f"p{i}"]
    return columns, at + dtype.itemsize * element.count


def _uniform_list_sizes(data: bytes, at: int, element: _Element, order: _ByteOrder) -> list[int] | None:
    """List sizes of the first row (scalars count 0), assuming every row has the same; None if unreadable."""
    sizes = []
    for p in element.properties:
        if p.count_dtype is None:
            sizes.append(0)
            at += p.dtype.itemsize
            continue
        if at + p.count_dtype.itemsize > len(data) or element.count == 0:
            return None
        size = int(np.frombuffer(data, p.count_dtype.newbyteorder(order), 1, at)[0])
        sizes.append(size)
        at += p.count_dtype.itemsize + size * p.dtype.itemsize
    return sizes


def _read_binary_rows(path, data: bytes, at: int, element: _Element, order: _ByteOrder) -> tuple[dict, int]:
    """Row by row, for lists of varying sizes (bounded: the size check allows count <= file bytes)."""
    columns: dict[str, list] = {p.name: [] for p in element.properties}
    for row in range(element.count):
        for p in element.properties:
            n = 1
            if p.count_dtype is not None:
                n = int(_take(path, data, at, p.count_dtype.newbyteorder(order), 1, element, row)[0])
                if n < 0:
                    raise FileFormatError(path, None, f"{element.name!r} element {row}: negative list size {n}")
                at += p.count_dtype.itemsize
            values = _take(path, data, at, p.dtype.newbyteorder(order), n, element, row)
            at += n * p.dtype.itemsize
            columns[p.name].append(values if p.count_dtype is not None else values[0])
    return {name: (np.array(v) if v and np.isscalar(v[0]) else v) for name, v in columns.items()}, at


def _take(path, data: bytes, at: int, dtype: np.dtype, n: int, element: _Element, row: int) -> np.ndarray:
    if at + n * dtype.itemsize > len(data):
        raise FileFormatError(path, None, f"the file ends inside {element.name!r} element {row} "
                              f"(of {element.count})")  # fmt: skip
    return np.frombuffer(data, dtype, n, at)


# ---------------------------------------------------------------------------------------- ASCII
def _read_ascii(path, lines: list[tuple[int, str]], at: int, element: _Element) -> tuple[dict, int]:
    """Columns of one element from one text line per row, and the index of the next line."""
    if element.count > len(lines) - at:
        raise FileFormatError(path, element.line, f"{element.count} {element.name!r} elements need as many lines, "
                              f"the file has {len(lines) - at} left")  # fmt: skip
    rows = lines[at : at + element.count]
    for number, text in rows:
        if _ASCII_NUMBERS.search(text):
            raise FileFormatError(path, number, f"expected numbers for a {element.name!r} element, got {text[:40]!r}")
    fields = [split_fields(text) for _, text in rows]
    widths = {len(f) for f in fields}
    if len(widths) == 1:  # the usual case: one table
        try:
            table = np.array(fields, dtype=np.float64).reshape(len(rows), -1)
        except ValueError:
            table = None
        if table is not None and np.isfinite(table).all():
            first = _split_row(path, rows[0][0], table[0], element)
            found = None if first is None else _columns_from_table(table, element, first)
            if found is not None:
                return found, at + element.count
    columns: dict[str, list] = {p.name: [] for p in element.properties}
    for (number, _), values in zip(rows, fields, strict=True):
        row = _split_row(path, number, _floats(path, number, values), element, strict=True)
        for name, value in row.items():
            columns[name].append(value)
    return {name: (np.array(v) if v and np.isscalar(v[0]) else v) for name, v in columns.items()}, at + element.count


def _floats(path, number: int, values: list[str]) -> np.ndarray:
    try:
        out = np.array(values, dtype=np.float64)
    except ValueError:
        raise FileFormatError(path, number, f"expected numbers, got {' '.join(values)[:40]!r}") from None
    if not np.isfinite(out).all():
        raise FileFormatError(path, number, "expected finite numbers")
    return out


def _split_row(path, number: int, values: np.ndarray, element: _Element, strict: bool = False):
    """{property: value or list} of one row; with ``strict`` False, None if it does not fit."""
    out, at = {}, 0
    for p in element.properties:
        n = 1
        if p.count_dtype is not None:
            if at >= len(values) or values[at] != int(values[at]) or values[at] < 0:
                if not strict:
                    return None
                raise FileFormatError(path, number, f"expected the size of list {p.name!r} (an integer >= 0)")
            n, at = int(values[at]), at + 1
        if at + n > len(values):
            if not strict:
                return None
            raise FileFormatError(path, number, f"expected {n} values for {p.name!r}, the line ends before")
        out[p.name] = values[at : at + n] if p.count_dtype is not None else values[at]
        at += n
    if at != len(values):
        if not strict:
            return None
        raise FileFormatError(path, number, f"expected {at} numbers on this {element.name!r} line, got {len(values)}")
    return out


def _columns_from_table(table: np.ndarray, element: _Element, first: dict) -> dict | None:
    """Columns of a table of rows of equal width, or None if their lists differ in size."""
    columns, at = {}, 0
    for p in element.properties:
        if p.count_dtype is None:
            columns[p.name], at = table[:, at], at + 1
        else:
            n = len(first[p.name])
            if np.any(table[:, at] != n):
                return None  # lists of several sizes: row by row
            columns[p.name], at = table[:, at + 1 : at + 1 + n], at + 1 + n
    return columns


# ---------------------------------------------------------------------------------------- the mesh
def read_ply(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> pv.PolyData:
    """Read a PLY mesh (ASCII or binary), checking sizes and face indices first.

    Parameters
    ----------
    path : str or path-like
        The file. Its ``vertex`` element needs ``x, y, z``; ``red, green, blue`` (``alpha``)
        become point data ``"RGB"`` (``"RGBA"``) as uint8, ``nx, ny, nz`` ``"Normals"``, other
        vertex properties point data of their name. Faces are the ``vertex_indices`` (or
        ``vertex_index``) lists of the ``face`` element; other elements are skipped.
    max_bytes : int
        Larger files are refused before reading.

    Returns
    -------
    pyvista.PolyData

    Raises
    ------
    FileFormatError
        For anything malformed: counts the file cannot hold, indices outside the vertices, ...

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "tri.ply"
    >>> header = "ply\\nformat ascii 1.0\\nelement vertex 3\\nproperty float x\\nproperty float y\\nproperty float z\\n"
    >>> header += "element face 1\\nproperty list uchar int vertex_indices\\nend_header\\n"
    >>> _ = path.write_text(header + "0 0 0\\n1 0 0\\n0 1 0\\n3 0 1 2\\n")
    >>> read_ply(path).n_cells
    1
    >>> _ = path.write_text(header + "0 0 0\\n1 0 0\\n0 1 0\\n3 0 1 7\\n")
    >>> read_ply(path)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...tri.ply, line 13: face 0 has vertex index 7: the file has 3 vertices
    """
    data = read_bytes(path, max_bytes)
    order, elements, body, n_header = _header(path, data)
    for element in elements:
        if element.count and not element.properties:
            raise FileFormatError(path, element.line, f"element {element.name!r} has no properties")
    columns: dict[str, dict] = {}
    first_line: dict[str, int | None] = {}
    if order is None:
        text = data[body:].decode("ascii", errors="replace")
        lines = [(n, t) for n, t in enumerate(text.replace("\r", "").split("\n"), start=n_header + 1) if t.strip(" \t")]
        at = 0
        for element in elements:
            first_line[element.name] = lines[at][0] if at < len(lines) else None
            columns[element.name], at = _read_ascii(path, lines, at, element)
    else:
        at = body
        for element in elements:
            first_line[element.name] = None
            columns[element.name], at = _read_binary(path, data, at, element, order)
    return _to_polydata(path, columns, first_line, elements)


def _to_polydata(path, columns: dict[str, dict], first_line: dict, elements: list[_Element]) -> pv.PolyData:
    vertex = columns.get("vertex")
    line = next((e.line for e in elements if e.name == "vertex"), 1)
    if not vertex or not {"x", "y", "z"} <= set(vertex) or len(vertex["x"]) == 0:
        raise FileFormatError(path, line, "expected an element 'vertex' with properties x, y, z and at least one row")
    if any(not isinstance(vertex[k], np.ndarray) or vertex[k].ndim != 1 for k in vertex):
        raise FileFormatError(path, line, "vertex properties must be numbers, not lists")
    # the file's precision, as VTK's reader keeps it: float32 stays float32, anything else is float64
    single = all(vertex[k].dtype == np.float32 for k in "xyz")
    points = np.column_stack([vertex["x"], vertex["y"], vertex["z"]]).astype(np.float32 if single else np.float64)
    if not np.isfinite(points).all():
        bad = int(np.flatnonzero(~np.isfinite(points).all(axis=1))[0])
        raise FileFormatError(path, _row_line(first_line, "vertex", bad), f"vertex {bad} has a coordinate that is "
                              "not a finite number")  # fmt: skip
    faces = _faces(path, columns.get("face"), len(points), first_line)
    mesh = pv.PolyData(points, faces=faces) if faces is not None else pv.PolyData(points)
    _point_data(path, mesh, vertex, line)
    return mesh


def _row_line(first_line: dict, name: str, row: int) -> int | None:
    start = first_line.get(name)
    return None if start is None else start + row  # ASCII: one line per row (blank lines are rare)


def _faces(path, face: dict | None, n_points: int, first_line: dict) -> np.ndarray | None:
    if not face:
        return None
    key = "vertex_indices" if "vertex_indices" in face else "vertex_index" if "vertex_index" in face else None
    if key is None:
        return None
    lists = face[key]
    if isinstance(lists, np.ndarray) and lists.ndim == 2:  # every face the same size
        sizes = np.full(len(lists), lists.shape[1], dtype=np.int64)
        flat = lists.reshape(-1)
    else:
        sizes = np.array([len(f) for f in lists], dtype=np.int64)
        flat = np.concatenate([np.asarray(f).reshape(-1) for f in lists]) if len(lists) else np.zeros(0)
    if len(sizes) and sizes.min() < 3:
        bad = int(np.argmax(sizes < 3))
        raise FileFormatError(path, _row_line(first_line, "face", bad), f"face {bad} has {sizes[bad]} vertices, "
                              "expected at least 3")  # fmt: skip
    bad_value = (flat < 0) | (flat >= n_points) | (flat != np.floor(flat))
    if bad_value.any():
        first = int(np.argmax(bad_value))
        row = int(np.searchsorted(np.cumsum(sizes), first, side="right"))
        raise FileFormatError(path, _row_line(first_line, "face", row), f"face {row} has vertex index "
                              f"{flat[first]:.15g}: the file has {n_points} vertices")  # fmt: skip
    return padded_cells(sizes, flat.astype(np.int64))


def _point_data(path, mesh: pv.PolyData, vertex: dict, line: int) -> None:
    color_names = [n for n in ("red", "green", "blue", "alpha") if n in vertex]
    if {"red", "green", "blue"} <= set(color_names):
        colors = np.column_stack([vertex[n] for n in color_names]).astype(np.float64)
        if colors.min() < 0 or colors.max() > 255 or (np.any(colors != np.floor(colors)) and colors.max() > 1):
            raise FileFormatError(path, line, "expected vertex colours as 0-255 integers or floats in [0, 1]")
        if all(vertex[n].dtype.kind == "f" for n in color_names) and colors.max() <= 1:
            colors = colors * 255.0
        colors = np.rint(colors).astype(np.uint8)
        if colors.shape[1] == 4:
            mesh.point_data["RGBA"] = colors
        mesh.point_data["RGB"] = np.ascontiguousarray(colors[:, :3])
        mesh.point_data.active_scalars_name = "RGB"
    else:
        color_names = []
    if {"nx", "ny", "nz"} <= set(vertex):
        mesh.point_data["Normals"] = np.column_stack([vertex["nx"], vertex["ny"], vertex["nz"]])
    for name, values in vertex.items():
        if name not in {"x", "y", "z", "nx", "ny", "nz", *color_names}:
            mesh.point_data[name] = values
