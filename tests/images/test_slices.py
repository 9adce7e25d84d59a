"""WarpedSlices: the editor's slices equal warp_image's, and a drag re-reads only what the control point reaches."""

from __future__ import annotations

import numpy as np
import pytest
from image_testing import awkward_grid, lattice_over, smooth_volume

from ffd_notebook import FFD
from ffd_notebook.ffd.grid import GridEvaluator
from ffd_notebook.images import ImageGrid, WarpedSlices, warp_image
from ffd_notebook.images.slices import intensity_window


def full_slices(array, ffd, grid, positions, interpolation="linear"):
    full = warp_image(array, ffd, interpolation=interpolation, spacing=grid.spacing, origin=grid.origin,
                      direction=grid.direction)  # fmt: skip
    i, j, k = positions
    return {0: full[:, :, i], 1: full[:, j, :], 2: full[k]}


@pytest.mark.parametrize("aligned", [False, True], ids=["deformer", "grid-evaluator"])
@pytest.mark.parametrize("border", ["zero", "clamp"])
def test_drags_update_only_the_reached_pixels_and_match_warp_image(border, aligned):
    """Both evaluators of a slice: separable (lattice along the image), and the cached plain one (turned)."""
    rng = np.random.default_rng(21)
    grid = awkward_grid((30, 26, 20))
    array = smooth_volume(grid.shape, rng)
    ffd = lattice_over(grid, (8, 8, 7), scale=1.0, rng=rng, aligned=aligned)
    ffd = FFD(ffd.lattice, border=border)
    slices = WarpedSlices(array, ffd, spacing=grid.spacing, origin=grid.origin, direction=grid.direction)
    assert all(isinstance(slices._evaluators[axis], GridEvaluator) == aligned for axis in range(3))
    tolerance = 1e-5 * np.ptp(array)
    expected = full_slices(array, ffd, grid, slices.positions)
    for axis in range(3):
        np.testing.assert_allclose(slices.values[axis], expected[axis], atol=tolerance, rtol=0)
    lat = ffd.lattice
    rest = {axis: lat.to_lattice(slices.slice_points(axis)) for axis in range(3)}
    reached_some = 0
    for cp in [(3, 3, 3), (4, 2, 3), (0, 4, 3), (3, 4, 2)]:
        before = {axis: slices.values[axis].copy() for axis in range(3)}
        lat.offsets[cp] += rng.normal(scale=2.0, size=3)
        regions = slices.update([cp])
        expected = full_slices(array, ffd, grid, slices.positions)
        for axis in range(3):
            region = regions[axis]
            np.testing.assert_allclose(slices.values[axis], expected[axis], atol=tolerance, rtol=0)
            np.testing.assert_array_equal(slices.values[axis][~region], before[axis][~region])
            assert not region.all(), "a drag should leave most of a slice alone"
            u = rest[axis][region.ravel()]
            reach = np.abs(u - np.array(cp)) < 2.0  # the cubic B-spline support: two cells each way
            if border == "clamp":  # a border control point also stands for those beyond the lattice
                reach |= (np.array(cp) == 0) & (u < 2.0)
            assert reach.all(axis=1).all(), "a pixel outside the control point's support was read again"
            reached_some += int(region.sum())
    assert reached_some > 0


def test_moving_a_slice_and_changing_the_affine_part():
    rng = np.random.default_rng(22)
    grid = awkward_grid((20, 18, 14))
    array = smooth_volume(grid.shape, rng)
    ffd = lattice_over(grid, (6, 6, 6), scale=1.5, rng=rng)
    geometry = {"spacing": grid.spacing, "origin": grid.origin, "direction": grid.direction}
    slices = WarpedSlices(array, ffd, interpolation="nearest", positions=(3, 4, 5), **geometry)
    slices.set_position(2, 11)
    slices.set_position(0, 99)  # clipped to the last voxel
    assert slices.positions == [19, 4, 11]
    affine = np.eye(4)
    affine[:3, 3] = (2.0, -1.0, 0.5)
    slices.ffd.affine = affine
    regions = slices.update()
    assert all(region.all() for region in regions.values())
    expected = full_slices(array, ffd, grid, slices.positions, interpolation="nearest")
    for axis in range(3):
        assert (slices.values[axis] != expected[axis]).mean() < 1e-3
    other = lattice_over(grid, (5, 7, 6), scale=2.0, rng=rng)  # a new lattice (the editor's size change, a file)
    slices.set_ffd(other)
    expected = full_slices(array, other, grid, slices.positions, interpolation="nearest")
    for axis in range(3):
        assert (slices.values[axis] != expected[axis]).mean() < 1e-3


def test_default_window_of_a_grey_image():
    level, width = intensity_window(np.linspace(-1000.0, 3000.0, 4001))
    assert abs(level - 1000.0) < 1e-9 and abs(width - 0.98 * 4000.0) < 1e-6
    assert intensity_window(np.zeros(10)) == (0.0, 1.0)


def test_rgb_photo_has_one_slice():
    photo = np.zeros((40, 60, 3), dtype=np.uint8)
    photo[10:30, 20:40] = (255, 128, 0)
    ffd = lattice_over(ImageGrid((60, 40)), (6, 6, 6), scale=2.0, rng=np.random.default_rng(0))
    slices = WarpedSlices(photo, ffd, spacing=(1.0, 1.0), interpolation="nearest")
    assert slices.axes == (2,) and slices.values[2].shape == photo.shape
    warped = warp_image(photo, ffd, spacing=(1.0, 1.0), interpolation="nearest")
    assert not np.array_equal(warped, photo)
    np.testing.assert_array_equal(slices.values[2], warped)
    with pytest.raises(ValueError, match="no slice across axis 0"):
        slices.set_position(0, 3)


@pytest.mark.parametrize("aligned", [False, True], ids=["deformer", "grid-evaluator"])
def test_voxel_weights_reach_every_slice_as_warp_image(aligned):
    """An FFD's weights on an image are one per voxel: each slice shows its voxels' share, set before or after."""
    rng = np.random.default_rng(23)
    grid = awkward_grid((16, 14, 12))
    array = smooth_volume(grid.shape, rng)
    ffd = lattice_over(grid, (6, 6, 6), scale=2.0, rng=rng, aligned=aligned)
    geometry = {"spacing": grid.spacing, "origin": grid.origin, "direction": grid.direction}
    slices = WarpedSlices(array, ffd, positions=(5, 6, 7), **geometry)
    ffd.weights = rng.random(array.size)  # set after binding: the next update takes them
    assert all(region.all() for region in slices.update([(2, 2, 2)]).values())
    expected = full_slices(array, ffd, grid, slices.positions)
    unweighted = full_slices(array, FFD(ffd.lattice), grid, slices.positions)
    for axis in range(3):
        np.testing.assert_allclose(slices.values[axis], expected[axis], atol=1e-5 * np.ptp(array), rtol=0)
        assert np.abs(slices.values[axis] - unweighted[axis]).max() > 1.0
    with pytest.raises(ValueError, match="one per voxel"):
        WarpedSlices(array, FFD(ffd.lattice, weights=np.ones(10)), **geometry)
