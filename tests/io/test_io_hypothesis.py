"""Property-based tests: random lattices and meshes survive save/load; corrupted files fail cleanly."""

from __future__ import annotations

import numpy as np
import pyvista as pv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from ffd_notebook import Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_ffd, read_obj, save_ffd, write_obj
from ffd_notebook.io.obj import _parse_fast, _parse_lines
from ffd_notebook.io.placement import quaternion_to_rotation

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@st.composite
def lattices(draw):
    shape = tuple(draw(st.lists(st.integers(2, 5), min_size=3, max_size=3)))
    spacing = draw(st.lists(st.floats(1e-3, 1e3), min_size=3, max_size=3))
    offsets = draw(arrays(np.float64, shape + (3,), elements=finite))
    origin = draw(st.lists(finite, min_size=3, max_size=3))
    kind = draw(st.sampled_from(["none", "quaternion", "matrix"]))
    if kind == "none":
        return Lattice(shape, spacing, offsets=offsets), kind
    if kind == "quaternion":  # what a file can describe: keep the values, as load_ffd does
        qf = draw(st.sampled_from([-1.0, 1.0]))
        b, c, d = Rotation.random(random_state=draw(st.integers(0, 2**32 - 1))).as_quat()[:3]
        rotation = quaternion_to_rotation(qf, b, c, d)
        lat = Lattice(shape, spacing, origin=origin, rotation=rotation, offsets=offsets)
        lat.metadata["placement"] = dict(
            zip(("qf", "qb", "qc", "qd", "qx", "qy", "qz"), (qf, b, c, d, *origin), strict=True)
        )
        return lat, kind
    rotation = Rotation.random(random_state=draw(st.integers(0, 2**32 - 1))).as_matrix()
    if draw(st.booleans()):
        rotation = rotation @ np.diag([1.0, 1.0, -1.0])  # a reflection
    return Lattice(shape, spacing, origin=origin, rotation=rotation, offsets=offsets), kind


@SETTINGS
@given(lattices(), st.booleans(), st.booleans())
def test_ffd_save_load_identical(tmp_path, drawn, crlf, trailing_tabs):
    lat, kind = drawn
    path = tmp_path / "random.ffd"
    save_ffd(path, lat)
    text = path.read_text()
    if not trailing_tabs:
        text = text.replace("\t\n", "\n")
    if crlf:
        text = text.replace("\n", "\r\n")
    path.write_bytes(text.encode())
    back = load_ffd(path)
    assert back.shape == lat.shape
    np.testing.assert_array_equal(back.offsets, lat.offsets)
    np.testing.assert_array_equal(back.spacing, lat.spacing)
    np.testing.assert_array_equal(back.origin, lat.origin)
    if kind == "matrix":  # a float matrix is not exactly the image of a float quaternion ...
        np.testing.assert_allclose(back.rotation, lat.rotation, rtol=0, atol=_rotation_tolerance(lat.rotation))
        save_ffd(path, back)  # ... but once read, the quaternion is kept and the cycle is exact
        assert load_ffd(path) == back
    else:
        assert back == lat
        assert back.metadata["placement"] == lat.metadata.get("placement")


def _rotation_tolerance(rotation: np.ndarray) -> float:
    """How well the file's quaternion can hold a rotation: the format stores b, c, d, not a.

    a = sqrt(1 - b^2 - c^2 - d^2) loses precision like eps / a near a half turn, and NIfTI's rule
    snaps rotations with a^2 < 1e-7 to exactly a half turn (an error of about 2a).
    """
    proper = rotation * np.array([1.0, 1.0, np.sign(np.linalg.det(rotation))])
    a = np.sqrt(max(1.0 + np.trace(proper), 0.0)) / 2.0
    return 2.5 * a if a * a < 1e-7 else 1e-14 + 1e-15 / a


@st.composite
def meshes(draw):
    n = draw(st.integers(3, 25))
    points = draw(
        arrays(draw(st.sampled_from([np.float32, np.float64])), (n, 3), elements=st.floats(-1e5, 1e5, width=32))
    )
    faces = draw(st.lists(st.lists(st.integers(0, n - 1), min_size=3, max_size=6), min_size=0, max_size=12))
    lines = draw(st.lists(st.lists(st.integers(0, n - 1), min_size=2, max_size=4), max_size=3))
    kwargs = {}
    if faces:
        kwargs["faces"] = [v for f in faces for v in (len(f), *f)]
    if lines:
        kwargs["lines"] = [v for f in lines for v in (len(f), *f)]
    mesh = pv.PolyData(points, **kwargs)
    if draw(st.booleans()):
        mesh.point_data["RGB"] = draw(arrays(np.uint8, (n, 3)))
    return mesh


@SETTINGS
@given(meshes())
def test_obj_write_read_identical(tmp_path, mesh):
    path = tmp_path / "random.obj"
    write_obj(path, mesh)
    back = read_obj(path)
    # float32 points are written with float32's shortest text: they read back as the same float32 values
    np.testing.assert_array_equal(back.points.astype(mesh.points.dtype), mesh.points)
    if mesh.points.dtype == np.float64:
        np.testing.assert_array_equal(back.points, mesh.points)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    np.testing.assert_array_equal(back.lines, mesh.lines)
    assert ("RGB" in back.point_data) == ("RGB" in mesh.point_data)
    if "RGB" in mesh.point_data:
        np.testing.assert_array_equal(back.point_data["RGB"], mesh.point_data["RGB"])


