"""The one evaluator of a deformation on a grid (``ffd.grid``) against ``FFD.deform`` point by point.

The property test draws FFDs with every option (basis, per axis too; border; strength; ``outside``;
``only_inside``, closed and half-open; per-voxel weights; an affine part; lattices along the grid,
permuted, flipped or sheared with it, and lattices turned against it) on 2D and 3D grids (rotated,
permuted, sheared, anisotropic, one voxel thick), and checks that every fast path — the evaluator
itself, ``warp_image``'s :class:`~ffd_notebook.images.sample.IndexSampler`, ``sample_displacement_field``
(``fit_lattice(region=<grid>)`` samples through it), the editor's :class:`~ffd_notebook.images.WarpedSlices`
— equals ``deform`` to 1e-9 of the spacing, and that the separable path runs exactly when the
lattice runs along the grid (the plain path, ``deform`` on each slab, everywhere else).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice
from ffd_notebook.ffd.grid import GridEvaluator, axis_matrix, grid_axes, grid_weights
from ffd_notebook.ffd.interpolation import LATTICE_INTERPOLATIONS
from ffd_notebook.images import ImageGrid, WarpedSlices, warp_image
from ffd_notebook.images.sample import IndexSampler
from ffd_notebook.io import fit_lattice, sample_displacement_field

EXAMPLES = 150
FACE = 1e-9  # lattice coordinates this close to a face of an only_inside domain may fall either side of it


def _unit_columns(matrix: np.ndarray) -> np.ndarray:
    return matrix / np.linalg.norm(matrix, axis=0)


@st.composite
def directions(draw, dim: int) -> np.ndarray:
    kind = draw(st.sampled_from(["identity", "permuted", "rotated", "sheared"]))
    if kind == "identity":
        return np.eye(dim)
    if kind == "permuted":
        order = draw(st.permutations(range(dim)))
        signs = np.array(draw(st.lists(st.sampled_from([-1.0, 1.0]), min_size=dim, max_size=dim)))
        return np.eye(dim)[:, order] * signs
    if kind == "rotated":
        if dim == 2:
            angle = draw(st.floats(-np.pi, np.pi))
            return np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        unit = st.floats(-1.0, 1.0)
        quaternion = draw(st.lists(unit, min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1))
        return Rotation.from_quat(quaternion).as_matrix()
    # sheared: unit columns clearly not orthogonal (a lattice with them is a sheared one, inverted exactly)
    shear = np.eye(dim)
    shear[0, 1] = draw(st.floats(0.05, 0.8) | st.floats(-0.8, -0.05))
    if dim == 3:
        shear[0, 2], shear[1, 2] = draw(st.floats(-0.5, 0.5)), draw(st.floats(-0.5, 0.5))
    return _unit_columns(shear)


@st.composite
def grids(draw) -> ImageGrid:
    dim = draw(st.sampled_from([2, 3]))
    size = tuple(draw(st.integers(1, 9 if dim == 3 else 14)) for _ in range(dim))
    spacing = [draw(st.floats(0.25, 3.0)) for _ in range(dim)]
    origin = [draw(st.floats(-20.0, 20.0)) for _ in range(dim)]
    return ImageGrid(size, spacing, origin, draw(directions(dim)))


@st.composite
def cases(draw):
    grid = draw(grids())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    basis = draw(st.sampled_from(["bspline", "bernstein", "per axis"]))
    if basis == "per axis":
        basis = tuple(draw(st.sampled_from(LATTICE_INTERPOLATIONS)) for _ in range(3))
    border = draw(st.sampled_from(["zero", "clamp"]))
    low = 2 if basis == "bernstein" or border == "clamp" else 4
    shape = tuple(draw(st.integers(low, 7)) for _ in range(3))
    # lattice axes: the grid's (a 2D grid's third is z), permuted and flipped; then maybe turned against it
    axes = np.eye(3)
    axes[: grid.dim, : grid.dim] = grid.direction
    order = draw(st.permutations(range(3)))
    signs = np.array(draw(st.lists(st.sampled_from([-1.0, 1.0]), min_size=3, max_size=3)))
    axes = axes[:, order] * signs
    along = draw(st.booleans())
    if not along:  # every angle well away from 0 and 90 degrees: each lattice axis crosses every grid axis
        angles = [draw(st.floats(0.05, 1.52)) for _ in range(3)]
        axes = _unit_columns(axes @ Rotation.from_euler("zyx", angles).as_matrix())
    spacing = np.array([draw(st.floats(0.5, 6.0)) for _ in range(3)])
    lo, hi = grid.bounds()
    centre = (lo + hi) / 2 + rng.normal(scale=2.0, size=3)
    origin = centre - axes @ (spacing * (np.array(shape) - 1) / 2)
    lattice = Lattice(shape, spacing, origin, axes)
    lattice.offsets[...] = rng.normal(scale=0.5 * spacing.mean(), size=lattice.offsets.shape)
    affine = None
    if draw(st.booleans()):
        affine = np.eye(4)
        affine[:3, :3] += rng.normal(scale=0.1, size=(3, 3))
        affine[:3, 3] = rng.normal(scale=2.0, size=3)
    weights = rng.random(int(np.prod(grid.size))) if draw(st.booleans()) else None
    options = {
        "border": border,
        "affine": affine,
        "only_inside": draw(st.sampled_from([False, True, "half-open"])),
        "outside": draw(st.booleans()),
        "strength": draw(st.floats(-1.0, 2.0)),
        "weights": weights,
    }
    ffd = FFD(lattice, basis, **options)
    source = ImageGrid(grid.size, np.array(grid.spacing) * 1.3, np.array(grid.origin) - 1.0, grid.direction.T)
    return grid, ffd, along, source


def _compared(ffd: FFD, points: np.ndarray) -> np.ndarray:
    """Voxels whose value is defined to rounding: not within FACE of a face of an only_inside domain."""
    if not ffd.only_inside:
        return np.ones(len(points), dtype=bool)
    u = ffd.lattice.to_lattice(points)
    dims = np.array(ffd.lattice.shape, dtype=np.float64)
    faces = [np.zeros(3), dims - 1.0] if ffd.basis == "bernstein" else [np.ones(3), dims - 2.0]
    return ~np.any([np.abs(u - f) < FACE for f in faces], axis=(0, 2))


@settings(max_examples=EXAMPLES, deadline=None)
@given(cases())
def test_every_fast_path_equals_deform_point_by_point(case):
    grid, ffd, along, source = case
    points = grid.physical_points()
    moved = ffd.deform(points)  # the plain path: the FFD's per-point weights are one per voxel
    keep = _compared(ffd, points)
    scale = min(grid.spacing.min(), source.spacing.min())
    tolerance = 1e-9 * scale + 1e-13 * np.abs(moved).max()

    evaluator = GridEvaluator(ffd, grid.index_to_physical(), grid.shape, output=source.physical_to_index())
    # the separable path runs where (and only where) the lattice runs along the grid
    assert evaluator.separable == (along or np.prod(grid.size) == 1)
    rows = grid.shape[0]
    cut = rows // 2 or rows
    got = np.concatenate([evaluator.points(0, cut), *([evaluator.points(cut, rows)] if cut < rows else [])], axis=1)
    expected = (source.physical_to_index() @ np.column_stack([moved, np.ones(len(moved))]).T)[:3]
    index_tolerance = tolerance / scale * 2
    np.testing.assert_allclose(got.reshape(3, -1)[:, keep], expected[:, keep], rtol=0, atol=index_tolerance)
    displacement = evaluator.displacements(0, rows).reshape(3, -1).T
    np.testing.assert_allclose(displacement[keep], (moved - points)[keep], rtol=0, atol=tolerance)

    # warp_image's sampler: input indices in array order, only the image's own axes
    sampler = IndexSampler(ffd, grid, source)
    assert sampler.separable == evaluator.separable
    indices = sampler.rows(0, rows).reshape(grid.dim, -1)
    np.testing.assert_allclose(indices[:, keep], expected[: grid.dim][::-1][:, keep], rtol=0, atol=index_tolerance)
    if grid.dim == 3:  # field sampling (and fit_lattice on a grid, which samples through it)
        field = sample_displacement_field(ffd, grid)
        np.testing.assert_allclose(field.vectors.reshape(-1, 3)[keep], (moved - points)[keep], rtol=0, atol=tolerance)


@settings(max_examples=EXAMPLES // 3, deadline=None)
@given(cases())
def test_the_editors_slices_follow_the_same_evaluator(case):
    grid, ffd, _, _ = case
    ffd.weights = None  # a slice is part of the grid: its voxel weights are tested above
    pixels = np.zeros(grid.shape, np.float32)
    slices = WarpedSlices(pixels, ffd, spacing=grid.spacing, origin=grid.origin, direction=grid.direction)
    for axis in slices.axes:
        points = slices.slice_points(axis)
        keep = _compared(ffd, points)
        tolerance = 1e-9 * grid.spacing.min() + 1e-13 * np.abs(points).max()
        np.testing.assert_allclose(slices.moved(axis)[keep], ffd.deform(points)[keep], rtol=0, atol=tolerance * 10)


# ---------------------------------------------------------------------------------------- examples
def test_strength_outside_and_weights_reach_warp_image():
    """Issue 35 item 1: the separable path ignored strength, outside and weights (0 strength warped fully)."""
    rng = np.random.default_rng(0)
    volume = rng.random((12, 11, 10)).astype(np.float32)
    grid = ImageGrid((10, 11, 12))
    lat = Lattice.around(grid.physical_points(), shape=6)
    lat.offsets[...] = rng.normal(scale=2.0, size=lat.offsets.shape)
    assert IndexSampler(FFD(lat), grid, grid).separable
    np.testing.assert_array_equal(warp_image(volume, FFD(lat, strength=0.0)), volume)
    half = warp_image(volume, FFD(lat, strength=0.5))
    assert np.abs(half - warp_image(volume, FFD(lat))).max() > 0.1
    weights = np.zeros(volume.size)
    weights[: volume.size // 2] = 1.0  # the first half of the voxels (array order) follows the lattice, the rest stays
    warped = warp_image(volume, FFD(lat, weights=weights))
    np.testing.assert_array_equal(warped.reshape(-1)[volume.size // 2 :], volume.reshape(-1)[volume.size // 2 :])
    assert np.abs(warped.reshape(-1)[: volume.size // 2] - volume.reshape(-1)[: volume.size // 2]).max() > 0.1
    with pytest.raises(ValueError, match="one per voxel"):
        warp_image(volume, FFD(lat, weights=np.ones(50)))  # a mesh's vertex weights say nothing of voxels


def test_field_sampling_and_fit_lattice_honour_every_option():
    """Issue 35 item 1: field sampling gave 0.296 where deform gave 0.148 (strength 0.5) and 0 (outside)."""
    lat = Lattice((4, 4, 4), 1.0, origin=(-1.0, -1.0, -1.0))
    lat.offsets[1, 1, 1] = (0.5, 0.0, 0.0)
    for ffd in (FFD(lat, strength=0.5), FFD(lat, outside=True), FFD(lat, only_inside="half-open")):
        expected = ffd.deform([[0.0, 0.0, 0.0]])[0, 0]
        assert sample_displacement_field(ffd, {"size": (2, 2, 2)}).vectors[0, 0, 0, 0] == pytest.approx(expected)
        fitted = fit_lattice(ffd, (4, 4, 4), region={"size": (2, 2, 2)})
        assert fitted.displacement([[0.0, 0.0, 0.0]])[0, 0] == pytest.approx(expected, abs=1e-9)


def test_sheared_lattice_over_a_sheared_grid_is_separable_and_exact():
    """Issue 35 item 2: the transpose of a sheared lattice's axes indexed it (1.8 voxels off)."""
    shear = _unit_columns(np.array([[1.0, 0.3, 0.1], [0.0, 1.0, 0.2], [0.0, 0.0, 1.0]]))
    lat = Lattice((6, 6, 6), 4.0, origin=(-5.0, -5.0, -5.0), rotation=shear)
    lat.offsets[...] = np.random.default_rng(1).normal(size=lat.offsets.shape)
    tricky = _unit_columns(np.linalg.inv(shear).T)  # rotation.T @ direction diagonal: the old test called it aligned
    for direction, separable in ((shear, True), (tricky, False)):
        grid = ImageGrid((15, 14, 13), spacing=(0.7, 1.0, 1.2), direction=direction)
        sampler = IndexSampler(FFD(lat), grid, ImageGrid((15, 14, 13)))
        assert sampler.separable == separable
        points = grid.physical_points()
        np.testing.assert_allclose(sampler.rows(0, 13).reshape(3, -1)[::-1].T, FFD(lat).deform(points), atol=1e-9)


