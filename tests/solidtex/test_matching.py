"""The histogram term of the block choice counts placed colours and prices over-used ones."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.solidtex import color_histogram
from ffd_notebook.solidtex.matching import HistogramTerm, colour_codes


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(*[st.integers(0, 255)] * 3), min_size=1, max_size=40))
def test_codes_are_the_histogram_bins(colors):
    c = np.array(colors, np.uint8)
    counts = np.bincount(colour_codes(c.astype(np.float32)), minlength=512)
    np.testing.assert_allclose(counts / len(c), color_histogram(c, bins=8))


def test_over_use_follows_what_was_placed():
    rng = np.random.default_rng(0)
    ex = np.zeros((16, 16, 16, 3), np.float32)
    ex[8:] = 200.0  # dark half, bright half: each half of the histogram
    ex += rng.uniform(0, 20, ex.shape)
    term = HistogramTerm(ex, weight=1.0)
    corners = np.array([[0, 0, 0], [8, 0, 0]])  # a dark and a bright block of 8
    np.testing.assert_array_equal(term.over(ex, corners, 8), [0.0, 0.0])  # nothing placed: no preference
    term.add(ex, (0, 0, 0), 8)
    dark, bright = term.over(ex, corners, 8)
    assert dark > 0.5 and bright < -0.5  # dark is now over-represented: another dark block is penalised
    term.add(ex, (8, 0, 0), 8)
    error = term.counts / term.counts.sum() - term.target
    assert np.abs(error).sum() < 0.2  # both halves placed: the counted histogram is the exemplar's
