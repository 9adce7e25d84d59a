import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from ffd_notebook.solidtex import box_mean, choose_block_size, classify_blocks, feature_inclusiveness
from ffd_notebook.solidtex.blocks import cell_starts


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 5), st.integers(0, 2**31 - 1))
def test_box_mean_equals_brute_force(size, seed):
    v = np.random.default_rng(seed).random((6, 7, 8, 2))
    got = box_mean(v, size)
    assert got.shape == (7 - size, 8 - size, 9 - size, 2)
    for q in np.random.default_rng(seed).integers(0, np.array(got.shape[:3]), size=(5, 3)):
        z, y, x = q
        want = v[z : z + size, y : y + size, x : x + size].mean(axis=(0, 1, 2))
        np.testing.assert_allclose(got[z, y, x], want, rtol=1e-5, atol=1e-6)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 64), st.floats(0.05, 0.5), st.integers(1, 8))
def test_cells_cover_the_overlap_and_stay_inside(block, frac, pool):
    overlap = max(1, min(block // 2, round(block * frac)))
    pool = min(pool, overlap)
    assume(block % pool == 0)
    starts, lead = cell_starts(block, overlap, pool)
    assert starts.min() == 0 and starts.max() == block - pool
    assert np.all(starts[lead] + pool <= overlap)  # a leading cell never reaches unsynthesised voxels
    covered = np.zeros(block, bool)
    for s in starts[lead]:
        covered[s : s + pool] = True
    assert covered[:overlap].all()


def test_classes_are_ordered_by_brightness_and_probabilities_are_fractions():
    rng = np.random.default_rng(3)
    centres = np.array([[20, 20, 20], [120, 100, 90], [240, 230, 220]], float)
    counts = [50, 300, 150]
    means = np.concatenate([c + rng.normal(0, 3, (n, 3)) for c, n in zip(centres, counts, strict=True)])
    labels, p = classify_blocks(means, rng=1)
    np.testing.assert_allclose(p, np.array(counts) / 500)
    assert labels[:50].tolist() == [0] * 50 and set(labels[350:]) == {2}
    again, _ = classify_blocks(means, rng=1)
    np.testing.assert_array_equal(labels, again)


def test_block_size_grows_with_the_feature_size():
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, (48, 48, 48, 3)).astype(np.uint8)
    # cubes of 12 voxels in 6 strongly different colours: small blocks see one colour only
    cubes = np.kron(rng.integers(0, 6, (4, 4, 4)), np.ones((12, 12, 12), int))
    palette = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0], [0, 255, 255], [255, 0, 255]])
    coarse = palette[cubes].astype(np.uint8)
    assert feature_inclusiveness(coarse, 8) > feature_inclusiveness(coarse, 24)
    assert choose_block_size(noise) == 8
    assert choose_block_size(coarse) > 16
    assert choose_block_size(coarse, sizes=(8, 12)) == 12  # none reaches the tolerance: the largest
    with pytest.raises(ValueError, match="no even block size"):
        choose_block_size(noise[:3, :3, :3])
