"""Minimum-error seams: the DP finds the cheapest path, and cut overlaps mismatch less than feathered ones."""

import itertools

import numpy as np
import pytest
import skimage.data
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ffd_notebook.solidtex import histogram_distance, sliding_crops, synthesize, volume_from_slices
from ffd_notebook.solidtex.seams import cut_depths, new_side


def _brute_force(error):
    d, r = error.shape
    best = np.inf
    for path in itertools.product(range(d), repeat=r):
        if all(abs(a - b) <= 1 for a, b in itertools.pairwise(path)):
            best = min(best, sum(error[p, k] for k, p in enumerate(path)))
    return best


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 3), st.integers(1, 4), st.integers(1, 5)), elements=st.floats(0, 100))
)
def test_cut_depths_is_the_least_error_connected_path(error):
    path = cut_depths(error)
    assert path.shape == (error.shape[0], error.shape[2])
    assert np.all(np.abs(np.diff(path, axis=1)) <= 1)
    for s in range(error.shape[0]):
        cost = error[s, path[s], np.arange(error.shape[2])].sum()
        assert cost == pytest.approx(_brute_force(error[s]), abs=1e-9)


def test_new_side_cuts_each_overlap_where_the_blocks_agree():
    rng = np.random.default_rng(0)
    old = rng.uniform(0, 255, (8, 8, 8, 3))
    new = rng.uniform(0, 255, (8, 8, 8, 3))
    new[:, 1:3, :] = old[:, 1:3, :]  # the blocks agree on the second and third layers along y
    mask = new_side(old, new, 3, (False, True, False))
    assert np.all(mask[:, 2:]) and not np.any(mask[:, :2])  # the seam runs between the agreeing layers
    assert np.all(new_side(old, new, 3, (False, False, False)))


@pytest.fixture(scope="module")
def exemplar():
    img = skimage.data.immunohistochemistry()
    return volume_from_slices(sliding_crops(img, 32, 32, step=(1, 1), start=(100, 100)))


def test_cut_seams_mismatch_less_than_feathering(exemplar):
    feather, cut = {}, {}
    a = synthesize(exemplar, 64, block=12, reuse=False, progress=False, stats=feather)
    b = synthesize(exemplar, 64, block=12, reuse=False, progress=False, seams="cut", stats=cut)
    np.testing.assert_array_equal(b, synthesize(exemplar, 64, block=12, reuse=False, progress=False, seams="cut"))
    assert cut["seam_mismatch"][0] < 0.6 * feather["seam_mismatch"][0]  # 0.30 measured
    assert histogram_distance(b, exemplar) < 0.1 and not np.array_equal(a, b)
    with pytest.raises(ValueError, match="seams"):
        synthesize(exemplar, 32, seams="graphcut")
