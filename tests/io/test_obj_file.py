"""OBJ reading and writing: every shared OBJ file, face forms, colours, speed, errors, atomic writes."""

from __future__ import annotations

import os

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import obj_write, read_obj, write_obj
from ffd_notebook.io._text import read_text
from ffd_notebook.io.obj import _parse_fast, _parse_lines

SHARED_OBJ = {  # file -> (vertices, cells) counted in the files themselves ("v " and "f " lines)
    "seed-lineage/ladybird.obj": (23932, 23496),
    "seed-lineage/teapot.obj": (3644, 6320),
    "seed-lineage/monkey.obj": (507, 500),
    "seed-lineage/sphere.obj": (382, 400),
    "seed-lineage/face.obj": (103, 98),
    "seed-lineage/cube.obj": (8, 6),
    "face/james.obj": (6393, 12228),
    "face/james_colored.obj": (6393, 12228),
    "face/template_colored.obj": (53349, 106111),
}


def write(tmp_path, text: str, name: str = "mesh.obj"):
    path = tmp_path / name
    path.write_bytes(text.encode())
    return path


@pytest.mark.parametrize("name", sorted(SHARED_OBJ))
def test_every_shared_obj_loads(shared_data, name):
    path = shared_data / name
    mesh = read_obj(path)
    assert (mesh.n_points, mesh.n_cells) == SHARED_OBJ[name]
    # the vectorised path and the line-by-line parser agree on every real file
    text = read_text(path)
    fast, slow = _parse_fast(text), _parse_lines(path, text)
    assert fast is not None
    np.testing.assert_array_equal(fast.points, slow.points)
    np.testing.assert_array_equal(fast.face_sizes, slow.face_sizes)
    np.testing.assert_array_equal(fast.face_indices, slow.face_indices)
    first_v = next(line for line in text.splitlines() if line.startswith("v "))
    assert mesh.points[0].tolist() == [float(t) for t in first_v.split()[1:4]]


def test_polygons_stay_polygons(shared_data):
    ladybird = read_obj(shared_data / "seed-lineage" / "ladybird.obj")  # quads with v/vt faces
    sizes = np.diff(pv.convert_array(ladybird.GetPolys().GetOffsetsArray()))
    assert set(sizes.tolist()) >= {4}
    assert not ladybird.is_all_triangles


def test_colours_of_james(shared_data):
    mesh = read_obj(shared_data / "face" / "james_colored.obj")
    rgb = mesh.point_data["RGB"]
    assert rgb.dtype == np.uint8 and rgb.shape == (6393, 3)
    assert mesh.point_data.active_scalars_name == "RGB"
    # line 3 of the file: v -101.439934 20.491423 -33.038589 0.0588 0.0471 0.0275 -> rounded, not truncated
    assert rgb[1].tolist() == [15, 12, 7]


def test_vtk_reader_is_not_faithful(shared_data):
    """Why read_obj exists: VTK's reader splits vertices at texture seams and truncates colours."""
    vtk_mesh = pv.read(shared_data / "face" / "james.obj")
    assert vtk_mesh.n_points > 6393  # one point per face corner with distinct vt
    assert read_obj(shared_data / "face" / "james.obj").n_points == 6393
    vtk_colored = pv.read(shared_data / "face" / "james_colored.obj")
    assert vtk_colored.point_data["RGB"][1].tolist() == [14, 12, 7]  # 0.0588 * 255 = 14.99 -> 14


def test_template_loads(shared_data):
    # its speed is measured by tests/benchmarks/bench_io.py against VTK's reader in the same run
    mesh = read_obj(shared_data / "face" / "template_colored.obj")
    assert mesh.n_points == 53349
    assert mesh.point_data["RGB"].shape == (53349, 3)


def test_colour_round_trip(shared_data, tmp_path):
    mesh = read_obj(shared_data / "face" / "james_colored.obj")
    write_obj(tmp_path / "out.obj", mesh)
    back = read_obj(tmp_path / "out.obj")
    np.testing.assert_array_equal(back.points, mesh.points)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    np.testing.assert_array_equal(back.point_data["RGB"], mesh.point_data["RGB"])
    assert "v -101.439934 20.491423 -33.038589 0.058824 0.047059 0.027451" in (tmp_path / "out.obj").read_text()


def test_face_forms_and_statements(tmp_path):
    text = (
        "# comment\n\nmtllib x.mtl\no thing\ng group\ns off\nusemtl red\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n"
        "f 1 2 3\nf 1/1 2/2 3/1\nf 1//1 2//1 3//1\nf 1/1/1 2/2/1 3/1/1\n"
        "f -4 -3 -2 -1\n"  # relative indices: the four vertices so far
        "f 1 2 \\\n 3 4 \\\n   \n"  # continuation lines make one quad
        "l 1 2 3\n"
    )
    mesh = read_obj(write(tmp_path, text))
    assert mesh.n_points == 4
    assert mesh.n_faces == 6 and mesh.n_lines == 1
    faces = mesh.irregular_faces
    assert [f.tolist() for f in faces[:4]] == [[0, 1, 2]] * 4
    assert faces[4].tolist() == [0, 1, 2, 3] and faces[5].tolist() == [0, 1, 2, 3]
    assert mesh.lines.tolist() == [3, 0, 1, 2]
    assert "RGB" not in mesh.point_data


