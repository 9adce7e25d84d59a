import itertools

import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import (
    histogram_distance,
    plan_stages,
    seam_energy,
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
