import itertools

import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import (
    histogram_distance,
    plan_stages,
    seam_energy,
    self_similarity,
    self_similarity_figure,
    synthesize,
)


def test_result_is_deterministic_and_seed_dependent(exemplar):
    a = synthesize(exemplar, (40, 36, 44), block=8, progress=False)
    assert a.shape == (40, 36, 44, 3) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, synthesize(exemplar, (40, 36, 44), block=8, progress=False))
    assert not np.array_equal(a, synthesize(exemplar, (40, 36, 44), block=8, rng=1, progress=False))


@pytest.mark.parametrize("reuse", [True, False])
def test_result_keeps_exemplar_statistics_without_seams(exemplar, reuse):
    out = synthesize(exemplar, 64, block=12, reuse=reuse, progress=False)
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
    out = synthesize(ex, 64, block=8, progress=False, match_statistics=False)
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
    out = synthesize(exemplar, 64, block=8, progress=False, match_statistics=False)
    first = synthesize(exemplar, 32, block=8, progress=False, match_statistics=False)
    stage = plan_stages(exemplar.shape, (64,) * 3, 8)[1]
    kept = stage.step * 1  # the first block row is kept; its trailing overlap is blended with new blocks
    core = slice(0, kept)
    assert np.mean(np.abs(out[core, core, core].astype(int) - first[core, core, core]) <= 1) > 0.99


def test_progress_bar_and_bad_input(exemplar, capsys):
    synthesize(exemplar, 20, block=8, progress=True)
    assert "solid texture" in capsys.readouterr().err
    with pytest.raises(ValueError, match="exemplar"):
        synthesize(exemplar[..., 0], 20)


@pytest.mark.parametrize("seams, floor", [("cut", 0.8), ("feather", 0.7)])
def test_twice_the_exemplar_does_not_tile(made, seams, floor):
    # issue 26: slices of a volume twice the exemplar's size as varied as the image (self-similarity
    # >= 0.8 cut, >= 0.7 feathered; a tiled or repeated block scores ~0, blur ~0.6). The benchmark measures
    # 192^3 from 96^3: histology 1.37-1.46 cut, 1.33-1.43 feathered; gravel 1.30-1.32 and 1.15-1.19
    name, image, ex = made
    out = synthesize(ex, 2 * ex.shape[0], rng=0, seams=seams, progress=False)
    ratios = self_similarity(out, image, slices=2)
    assert ratios.min() >= floor, (name, seams, ratios)
    assert ratios.max() <= 1.6, (name, seams, ratios)
    # the same exemplar simply tiled twice along each axis: every window has a copy (measured on
    # whole slices, against the image's figure)
    tiled = np.tile(ex, (2, 2, 2, 1))
    assert self_similarity(tiled, self_similarity_figure(image), crop=2 * ex.shape[0], slices=1).max() < 0.3


def test_blocks_come_from_every_offset_and_never_sit_next_to_themselves(exemplar):
    stats = {}
    synthesize(exemplar, 64, block=8, rng=0, progress=False, stats=stats, reuse=False)
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
