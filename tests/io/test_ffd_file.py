"""The .ffd reader and writer: the real registration file, the format's variants, placement, atomic saves."""

from __future__ import annotations

import os

import numpy as np
import pytest

from ffd_notebook import Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import ffd_file, load_ffd, place_at_mesh_minimum, save_ffd
from ffd_notebook.io.placement import quaternion_to_rotation, rotation_to_quaternion

TINY = (
    "#dimension#\n3\n#one to one#\n1\n#control grid size#\n2\n2\n2\n#control grid spacing#\n1\n1\n1\n"
    "#offsets of the control points#\n0 0 0\t0 0 0.5\t\n0 0 0\t0 0 0\t\n\n1.5 0 0\t0 0 0\t\n0 0 0\t0 -2 0\t\n\n"
)


@pytest.fixture
def real_ffd(shared_data):
    return shared_data / "seed-lineage" / "registration_11x12x11.FFD"


def write(tmp_path, text: str, name: str = "lattice.ffd", newline: str = "\n"):
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode())
    return path


def test_real_file_values(real_ffd):
    lat = load_ffd(real_ffd)
    assert lat.shape == (11, 12, 11)
    assert lat.spacing.tolist() == [20.0, 20.0, 20.0]
    assert lat.offsets[0, 0, 0].tolist() == [-0.088884, -0.073808, -0.002516]
    assert lat.offsets[0, 0, 1].tolist() == [-0.018505, -0.155581, -0.004782]
    assert lat.offsets[0, 1, 0].tolist() == [-0.217379, -0.024792, -0.001119]
    assert lat.offsets[1, 0, 0].tolist() == [-0.191950, -0.152277, -0.006144]
    assert lat.metadata["placement"] == {"qf": -1.0, "qb": 0.0, "qc": 1.0, "qd": 0.0, "qx": 90.0, "qy": -126.0,
                                         "qz": -72.0}  # fmt: skip
    assert lat.metadata["one_to_one"] == 1
    # NIfTI qform: R = 180 degrees about y, then qf = -1 flips k: the lattice's x axis points to -x
    assert lat.origin.tolist() == [90.0, -126.0, -72.0]
    assert lat.rotation.tolist() == [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    # a head-sized box: 200 x 220 x 200 mm
    assert (np.ptp(lat.control_points().reshape(-1, 3), axis=0)).tolist() == [200.0, 220.0, 200.0]
    # sub-millimetre offsets on a 20 mm grid: world units, not multiples of the spacing
    assert 0 < np.abs(lat.offsets).max() < 1.0


def test_real_file_round_trip_is_identical(real_ffd, tmp_path):
    lat = load_ffd(real_ffd)
    save_ffd(tmp_path / "copy.ffd", lat)
    back = load_ffd(tmp_path / "copy.ffd")
    assert back == lat
    assert back.metadata == lat.metadata
    save_ffd(tmp_path / "copy2.ffd", back)
    assert (tmp_path / "copy2.ffd").read_bytes() == (tmp_path / "copy.ffd").read_bytes()


def test_documented_example(tmp_path):
    lat = load_ffd(write(tmp_path, TINY))
    assert lat.offsets[0, 0, 1].tolist() == [0, 0, 0.5]
    assert lat.offsets[1, 0, 0].tolist() == [1.5, 0, 0]
    assert lat.offsets[1, 1, 1].tolist() == [0, -2, 0]
    assert np.count_nonzero(lat.offsets) == 3


def test_variants_in_the_wild(tmp_path):
    """CRLF, no trailing tabs, indented spacing, loose header names, no block separators."""
    expected = load_ffd(write(tmp_path, TINY))
    variant = (
        TINY.replace("\t\n", "\n")
        .replace("#offsets of the control points#", "# Offsets of the Control Points #")
        .replace("#control grid spacing#\n1\n1\n1", "#Control Grid Spacing#\n      1.000000\n   1.0\n 1")
        .replace("\t\n\n1.5", "\t\n1.5")
    )
    for newline in ("\n", "\r\n"):
        assert load_ffd(write(tmp_path, variant, newline=newline)) == expected


def test_file_without_quaternion_rests_at_origin_and_saves_without(tmp_path):
    lat = load_ffd(write(tmp_path, TINY))
    assert lat.metadata["placement"] is None
    assert lat.origin.tolist() == [0, 0, 0] and np.array_equal(lat.rotation, np.eye(3))
    save_ffd(tmp_path / "out.ffd", lat)
    assert "quaternion" not in (tmp_path / "out.ffd").read_text()
    save_ffd(tmp_path / "forced.ffd", lat, placement=True)
    assert load_ffd(tmp_path / "forced.ffd").metadata["placement"]["qf"] == 1.0


def test_moved_lattice_writes_its_placement(tmp_path):
    rotation = quaternion_to_rotation(-1.0, 0.5, 0.5, 0.5)
    lat = Lattice((3, 4, 2), (2.0, 1.0, 0.5), origin=(1.0, -2.0, 3.5), rotation=rotation)
    lat.offsets[...] = np.random.default_rng(1).normal(size=lat.offsets.shape)
    save_ffd(tmp_path / "moved.ffd", lat)
    back = load_ffd(tmp_path / "moved.ffd")
    assert back.origin.tolist() == [1.0, -2.0, 3.5]
    assert np.linalg.det(back.rotation) < 0
    np.testing.assert_allclose(back.rotation, rotation, atol=1e-15)
    np.testing.assert_array_equal(back.offsets, lat.offsets)
    # the quaternion values are now metadata: a second cycle is bit-identical
    save_ffd(tmp_path / "again.ffd", back)
    assert load_ffd(tmp_path / "again.ffd") == back


def test_edited_placement_is_recomputed(real_ffd, tmp_path):
    lat = load_ffd(real_ffd)
    lat.origin = lat.origin + (1.0, 0.0, 0.0)
    lat.rotation = np.eye(3)
    save_ffd(tmp_path / "edited.ffd", lat)
    back = load_ffd(tmp_path / "edited.ffd")
    assert back.origin.tolist() == [91.0, -126.0, -72.0]
    assert np.array_equal(back.rotation, np.eye(3))


def test_quaternion_matches_nifti_formula():
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        if q[0] < 0:
            q = -q
        _, b, c, d = q
        qf = rng.choice([-1.0, 1.0])
        rot = quaternion_to_rotation(qf, b, c, d)
        assert np.allclose(rot.T @ rot, np.eye(3)) and np.isclose(np.linalg.det(rot), qf)
        # a point (i, j, k) rests at R @ (i sx, j sy, qf k sz) + offset, R the rotation of (a, b, c, d)
        r = rot @ np.diag([1.0, 1.0, qf])
        v = rng.normal(size=3)
        rotated = _quat_rotate(q, v)
        np.testing.assert_allclose(r @ v, rotated, atol=1e-12)
        np.testing.assert_allclose(rotation_to_quaternion(rot), (qf, b, c, d), atol=1e-12)


def _quat_rotate(q, v):
    """Rotate v by the unit quaternion q = (a, b, c, d) as q v q*."""
    a, u = q[0], np.asarray(q[1:])
    return v + 2 * a * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def test_unknown_sections_are_kept_in_order(tmp_path):
    text = TINY.replace("#control grid size#", "#made by#\nstudent tool v2\n\n#control grid size#") + (
        "#comment#\nfirst\nsecond\n#quaternion qf,qb,qc,qd,qx,qy,qz#\n1\t0\t0\t0\t5\t6\t7\n#trailer#\nx\n"
    )
    lat = load_ffd(write(tmp_path, text))
    extra = lat.metadata["ffd_extra_sections"]
    assert [(s["header"], s["after"], s["lines"]) for s in extra] == [
        ("made by", "one to one", ["student tool v2"]),
        ("comment", "offsets", ["first", "second"]),
        ("trailer", "quaternion", ["x"]),
    ]
    save_ffd(tmp_path / "out.ffd", lat)
    headers = [line for line in (tmp_path / "out.ffd").read_text().splitlines() if line.startswith("#")]
    assert headers == ["#dimension#", "#one to one#", "#made by#", "#control grid size#", "#control grid spacing#",
                       "#offsets of the control points#", "#comment#", "#quaternion qf,qb,qc,qd,qx,qy,qz#",
                       "#trailer#"]  # fmt: skip
    back = load_ffd(tmp_path / "out.ffd")
    assert back == lat and back.metadata == lat.metadata


def test_one_to_one_value_is_kept(tmp_path):
    lat = load_ffd(write(tmp_path, TINY.replace("#one to one#\n1", "#one to one#\n0")))
    save_ffd(tmp_path / "out.ffd", lat)
    assert load_ffd(tmp_path / "out.ffd").metadata["one_to_one"] == 0
    save_ffd(tmp_path / "fresh.ffd", Lattice((2, 2, 2), 1.0))
    assert load_ffd(tmp_path / "fresh.ffd").metadata["one_to_one"] == 1


def test_place_at_mesh_minimum(real_ffd, shared_data):
    from ffd_notebook.io import read_obj

    mesh = read_obj(shared_data / "seed-lineage" / "teapot.obj")
    lat = place_at_mesh_minimum(load_ffd(real_ffd), mesh)
    assert lat.origin.tolist() == np.asarray(mesh.points).min(axis=0).tolist()
    assert np.array_equal(lat.rotation, np.eye(3)) and lat.spacing.tolist() == [20.0] * 3
    assert lat.metadata["placement"] is None
    assert lat.control_points()[0, 0, 0].tolist() == list(mesh.bounds[::2])
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        place_at_mesh_minimum(lat, np.zeros((0, 3)))
    with pytest.raises(ValueError, match="NaN"):
        place_at_mesh_minimum(lat, [[0.0, np.nan, 0.0]])


def test_save_is_atomic(real_ffd, tmp_path, monkeypatch):
    target = tmp_path / "keep.ffd"
    save_ffd(target, Lattice((2, 2, 2), 1.0))
    before = target.read_bytes()

    def failing_rows(offsets):
        yield "0.0 0.0 0.0\t"  # part of the file is written, then the disk "fills up"
        raise OSError("No space left on device")

    monkeypatch.setattr(ffd_file, "_offset_lines", failing_rows)
    with pytest.raises(OSError, match="No space"):
        save_ffd(target, load_ffd(real_ffd))
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == ["keep.ffd"]  # no temporary file left behind


def test_save_refuses_nan_offsets(tmp_path):
    lat = Lattice((2, 2, 2), 1.0)
    lat.offsets[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        save_ffd(tmp_path / "nan.ffd", lat)
    assert not list(tmp_path.iterdir())


BAD = [
    # (what is wrong, file text, expected line, words of the message)
    ("empty file", "", 1, "no sections"),
    ("an OBJ file", "####\n# Object\nv 1 2 3\nf 1 1 1\n", 1, "not a .ffd file"),
    ("text before the first header", "hello\n" + TINY, 1, "section header"),
    ("missing offsets", TINY.split("#offsets")[0], 12, "missing section #offsets of the control points#"),
    ("missing size", TINY.replace("#control grid size#\n2\n2\n2\n", ""), 15, "missing section #control grid size#"),
    ("two sizes only", TINY.replace("#control grid size#\n2\n2\n2", "#control grid size#\n2\n2"), 7, "nx, ny, nz"),
    ("size not an integer", TINY.replace("#control grid size#\n2", "#control grid size#\n2.5"), 6, "nx"),
    ("size of 1", TINY.replace("#control grid size#\n2", "#control grid size#\n1"), 8, "at least 2"),
    ("spacing not a number", TINY.replace("spacing#\n1", "spacing#\nabc"), 10, "sx"),
    ("NaN spacing", TINY.replace("spacing#\n1", "spacing#\nnan"), 10, "finite"),
    ("negative spacing", TINY.replace("spacing#\n1", "spacing#\n-1"), 12, "positive"),
    ("dimension 2", TINY.replace("#dimension#\n3", "#dimension#\n2"), 2, "dimension 3"),
    ("NaN offset", TINY.replace("0 0 0.5", "0 0 nan"), 14, "finite"),
    ("offset not a number", TINY.replace("0 0 0.5", "0 0 x"), 14, "offset of control point (0, 0, 1)"),
    ("two numbers in an entry", TINY.replace("0 0 0.5", "0 0.5"), 14, "'dx dy dz' for control point (0, 0, 1)"),
    ("entry missing", TINY.replace("0 0 0\t0 0 0.5\t\n", "0 0 0\t\n"), 14, "nz=2 entries"),
    ("line missing in a block", TINY.replace("0 0 0\t0 0 0\t\n\n1.5", "\n1.5"), 14, "ny=2"),
    ("extra block", TINY + "0 0 0\t0 0 0\t\n0 0 0\t0 0 0\t\n", 20, "nx=2 blocks"),
    ("truncated after a block", TINY[:-30], 15, "nx=2 blocks"),
    ("truncated mid-block", TINY[:-16], 17, "block 2 of the offsets (x index 1) has 1 lines, expected ny=2"),
    ("duplicate section", TINY + "#dimension#\n3\n", 20, "appears twice"),
    ("empty header", TINY.replace("#one to one#", "##"), 3, "empty section header"),
    ("quaternion with 6 values", TINY + "#quaternion qf,qb,qc,qd,qx,qy,qz#\n1\t0\t0\t0\t1\t2\n", 21, "qz"),
    ("quaternion not unit", TINY + "#quaternion qf,qb,qc,qd,qx,qy,qz#\n1\t3\t0\t0\t1\t2\t3\n", 21, "unit quaternion"),
]


@pytest.mark.parametrize(("text", "line", "words"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_malformed_files_name_file_and_line(tmp_path, text, line, words):
    path = write(tmp_path, text, name="bad.ffd")
    with pytest.raises(FileFormatError) as info:
        load_ffd(path)
    assert info.value.path == str(path)
    assert info.value.line == line, str(info.value)
    assert words in info.value.problem
    assert str(path) in str(info.value) and f"line {line}" in str(info.value)


def test_binary_junk_is_a_file_format_error(tmp_path):
    path = tmp_path / "junk.ffd"
    path.write_bytes(TINY.encode()[:40] + bytes(range(128, 256)))
    with pytest.raises(FileFormatError, match="line 5: not UTF-8"):
        load_ffd(path)


def test_missing_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_ffd(tmp_path / "nope.ffd")


def test_near_half_turn_follows_nifti_precision(tmp_path):
    """The file stores b, c, d (not a): near a half turn a is recovered poorly; NIfTI snaps a^2 < 1e-7 to 0."""
    from scipy.spatial.transform import Rotation

    for angle_gap, tolerance in ((1e-2, 1e-13), (1e-5, 2e-5)):
        rotation = Rotation.from_rotvec((np.pi - angle_gap) * np.array([0.0, 0.6, 0.8])).as_matrix()
        lat = Lattice((2, 2, 2), 1.0, rotation=rotation)
        save_ffd(tmp_path / "turn.ffd", lat)
        back = load_ffd(tmp_path / "turn.ffd")
        np.testing.assert_allclose(back.rotation, rotation, rtol=0, atol=tolerance)
        assert np.allclose(back.rotation.T @ back.rotation, np.eye(3), atol=1e-15)
