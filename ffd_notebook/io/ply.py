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

Every property is read for all rows at once, as the OBJ reader does: ASCII text a few MiB at a
time into one array of numbers with the count on each line (:class:`_AsciiRows`), split into
columns by a cursor per row (:func:`_columns`); binary rows whose lists differ in length (faces
mixing triangles and quads) by one walk that finds where each row starts, then one gather per
column. Measured on a 43 MB ASCII file (500k coloured vertices, 1M triangles) and a 21 MB binary
one (1M triangles and quads), ``tests/benchmarks/bench_io.py`` on a shared machine: 2.2 s and
0.6 s, 2-4x and about 1x VTK's reader, adding 5.5x and 8x the file's size to the process (the
row-by-row reader this replaced: 12-17 s and 3-5 s, 10-12x VTK's; 17x and 22x the file).
"""

from __future__ import annotations

import os
import re
import struct
from array import array
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


# ---------------------------------------------------------------------------------------- rows
@dataclass
class _Ragged:
    """A list property whose rows differ in length: every row's length, and their items end to end."""

    sizes: np.ndarray  # (rows,) int64
    flat: np.ndarray  # (sizes.sum(),)


def _gather(source: np.ndarray, starts: np.ndarray, sizes: np.ndarray, step: int = 1) -> np.ndarray | _Ragged:
    """Each row's run ``source[starts[r] + step * k]``, ``k < sizes[r]``: ``(rows, n)`` if all ``sizes[r] == n``."""
    if len(sizes) == 0 or sizes.min() == sizes.max():
        n = int(sizes[0]) if len(sizes) else 0
        return source[starts[:, None] + step * np.arange(n)]
    first = np.cumsum(sizes) - sizes  # where each row's run begins in the flat result
    flat = np.arange(int(sizes.sum()), dtype=np.int64)
    flat *= step
    flat += np.repeat(starts - step * first, sizes)
    return _Ragged(sizes, source[flat])


def _unaligned(data: bytes, dtype: np.dtype) -> np.ndarray:
    """A view of ``data`` with a ``dtype`` value starting at every byte (``view[i]`` is the value at offset ``i``)."""
    return np.ndarray((max(len(data) - dtype.itemsize + 1, 0),), dtype, buffer=data, strides=(1,))


# ---------------------------------------------------------------------------------------- binary
def _read_binary(path, data: bytes, at: int, element: _Element, order: _ByteOrder) -> tuple[dict[str, Any], int]:
    """Columns of one element (a list property of rows of several lengths gives a :class:`_Ragged`) and the
    offset after it."""
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
    """Lists of several lengths: a walk over the rows finds where each starts, then every column is one gather.

    Where a row starts depends on the lengths of the lists before it, so the walk is a Python loop;
    it keeps 8 bytes a row and a list (``array``), and reads a count with one indexing (one-byte
    counts, the usual ``uchar``) or ``struct`` (wider ones). The values themselves are then read
    with NumPy through unaligned views of the file (:func:`_unaligned`), a few bytes a value.
    """
    props = element.properties
    # the row as steps: a run of scalars is a fixed number of bytes; a list is (count reader, its bytes, item bytes)
    steps: list[tuple[int, Any, int]] = []
    for p in props:
        if p.count_dtype is None:
            if steps and steps[-1][1] is None:
                steps[-1] = (steps[-1][0] + p.dtype.itemsize, None, 0)
            else:
                steps.append((p.dtype.itemsize, None, 0))
        else:
            code = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I"}[p.count_dtype.str[1:]]
            steps.append((p.count_dtype.itemsize, struct.Struct(order + code).unpack_from, p.dtype.itemsize))
    starts = array("q")
    counts = [array("q") for _, read, _ in steps if read is not None]
    end = len(data)
    try:
        if len(steps) == 1 and steps[0][0] == 1 and props[0].count_dtype.kind == "u":  # type: ignore[union-attr]
            width, add = steps[0][2], counts[0].append  # the usual face: 'property list uchar int vertex_indices'
            for _ in range(element.count):
                starts.append(at)
                n = data[at]
                add(n)
                at += 1 + n * width
        else:
            for row in range(element.count):
                starts.append(at)
                k = 0
                for size, read, width in steps:
                    if read is None:
                        at += size
                        continue
                    n = read(data, at)[0]
                    if n < 0:
                        raise FileFormatError(path, None, f"{element.name!r} element {row}: negative list size {n}")
                    counts[k].append(n)
                    at += size + n * width
                    k += 1
        if at > end:
            raise IndexError
    except (IndexError, struct.error):  # a count or the items past the end: in the last row that starts inside
        row = int(np.searchsorted(np.frombuffer(starts, np.int64), end, side="right")) - 1
        raise FileFormatError(path, None, f"the file ends inside {element.name!r} element {row} "
                              f"(of {element.count})") from None  # fmt: skip
    cursor = np.frombuffer(starts, np.int64).copy()
    sizes = iter(counts)
    columns: dict[str, Any] = {}
    for p in props:
        values = _unaligned(data, p.dtype.newbyteorder(order))
        if p.count_dtype is None:
            columns[p.name] = values[cursor]
            cursor += p.dtype.itemsize
            continue
        lengths = np.frombuffer(next(sizes), np.int64)
        cursor += p.count_dtype.itemsize
        columns[p.name] = _gather(values, cursor, lengths, p.dtype.itemsize)  # at cursor[r], itemsize apart
        cursor += lengths * p.dtype.itemsize
    return columns, at


# ---------------------------------------------------------------------------------------- ASCII
_CHUNK = 1 << 22  # bytes of text parsed at once: bounds the temporary arrays (a few bytes a byte, 16 a line)
_BLANK = np.zeros(256, dtype=bool)
_BLANK[[9, 10, 13, 32]] = True  # TAB, LF, CR and space separate numbers; a line of them alone is skipped
_NUMERIC = np.zeros(256, dtype=bool)
_NUMERIC[np.frombuffer(b"0123456789eE+-. \t\r\n", np.uint8)] = True


class _AsciiRows:
    """The non-blank lines of an ASCII PLY body, read a chunk at a time into numbers with NumPy.

    Each line is one row of an element; :meth:`take` returns the next ``n`` rows as every number
    end to end, the count on each row and each row's line number (for messages). Only the lines
    the elements need are looked at (what follows them is ignored, as before).
    """

    def __init__(self, path, data: bytes, body: int, first_line: int) -> None:
        self.path, self.data, self.at, self.line = path, data, body, first_line
        self.bytes = np.frombuffer(data, np.uint8)

    def take(self, n: int, element: _Element) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        values, counts, lines = [], [], []
        found = 0
        while found < n and self.at < len(self.data):
            chunk_values, chunk_counts, chunk_lines = self._chunk(n - found, element)
            values.append(chunk_values)
            counts.append(chunk_counts)
            lines.append(chunk_lines)
            found += len(chunk_counts)
        if found < n:
            raise FileFormatError(self.path, element.line, f"{n} {element.name!r} elements need as many lines, the "
                                  f"file has {found} left")  # fmt: skip
        if len(values) == 1:
            return values[0], counts[0], lines[0]
        if not values:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64)
        return np.concatenate(values), np.concatenate(counts), np.concatenate(lines)

    def _chunk(self, wanted: int, element: _Element) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Up to ``wanted`` non-blank lines from ``self.at`` in about :data:`_CHUNK` bytes (whole lines)."""
        data, start = self.data, self.at
        end = min(start + _CHUNK, len(data))
        if end < len(data):  # end on a line's end (a line longer than a chunk: at its own end)
            cut = data.rfind(b"\n", start, end)
            end = cut + 1 if cut >= 0 else (data.find(b"\n", end) + 1 or len(data))
        text = self.bytes[start:end]
        newlines = np.flatnonzero(text == 10)
        line_starts = np.concatenate([[0], newlines + 1])
        if line_starts[-1] == len(text):
            line_starts = line_starts[:-1]  # the chunk ends with a newline: no line begins after it
        ink = ~_BLANK[text]
        token_starts = ink.copy()
        token_starts[1:] &= ~ink[:-1]
        counts = np.add.reduceat(token_starts, line_starts, dtype=np.int64) if len(text) else np.zeros(0, np.int64)
        lines = np.flatnonzero(counts)  # the non-blank ones
        consumed = len(line_starts)
        if len(lines) > wanted:  # the element's rows end inside this chunk: stop after its last line
            consumed = int(lines[wanted - 1]) + 1
            end = start + (int(line_starts[consumed]) if consumed < len(line_starts) else len(text))
            text, lines = text[: end - start], lines[:wanted]
        numbers = self.line + lines
        self.at, self.line = end, self.line + consumed
        counts = counts[lines]
        if len(lines) == 0:  # blank lines only (NumPy would read a blank text as [-1.0])
            return np.zeros(0), counts, numbers
        bad = np.flatnonzero(~_NUMERIC[text])
        if len(bad):
            row = int(np.searchsorted(line_starts[lines], bad[0], side="right")) - 1
            line = data[start + line_starts[lines[row]] :].split(b"\n", 1)[0].decode("ascii", "replace").rstrip("\r")
            raise FileFormatError(self.path, int(numbers[row]), f"expected numbers for a {element.name!r} element, "
                                  f"got {line[:40]!r}")  # fmt: skip
        try:
            values = np.fromstring(text.tobytes().decode("ascii"), dtype=np.float64, sep=" ")
        except ValueError:
            values = None
        if values is None or len(values) != counts.sum() or not np.isfinite(values).all():
            for row, number in enumerate(numbers):  # find the line, for its message
                line_start = start + int(line_starts[lines[row]])
                _floats(self.path, int(number), split_fields(data[line_start:].split(b"\n", 1)[0].decode("ascii")))
            raise FileFormatError(self.path, int(numbers[0]), "expected numbers")  # (not reached: a line fails above)
        return values, counts, numbers


def _read_ascii(path, rows: _AsciiRows, element: _Element) -> tuple[dict[str, Any], np.ndarray]:
    """Columns of one element from one text line per row, and each row's line number."""
    values, counts, lines = rows.take(element.count, element)
    columns, bad = _columns(values, counts, element)
    if bad is not None:  # the strict row reader says what is wrong with it
        row_start = int(np.sum(counts[:bad]))
        _split_row(path, int(lines[bad]), values[row_start : row_start + counts[bad]], element, strict=True)
    return columns, lines


