import itertools

import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import (
    LazySolidTexture,
    block_grid,
    histogram_distance,
    plan_stages,
    seam_energy,
    self_similarity,
    self_similarity_figure,
    synthesize,
    synthesize_by_blocks,
)


def test_result_is_deterministic_and_seed_dependent(exemplar):
    a = synthesize_by_blocks(exemplar, (40, 36, 44), block=8, progress=False)
    assert a.shape == (40, 36, 44, 3) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, synthesize_by_blocks(exemplar, (40, 36, 44), block=8, progress=False))
    assert not np.array_equal(a, synthesize_by_blocks(exemplar, (40, 36, 44), block=8, rng=1, progress=False))


@pytest.mark.parametrize("reuse", [True, False])
def test_result_keeps_exemplar_statistics_without_seams(exemplar, reuse):
    out = synthesize_by_blocks(exemplar, 64, block=12, reuse=reuse, progress=False)
    stage = plan_stages(exemplar.shape, (64,) * 3, 12, reuse=reuse)[-1]
    rng = np.random.default_rng(0)
    shuffled = exemplar[rng.permutation(32)][:, rng.permutation(32)][:, :, rng.permutation(32)]
    # closer to the exemplar's colours than an unrelated tissue-coloured image...
    assert histogram_distance(out, exemplar) < 0.1
    assert histogram_distance(out, exemplar) < histogram_distance(skimage.data.coffee(), exemplar)
    # ...with seams no stronger than the texture itself, and more structure than shuffled voxels
    assert seam_energy(out, stage.step, stage.overlap) < 1.2
    # random exemplar blocks simply put side by side have clear seams at the same places
    corners = rng.integers(0, 32 - stage.step, size=(6, 6, 6, 3))
    step = stage.step
    tiled = np.zeros((6 * step,) * 3 + (3,), np.uint8)
    for i, j, k in np.ndindex(6, 6, 6):
        z, y, x = corners[i, j, k]
        tiled[i * step : (i + 1) * step, j * step : (j + 1) * step, k * step : (k + 1) * step] = exemplar[
            z : z + step, y : y + step, x : x + step
        ]
    assert seam_energy(tiled, step, 0) > 1.3 * seam_energy(out, stage.step, stage.overlap)
    assert np.abs(np.diff(out.astype(float), axis=2)).mean() < np.abs(np.diff(shuffled.astype(float), axis=2)).mean()


def test_class_probabilities_are_kept():
    # two colours in the proportion 1:3 (planes 8 voxels thick along z)
    ex = np.zeros((32, 32, 32, 3), np.uint8)
    ex[:] = (200, 60, 60)
    ex[:8] = (40, 40, 200)
    out = synthesize_by_blocks(ex, 64, block=8, progress=False, match_statistics=False)
    blue = np.mean(out[..., 2] > 128)
    assert 0.1 < blue < 0.45


def test_reuse_plan_doubles_region_and_block():
    stages = plan_stages((64, 64, 64), (256, 200, 100), 16)
    assert [s.region for s in stages] == [(64, 50, 25), (128, 100, 50), (256, 200, 100)]
    # blocks double, but never exceed the smallest side of the region they are drawn from
    assert [s.block for s in stages] == [16, 24, 50]
    assert [(s.overlap, s.pool) for s in stages] == [(3, 2), (4, 4), (8, 5)]
    assert [s.block for s in plan_stages((64,) * 3, (256,) * 3, 16)] == [16, 32, 64]
    assert all(s.source_shape == p.region for p, s in itertools.pairwise(stages))
    assert sum(s.count for s in stages) < plan_stages((64,) * 3, (256, 200, 100), 16, reuse=False)[0].count / 5
    with pytest.raises(ValueError, match="overlap"):
        plan_stages((64,) * 3, (64,) * 3, 16, overlap=0.7)
    with pytest.raises(ValueError, match="block"):
        plan_stages((16,) * 3, (64,) * 3, 32)


def test_reuse_keeps_the_first_region(exemplar):
    # blocks lying inside the region already synthesised are copied from it in place
    out = synthesize_by_blocks(exemplar, 64, block=8, progress=False, match_statistics=False)
    first = synthesize_by_blocks(exemplar, 32, block=8, progress=False, match_statistics=False)
    stage = plan_stages(exemplar.shape, (64,) * 3, 8)[1]
    kept = stage.step * 1  # the first block row is kept; its trailing overlap is blended with new blocks
    core = slice(0, kept)
    assert np.mean(np.abs(out[core, core, core].astype(int) - first[core, core, core]) <= 1) > 0.99


