"""Hostile .ffd and OBJ files (issue 8): every one is a FileFormatError naming the file and line."""

from __future__ import annotations

import numpy as np
import pytest

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_ffd, read_obj

TINY = (
    "#dimension#\n3\n#one to one#\n1\n#control grid size#\n2\n2\n2\n#control grid spacing#\n1\n1\n1\n"
    "#offsets of the control points#\n0 0 0\t0 0 0.5\t\n0 0 0\t0 0 0\t\n\n1.5 0 0\t0 0 0\t\n0 0 0\t0 -2 0\t\n\n"
)
QUATERNION = "#quaternion qf,qb,qc,qd,qx,qy,qz#\n-1\t0\t1\t0\t90\t-126\t-72\n"


def _write(tmp_path, text: str, name: str = "bad.ffd"):
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def _fails_at(path, line: int, reader=load_ffd) -> FileFormatError:
    with pytest.raises(FileFormatError) as info:
        reader(path)
    assert info.value.path == str(path) and info.value.line == line, str(info.value)
    assert str(path) in str(info.value) and f"line {line}" in str(info.value)
    return info.value


def test_tiny_file_still_loads(tmp_path):
    lat = load_ffd(_write(tmp_path, TINY + QUATERNION, "ok.ffd"))
    assert lat.offsets[1, 1, 1].tolist() == [0.0, -2.0, 0.0] and lat.metadata["placement"]["qf"] == -1.0


@pytest.mark.parametrize(
    ("old", "new", "line"),
    [
        ("#dimension#\n3\n", "#dimension#\n" + "3" * 5000 + "\n", 2),  # plain ValueError (4300 digits) before
        ("#control grid size#\n2\n", "#control grid size#\n" + "2" * 5000 + "\n", 6),
        ("#control grid size#\n2\n", "#control grid size#\n\u0662\n", 6),  # Arabic-Indic two
        ("#control grid size#\n2\n", "#control grid size#\n\uff12\n", 6),  # full-width two
        ("#control grid spacing#\n1\n", "#control grid spacing#\n\uff11\n", 10),
        ("1.5 0 0\t", "\u0661.5 0 0\t", 17),
        ("1.5 0 0\t", "1.5\u00a00 0\t", 17),  # NBSP as separator
        ("1.5 0 0\t", "1.5\x0c0 0\t", 17),  # form feed as separator
        ("#one to one#\n1\n", "#one to one#\n1\x0b\n", 4),  # vertical tab after a number
        ("#control grid spacing#\n1\n", "#control grid spacing#\n1e-320\n", 12),  # subnormal: 1/spacing is inf
    ],
    ids=lambda v: v[:30].encode("unicode_escape").decode() if isinstance(v, str) else str(v),
)
def test_ffd_hostile_numbers(tmp_path, old, new, line):
    assert TINY.count(old) == 1
    _fails_at(_write(tmp_path, TINY.replace(old, new)), line)


def test_ffd_huge_spacing_never_gives_inf(tmp_path, shared_data):
    # the case: finite numbers, but control point 10 along x is at 10 * 1e308 = inf
    text = (shared_data / "seed-lineage" / "registration_11x12x11.FFD").read_text()
    assert text.count("      20.000000\n") == 3
    path = _write(tmp_path, text.replace("      20.000000\n", "1e308\n", 1))
    err = _fails_at(path, 12)
    assert "floating-point" in err.problem
    # two control points 1e308 apart are finite: that lattice loads, and its points are finite
    lat = load_ffd(_write(tmp_path, TINY.replace("#control grid spacing#\n1\n", "#control grid spacing#\n1e308\n")))
    assert np.isfinite(lat.control_points(deformed=True)).all()
    # ... but an offset of 1.7e308 on the control point at 1e308 is not
    _fails_at(_write(tmp_path, TINY.replace("#control grid spacing#\n1\n", "#control grid spacing#\n1e308\n")
                     .replace("1.5 0 0\t", "1.7e308 0 0\t")), 13)  # fmt: skip


@pytest.mark.parametrize("qf", ["0", "0.5", "2", "-0.999", "1.0000001"])
def test_quaternion_qfac_must_be_plus_or_minus_one(tmp_path, qf):
    err = _fails_at(_write(tmp_path, TINY + QUATERNION.replace("\n-1\t", f"\n{qf}\t")), 21)
    assert "qf" in err.problem


@pytest.mark.parametrize("qf", ["1", "-1", "1.000000", "-1.0"])
def test_quaternion_qfac_plus_or_minus_one_loads(tmp_path, qf):
    lat = load_ffd(_write(tmp_path, TINY + QUATERNION.replace("\n-1\t", f"\n{qf}\t"), "ok.ffd"))
    assert np.linalg.det(lat.rotation) == pytest.approx(float(qf))


OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


@pytest.mark.parametrize(
    "face",
    [
        "f 1 2 100000000000000000000",  # OverflowError before
        "f 1 2 " + "9" * 5000,  # plain ValueError (4300 digits) before
        "f 1 2 9223372036854775808",  # wrapped to a negative index before
        "f 1 2 -9223372036854775809",
        "f 1 2 18446744073709551619",
        "f 1 2 3/1/" + "7" * 5000,
        "f 1 2 \u0663",  # Arabic-Indic three
        "f 1 2\u00a03",
        "l 1 99999999999999999999999",
    ],
    ids=lambda v: v[:30].encode("unicode_escape").decode(),
)
def test_obj_hostile_indices(tmp_path, face):
    path = _write(tmp_path, OBJ + face + "\n", "bad.obj")
    _fails_at(path, 5, read_obj)


@pytest.mark.parametrize(
    "vertex",
    ["v 0 0 \uff10", "v 0\x0c0 0", "v 0 0 " + "1" * 5000, "v 0 0 0x10", "v 0 0 1e999", "v 0 0 nan"],
    ids=lambda v: v[:30].encode("unicode_escape").decode(),
)
def test_obj_hostile_vertices(tmp_path, vertex):
    path = _write(tmp_path, OBJ + vertex + "\n", "bad.obj")
    _fails_at(path, 5, read_obj)
