"""Lazy solid textures: only what is sampled, the same whatever is asked first; the pyramid's look at organ scale.

``LazySolidTexture`` (per-voxel pyramid synthesis, issue 31) and ``LazyBlockTexture`` (the seed's block method,
kept by name).
"""

import time

import numpy as np
import pytest
from distributed import Client

from ffd_notebook.batch import local_cluster
from ffd_notebook.solidtex import (
    LazyBlockTexture,
    LazySolidTexture,
    SolidTexture,
    block_grid,
    histogram_distance,
    likeness,
    seam_energy,
    self_similarity,
)
from ffd_notebook.solidtex.pyramid import PyramidExemplar, region


def _plane_points(rng, axis, value, extent, n=3000):
    p = rng.uniform(0, extent, size=(n, 3))
    p[:, axis] = value
    return p


def _plane_grid(axis, value, extent, spacing=2.0):
    u = np.arange(0, extent, spacing)
    g = np.stack(np.meshgrid(u, u, indexing="ij"), axis=-1).reshape(-1, 2)
    return np.insert(g, axis, value, axis=1)


@pytest.fixture(scope="module")
def prepared(exemplar):
    return PyramidExemplar(exemplar)


# -- the pyramid texture ---------------------------------------------------------------------------------------


def test_same_colours_whatever_is_sampled_first(exemplar, prepared):
    rng = np.random.default_rng(3)
    sets = [_plane_points(rng, a, v, 160, n=1500) for a, v in ((0, 40.0), (2, 110.5), (1, 123.0))]
    first = LazySolidTexture(exemplar, 160, rng=5, prepared=prepared)
    second = LazySolidTexture(exemplar, 160, rng=5, prepared=prepared)
    colours_first = [first.sample(p) for p in sets]
    colours_second = [second.sample(p) for p in reversed(sets)][::-1]
    for a, b in zip(colours_first, colours_second, strict=True):
        np.testing.assert_array_equal(a, b)
    assert first.tiles_synthesised == second.tiles_synthesised  # the same tiles, made in another order
    other_seed = LazySolidTexture(exemplar, 160, rng=6, prepared=prepared)
    assert not np.array_equal(other_seed.sample(sets[0]), colours_first[0])
    # its own preparation gives the same texture (the tables are deterministic)
    np.testing.assert_array_equal(LazySolidTexture(exemplar, 160, rng=5).sample(sets[1]), colours_first[1])


def test_only_what_a_cut_samples_is_synthesised_and_kept(exemplar, prepared):
    tex = LazySolidTexture(exemplar, 240, prepared=prepared)
    plane = _plane_grid(0, 100.0, 240)
    tex.sample(plane)
    made = (tex.tiles_synthesised, tex.voxels_synthesised, tex.nbytes)
    # a plane needs two or three layers of the finest level's 4-voxel tiles out of 60 (the one it crosses and those
    # its neighbourhoods reach), and the coarser tiles they depend on
    assert 240**2 * 4 <= made[1] <= 240**2 * 12
    assert made[2] < 0.1 * 240**3 * 4  # a tenth of the whole volume's coordinates
    tex.sample(plane[::-1])  # the same points: nothing new
    assert (tex.tiles_synthesised, tex.voxels_synthesised, tex.nbytes) == made
    tex.sample(_plane_grid(0, 200.0, 240))  # a parallel cut elsewhere: its own tiles only
    assert tex.voxels_synthesised <= 2 * made[1]


def test_sampling_is_trilinear_on_the_whole_volume(exemplar, prepared):
    tex = LazySolidTexture(exemplar, (30, 40, 50), spacing=0.5, origin=(1.0, 2.0, 3.0), prepared=prepared)
    whole = SolidTexture(tex.volume(), spacing=0.5, origin=(1.0, 2.0, 3.0))
    rng = np.random.default_rng(1)
    lo, hi = whole.bounds[::2], whole.bounds[1::2]
    points = rng.uniform(lo, hi, size=(2000, 3))
    diff = np.abs(tex.sample(points).astype(int) - whole.sample(points))
    assert diff.max() <= 1  # rounding only
    np.testing.assert_array_equal(tex.voxels([[0, 0, 0], [13, 20, 7]]), whole.volume[[0, 13], [0, 20], [0, 7]])
    with pytest.raises(IndexError, match="shape"):
        tex.voxels([[30, 0, 0]])


