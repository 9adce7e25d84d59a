"""The vectorised PLY reader: every layout it parses gives back what was written, and errors name the row's line.

Files are written here byte by byte from drawn meshes (faces of several sizes in any order, colours, other vertex
properties, scalar face properties around the index list, blank lines and CRLF in ASCII, both byte orders), so
the reference is what was written; VTK's reader (``pyvista.read``) is checked on the files it reads too.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io.ply import read_ply

FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}


def _ply(fmt: str, points, colours, faces, *, flags=None, crlf=False, blank_lines=()) -> bytes:
    """A PLY file: float x y z (+ uchar red green blue), faces 'list uchar int' (+ an int before, a float after)."""
    order = FORMATS[fmt]
    header = ["ply", f"format {fmt} 1.0", "comment written by the test", f"element vertex {len(points)}"]
    header += [f"property float {a}" for a in "xyz"]
    header += [f"property uchar {c}" for c in ("red", "green", "blue")] if colours is not None else []
    header += [f"element face {len(faces)}"]
    header += ["property int flag"] if flags is not None else []
    header += ["property list uchar int vertex_indices"]
    header += ["property float quality"] if flags is not None else []
    header += ["end_header"]
    newline = "\r\n" if crlf else "\n"
    head = (newline.join(header) + newline).encode()
    if order is None:
        rows = [" ".join(f"{v:.9g}" for v in p) for p in points]
        if colours is not None:
            rows = [f"{r} {c[0]} {c[1]} {c[2]}" for r, c in zip(rows, colours, strict=True)]
        for i, face in enumerate(faces):
            items = [str(len(face)), *map(str, face)]
            rows.append(" ".join(items if flags is None else [str(flags[i]), *items, f"{flags[i] / 2:.9g}"]))
        for at in sorted(blank_lines, reverse=True):
            rows.insert(min(at, len(rows)), " \t" if at % 2 else "")
        return head + (newline.join(rows) + newline).encode()
    vertex = [("x", order + "f4"), ("y", order + "f4"), ("z", order + "f4")]
    vertex += [(c, "u1") for c in ("red", "green", "blue")] if colours is not None else []
    table = np.zeros(len(points), vertex)
    for i, a in enumerate("xyz"):
        table[a] = points[:, i]
    if colours is not None:
        for i, c in enumerate(("red", "green", "blue")):
            table[c] = colours[:, i]
    body = bytearray(table.tobytes())
    for i, face in enumerate(faces):
        if flags is not None:
            body += np.array([flags[i]], order + "i4").tobytes()
        body += bytes([len(face)]) + np.asarray(face, order + "i4").tobytes()
        if flags is not None:
            body += np.array([flags[i] / 2], order + "f4").tobytes()
    return head + bytes(body)


@st.composite
def meshes(draw):
    n = draw(st.integers(3, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    points = rng.uniform(-10, 10, (n, 3)).astype(np.float32)
    colours = rng.integers(0, 256, (n, 3)) if draw(st.booleans()) else None
    sizes = draw(st.lists(st.sampled_from([3, 3, 4, 5, 8]), min_size=0, max_size=30))
    faces = [rng.integers(0, n, size).tolist() for size in sizes]
    flags = rng.integers(-5, 5, len(faces)).tolist() if draw(st.booleans()) else None
    return points, colours, faces, flags


@settings(max_examples=60, deadline=None)
@given(drawn=meshes(), fmt=st.sampled_from(sorted(FORMATS)), crlf=st.booleans(),
       blank_lines=st.lists(st.integers(0, 80), max_size=4))  # fmt: skip
def test_what_was_written_is_read(tmp_path_factory, drawn, fmt, crlf, blank_lines):
    points, colours, faces, flags = drawn
    path = tmp_path_factory.mktemp("ply") / "mesh.ply"
    ascii = fmt == "ascii"
    path.write_bytes(_ply(fmt, points, colours, faces, flags=flags, crlf=crlf and ascii,
                          blank_lines=blank_lines if ascii else ()))  # fmt: skip
    mesh = read_ply(path)
    np.testing.assert_allclose(mesh.points, points, rtol=1e-6 if ascii else 0, atol=0)
    if colours is not None:
        np.testing.assert_array_equal(mesh.point_data["RGB"], colours)
    if faces:
        expected = np.concatenate([[len(f), *f] for f in faces])
        np.testing.assert_array_equal(mesh.faces, expected)
    else:
        assert mesh.n_cells == 0
    if faces and flags is None and not crlf and not blank_lines:  # what VTK's reader takes too
        vtk = pv.read(path)
        np.testing.assert_array_equal(vtk.faces, mesh.faces)
        np.testing.assert_allclose(vtk.points, mesh.points, rtol=1e-6, atol=0)


def test_binary_faces_of_several_sizes_cut_short(tmp_path):
    points = np.zeros((4, 3), np.float32)
    data = _ply("binary_little_endian", points, None, [[0, 1, 2], [0, 1, 2, 3], [1, 2, 3]])
    for cut, row in ((1, 2), (13, 2), (14, 1), (28, 1)):
        (tmp_path / "cut.ply").write_bytes(data[:-cut])
        with pytest.raises(FileFormatError, match=f"ends inside 'face' element {row} "):
            read_ply(tmp_path / "cut.ply")


@pytest.mark.parametrize(
    ("row", "match"),
    [
        ("3 0 1 x", "line 18: expected numbers for a 'face' element"),
        ("3 0 1", "line 18: expected 3 values for 'vertex_indices'"),
        ("3 0 1 2 3", "line 18: expected 4 numbers on this 'face' line, got 5"),
        ("2.5 0 1", "line 18: expected the size of list 'vertex_indices'"),
        ("3 0 1 1e999", "line 18: expected finite numbers"),
        ("3 0 1 1-2", "line 18: expected numbers, got '3 0 1 1-2'"),
        ("4 0 1 2 9", "line 18: face 1 has vertex index 9: the file has 4 vertices"),
    ],
)
def test_ascii_errors_name_the_line_of_the_row_past_blank_lines(tmp_path, row, match):
    data = _ply("ascii", np.zeros((4, 3)), None, [[0, 1, 2], [0, 1, 2, 3]], blank_lines=[4, 5])
    lines = data.decode().split("\n")
    assert lines[17] == "4 0 1 2 3"  # 10 header lines, 4 vertices, a blank line, the first face, a blank line
    lines[17] = row
    (tmp_path / "bad.ply").write_text("\n".join(lines))
    with pytest.raises(FileFormatError, match=match):
        read_ply(tmp_path / "bad.ply")


def test_lines_after_the_last_element_are_not_read(tmp_path):
    data = _ply("ascii", np.zeros((3, 3)), None, [[0, 1, 2]])
    (tmp_path / "tail.ply").write_bytes(data + b"anything at all \xff\n")
    assert read_ply(tmp_path / "tail.ply").n_cells == 1


def test_ascii_chunks_split_rows_anywhere(tmp_path, monkeypatch):
    """Rows are read in chunks of bytes; with tiny chunks every row boundary falls on one."""
    from ffd_notebook.io import ply

    rng = np.random.default_rng(5)
    points = rng.uniform(-1, 1, (50, 3))
    faces = [rng.integers(0, 50, size).tolist() for size in rng.choice([3, 4, 7], 60)]
    (tmp_path / "m.ply").write_bytes(_ply("ascii", points, None, faces, blank_lines=[3, 70, 71]))
    whole = read_ply(tmp_path / "m.ply")
    for chunk in (7, 64, 1000):
        monkeypatch.setattr(ply, "_CHUNK", chunk)
        mesh = read_ply(tmp_path / "m.ply")
        np.testing.assert_array_equal(mesh.points, whole.points)
        np.testing.assert_array_equal(mesh.faces, whole.faces)
