"""ITK transform files against SimpleITK itself: what we write it applies identically, what it writes we read."""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest
import SimpleITK as sitk
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice, load_ffd, load_transform, save_transform
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io.itk_text import HEADER

TOL = 1e-9
SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def sitk_apply(path, points: np.ndarray) -> np.ndarray:
    tx = sitk.ReadTransform(os.fspath(path))
    return np.array([tx.TransformPoint(p) for p in points.tolist()])


def around(lattice: Lattice, rng, n: int = 400, reach: float = 4.0) -> np.ndarray:
    """Random points in the lattice's box grown by ``reach`` spacings all round (inside and outside)."""
    lo = -reach * np.ones(3)
    hi = np.array(lattice.shape) - 1 + reach
    return lattice.to_world(lo + rng.random((n, 3)) * (hi - lo))


def random_ffd(seed: int, reflect: bool, with_affine: bool, only_inside: bool = False) -> FFD:
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(random_state=seed).as_matrix()
    if reflect:
        rotation = rotation @ np.diag([1.0, -1.0, 1.0])
    lat = Lattice(tuple(rng.integers(4, 8, 3)), rng.uniform(0.3, 4.0, 3), rng.normal(size=3) * 10, rotation)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * lat.spacing.min()
    affine = None
    if with_affine:
        affine = np.eye(4)
        affine[:3, :3] += 0.3 * rng.normal(size=(3, 3))
        affine[:3, 3] = rng.normal(size=3) * 5
    return FFD(lat, affine=affine, only_inside=only_inside)


@SETTINGS
@given(
    seed=st.integers(0, 2**32 - 1),
    reflect=st.booleans(),
    with_affine=st.booleans(),
    only_inside=st.booleans(),
    suffix=st.sampled_from([".tfm", ".h5", ".txt"]),
)
def test_simpleitk_applies_what_we_write(tmp_path, seed, reflect, with_affine, only_inside, suffix):
    ffd = random_ffd(seed, reflect, with_affine, only_inside)
    path = tmp_path / f"warp{suffix}"
    save_transform(path, ffd)
    points = around(ffd.lattice, np.random.default_rng(seed))
    expected = ffd.deform(points)
    np.testing.assert_allclose(sitk_apply(path, points), expected, rtol=0, atol=TOL * max(1, abs(expected).max()))
    back = load_transform(path)
    np.testing.assert_allclose(back.deform(points), expected, rtol=0, atol=TOL * max(1, abs(expected).max()))
    assert back.only_inside == only_inside
    assert back.lattice.shape == ffd.lattice.shape


def test_real_ffd_to_tfm(tmp_path, shared_data):
    lattice = load_ffd(shared_data / "seed-lineage" / "registration_11x12x11.FFD")
    assert np.linalg.det(lattice.rotation) < 0  # the real file's lattice is reflected
    ffd = FFD(lattice)
    path = tmp_path / "registration.tfm"
    save_transform(path, ffd)
    points = around(lattice, np.random.default_rng(1), n=3000, reach=3.0)
    expected = ffd.deform(points)
    assert np.abs(expected - points).max() > 0.1  # the points do move
    np.testing.assert_allclose(sitk_apply(path, points), expected, rtol=0, atol=TOL)
    back = load_transform(path)
    assert back.lattice.shape == lattice.shape and not back.only_inside
    np.testing.assert_array_equal(back.lattice.offsets, lattice.offsets)
    np.testing.assert_allclose(back.lattice.origin, lattice.origin, rtol=0, atol=1e-12)


def sitk_bspline(rng, mesh=(3, 4, 2), direction=None) -> sitk.BSplineTransform:
    image = sitk.Image([12, 10, 9], sitk.sitkFloat32)
    image.SetSpacing(rng.uniform(0.5, 3.0, 3).tolist())
    image.SetOrigin(rng.normal(size=3).tolist())
    if direction is not None:
        image.SetDirection(direction.ravel().tolist())
    tx = sitk.BSplineTransformInitializer(image, list(mesh), 3)
    tx.SetParameters(rng.normal(size=len(tx.GetParameters())).tolist())
    return tx