def test_progress_bar_and_bad_input(exemplar, capsys):
    synthesize_by_blocks(exemplar, 20, block=8, progress=True)
    assert "solid texture" in capsys.readouterr().err
    with pytest.raises(ValueError, match="exemplar"):
        synthesize(exemplar[..., 0], 20)


@pytest.mark.parametrize("seams, floor", [("cut", 0.8), ("feather", 0.7)])
def test_twice_the_exemplar_does_not_tile(made, seams, floor):
    # issues 26 and 31: whole slices of a volume twice the exemplar's size, grown by region doubling, as varied as
    # the image (self-similarity >= 0.8 cut, >= 0.7 feathered; a region repeated across a slice scores ~0, blur
    # ~0.6). Measured, whole slices: histology 1.09-1.18 cut, 1.03-1.12 feathered; gravel 1.05-1.09 and 0.93-0.97
    # (the benchmark, 4x: 192^3 from 48^3, histology 1.15-1.25 cut / 1.01-1.08 feathered, gravel 1.09-1.13 /
    # 0.91-0.94; 384^3 from 96^3 cut 1.09-1.17). Their block-grid score: cut 1.5-2.3, feathered 1.2-1.3
    name, image, ex = made
    out = synthesize_by_blocks(ex, 2 * ex.shape[0], rng=0, seams=seams, progress=False)
    ratios = self_similarity(out, image, slices=2)
    assert ratios.min() >= floor, (name, seams, ratios)
    assert ratios.max() <= 1.6, (name, seams, ratios)


def test_four_times_the_exemplar_does_not_repeat(made):
    # issue 31: the doubling reuse draws every block of a stage from the region already made; over two doublings no
    # region may come back across a whole slice (the cut seams' 4x is in the benchmark: 28 s). Measured: histology
    # 0.94-1.07, gravel 0.89-0.90
    name, image, ex = made
    out = synthesize_by_blocks(ex, 4 * ex.shape[0], rng=1, seams="feather", progress=False)
    ratios = self_similarity(out, image, slices=1)
    assert ratios.min() >= 0.7, (name, ratios)


def test_the_default_is_the_pyramid_and_has_no_tiles_and_no_grid(made):
    # issue 31: synthesize(ex, shape) with no options: whole-slice self-similarity in [0.8, 1.6] and block-grid
    # score <= 1.5 in every orientation (measured: histology 0.97-1.09, grid 1.22-1.23; gravel 0.87-0.89,
    # 1.27-1.33; block synthesis with cut seams from the same exemplars: grid 1.5-2.3): the lazy texture's volume
    name, image, ex = made
    out = synthesize(ex, 2 * ex.shape[0], progress=False)
    np.testing.assert_array_equal(out, LazySolidTexture(ex, 2 * ex.shape[0]).volume())
    similarity, grid = self_similarity(out, image, slices=2), block_grid(out, slices=2)
    assert 0.8 <= similarity.min() and similarity.max() <= 1.6, (name, similarity)
    assert grid.max() <= 1.5, (name, grid)
    # the same exemplar simply tiled twice along each axis: every window has a copy (measured on
    # whole slices, against the image's figure)
    tiled = np.tile(ex, (2, 2, 2, 1))
    assert self_similarity(tiled, self_similarity_figure(image), crop=2 * ex.shape[0], slices=1).max() < 0.3


def test_blocks_come_from_every_offset_and_never_sit_next_to_themselves(exemplar):
    stats = {}
    synthesize_by_blocks(exemplar, 64, block=8, rng=0, progress=False, stats=stats, reuse=False)
    corners = stats["positions"][0]  # (nz, ny, nx, 3) corners in the exemplar
    stage = plan_stages(exemplar.shape, (64,) * 3, 8, reuse=False)[0]
    assert corners.shape == (*stage.n_blocks, 3)
    # candidates at any offset: corners are not confined to multiples of the block or the step
    assert len({int(v) % stage.step for v in corners.ravel()}) == stage.step
    # no two touching blocks (faces, edges, corners) within half a block of each other
    for d in itertools.product((0, 1), repeat=3):
        if d == (0, 0, 0):
            continue
        n = np.array(stage.n_blocks) - d
        a = corners[: n[0], : n[1], : n[2]]
        b = corners[d[0] :, d[1] :, d[2] :][: n[0], : n[1], : n[2]]
        assert np.abs(a - b).max(axis=-1).min() >= 4