def test_a_voxel_depends_only_on_its_position(exemplar, prepared):
    # the property that laziness and a cluster need: any box synthesised alone agrees with the whole
    levels = prepared.n_levels
    whole = region(prepared, 2, levels - 1, (0, 0, 0), (40, 36, 44))
    for lo, hi in (((3, 5, 7), (20, 36, 30)), ((31, 0, 41), (40, 9, 44)), ((-6, 30, 2), (5, 50, 3))):
        part = region(prepared, 2, levels - 1, lo, hi)
        inside = tuple(slice(max(a, 0), min(b, n)) for a, b, n in zip(lo, hi, whole.shape, strict=True))
        offset = tuple(slice(s.start - a, s.stop - a) for s, a in zip(inside, lo, strict=True))
        np.testing.assert_array_equal(part[offset], whole[inside])
    tex = LazySolidTexture(exemplar, (40, 36, 44), rng=2, prepared=prepared)
    volume = tex.volume()
    np.testing.assert_array_equal(volume, prepared.colour(whole))
    np.testing.assert_array_equal(tex.volume(chunk=13, scheduler="threads"), volume)
    grid = np.stack(np.meshgrid(*[np.arange(n) for n in tex.shape], indexing="ij"), -1).reshape(-1, 3)
    np.testing.assert_array_equal(tex.voxels(grid[::-1]).reshape(*tex.shape, 3)[::-1, ::-1, ::-1], volume)


@pytest.mark.slow
def test_a_volume_on_a_cluster_is_the_volume_made_here(exemplar, prepared):
    tex = LazySolidTexture(exemplar, (48, 40, 56), rng=9, prepared=prepared)
    here = tex.volume(chunk=24)
    with local_cluster(2, dashboard_address=None) as cluster, Client(cluster) as client:
        np.testing.assert_array_equal(tex.volume(chunk=16, client=client), here)
    np.testing.assert_array_equal(tex.volume(chunk=32, scheduler="processes"), here)


def test_a_deep_slice_of_an_organ_sized_texture_looks_like_the_tissue(made):
    # issue 31: a 96 x 96 region of a deep slice of a 512^3 texture, lazily (the benchmark measures 192 x 192 in
    # the 64^3 honeycomb's 512^3 texture: 1.00, block grid 1.17, likeness 0.97, 5 s). Measured here: histology
    # self-similarity 1.13, block grid 1.21, likeness 1.01; gravel 0.86, 1.25, 0.87 (other 96 px crops of gravel:
    # likeness 0.99-1.08, block grid 1.35-1.43)
    name, image, ex = made
    tex = LazySolidTexture(ex, 512, rng=0)
    start = time.perf_counter()
    rows, cols = np.meshgrid(np.arange(200, 296), np.arange(300, 396), indexing="ij")
    ids = np.stack([np.full(rows.size, 333), rows.ravel(), cols.ravel()], axis=-1)
    cut = tex.voxels(ids).reshape(96, 96, 3)
    seconds = time.perf_counter() - start
    assert tex.voxels_synthesised < 512**3 / 50 and seconds < 60
    similarity, grid, near = self_similarity(cut, image), block_grid(cut), likeness(cut, image)
    assert 0.8 <= similarity <= 1.6, (name, similarity)
    assert grid <= 1.5, (name, grid)
    assert 0.8 <= near <= 1.2, (name, near)


def test_twice_the_exemplar_has_no_tiles_and_no_grid(made):
    name, image, ex = made
    volume = LazySolidTexture(ex, 2 * ex.shape[0], rng=0).volume()
    # measured: histology 0.97-1.09, grid 1.22-1.23; gravel 0.87-0.89, 1.27-1.33 (new 96 px crops of the images:
    # 1.0-1.3, grid 1.25-1.43); without a correction pass at the finest level its parents' seams every second voxel
    # gave 1.37-1.48
    similarity, grid = self_similarity(volume, image, slices=2), block_grid(volume, slices=2)
    assert 0.8 <= similarity.min() and similarity.max() <= 1.6, (name, similarity)
    assert grid.max() <= 1.5, (name, grid)
    assert histogram_distance(volume, ex) < 0.05


def test_bad_input(exemplar):
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\]"):
        LazySolidTexture(exemplar.astype(float), 64)
    with pytest.raises(ValueError, match="at least 8 voxels"):
        LazySolidTexture(exemplar[:6], 64)
    with pytest.raises(ValueError, match="shape"):
        LazySolidTexture(exemplar, (64, 0, 3))
    with pytest.raises(ValueError, match="chunk"):
        LazySolidTexture(exemplar, 16).volume(chunk=0)


# -- the seed's block method, kept by name ------------------------------------------------------------------------


def test_blocks_same_colours_whatever_is_sampled_first(exemplar):
    rng = np.random.default_rng(3)
    sets = [_plane_points(rng, a, v, 300) for a, v in ((0, 40.0), (2, 210.5), (1, 123.0))]
    first = LazyBlockTexture(exemplar, 300, block=8, rng=5)
    second = LazyBlockTexture(exemplar, 300, block=8, rng=5)
    colours_first = [first.sample(p) for p in sets]
    colours_second = [second.sample(p) for p in reversed(sets)][::-1]
    for a, b in zip(colours_first, colours_second, strict=True):
        np.testing.assert_array_equal(a, b)
    # the chosen blocks agree wherever both textures chose one
    both = (first._choice >= 0) & (second._choice >= 0)
    assert both.sum() > 100
    np.testing.assert_array_equal(first._choice[both], second._choice[both])
    other_seed = LazyBlockTexture(exemplar, 300, block=8, rng=6)
    assert not np.array_equal(other_seed.sample(sets[0]), colours_first[0])