def _columns(values: np.ndarray, counts: np.ndarray, element: _Element) -> tuple[dict[str, Any], int | None]:
    """Columns of rows given as their numbers end to end and how many each has; else the first bad row.

    Each property is taken from every row at once: a cursor per row moves over the scalars and the
    lists (count, then items), and a row that runs out of numbers, has a list count that is not a
    whole number >= 0, or has numbers left over is bad.
    """
    if len(counts) and counts.min() == counts.max() and all(p.count_dtype is None for p in element.properties):
        if counts[0] != len(element.properties):
            return {}, 0
        table = values.reshape(len(counts), -1)  # the usual vertex rows: columns are views
        return {p.name: table[:, i] for i, p in enumerate(element.properties)}, None
    ends = np.cumsum(counts)
    cursor = ends - counts
    bad = np.zeros(len(counts), dtype=bool)
    last = max(len(values) - 1, 0)
    source = values if len(values) else np.zeros(1)
    columns: dict[str, Any] = {}
    for p in element.properties:
        bad |= cursor >= ends
        here = source[np.minimum(cursor, last)]
        cursor = cursor + 1
        if p.count_dtype is None:
            columns[p.name] = here
            continue
        bad |= (here < 0) | (here != np.floor(here)) | (here > counts)
        n = np.where(bad, 0, here).astype(np.int64)
        bad |= cursor + n > ends
        n[bad] = 0
        columns[p.name] = _gather(source, np.minimum(cursor, last), n)
        cursor = cursor + n
    bad |= cursor != ends
    if bad.any():
        return {}, int(np.argmax(bad))
    return columns, None


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
    row_lines: dict[str, np.ndarray] = {}  # ASCII: each row's line, for messages
    if order is None:
        rows = _AsciiRows(path, data, body, n_header + 1)
        for element in elements:
            columns[element.name], row_lines[element.name] = _read_ascii(path, rows, element)
    else:
        at = body
        for element in elements:
            columns[element.name], at = _read_binary(path, data, at, element, order)
    return _to_polydata(path, columns, row_lines, elements)


