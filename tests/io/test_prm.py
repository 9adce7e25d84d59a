"""PyGeM .prm files: PyGeM's own test data reproduced, round trips, bad files named by line."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice, load_prm, save_prm
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io.prm import rotation_from_angles

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture
def pygem(shared_data):
    return shared_data / "pygem"


def test_sphere_as_pygem_deforms_it(pygem):
    """PyGeM's tests/test_ffd.py: this file on meshpoints_sphere_orig gives meshpoints_sphere_mod."""
    lattice = load_prm(pygem / "parameters_test_ffd_sphere.prm")
    assert lattice.shape == (3, 2, 2)
    original = np.load(pygem / "meshpoints_sphere_orig.npy")
    expected = np.load(pygem / "meshpoints_sphere_mod.npy")
    ffd = FFD(lattice, "bernstein", only_inside=True)
    np.testing.assert_allclose(ffd.deform(original), expected, rtol=0, atol=1e-10)
    np.testing.assert_allclose(ffd.bind(original, dtype=np.float64).update(), expected, rtol=0, atol=1e-10)
    outside = np.all(expected == original, axis=1)
    assert outside.any() and not outside.all()  # some points are outside the box and stay, the others move
    # without the option the points outside the box move too: PyGeM's result needs it
    assert np.abs(FFD(lattice, "bernstein").deform(original) - expected).max() > 1.0


def test_box_values(pygem):
    lattice = load_prm(pygem / "parameters_test_ffd_sphere.prm")
    np.testing.assert_array_equal(lattice.origin, [-20.0, -55.0, -45.0])
    np.testing.assert_array_equal(lattice.spacing, [45.0 / 2, 90.0, 90.0])
    stored = lattice.metadata["prm"]
    np.testing.assert_array_equal(stored["rotation_angles"], [0.0, 10.0, 15.0])
    assert stored["weights"][2, 0, 0].tolist() == [0.8, -0.5, -1.0]
    # control point (2, 0, 0) moves by R @ (weight * box length)
    np.testing.assert_allclose(lattice.offsets[2, 0, 0], lattice.rotation @ ([0.8, -0.5, -1.0] * stored["box_length"]))
    np.testing.assert_allclose(lattice.rotation, Rotation.from_euler("XYZ", [0, 10, 15], degrees=True).as_matrix())


@pytest.mark.parametrize(
    "name",
    [
        "parameters_sphere.prm",
        "parameters_test_ffd_identity.prm",
        "parameters_test_ffd_pipe_unv_C0.prm",
        "parameters_test_ffd_sphere.prm",
    ],
)
def test_every_pygem_file_loads_and_round_trips(tmp_path, pygem, name):
    lattice = load_prm(pygem / name)
    path = tmp_path / name
    save_prm(path, lattice)
    back = load_prm(path)
    assert back == lattice
    for key in ("box_length", "rotation_angles", "weights"):
        np.testing.assert_array_equal(back.metadata["prm"][key], lattice.metadata["prm"][key])


def test_identity_file_moves_nothing(pygem):
    lattice = load_prm(pygem / "parameters_test_ffd_identity.prm")
    assert not lattice.offsets.any()


@st.composite
def lattices(draw):
    shape = tuple(draw(st.lists(st.integers(2, 5), min_size=3, max_size=3)))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    rotation = Rotation.random(random_state=rng).as_matrix()
    lattice = Lattice(shape, rng.uniform(0.01, 100, 3), rng.normal(size=3) * 100, rotation)
    lattice.offsets[...] = rng.normal(size=lattice.offsets.shape) * 10
    return lattice


@SETTINGS
@given(lattices())
def test_any_lattice_round_trips(tmp_path, lattice):
    path = tmp_path / "random.prm"
    save_prm(path, lattice)
    back = load_prm(path)
    assert back.shape == lattice.shape
    for name in ("spacing", "origin", "rotation", "offsets"):
        a, b = getattr(back, name), getattr(lattice, name)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max()))
    save_prm(path, back)  # once read, the file's own values are kept: the cycle is exact
    assert load_prm(path) == back


