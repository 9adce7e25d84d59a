"""Blender's options in files: .ffd records the per-axis interpolation, "outside" mode and strength in
sections of their own (older files load as before); ITK and PyGeM writers write what they can hold
exactly (a strength and "outside" mode are offsets) and refuse the rest with the reason."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.ffd.interpolation import LATTICE_INTERPOLATIONS
from ffd_notebook.io import load_deformation, load_ffd, save_deformation, save_ffd

TINY = (
    "#dimension#\n3\n#one to one#\n1\n#control grid size#\n2\n2\n2\n#control grid spacing#\n1\n1\n1\n"
    "#offsets of the control points#\n0 0 0\t0 0 0.5\t\n0 0 0\t0 0 0\t\n\n1.5 0 0\t0 0 0\t\n0 0 0\t0 -2 0\t\n\n"
)


def _ffd(rng, basis, *, border="clamp", outside=False, strength=1.0):
    lat = Lattice(tuple(int(n) for n in rng.integers(4, 7, 3)), rng.uniform(0.5, 2, 3), rng.normal(size=3))
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * 0.2
    return FFD(lat, basis=basis, border=border, outside=outside, strength=strength)


def _points(ffd, rng, n=60):
    return ffd.lattice.to_world(rng.uniform(-1.5, np.array(ffd.lattice.shape) + 0.5, size=(n, 3)))


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    basis=st.tuples(*[st.sampled_from(LATTICE_INTERPOLATIONS)] * 3),
    outside=st.booleans(),
    strength=st.floats(-2, 2, allow_nan=False),
    border=st.sampled_from(["zero", "clamp"]),
)
def test_options_round_trip_through_ffd_files(tmp_path_factory, seed, basis, outside, strength, border):
    rng = np.random.default_rng(seed)
    ffd = _ffd(rng, basis, border=border, outside=outside, strength=strength)
    path = tmp_path_factory.mktemp("options") / "lattice.ffd"
    save_deformation(path, ffd)
    back = load_deformation(path)
    assert (back.basis, back.outside, back.strength, back.border) == (ffd.basis, outside, strength, border)
    pts = _points(ffd, rng)
    np.testing.assert_array_equal(back.deform(pts), ffd.deform(pts))
    # the lattice-level reader and writer keep the sections
    lattice = load_ffd(path)
    save_ffd(path, lattice)
    assert load_deformation(path).basis == ffd.basis


def test_default_options_add_no_section_and_old_files_load_as_bspline(tmp_path):
    path = tmp_path / "tiny.ffd"
    path.write_text(TINY)
    assert "ffd_options" not in load_ffd(path).metadata
    old = tmp_path / "old.ffd"
    save_ffd(old, Lattice((4, 4, 4), 1.0, border="clamp"))  # what the writer made before these options
    ffd = load_deformation(old)
    assert (ffd.basis, ffd.outside, ffd.strength, ffd.border) == ("bspline", False, 1.0, "clamp")
    save_deformation(path, ffd)
    assert path.read_text() == old.read_text()


def test_sections_are_written_as_documented(tmp_path):
    ffd = _ffd(np.random.default_rng(1), ("bspline", "catmull-rom", "linear"), outside=True, strength=0.25)
    path = tmp_path / "blender.ffd"
    save_deformation(path, ffd)
    text = path.read_text()
    assert "#interpolation#\nbspline\ncatmull-rom\nlinear\n#outside#\ntrue\n#strength#\n0.25\n" in text


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ("#interpolation#\nbspline linear\n", "three words"),
        ("#interpolation#\nbspline cubic linear\n", "three words"),
        ("#outside#\nmaybe\n", "'true' or 'false'"),
        ("#strength#\nstrong\n", "strength"),
        ("#strength#\n1 2\n", "1 numbers"),
    ],
)
def test_bad_option_sections_name_the_file_and_line(tmp_path, section, message):
    path = tmp_path / "bad.ffd"
    path.write_text(TINY + section)
    with pytest.raises(FileFormatError, match=rf"bad\.ffd.*line 2\d.*{message}"):
        load_ffd(path)


def test_itk_writes_strength_and_outside_as_offsets_and_refuses_interpolations(tmp_path):
    sitk = pytest.importorskip("SimpleITK")
    rng = np.random.default_rng(3)
    ffd = _ffd(rng, "bspline", border="zero", outside=True, strength=0.6)
    path = tmp_path / "warp.tfm"
    save_deformation(path, ffd)
    transform = sitk.ReadTransform(str(path))
    pts = _points(ffd, rng, 30)
    theirs = np.array([transform.TransformPoint(p.tolist()) for p in pts])
    np.testing.assert_allclose(theirs, ffd.deform(pts), atol=1e-9)
    per_axis = _ffd(rng, ("bspline", "linear", "bspline"), border="zero")
    with pytest.raises(ValueError, match=r"warp2\.tfm.*'linear'.*no ITK transform"):
        save_deformation(tmp_path / "warp2.tfm", per_axis)


def test_writers_refuse_per_point_weights_and_prm_per_axis(tmp_path):
    rng = np.random.default_rng(4)
    ffd = _ffd(rng, ("linear", "linear", "linear"))
    ffd.weights = np.ones(10)
    for name in ("a.ffd", "a.tfm", "a.prm"):
        with pytest.raises(ValueError, match="per-point weights"):
            save_deformation(tmp_path / name, ffd)
    ffd.weights = None
    with pytest.raises(ValueError, match=r"a\.prm.*Bernstein"):
        save_deformation(tmp_path / "a.prm", ffd)


def test_prm_writes_strength_as_offsets(tmp_path):
    rng = np.random.default_rng(5)
    lat = Lattice((3, 4, 3), 1.0)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * 0.1
    ffd = FFD(lat, "bernstein", only_inside=True, strength=-0.5)
    save_deformation(tmp_path / "box.prm", ffd)
    pts = rng.uniform(0, 2, size=(40, 3))
    np.testing.assert_allclose(load_deformation(tmp_path / "box.prm").deform(pts), ffd.deform(pts), atol=1e-12)


def test_elastix_writes_strength_and_outside_as_offsets_and_refuses_weights(tmp_path):
    rng = np.random.default_rng(6)
    ffd = _ffd(rng, "bspline", border="zero", outside=True, strength=-0.7)
    path = tmp_path / "TransformParameters.0.txt"
    save_deformation(path, ffd, format="elastix")
    back = load_deformation(path)
    assert back.strength == 1.0 and not back.outside
    pts = _points(ffd, rng)
    np.testing.assert_allclose(back.deform(pts), ffd.deform(pts), atol=1e-9)
    ffd.weights = rng.random(12)
    with pytest.raises(ValueError, match="per-point weights"):
        save_deformation(path, ffd, format="elastix")
    per_axis = _ffd(rng, ("catmull-rom", "bspline", "bspline"), border="zero")
    with pytest.raises(ValueError, match=r"elastix file cannot hold this FFD exactly.*catmull-rom"):
        save_deformation(tmp_path / "b.txt", per_axis, format="elastix")