def sitk_affine(rng) -> sitk.AffineTransform:
    affine = sitk.AffineTransform(3)
    affine.SetMatrix((np.eye(3) + 0.2 * rng.normal(size=(3, 3))).ravel().tolist())
    affine.SetTranslation(rng.normal(size=3).tolist())
    affine.SetCenter(rng.normal(size=3).tolist())
    return affine


def check_read(tmp_path, transform, rng, suffix):
    path = tmp_path / f"sitk{suffix}"
    sitk.WriteTransform(transform, os.fspath(path))
    ffd = load_transform(path)
    points = around(ffd.lattice, rng, n=600, reach=3.0)
    expected = sitk_apply(path, points)
    np.testing.assert_allclose(ffd.deform(points), expected, rtol=0, atol=TOL * max(1, abs(expected).max()))
    return ffd, points, expected


# directions SimpleITK's initializer keeps exact (it rounds others to float32, see the next test)
DIRECTIONS = [np.eye(3), np.diag([1.0, -1.0, 1.0]), np.eye(3)[[1, 2, 0]], -np.eye(3)[[2, 1, 0]]]


@pytest.mark.parametrize("suffix", [".tfm", ".h5"])
@pytest.mark.parametrize("seed", range(4))
def test_read_simpleitk_bspline(tmp_path, suffix, seed):
    rng = np.random.default_rng(seed)
    ffd, points, expected = check_read(tmp_path, sitk_bspline(rng, direction=DIRECTIONS[seed]), rng, suffix)
    assert ffd.only_inside  # ITK leaves points outside its domain unmoved: so must we
    assert np.any(np.all(expected == points, axis=1)) and np.any(np.any(expected != points, axis=1))


def test_read_float32_rounded_direction(tmp_path):
    """A rotated image's grid direction comes out of SimpleITK rounded to float32: read as the nearest rotation."""
    rng = np.random.default_rng(7)
    path = tmp_path / "rotated.tfm"
    sitk.WriteTransform(sitk_bspline(rng, direction=Rotation.random(random_state=7).as_matrix()), os.fspath(path))
    ffd = load_transform(path)
    points = around(ffd.lattice, rng, n=600, reach=3.0)
    np.testing.assert_allclose(ffd.deform(points), sitk_apply(path, points), rtol=0, atol=1e-5)


@pytest.mark.parametrize("suffix", [".tfm", ".h5"])
@pytest.mark.parametrize("seed", range(3))
def test_read_simpleitk_composite_affine_after_bspline(tmp_path, suffix, seed):
    rng = np.random.default_rng(10 + seed)
    composite = sitk.CompositeTransform(3)
    composite.AddTransform(sitk_affine(rng))  # applied last
    composite.AddTransform(sitk_bspline(rng))
    ffd, _, _ = check_read(tmp_path, composite, rng, suffix)
    assert not np.array_equal(ffd.affine, np.eye(4))


@pytest.mark.parametrize("suffix", [".tfm", ".h5"])
def test_read_simpleitk_composite_rigid_before_bspline(tmp_path, suffix):
    rng = np.random.default_rng(20)
    rigid = sitk.AffineTransform(3)
    rigid.SetMatrix((Rotation.random(random_state=3).as_matrix() * 1.5).ravel().tolist())  # rotation and scale
    rigid.SetTranslation((1.0, -2.0, 0.5))
    composite = sitk.CompositeTransform(3)
    composite.AddTransform(sitk_affine(rng))
    composite.AddTransform(sitk_bspline(rng))
    composite.AddTransform(sitk.TranslationTransform(3, (0.5, 0.25, -1.0)))
    composite.AddTransform(rigid)  # applied first: the lattice absorbs it
    check_read(tmp_path, composite, rng, suffix)


def test_read_refuses_shearing_affine_before_bspline(tmp_path):
    rng = np.random.default_rng(21)
    composite = sitk.CompositeTransform(3)
    composite.AddTransform(sitk_bspline(rng))
    composite.AddTransform(sitk_affine(rng))
    path = tmp_path / "sheared.tfm"
    sitk.WriteTransform(composite, os.fspath(path))
    with pytest.raises(FileFormatError, match=r"sheared.tfm, line 5: the affine applied before the B-spline"):
        load_transform(path)