def test_grid_axes_pairs_permuted_and_one_voxel_axes():
    lat = Lattice((5, 6, 7), (1.0, 2.0, 4.0))
    placement = np.eye(4)
    placement[:3, :3] = [[0.0, 0.0, 2.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]  # i along -y, j along z, k along x
    axes = grid_axes(lat, placement, (3, 4, 2))
    assert [a for a, _ in axes] == [1, 2, 0]
    assert axes[0][1].tolist() == [0.0, -0.5, -1.0] and axes[2][1].tolist() == [0.0, 2.0]
    turned = np.eye(4)
    turned[:2, :2] = [[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]]
    assert grid_axes(lat, turned, (3, 4, 2)) is None
    assert grid_axes(lat, turned, (1, 1, 5)) is not None  # a line along z: x and y constant, z along k


def test_axis_matrix_is_the_engines_border_rule():
    u = np.linspace(-3.0, 9.0, 97)
    for kind in LATTICE_INTERPOLATIONS:
        for border in ("zero", "clamp"):
            dense = axis_matrix(kind, u, 7, border)
            lat = Lattice((7, 4, 4), 1.0, origin=(0.0, -1.5, -1.5))
            lat.offsets[..., 0] = np.arange(7.0)[:, None, None] ** 2
            ffd = FFD(lat, (kind, "bspline", "bspline"), border=border)
            expected = ffd.displacement(np.column_stack([u, np.zeros_like(u), np.zeros_like(u)]))[:, 0]
            np.testing.assert_allclose(dense @ np.arange(7.0) ** 2, expected, atol=1e-12)


def test_grid_weights_refuse_another_point_sets():
    assert grid_weights(None, (2, 3)) is None
    with pytest.raises(ValueError, match="point-data"):
        grid_weights("group", (2, 3))
    with pytest.raises(ValueError, match="between 0 and 1"):
        grid_weights(np.full(6, 2.0), (2, 3))


def test_a_lattice_turned_later_is_evaluated_point_by_point():
    grid = ImageGrid((6, 5, 4))
    lat = Lattice((5, 5, 5), 2.0, origin=(-3.0, -3.0, -3.0))
    lat.offsets[...] = np.random.default_rng(2).normal(size=lat.offsets.shape)
    ffd = FFD(lat)
    evaluator = GridEvaluator(ffd, grid.index_to_physical(), grid.shape)
    assert evaluator.separable
    lat.rotation = Rotation.from_euler("z", 20, degrees=True).as_matrix()
    assert not evaluator.separable
    points = grid.physical_points()
    np.testing.assert_allclose(evaluator.displacements(0, 4).reshape(3, -1).T, ffd.deform(points) - points, atol=1e-12)
    ffd.strength = 0.25  # read at each call
    np.testing.assert_allclose(evaluator.displacements(0, 4).reshape(3, -1).T, ffd.deform(points) - points, atol=1e-12)
