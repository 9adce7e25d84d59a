"""A sheared lattice (axes at any angles, placed by a general affine map): every reader of the placement follows."""

from __future__ import annotations

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice

SHEAR = np.array([[1.0, 0.3, 0.1], [0.0, 0.9, -0.2], [0.1, 0.0, 1.1]])


def _lattices(seed: int = 0) -> tuple[Lattice, Lattice]:
    """A sheared lattice and, for reference, the same control points as an unsheared lattice seen through SHEAR."""
    rng = np.random.default_rng(seed)
    plain = Lattice((5, 6, 5), (1.5, 1.0, 2.0), origin=(0.5, -1.0, 2.0))
    plain.offsets[...] = rng.normal(0.0, 0.4, plain.offsets.shape)
    placement = SHEAR @ (plain.rotation * plain.spacing)
    spacing = np.linalg.norm(placement, axis=0)
    sheared = Lattice(plain.shape, spacing, SHEAR @ plain.origin, placement / spacing, plain.offsets)
    return sheared, plain


def test_placement_and_coordinates():
    sheared, plain = _lattices()
    assert sheared.sheared and not plain.sheared
    assert np.allclose(sheared.control_points(), plain.control_points() @ SHEAR.T)
    points = np.random.default_rng(1).random((50, 3)) * 6
    assert np.allclose(sheared.to_lattice(points @ SHEAR.T), plain.to_lattice(points))
    assert np.allclose(sheared.to_world(sheared.to_lattice(points)), points)
    with pytest.raises(ValueError, match="unit columns"):
        Lattice((2, 2, 2), 1.0, rotation=SHEAR)
    with pytest.raises(ValueError, match="singular"):
        Lattice((2, 2, 2), 1.0, rotation=[[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("border", ["zero", "clamp"])
def test_deformation_jacobian_and_cached_path_follow_the_shear(border):
    """T_sheared(S x) - S x == T_plain(x) - x: the local part reads lattice coordinates only."""
    sheared, plain = _lattices(2)
    points = plain.to_world(np.random.default_rng(3).random((400, 3)) * [5, 6, 5] - 0.5)
    world = points @ SHEAR.T
    a, b = FFD(sheared, border=border), FFD(plain, border=border)
    assert np.abs((a.deform(world) - world) - (b.deform(points) - points)).max() < 1e-12
    bound = a.bind(world, dtype=np.float64)
    assert np.abs(bound.update() - a.deform(world)).max() < 1e-9
    assert np.abs(bound.jacobian_determinant() - a.jacobian_determinant(world)).max() < 1e-6
    # chain rule: d T_local / d world = (d T_local / d x) S^-1
    ja, jb = a.jacobian(world), b.jacobian(points)
    expected = np.eye(3) + (jb - np.eye(3)) @ np.linalg.inv(SHEAR)
    assert np.abs(ja - expected).max() < 1e-10
    step = 1e-6
    numeric = np.stack([(a.deform(world + step * e) - a.deform(world - step * e)) / (2 * step) for e in np.eye(3)], 2)
    assert np.abs(numeric - ja).max() < 1e-6


def test_fit_points_on_a_sheared_lattice():
    sheared, _ = _lattices(4)
    sheared.reset()
    ffd = FFD(sheared)
    target = sheared.to_world([[2.0, 2.5, 2.0]])
    ffd.fit_points(target, target + [0.0, 0.5, 0.0])
    assert np.abs(ffd.deform(target) - target - [0.0, 0.5, 0.0]).max() < 1e-12