def test_relative_indices_count_from_their_line(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n"
    mesh = read_obj(write(tmp_path, text))
    assert [f.tolist() for f in mesh.irregular_faces] == [[0, 1, 2], [3, 4, 5]]


def test_colours_0_255_and_crlf(tmp_path):
    text = "v 0 0 0 255 0 10\r\nv 1 0 0 0 128 0\r\nv 0 1 0 1 1 1\r\nf 1 2 3\r\n"
    mesh = read_obj(write(tmp_path, text))
    assert mesh.point_data["RGB"].tolist() == [[255, 0, 10], [0, 128, 0], [1, 1, 1]]


def test_write_polygons_lines_and_no_colour(tmp_path):
    mesh = pv.PolyData(
        np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 2, 0]], dtype=np.float32),
        faces=[4, 0, 1, 2, 3, 3, 3, 2, 4],
        lines=[2, 0, 4],
    )
    write_obj(tmp_path / "poly.obj", mesh)
    text = (tmp_path / "poly.obj").read_text()
    assert "f 1 2 3 4\nf 4 3 5\nl 1 5\n" in text and "v 0.5 2.0 0.0\n" in text
    back = read_obj(tmp_path / "poly.obj")
    np.testing.assert_array_equal(back.points, mesh.points)
    assert [f.tolist() for f in back.irregular_faces] == [[0, 1, 2, 3], [3, 2, 4]]
    assert back.lines.tolist() == [2, 0, 4]


def test_write_float_and_rgba_colours(tmp_path):
    mesh = pv.PolyData(np.eye(3), faces=[3, 0, 1, 2])
    mesh.point_data["RGB"] = np.array([[1.0, 0.0, 0.5], [0.2, 0.4, 0.6], [0, 0, 0]])
    write_obj(tmp_path / "f.obj", mesh)
    assert read_obj(tmp_path / "f.obj").point_data["RGB"].tolist() == [[255, 0, 128], [51, 102, 153], [0, 0, 0]]
    rgba = pv.PolyData(np.eye(3), faces=[3, 0, 1, 2])
    rgba.point_data["RGBA"] = np.array([[10, 20, 30, 255]] * 3, dtype=np.uint8)
    write_obj(tmp_path / "rgba.obj", rgba)
    assert read_obj(tmp_path / "rgba.obj").point_data["RGB"].tolist() == [[10, 20, 30]] * 3


def test_write_is_atomic(shared_data, tmp_path, monkeypatch):
    target = tmp_path / "keep.obj"
    write_obj(target, pv.Triangle())
    before = target.read_bytes()
    real_cell_lines = obj_write._cell_lines

    def failing(keyword, cells):
        yield from list(real_cell_lines(keyword, cells))[:10]
        raise OSError("No space left on device")

    monkeypatch.setattr(obj_write, "_cell_lines", failing)
    with pytest.raises(OSError, match="No space"):
        write_obj(target, read_obj(shared_data / "seed-lineage" / "teapot.obj"))
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == ["keep.obj"]


def test_write_refuses_nan_points(tmp_path):
    mesh = pv.Triangle()
    mesh.points[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        write_obj(tmp_path / "nan.obj", mesh)
    assert not (tmp_path / "nan.obj").exists()


GOOD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
BAD = [
    # (what is wrong, text, line, words of the message)
    ("empty", "", 1, "no vertices"),
    ("only comments", "# nothing\n\n", 2, "no vertices"),
    ("two coordinates", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", 2, "'v x y z'"),
    ("not a number", "v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", 2, "the vertex z"),
    ("NaN coordinate", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", 2, "finite"),
    ("Python-only number form", "v 0 0 0\nv 1_000 0 0\nv 0 1 0\nf 1 2 3\n", 2, "the vertex x"),
    ("inf colour", "v 0 0 0 1 1 1\nv 1 0 0 1 inf 1\n", 2, "the vertex green"),
    ("negative colour", "v 0 0 0 1 1 1\nv 1 0 0 1 -1 1\n", 2, "colour components"),
    ("colour above 255", "v 0 0 0 1 1 1\nv 1 0 0 1 300 1\n", 2, "colour components"),
    ("colour on some vertices", "v 0 0 0 1 1 1\nv 1 0 0\n", 2, "no colour"),
    ("index out of range", GOOD + "f 1 2 4\n", 5, "face index 4 is out of range"),
    ("index zero", GOOD + "f 0 1 2\n", 5, "index 0"),
    ("relative index too far back", GOOD + "f -1 -2 -4\n", 5, "relative face index -4"),
    ("face of two", GOOD + "f 1 2\n", 5, "at least 3"),
    ("line of one", GOOD + "l 1\n", 5, "at least 2"),
    ("float index", GOOD + "f 1 2 3.5\n", 5, "face index like 7"),
    ("junk index", GOOD + "f 1 2 3/x\n", 5, "face index like 7"),
    ("unknown statement", GOOD + "vx 1 2 3\n", 5, "'vx'"),
    ("junk line", "v 0 0 0\n\x00\x01garbage\n", 2, "OBJ statement"),
    ("truncated face", GOOD[:-2], 4, "at least 3"),
]


@pytest.mark.parametrize(("text", "line", "words"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_malformed_files_name_file_and_line(tmp_path, text, line, words):
    path = write(tmp_path, text, name="bad.obj")
    with pytest.raises(FileFormatError) as info:
        read_obj(path)
    assert info.value.path == str(path)
    assert info.value.line == line, str(info.value)
    assert words in info.value.problem, str(info.value)


def test_binary_and_undecodable_files(tmp_path):
    path = tmp_path / "junk.obj"
    path.write_bytes(GOOD.encode() + b"\xff\xd8\xff\xe0binary")
    with pytest.raises(FileFormatError, match="line 5: not UTF-8"):
        read_obj(path)
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(FileFormatError):
        read_obj(path)