@pytest.mark.parametrize(
    ("transform", "problem"),
    [
        (sitk.Euler3DTransform(), r"line 3: unsupported transform type 'Euler3DTransform_double_3_3'"),
        (sitk.AffineTransform(3), r"line 3: expected exactly one BSplineTransform, found 0"),
    ],
)
def test_read_refuses_other_types(tmp_path, transform, problem):
    path = tmp_path / "other.tfm"
    sitk.WriteTransform(transform, os.fspath(path))
    with pytest.raises(FileFormatError, match=problem):
        load_transform(path)


def test_read_refuses_two_bsplines_in_hdf5(tmp_path):
    rng = np.random.default_rng(5)
    composite = sitk.CompositeTransform(3)
    composite.AddTransform(sitk_bspline(rng))
    composite.AddTransform(sitk_bspline(rng))
    path = tmp_path / "two.h5"
    sitk.WriteTransform(composite, os.fspath(path))
    with pytest.raises(FileFormatError, match=r"two.h5: HDF5 dataset /TransformGroup/2/TransformType: expected "
                       "exactly one BSplineTransform, found 2"):  # fmt: skip
        load_transform(path)


def test_writer_refuses_what_itk_cannot_hold(tmp_path):
    path = tmp_path / "keep.tfm"
    path.write_text("old")
    lat = Lattice((4, 4, 4), 1.0)
    with pytest.raises(ValueError, match=r"keep.tfm: an FFD with the 'bernstein' basis has no ITK transform"):
        save_transform(path, FFD(lat, "bernstein"))
    with pytest.raises(ValueError, match=r"border='clamp' has no ITK transform"):
        save_transform(path, FFD(lat, border="clamp"))
    with pytest.raises(ValueError, match=r"border='clamp' has no ITK transform"):  # the lattice's own rule
        save_transform(path, FFD(Lattice((4, 4, 4), 1.0, border="clamp")))
    with pytest.raises(ValueError, match="singular"):
        save_transform(path, FFD(lat, affine=np.diag([1.0, 0.0, 1.0, 1.0])))
    with pytest.raises(ValueError, match=r"unknown transform file extension '\.xfm'"):
        save_transform(tmp_path / "x.xfm", FFD(lat))
    with pytest.raises(ValueError, match=r"x.mat: an ITK .mat file holds one transform, not a composite"):
        save_transform(tmp_path / "x.mat", FFD(lat, affine=np.diag([2.0, 1.0, 1.0, 1.0])))
    assert path.read_text() == "old"  # refused before the file was touched
    assert sorted(os.listdir(tmp_path)) == ["keep.tfm"]  # and no temporary file left behind


