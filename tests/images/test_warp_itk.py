"""``warp_image`` against SimpleITK's ``Resample`` through the transform file ``save_transform`` writes."""

from __future__ import annotations

import numpy as np
import pytest
import SimpleITK as sitk
from image_testing import awkward_grid, lattice_over, sitk_image, smooth_volume

from ffd_notebook import FFD, Lattice, save_transform
from ffd_notebook.images import ImageGrid, warp_image
from ffd_notebook.images.sample import IndexSampler

ITK_INTERPOLATORS = {"linear": sitk.sitkLinear, "nearest": sitk.sitkNearestNeighbor}


def itk_resample(image: sitk.Image, ffd: FFD, path, reference: sitk.Image, interpolation: str, default: float):
    """``sitk.Resample`` through the file ``save_transform`` writes; a 2D image as a one-slice volume at z = 0."""
    save_transform(path, ffd)
    transform = sitk.ReadTransform(str(path))
    if image.GetDimension() == 3:
        return sitk.Resample(image, reference, transform, ITK_INTERPOLATORS[interpolation], default)
    volume, ref_volume = sitk.JoinSeries(image), sitk.JoinSeries(reference)
    for v, src in ((volume, image), (ref_volume, reference)):
        d = np.eye(3)
        d[:2, :2] = np.reshape(src.GetDirection(), (2, 2))
        v.SetDirection(d.ravel().tolist())
        v.SetOrigin((*src.GetOrigin(), 0.0))
    out = sitk.Resample(volume, ref_volume, transform, ITK_INTERPOLATORS[interpolation], default)
    return out[:, :, 0]


@pytest.mark.parametrize("aligned", [False, True], ids=["lattice-along-xyz", "lattice-along-image"])
@pytest.mark.parametrize("size", [(26, 21, 15), (40, 33)], ids=["3D", "2D"])
@pytest.mark.parametrize("interpolation", ["linear", "nearest"])
def test_equals_sitk_resample_with_saved_transform(tmp_path, size, interpolation, aligned):
    """Both ways of evaluating T: point by point (a lattice turned against the image) and separably (along it)."""
    rng = np.random.default_rng(len(size) * 10 + len(interpolation))
    grid = awkward_grid(size)
    array = smooth_volume(grid.shape, rng)
    image = sitk_image(array, grid)
    ffd = lattice_over(grid, (7, 6, 6), scale=3.0, rng=rng, aligned=aligned)
    assert IndexSampler(ffd, grid, grid).separable == aligned
    expected = sitk.GetArrayFromImage(itk_resample(image, ffd, tmp_path / "t.tfm", image, interpolation, -7.0))
    got = warp_image(image, ffd, interpolation=interpolation, default_value=-7.0)
    assert isinstance(got, sitk.Image)
    assert ImageGrid.of(got) == grid and got.GetPixelID() == image.GetPixelID()
    got = sitk.GetArrayFromImage(got)
    inside = expected != -7.0
    assert np.abs(got - array)[inside].max() > 0.1 * np.ptp(array), "the deformation should change the image"
    assert ((got == -7.0) == (expected == -7.0)).mean() > 0.999, "the same voxels fall outside"
    tolerance = 1e-5 * np.ptp(array)
    if interpolation == "nearest":  # a point exactly between voxel centres may round either way
        assert (np.abs(got - expected) > tolerance).mean() < 1e-3
    else:
        np.testing.assert_allclose(got, expected, atol=tolerance, rtol=0)


@pytest.mark.parametrize("separable", [True, False], ids=["reference-along-lattice", "reference-turned"])
@pytest.mark.parametrize("dim", [3, 2])
def test_other_reference_grid_and_affine_part(tmp_path, dim, separable):
    """Output on a grid other than the input's, through an FFD with an affine part (a CompositeTransform)."""
    rng = np.random.default_rng(7)
    grid = awkward_grid((24, 20, 14) if dim == 3 else (36, 30))
    array = smooth_volume(grid.shape, rng)
    image = sitk_image(array, grid)
    ffd = lattice_over(grid, (6, 6, 6), scale=2.0, rng=rng)
    affine = np.eye(4)
    angle = np.radians(6.0)
    affine[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    affine[:2, 3] = (1.5, -2.0)
    ffd = FFD(ffd.lattice, affine=affine)
    lo, hi = grid.bounds()
    size = (30, 22, 12) if dim == 3 else (44, 25)
    turned = None if separable else grid.direction
    reference = ImageGrid(size, spacing=(hi - lo)[:dim] / np.array(size), origin=lo[:dim] + 0.3, direction=turned)
    assert IndexSampler(ffd, reference, grid).separable == separable
    ref_image = reference.to_sitk(sitk.Image(list(size), sitk.sitkFloat32))
    expected = sitk.GetArrayFromImage(itk_resample(image, ffd, tmp_path / "t.h5", ref_image, "linear", 0.0))
    got = warp_image(image, ffd, reference=reference)
    assert ImageGrid.of(got) == reference
    np.testing.assert_allclose(sitk.GetArrayFromImage(got), expected, atol=1e-5 * np.ptp(array), rtol=0)
    assert (expected == 0).mean() > 0.05, "part of the reference grid should read outside the image"


def test_identity_returns_the_image():
    grid = awkward_grid((12, 10, 8))
    array = smooth_volume(grid.shape, np.random.default_rng(1))
    lat = Lattice.around(np.array(grid.bounds()), shape=5)
    for interpolation in ("nearest", "linear", "bspline"):
        got = warp_image(array, FFD(lat), interpolation=interpolation, spacing=grid.spacing, origin=grid.origin,
                         direction=grid.direction)  # fmt: skip
        np.testing.assert_allclose(got, array, atol=2e-4 * np.ptp(array), rtol=0)
