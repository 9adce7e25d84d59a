"""Lazy block synthesis: only what is sampled, deterministic whatever is asked first, matching that helps."""

import numpy as np
import pytest

from ffd_notebook.solidtex import (
    LazySolidTexture,
    SolidTexture,
    histogram_distance,
    seam_energy,
    self_similarity,
)


def _plane_points(rng, axis, value, extent, n=3000):
    p = rng.uniform(0, extent, size=(n, 3))
    p[:, axis] = value
    return p


def _plane_grid(axis, value, extent, spacing=2.0):
    u = np.arange(0, extent, spacing)
    g = np.stack(np.meshgrid(u, u, indexing="ij"), axis=-1).reshape(-1, 2)
    return np.insert(g, axis, value, axis=1)


def test_same_colours_whatever_is_sampled_first(exemplar):
    rng = np.random.default_rng(3)
    sets = [_plane_points(rng, a, v, 300) for a, v in ((0, 40.0), (2, 210.5), (1, 123.0))]
    first = LazySolidTexture(exemplar, 300, block=8, rng=5)
    second = LazySolidTexture(exemplar, 300, block=8, rng=5)
    colours_first = [first.sample(p) for p in sets]
    colours_second = [second.sample(p) for p in reversed(sets)][::-1]
    for a, b in zip(colours_first, colours_second, strict=True):
        np.testing.assert_array_equal(a, b)
    # the chosen blocks agree wherever both textures chose one
    both = (first._choice >= 0) & (second._choice >= 0)
    assert both.sum() > 100
    np.testing.assert_array_equal(first._choice[both], second._choice[both])
    other_seed = LazySolidTexture(exemplar, 300, block=8, rng=6)
    assert not np.array_equal(other_seed.sample(sets[0]), colours_first[0])


def test_only_the_sampled_tiles_are_synthesised_and_kept(exemplar):
    tex = LazySolidTexture(exemplar, 400, block=8)
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


def test_sampling_is_trilinear_on_the_whole_volume(exemplar):
    tex = LazySolidTexture(exemplar, (30, 40, 50), spacing=0.5, origin=(1.0, 2.0, 3.0), block=8)
    whole = SolidTexture(tex.volume(), spacing=0.5, origin=(1.0, 2.0, 3.0))
    rng = np.random.default_rng(1)
    lo, hi = whole.bounds[::2], whole.bounds[1::2]
    points = rng.uniform(lo, hi, size=(2000, 3))
    diff = np.abs(tex.sample(points).astype(int) - whole.sample(points))
    assert diff.max() <= 1  # rounding only
    np.testing.assert_array_equal(tex.voxels([[0, 0, 0], [13, 20, 7]]), whole.volume[[0, 13], [0, 20], [0, 7]])


def test_feathering_weights_sum_to_one():
    tex = LazySolidTexture(np.full((24, 24, 24, 3), 77, np.uint8), 50, block=8)
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


def test_matching_lowers_seams_and_keeps_colours(exemplar):
    matched = LazySolidTexture(exemplar, 64, block=12, rng=2, candidates=64)
    random = LazySolidTexture(exemplar, 64, block=12, rng=2, candidates=1)  # first candidate: no matching
    a, b = matched.volume(), random.volume()
    assert histogram_distance(a, exemplar) < 0.06
    assert seam_energy(a, matched.step, matched.overlap) < seam_energy(b, random.step, random.overlap)
    assert _overlap_mismatch(matched) < 0.75 * _overlap_mismatch(random)


def test_bad_input(exemplar):
    with pytest.raises(ValueError, match="uint8"):
        LazySolidTexture(exemplar.astype(float), 64)
    with pytest.raises(ValueError, match="block"):
        LazySolidTexture(exemplar, 64, block=64)


def test_a_lazy_volume_twice_the_exemplar_does_not_tile(made):
    # the lazy texture shares synthesize's devices (random class, any offset, no block next to itself):
    # its slices are as varied as the image's, feathered like synthesize's default
    name, image, ex = made
    volume = LazySolidTexture(ex, 2 * ex.shape[0], rng=0).volume()
    ratios = self_similarity(volume, image, slices=2)
    assert 0.7 <= ratios.min() and ratios.max() <= 1.6, (name, ratios)