def test_rotation_matches_pygem_order():
    angles = np.array([20.3, 11.0, -7.5])
    expected = Rotation.from_euler("XYZ", angles, degrees=True).as_matrix()  # Rx @ Ry @ Rz
    np.testing.assert_allclose(rotation_from_angles(angles), expected, rtol=0, atol=1e-15)


def test_save_refuses_reflection_and_keeps_old_file(tmp_path):
    path = tmp_path / "box.prm"
    path.write_text("old")
    with pytest.raises(ValueError, match="reflection"):
        save_prm(path, Lattice((2, 2, 2), 1.0, rotation=np.diag([1.0, 1.0, -1.0])))
    assert path.read_text() == "old"
    assert os.listdir(tmp_path) == ["box.prm"]


GOOD = (
    "[Box info]\nn control points x: 2\nn control points y: 2\nn control points z: 2\n"
    "box length x: 1\nbox length y: 1\nbox length z: 1\nbox origin x: 0\nbox origin y: 0\nbox origin z: 0\n"
    "rotation angle x: 0\nrotation angle y: 0\nrotation angle z: 0\n"
    "[Parameters weights]\nparameter x: 1 1 1 0.5\n             0 0 0 -.25\nparameter y:\nparameter z: 0 1 0 1e-3\n"
)


def test_small_file_with_missing_weight_lines(tmp_path):
    path = tmp_path / "small.prm"
    path.write_text(GOOD.replace("\n", "\r\n"))
    lattice = load_prm(path)
    expected = np.zeros((2, 2, 2, 3))
    expected[1, 1, 1, 0], expected[0, 0, 0, 0], expected[0, 1, 0, 2] = 0.5, -0.25, 1e-3
    np.testing.assert_array_equal(lattice.offsets, expected)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        (GOOD.replace("n control points y: 2\n", ""), r"line 1: missing 'n control points y' in \[box info\]"),
        (GOOD.replace("n control points y: 2", "n control points y: 1"), r"line 3: expected at least 2 control"),
        (GOOD.replace("box length z: 1", "box length z: -1"), r"line 7: expected a positive box length z"),
        (GOOD.replace("box origin x: 0", "box origin x: nan"), r"line 8: expected box origin x \(a finite number\)"),
        (GOOD.replace("box origin x: 0", "box origin x: 0 1"), r"line 8: expected one number after 'box origin x'"),
        (GOOD.replace("1 1 1 0.5", "1 1 2 0.5"), r"line 15: control point \(1, 1, 2\) is outside the \(2, 2, 2\)"),
        (
            GOOD.replace("0 0 0 -.25", "1 1 1 -.25"),
            r"line 16: control point \(1, 1, 1\) given twice \(first on "
            "line 15",
        ),
        (GOOD.replace("0 0 0 -.25", "0 0 0"), r"line 16: expected 'i j k weight' \(4 numbers\)"),
        (GOOD.replace("0 0 0 -.25", "0 0.5 0 1"), r"line 16: expected the y index \(an integer\)"),
        (GOOD.replace("parameter y:\n", ""), r"line 14: missing 'parameter y' in \[parameters weights\]"),
        (GOOD + "parameter z: 0 0 1 1\n", r"line 19: 'parameter z' given twice \(first on line 18\)"),
        ("n control points x: 2\n", r"line 1: expected a section header like \[Box info\]"),
        ("[Box info\n", r"line 1: expected a section header like \[Box info\], got '\[Box info'"),
        (GOOD.replace("n control points x: 2", "n control points x: 2000000"), r"line 4: \(2000000, 2, 2\) is more"),
    ],
)
def test_bad_files(tmp_path, text, problem):
    path = tmp_path / "bad.prm"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=r"bad.prm, " + problem):
        load_prm(path)
