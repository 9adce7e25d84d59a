import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.solidtex import axis_ramp, block_weights


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 16), st.floats(0.05, 0.5), st.integers(1, 3), st.integers(1, 3), st.integers(1, 3))
def test_weights_sum_to_one_in_every_overlap_shape(block, frac, nz, ny, nx):
    overlap = max(1, min(block // 2, round(block * frac)))
    step = block - overlap
    n = (nz, ny, nx)
    total = np.zeros(tuple(k * step + overlap for k in n))
    count = np.zeros_like(total, dtype=int)
    for idx in np.ndindex(*n):
        prev = tuple(i > 0 for i in idx)
        nxt = tuple(i < k - 1 for i, k in zip(idx, n, strict=True))
        region = tuple(slice(i * step, i * step + block) for i in idx)
        total[region] += block_weights(block, overlap, prev, nxt)
        count[region] += 1
    np.testing.assert_allclose(total, 1.0, atol=1e-6)
    # the layouts really contain faces, edges and corners shared by 2, 4 and 8 blocks
    shared = {2 ** sum(k > 1 for k in n)}  # the most blocks sharing a voxel: 1, 2, 4 or 8
    assert set(np.unique(count)) >= shared


def test_ramps_are_monotone_feathers():
    r = axis_ramp(12, 3, True, True)
    assert np.all(np.diff(r[:3]) > 0) and np.all(np.diff(r[-3:]) < 0) and np.all(r[3:9] == 1)
    assert np.all(axis_ramp(12, 3, False, False) == 1)
    w = block_weights(12, 3, (True, False, True), (False, True, False))
    assert w.shape == (12, 12, 12) and not w.flags.writeable
