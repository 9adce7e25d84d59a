import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import color_histogram, gradient_energy, histogram_distance, seam_energy
from ffd_notebook.solidtex.quality import band_mask


def test_histogram_distance_is_a_metric_on_real_colours():
    a = skimage.data.coffee()[:64, :64]
    b = skimage.data.astronaut()[:64, :64]
    c = skimage.data.immunohistochemistry()[:64, :64]
    assert histogram_distance(a, a) == 0
    assert histogram_distance(a, b) == pytest.approx(histogram_distance(b, a))
    assert histogram_distance(a, c) <= histogram_distance(a, b) + histogram_distance(b, c) + 1e-12
    assert color_histogram(a).sum() == pytest.approx(1)
    with pytest.raises(ValueError, match="RGB"):
        color_histogram(np.zeros((4, 4)))


def test_seam_energy_sees_tiles_and_not_smooth_volumes():
    rng = np.random.default_rng(0)
    tiles = np.kron(rng.integers(0, 255, (4, 4, 4, 3)), np.ones((10, 10, 10, 1))).astype(np.uint8)
    assert seam_energy(tiles, step=10, overlap=0) > 5
    # the same tiles, with borders elsewhere than where we look, show nothing at those places
    assert seam_energy(tiles[5:, 5:, 5:], step=10, overlap=0) < 1
    x = np.linspace(0, 255, 40)
    ramp = np.broadcast_to(x[None, None, :, None], (40, 40, 40, 3)).astype(np.uint8)
    assert seam_energy(ramp, 8, 2) == pytest.approx(1.0, abs=0.1)
    assert np.isnan(seam_energy(np.zeros((8, 8, 8, 3), np.uint8), 4, 1))
    assert gradient_energy(ramp) > 0


def test_band_mask_marks_faces_around_each_overlap():
    m = band_mask(30, step=10, overlap=3)
    assert np.flatnonzero(m).tolist() == [9, 10, 11, 12, 19, 20, 21, 22]