GOOD = (
    f"{HEADER}\n#Transform 0\nTransform: BSplineTransform_double_3_3\nParameters: " + " ".join(["0"] * 192) + "\n"
    "FixedParameters: 4 4 4 0 0 0 1 1 1 1 0 0 0 1 0 0 0 1\n"
)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", r"line 1: expected the header line '#Insight Transform File V1.0'"),
        ("#Insight Transform File V2.0\n", r"line 1: expected the header line"),
        (f"{HEADER}\n", r"line 1: no 'Transform:' line"),
        (f"{HEADER}\nParameters: 1 2 3\n", r"line 2: 'Parameters:' before any 'Transform:' line"),
        (f"{HEADER}\nTransform:\n", r"line 2: expected a transform type"),
        (f"{HEADER}\nhello\n", r"line 2: expected 'Transform:', 'Parameters:' or 'FixedParameters:', got 'hello'"),
        (
            GOOD.replace("Parameters: 0 0", "Parameters: 0 nan"),
            r"line 4: expected a parameter \(a finite number\), "
            "got 'nan'",
        ),
        (GOOD + "Parameters: 1\n", r"line 6: second 'Parameters:' line for one transform \(the first is line 4\)"),
        (GOOD.replace(" 0 0\n", " 0\n", 1), r"line 4: a 4x4x4 grid has 192 parameters, got 191"),
        (GOOD.replace("4 4 4 0", "4 3 4 0"), r"line 5: expected a grid size of integers in 4..4096"),
        (GOOD.replace("4 4 4 0", "4 4.5 4 0"), r"line 5: expected a grid size of integers"),
        (GOOD.replace("1 1 1 1 0 0", "1 -1 1 1 0 0"), r"line 5: expected a positive grid spacing"),
        (
            GOOD.replace("1 0 0 0 1 0 0 0 1", "1 0.5 0 0 1 0 0 0 1"),
            r"line 5: the grid direction is not orthogonal "
            r"\(off by 0.5",
        ),
        (GOOD.replace("1 0 0 0 1\n", "1 0 0 0\n"), r"line 5: a 3D BSplineTransform has 18 fixed parameters"),
        (GOOD.replace("_double_3_3", "_double_2_2"), r"line 3: unsupported transform type"),
        (
            GOOD + "Transform: AffineTransform_double_3_3\nParameters: 1 0 0 0 1 0 0 0 1 0 0 0\n",
            r"line 6: 2 transforms side by side",
        ),
    ],
)
def test_bad_text_files(tmp_path, text, problem):
    path = tmp_path / "bad.tfm"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=r"bad.tfm, " + problem):
        load_transform(path)


def test_good_text_file_and_float_variant(tmp_path):
    path = tmp_path / "good.txt"
    path.write_text(GOOD.replace("_double_", "_float_").replace("\n", "\r\n"))
    ffd = load_transform(path)
    assert ffd.lattice.shape == (4, 4, 4) and ffd.only_inside


def rewrite_h5(path, dataset: str, value) -> None:
    with h5py.File(path, "r+") as f:
        del f[dataset]
        if value is not None:
            f[dataset] = value


@pytest.mark.parametrize(
    ("dataset", "value", "problem"),
    [
        ("/TransformGroup/0/TransformParameters", np.full(192, np.nan), "contains NaN"),
        ("/TransformGroup/0/TransformParameters", np.zeros((2, 96)), "expected a 1-D array of numbers"),
        ("/TransformGroup/0/TransformParameters", None, "missing; expected a 1-D array"),
        ("/TransformGroup/0/TransformFixedParameters", np.zeros(18), "expected a grid size of integers"),
        ("/TransformGroup/0/TransformType", np.array([1.0]), "expected one string"),
        ("/TransformGroup/0/TransformType", np.array([b"Euler3DTransform_double_3_3"]), "unsupported transform"),
        ("/TransformGroup/0", None, "/TransformGroup: missing|expected subgroups named 0, 1"),
    ],
)
def test_bad_hdf5_files(tmp_path, dataset, value, problem):
    path = tmp_path / "bad.h5"
    save_transform(path, FFD(Lattice((4, 4, 4), 1.0), only_inside=True))
    rewrite_h5(path, dataset, value)
    with pytest.raises(FileFormatError, match=rf"bad.h5: HDF5 dataset .*({problem})"):
        load_transform(path)


def test_not_hdf5(tmp_path):
    path = tmp_path / "text.h5"
    path.write_text(GOOD)
    with pytest.raises(FileFormatError, match=r"text.h5: not a readable HDF5 file"):
        load_transform(path)


@pytest.mark.parametrize("suffix", [".tfm", ".h5"])
def test_save_is_atomic(tmp_path, suffix, monkeypatch):
    path = tmp_path / f"warp{suffix}"
    ffd = FFD(Lattice((4, 4, 4), 1.0))
    save_transform(path, ffd)
    before = path.read_bytes()
    ffd.lattice.offsets[1, 1, 1] = 5.0

    def fail(*_args, **_kwargs):
        raise OSError("disk full")

    module = "ffd_notebook.io.itk.write_itk_text" if suffix == ".tfm" else "h5py.Group.create_dataset"
    monkeypatch.setattr(module, fail)
    with pytest.raises(OSError, match="disk full"):
        save_transform(path, ffd)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == [path.name]
