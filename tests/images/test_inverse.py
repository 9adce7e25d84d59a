"""invert_points: T(T^-1(p)) = p for FFDs (analytic Jacobian) and for deformations with deform() alone."""

from __future__ import annotations

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.images import invert_points


class Swirl:
    """A smooth deformation with only ``deform``: a twist about z that fades with distance (no jacobian method)."""

    def deform(self, points):
        p = np.asarray(points, dtype=np.float64)
        r2 = (p[:, :2] ** 2).sum(axis=1)
        angle = 0.6 * np.exp(-r2 / 50.0)
        c, s = np.cos(angle), np.sin(angle)
        return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2] + 0.1 * p[:, 0]])


def test_inverts_an_ffd_and_a_deform_only_deformation():
    rng = np.random.default_rng(3)
    points = rng.uniform(-8, 8, (2000, 3))
    lat = Lattice.around(points, shape=6)
    lat.offsets[...] = rng.normal(scale=0.4, size=lat.offsets.shape)
    for deformation in (FFD(lat), Swirl()):
        q = invert_points(deformation, points)
        assert np.abs(deformation.deform(q) - points).max() < 1e-7
        assert np.abs(q - points).max() > 0.2, "the deformation should move points"


def test_a_folding_deformation_is_reported():
    lat = Lattice((4, 4, 4), 1.0, origin=(-1.5, -1.5, -1.5))
    lat.offsets[1:3, :, :, 0] = [[[-4.0]], [[4.0]]]  # two layers crossed over: folds
    points = np.random.default_rng(0).uniform(-0.4, 0.4, (300, 3))
    with pytest.raises(ValueError, match=r"could not be inverted at \d+ of 300 points"):
        invert_points(FFD(lat), points, max_iterations=10)