def _to_polydata(path, columns: dict[str, dict], row_lines: dict, elements: list[_Element]) -> pv.PolyData:
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
        raise FileFormatError(path, _row_line(row_lines, "vertex", bad), f"vertex {bad} has a coordinate that is "
                              "not a finite number")  # fmt: skip
    faces = _faces(path, columns.get("face"), len(points), row_lines)
    mesh = pv.PolyData(points, faces=faces) if faces is not None else pv.PolyData(points)
    _point_data(path, mesh, vertex, line)
    return mesh


def _row_line(row_lines: dict, name: str, row: int) -> int | None:
    lines = row_lines.get(name)
    return None if lines is None else int(lines[row])  # ASCII: the row's own line; binary: none


def _faces(path, face: dict | None, n_points: int, row_lines: dict) -> np.ndarray | None:
    if not face:
        return None
    key = "vertex_indices" if "vertex_indices" in face else "vertex_index" if "vertex_index" in face else None
    if key is None:
        return None
    lists = face[key]
    if isinstance(lists, _Ragged):
        sizes, flat = lists.sizes, lists.flat
    elif lists.ndim == 2:  # every face the same size
        sizes = np.full(len(lists), lists.shape[1], dtype=np.int64)
        flat = lists.reshape(-1)
    else:
        raise FileFormatError(path, None, f"the faces' {key!r} must be a list property")
    if len(sizes) and sizes.min() < 3:
        bad = int(np.argmax(sizes < 3))
        raise FileFormatError(path, _row_line(row_lines, "face", bad), f"face {bad} has {sizes[bad]} vertices, "
                              "expected at least 3")  # fmt: skip
    bad_value = (flat < 0) | (flat >= n_points) | (flat != np.floor(flat))
    if bad_value.any():
        first = int(np.argmax(bad_value))
        row = int(np.searchsorted(np.cumsum(sizes), first, side="right"))
        raise FileFormatError(path, _row_line(row_lines, "face", row), f"face {row} has vertex index "
                              f"{flat[first]:.15g}: the file has {n_points} vertices")  # fmt: skip
    return padded_cells(sizes, flat.astype(np.int64, copy=False))


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
