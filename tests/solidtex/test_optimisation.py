"""synthesize_by_optimisation: a volume twice the exemplar's size whose slices are as varied as the image (issue 26)."""

import numpy as np
import pytest

from ffd_notebook.solidtex import self_similarity, self_similarity_figure, synthesize_by_optimisation
from ffd_notebook.solidtex.slice_search import transfer_colours


def test_twice_the_exemplar_is_as_varied_as_the_image(made):
    # the band of genuinely new samples is 0.97-1.14; tiles score ~0, blur ~0.6. Measured with seeds 0 and 1:
    # histology 0.91-1.08, gravel 0.83-0.90 (block synthesis with cut seams from the same exemplars scores
    # 1.07-1.18, a mosaic of cell fragments up close that the 8 px windows do not see)
    name, image, ex = made
    out = synthesize_by_optimisation(ex, 2 * ex.shape[0], rng=0, progress=False)
    assert out.shape == (96, 96, 96, 3) and out.dtype == np.uint8
    ratios = self_similarity(out, image, slices=2, crop=ex.shape[0])  # in crops of the exemplar's size (issue 26)
    assert ratios.min() >= 0.8, (name, ratios)
    assert ratios.max() <= 1.6, (name, ratios)
    # not the exemplar tiled: over whole slices the tiled exemplar scores < 0.3 (every window has a copy);
    # the result 0.67-0.84 (it copies regions of an exemplar an eighth of its volume, each a few times: whole
    # slices, self_similarity's default since issue 31, score 0.75-0.93, where the pyramid, the default method,
    # scores 0.87-1.09).
    # Matching blocks that wrap around the (periodic) exemplar gave the tiling itself: 0.01-0.08.
    tiled = np.tile(ex, (2, 2, 2, 1))
    figure = self_similarity_figure(image)
    assert self_similarity(tiled, figure, crop=96, slices=1).max() < 0.3
    assert self_similarity(out, figure, crop=96, slices=1).min() >= 0.5


def test_shapes_seeds_and_bad_input(exemplar, capsys):
    a = synthesize_by_optimisation(exemplar, (20, 24, 36), levels=2, iterations=1, rng=3, progress=True)
    assert "solid texture" in capsys.readouterr().err
    assert a.shape == (20, 24, 36, 3)
    b = synthesize_by_optimisation(exemplar, (20, 24, 36), levels=2, iterations=1, rng=3, progress=False)
    c = synthesize_by_optimisation(exemplar, (20, 24, 36), levels=2, iterations=1, rng=4, progress=False)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    for kwargs, message in [
        (dict(neighbourhood=7), "even"),
        (dict(levels=0), "at least 1"),
        (dict(robust=2.0), "robust"),
        (dict(levels=4), r"neighbourhood \* 2 \*\* \(levels - 1\) = 64"),
    ]:
        with pytest.raises(ValueError, match=message):
            synthesize_by_optimisation(exemplar, 32, progress=False, **kwargs)
    with pytest.raises(ValueError, match="exemplar"):
        synthesize_by_optimisation(exemplar[..., 0], 32)
    with pytest.raises(ValueError, match="shape"):
        synthesize_by_optimisation(exemplar, (32, 32))


def test_colour_transfer_through_estimated_quantiles_matches_the_exact_one():
    # synthesize_by_optimisation's colour transfer on a large volume estimates each channel's quantiles on a
    # sample (an exact sort of 2 million voxels was two thirds of its time at 128^3): every voxel must get
    # the exact transfer's colour within a grey level or two (median 0.43, 99.9% within 3.1)
    rng = np.random.default_rng(0)
    volume = rng.gamma(2.0, 20.0, (64, 64, 64, 3)).astype(np.float32)
    image = rng.uniform(0, 255, (48, 48, 3)).astype(np.float32) * [1.0, 0.6, 0.3]
    exact = transfer_colours(volume, image, 2, seed=1)
    estimated = transfer_colours(volume, image, 2, seed=1, sample=20_000)
    error = np.abs(estimated - exact)
    assert np.median(error) < 1.0 and np.quantile(error, 0.999) < 6.0, (np.median(error), error.max())
    assert not np.array_equal(exact, estimated)
    # below the sample size it is the exact transfer
    assert np.array_equal(transfer_colours(volume, image, 2, seed=1, sample=10**6), exact)