def test_blocks_only_the_sampled_tiles_are_synthesised_and_kept(exemplar):
    tex = LazyBlockTexture(exemplar, 400, block=8)
    total = int(np.prod(tex.n_blocks))
    plane = _plane_grid(0, 100.0, 400)
    tex.sample(plane)
    # a plane crosses one or two tile layers out of ~57
    layers = tex.tiles_synthesised / (tex.n_blocks[1] * tex.n_blocks[2])
    assert 1 <= layers <= 2 and tex.tiles_synthesised < total / 20
    assert tex.voxels_synthesised == tex.tiles_synthesised * tex.step**3
    before = (tex.tiles_synthesised, tex.blocks_chosen)
    tex.sample(plane[::-1])  # the same points: nothing new
    assert (tex.tiles_synthesised, tex.blocks_chosen) == before
    tex.sample(_plane_grid(0, 300.0, 400))  # a parallel cut elsewhere: only its own tiles
    assert tex.tiles_synthesised - before[0] <= 2 * tex.n_blocks[1] * tex.n_blocks[2]
    assert tex.nbytes < 0.2 * total * tex.step**3 * 3


def test_blocks_sampling_is_trilinear_on_the_whole_volume(exemplar):
    tex = LazyBlockTexture(exemplar, (30, 40, 50), spacing=0.5, origin=(1.0, 2.0, 3.0), block=8)
    whole = SolidTexture(tex.volume(), spacing=0.5, origin=(1.0, 2.0, 3.0))
    rng = np.random.default_rng(1)
    lo, hi = whole.bounds[::2], whole.bounds[1::2]
    points = rng.uniform(lo, hi, size=(2000, 3))
    diff = np.abs(tex.sample(points).astype(int) - whole.sample(points))
    assert diff.max() <= 1  # rounding only
    np.testing.assert_array_equal(tex.voxels([[0, 0, 0], [13, 20, 7]]), whole.volume[[0, 13], [0, 20], [0, 7]])


def test_blocks_feathering_weights_sum_to_one():
    tex = LazyBlockTexture(np.full((24, 24, 24, 3), 77, np.uint8), 50, block=8)
    assert np.all(tex.volume() == 77)


def _overlap_mismatch(tex):
    """Mean squared colour difference between face-neighbouring blocks where they overlap."""
    b, s = tex.block, tex.step
    blocks = {}
    for i in np.argwhere(tex._choice >= 0):
        q = tex._pool[tex._choice[tuple(i)]]
        blocks[tuple(i)] = tex.exemplar[q[0] : q[0] + b, q[1] : q[1] + b, q[2] : q[2] + b].astype(float)
    errors = []
    for i, block in blocks.items():
        for a in range(3):
            j = list(i)
            j[a] += 1
            if tuple(j) in blocks:
                trailing = np.take(block, range(s, b), axis=a)
                leading = np.take(blocks[tuple(j)], range(b - s), axis=a)
                errors.append(np.mean((trailing - leading) ** 2))
    return float(np.mean(errors))


def test_blocks_matching_lowers_seams_and_keeps_colours(exemplar):
    matched = LazyBlockTexture(exemplar, 64, block=12, rng=2, candidates=64)
    random = LazyBlockTexture(exemplar, 64, block=12, rng=2, candidates=1)  # first candidate: no matching
    a, b = matched.volume(), random.volume()
    assert histogram_distance(a, exemplar) < 0.06
    assert seam_energy(a, matched.step, matched.overlap) < seam_energy(b, random.step, random.overlap)
    assert _overlap_mismatch(matched) < 0.75 * _overlap_mismatch(random)


def test_blocks_bad_input(exemplar):
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\]"):
        LazyBlockTexture(exemplar.astype(float), 64)
    with pytest.raises(ValueError, match="block"):
        LazyBlockTexture(exemplar, 64, block=64)


def test_blocks_a_lazy_volume_twice_the_exemplar_does_not_tile(made):
    # the block texture's floor (issue 26), on whole slices now: its slices are as varied as the image's (the eye
    # sees a mosaic of block fragments up close: the pyramid texture is the default)
    name, image, ex = made
    volume = LazyBlockTexture(ex, 2 * ex.shape[0], rng=0).volume()
    ratios = self_similarity(volume, image, slices=2)
    assert 0.7 <= ratios.min() and ratios.max() <= 1.6, (name, ratios)
