"""``warp_image`` beyond the ITK comparison: inputs, components, label maps, volumes, B-splines, errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import SimpleITK as sitk
from image_testing import awkward_grid, lattice_over, sitk_image, smooth_volume

import ffd_notebook as fn
from ffd_notebook import FFD, FileFormatError, Lattice, save_transform
from ffd_notebook.images import ImageGrid, read_image, read_image_information, warp_image, write_image


def test_public_from_the_package_root():
    assert fn.warp_image is warp_image


def test_array_file_and_sitk_image_agree(tmp_path):
    rng = np.random.default_rng(3)
    grid = awkward_grid((20, 16, 12))
    array = smooth_volume(grid.shape, rng)
    ffd = lattice_over(grid, (6, 6, 6), scale=2.5, rng=rng)
    path = tmp_path / "scan.nii.gz"
    write_image(path, sitk_image(array, grid))
    from_file = warp_image(path, ffd)
    from_sitk = warp_image(read_image(path), ffd)
    from_array = warp_image(array, ffd, spacing=grid.spacing, origin=grid.origin, direction=grid.direction)
    assert isinstance(from_file, sitk.Image) and isinstance(from_array, np.ndarray)
    np.testing.assert_array_equal(sitk.GetArrayFromImage(from_file), sitk.GetArrayFromImage(from_sitk))
    # NIfTI stores the geometry in float32: the file's grid differs from the array's by rounding only
    np.testing.assert_allclose(sitk.GetArrayFromImage(from_file), from_array, atol=1e-3 * np.ptp(array))
    # a reference given as a file: its header's grid
    on_file_grid = warp_image(array, ffd, reference=path, spacing=grid.spacing, origin=grid.origin)
    assert on_file_grid.shape == read_image_information(path).shape


@pytest.mark.parametrize("dim", [2, 3])
def test_multi_component_image_warps_each_component(tmp_path, dim):
    """An RGB image: each component as the scalar image alone would be, and as sitk.Resample does the vector image."""
    rng = np.random.default_rng(4)
    grid = awkward_grid((30, 24) if dim == 2 else (16, 14, 10))
    rgb = np.stack([smooth_volume(grid.shape, rng) for _ in range(3)], axis=-1).astype(np.uint8)
    ffd = lattice_over(grid, (6, 6, 6), scale=2.0, rng=rng)
    image = sitk_image(rgb, grid, vector=True)
    got = warp_image(image, ffd, interpolation="nearest")
    assert got.GetNumberOfComponentsPerPixel() == 3 and got.GetPixelID() == image.GetPixelID()
    got = sitk.GetArrayFromImage(got)
    for c in range(3):
        alone = warp_image(sitk_image(np.ascontiguousarray(rgb[..., c]), grid), ffd, interpolation="nearest")
        np.testing.assert_array_equal(got[..., c], sitk.GetArrayFromImage(alone))
    linear = warp_image(rgb, ffd, spacing=grid.spacing, origin=grid.origin, direction=grid.direction)
    assert linear.shape == rgb.shape and linear.dtype == np.uint8
    if dim == 3:
        save_transform(tmp_path / "t.tfm", ffd)
        expected = sitk.Resample(image, image, sitk.ReadTransform(str(tmp_path / "t.tfm")), sitk.sitkLinear, 0.0)
        # ITK truncates the interpolated value into uint8, warp_image rounds it: at most one grey level apart
        assert np.abs(linear.astype(int) - sitk.GetArrayFromImage(expected)).max() <= 1


def test_photo_array_with_components_needs_two_spacings():
    photo = np.zeros((40, 60, 3), dtype=np.uint8)
    photo[10:30, 20:40] = (255, 128, 0)
    lat = Lattice((5, 5, 4), spacing=20.0, origin=(-10.0, -10.0, -30.0))
    lat.offsets[2, 2, :, 0] = 6.0
    warped = warp_image(photo, FFD(lat), spacing=(1.0, 1.0))
    assert warped.shape == photo.shape
    orange = np.all(warped == (255, 128, 0), axis=-1)
    assert orange.sum() > 0.8 * 400 and not np.array_equal(warped, photo)
    # T(x) = x + d with d > 0 in x: every output pixel reads further right, so the rectangle moves left
    assert orange[20, 19] and not orange[20, 38], "background on the left turns orange, orange on the right goes"
    assert (warped[..., 2] == 0).all(), "a component that is zero everywhere stays zero"


def label_map(shape: tuple[int, ...]) -> np.ndarray:
    labels = np.zeros(shape, dtype=np.uint16)
    grids = np.meshgrid(*[np.arange(n, dtype=float) for n in shape], indexing="ij")
    for value, centre, radius in (
        (1, (0.3, 0.35, 0.5), 0.22),
        (7, (0.65, 0.6, 0.45), 0.25),
        (300, (0.3, 0.72, 0.72), 0.18),
    ):
        r2 = sum(((g - c * n) / (radius * n)) ** 2 for g, c, n in zip(grids, centre, shape, strict=True))
        labels[r2 < 1.0] = value
    return labels


def test_label_maps_stay_label_maps_and_volumes_follow_the_jacobian():
    """Nearest interpolation adds no label value; each label's volume changes by the mean det J over it.

    Pull-back: voxel x of the output has the label of T(x), so the input volume of a label is the
    integral of det J(x) over the output's label: ``input voxels ~ sum of det J over the output voxels``.
    (For labels a few voxels across, nearest-neighbour rounding biases the count by more than a few percent.)
    """
    grid = ImageGrid((64, 60, 56), spacing=(1.0, 1.1, 1.2), origin=(5.0, -3.0, 2.0))
    labels = label_map(grid.shape)
    lo, hi = grid.bounds()
    lat = Lattice.around(np.array([lo, hi]), shape=(6, 6, 6))
    centre = (np.array(lat.shape) - 1) / 2.0
    for index in np.ndindex(*lat.shape):  # push out from the middle: it swells, the sides are squeezed
        direction = (np.array(index) - centre) * lat.spacing
        lat.offsets[index] = 0.15 * direction * np.exp(-np.sum((np.array(index) - centre) ** 2) / 4.0)
    ffd = FFD(lat)
    warped = warp_image(labels, ffd, interpolation="nearest", spacing=grid.spacing, origin=grid.origin)
    assert warped.dtype == labels.dtype
    assert set(np.unique(warped).tolist()) <= set(np.unique(labels).tolist())
    det = ffd.jacobian_determinant(grid.physical_points()).reshape(grid.shape)
    assert det.max() > 1.15, "the deformation should change volumes visibly"
    for value in (1, 7, 300):
        before, after = np.count_nonzero(labels == value), np.count_nonzero(warped == value)
        predicted = det[warped == value].sum()
        assert abs(predicted - before) / before < 0.03, (value, before, after, predicted)
        assert abs(after - before) / before > 0.05, "each label's volume should change"


def test_bspline_interpolation_close_to_itk(tmp_path):
    rng = np.random.default_rng(5)
    grid = awkward_grid((24, 20, 14))
    array = smooth_volume(grid.shape, rng)
    image = sitk_image(array, grid)
    ffd = lattice_over(grid, (6, 6, 6), scale=2.0, rng=rng)
    save_transform(tmp_path / "t.tfm", ffd)
    expected = sitk.GetArrayFromImage(
        sitk.Resample(image, image, sitk.ReadTransform(str(tmp_path / "t.tfm")), sitk.sitkBSpline, 0.0)
    )
    got = sitk.GetArrayFromImage(warp_image(image, ffd, interpolation="bspline"))
    linear = sitk.GetArrayFromImage(warp_image(image, ffd))
    inside = expected != 0
    assert ((got != 0) == inside).mean() > 0.999
    error = np.abs(got - expected)[inside]
    # ITK's B-spline coefficients come from a recursive filter with a truncated start: close, not equal
    assert np.median(error) < 1e-3 * np.ptp(array) and error.max() < 2e-2 * np.ptp(array)
    assert np.abs(linear - expected)[inside].max() > 10 * np.median(error)


def test_bad_inputs_get_clear_errors(tmp_path):
    ffd = FFD(Lattice((4, 4, 4), 4.0, origin=(-4.0, -4.0, -4.0)))
    image = np.zeros((5, 6, 7), dtype=np.float32)
    with pytest.raises(ValueError, match="interpolation must be one of"):
        warp_image(image, ffd, interpolation="cubic")
    with pytest.raises(ValueError, match="a 2D image is an array of 2 axes"):
        warp_image(np.zeros((2, 3, 4, 5)), ffd, spacing=(1.0, 1.0))
    with pytest.raises(TypeError, match="deform"):
        warp_image(image, object())
    with pytest.raises(ValueError, match="returned shape"):
        warp_image(image, type("Flat", (), {"deform": lambda self, p: np.asarray(p)[:, :2]})())
    with pytest.raises(ValueError, match="for a NumPy array"):
        warp_image(sitk.GetImageFromArray(image), ffd, spacing=2.0)
    with pytest.raises(ValueError, match="spacing must be positive"):
        warp_image(image, ffd, spacing=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="reference grid is 2D"):
        warp_image(image, ffd, reference=ImageGrid((4, 4)))
    bad = tmp_path / "broken.nrrd"
    bad.write_bytes(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n" + b"\0" * 100)
    with pytest.raises(FileFormatError, match=r"broken\.nrrd"):
        warp_image(bad, ffd)
    with pytest.raises(FileNotFoundError):
        warp_image(tmp_path / "missing.nii", ffd)


def test_write_image_is_atomic(tmp_path):
    """A write that fails (PNG holds no 3D float image) leaves the previous file and no temporary one."""
    path = tmp_path / "out.png"
    write_image(path, sitk.GetImageFromArray(np.full((3, 4), 7, dtype=np.uint8)))
    with pytest.raises(ValueError, match=r"out\.png: SimpleITK cannot write"):
        write_image(path, sitk.Image([4, 4, 4], sitk.sitkFloat64))
    assert sitk.GetArrayFromImage(read_image(path)).tolist() == np.full((3, 4), 7).tolist()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]


class _NotANumberAt:
    """T(x) is NaN at the first voxel, +inf and -inf in x at the next two, beyond any index at the fourth."""

    def deform(self, points):
        out = np.array(points, dtype=np.float64)
        out[0] = np.nan
        out[1, 0], out[2, 0], out[3] = np.inf, -np.inf, 1e300
        return out


@pytest.mark.parametrize("dtype", [np.float32, np.uint8, np.int16])
@pytest.mark.parametrize("interpolation", ["nearest", "linear", "bspline"])
def test_positions_that_are_not_numbers_read_the_default_value(dtype, interpolation):
    """ITK's IsInsideBuffer is false for NaN: its default value, not a NaN pixel (or 0 and a cast warning)."""
    image = np.full((4, 5, 6), 7, dtype=dtype)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "invalid value encountered in cast"
        out = warp_image(image, _NotANumberAt(), interpolation=interpolation, default_value=3)
    assert out.reshape(-1)[:4].tolist() == [3, 3, 3, 3]
    assert (out.reshape(-1)[4:] == 7).all()