@st.composite
def obj_texts(draw):
    """OBJ text in the forms found in the wild, and the faces (0-based) it describes."""
    n = draw(st.integers(3, 12))
    colour = draw(st.sampled_from([None, "unit", "byte"]))
    lines, faces = ["# made up", "o thing"], []
    for i in range(n):
        xyz = " ".join(repr(v) for v in draw(st.lists(finite, min_size=3, max_size=3)))
        rgb = {None: "", "unit": " 0.5 0.25 1.0", "byte": " 128 64 255"}[colour]
        lines.append(f"v {xyz}{rgb}")
        lines.append(f"vt 0.{i} 0.5")
    for _ in range(draw(st.integers(0, 6))):
        face = draw(st.lists(st.integers(0, n - 1), min_size=3, max_size=5))
        form = draw(st.sampled_from(["{}", "{}/1", "{}//1", "{}/1/1"]))
        relative = draw(st.booleans())
        tokens = [form.format(v - n if relative else v + 1) for v in face]
        lines.append(
            draw(st.sampled_from(["f ", "f  ", "\tf\t"])) + " ".join(tokens) + draw(st.sampled_from(["", " "]))
        )
        faces.append(face)
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    return newline.join(lines) + newline, faces, colour


@SETTINGS
@given(obj_texts())
def test_obj_forms_parse_the_same_fast_and_slow(tmp_path, drawn):
    text, faces, colour = drawn
    path = tmp_path / "forms.obj"
    path.write_bytes(text.encode())
    mesh = read_obj(path)
    assert [f.tolist() for f in mesh.irregular_faces] == faces
    assert mesh.n_points == len(slow_points := _parse_lines(path, text).points) and np.isfinite(slow_points).all()
    if colour:
        assert mesh.point_data["RGB"][0].tolist() == [128, 64, 255]
    slow = _parse_lines(path, text.replace("\r\n", "\n"))
    fast = _parse_fast(text)
    if fast is not None:
        np.testing.assert_array_equal(fast.points, slow.points)
        np.testing.assert_array_equal(fast.face_indices, slow.face_indices)


VALID_FFD = (
    b"#dimension#\r\n3\r\n#one to one#\r\n1\r\n#control grid size#\r\n2\r\n2\r\n2\r\n#control grid spacing#\r\n"
    b"  20.000000\r\n  20.000000\r\n  20.000000\r\n#offsets of the control points#\r\n"
    b"0 0 0\t0 0 0.5\t\r\n0 0 0\t0 0 0\t\r\n\r\n1.5 0 0\t0 0 0\t\r\n0 0 0\t0 -2 0\t\r\n\r\n"
    b"#quaternion qf,qb,qc,qd,qx,qy,qz#\r\n-1.000000\t 0.000000\t1.000000\t0.000000\t 90.000000\t-126.0\t-72.0\r\n"
)
VALID_OBJ = (
    b"# test\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\nvt 0 0\nvn 0 0 1\n"
    b"f 1/1/1 2/1/1 3/1/1\nf -4 -2 -1\nf 1 2 3 4\nl 1 3\n"
)


@st.composite
def corrupted(draw, data: bytes):
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        action = draw(st.sampled_from(["flip", "truncate", "insert", "delete"]))
        pos = draw(st.integers(0, max(len(data) - 1, 0)))
        if action == "flip" and data:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif action == "truncate":
            del data[pos:]
        elif action == "insert":
            data[pos:pos] = draw(
                st.binary(min_size=1, max_size=8) | st.sampled_from([b"nan", b"#", b"\t", b"\n", b"-"])
            )
        elif data:
            del data[pos : pos + draw(st.integers(1, 10))]
    return bytes(data)


@SETTINGS
@given(corrupted(VALID_FFD))
def test_corrupted_ffd_loads_or_raises_file_format_error(tmp_path, data):
    path = tmp_path / "corrupt.ffd"
    path.write_bytes(data)
    try:
        lat = load_ffd(path)
    except FileFormatError as err:
        assert err.path == str(path) and err.line is not None and err.line >= 1
    else:
        assert np.isfinite(lat.offsets).all()


@SETTINGS
@given(corrupted(VALID_OBJ))
def test_corrupted_obj_loads_or_raises_file_format_error(tmp_path, data):
    path = tmp_path / "corrupt.obj"
    path.write_bytes(data)
    try:
        mesh = read_obj(path)
    except FileFormatError as err:
        assert err.path == str(path) and err.line is not None and err.line >= 1
    else:
        assert np.isfinite(mesh.points).all() and mesh.n_points >= 1
        for cells in (mesh.GetPolys(), mesh.GetLines()):
            connectivity = pv.convert_array(cells.GetConnectivityArray())
            assert connectivity.size == 0 or (connectivity.min() >= 0 and connectivity.max() < mesh.n_points)


def test_uncorrupted_inputs_are_valid(tmp_path):
    """The seeds of the corruption tests read as what they say (so a corruption is a real change)."""
    (tmp_path / "ok.ffd").write_bytes(VALID_FFD)
    lat = load_ffd(tmp_path / "ok.ffd")
    assert lat.shape == (2, 2, 2) and lat.spacing.tolist() == [20.0] * 3
    assert lat.offsets[1, 1, 1].tolist() == [0.0, -2.0, 0.0] and lat.origin.tolist() == [90.0, -126.0, -72.0]
    (tmp_path / "ok.obj").write_bytes(VALID_OBJ)
    mesh = read_obj(tmp_path / "ok.obj")
    assert mesh.n_points == 4 and mesh.point_data["RGB"][1].tolist() == [0, 255, 0]
    assert [f.tolist() for f in mesh.irregular_faces] == [[0, 1, 2], [0, 2, 3], [0, 1, 2, 3]]
    assert mesh.lines.tolist() == [2, 0, 2]
