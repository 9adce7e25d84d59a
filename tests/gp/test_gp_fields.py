"""Grids and arrow fields."""

from __future__ import annotations

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.gp import GaussianKernel, GaussianProcess, arrow_field, grid_points, sample_jointly


def test_grid_points_fill_the_box_in_c_order():
    pts = grid_points([0, 4, -1, 1, 2, 2], shape=(5, 3, 1))
    assert pts.shape == (15, 3)
    np.testing.assert_allclose(pts.min(0), [0, -1, 2])
    np.testing.assert_allclose(pts.max(0), [4, 1, 2])
    np.testing.assert_allclose(pts[1] - pts[0], [0, 1, 0])  # z varies fastest; with one z, y is next
    padded = grid_points([0, 1, 0, 1, 0, 1], shape=2, margin=0.5)
    np.testing.assert_allclose(padded.min(0), [-0.5] * 3)
    with pytest.raises(ValueError, match="bounds"):
        grid_points([1, 0, 0, 1, 0, 1])


def test_arrow_field_of_an_ffd_and_of_a_process():
    lattice = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
    lattice.offsets[1, 1, 1] = (0.0, 0.0, 3.0)
    bounds = [0, 1, 0, 1, 0, 1]
    field = arrow_field(FFD(lattice).displacement, bounds, shape=4)
    np.testing.assert_allclose(field.vectors, FFD(lattice).displacement(field.points))
    assert field.magnitudes.max() > 0.1
    gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=0.1))
    drawn = arrow_field(gp, bounds, shape=(3, 3, 3), rng=5)
    np.testing.assert_allclose(drawn.vectors, gp.sample(drawn.points, 1, rng=5)[0])
    with pytest.raises(ValueError, match="shape"):
        arrow_field(lambda p: p[:, :2], bounds)


def test_sample_jointly_is_one_sample_split():
    gp = GaussianProcess(GaussianKernel(sigma=1.0))
    a, b = np.random.default_rng(0).random((10, 3)), np.random.default_rng(1).random((4, 3))
    ua, ub = sample_jointly(gp, [a, b], rng=3)
    whole = gp.sample(np.vstack([a, b]), 1, rng=3)[0]
    np.testing.assert_array_equal(np.vstack([ua, ub]), whole)
