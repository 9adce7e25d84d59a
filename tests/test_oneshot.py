"""One-shot deformation (``FFD.deform`` without a cache) and ``FFD(only_inside=True)``."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference_ffd import bernstein_loop, deform_loop

from ffd_notebook import FFD, Lattice
from ffd_notebook.ffd.oneshot import lattice_rows
from ffd_notebook.ffd.support import in_domain


def random_lattice(seed: int, low: int = 4, high: int = 9) -> Lattice:
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    lat = Lattice(tuple(rng.integers(low, high, 3)), rng.uniform(0.2, 3.0, 3), rng.normal(size=3), q)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape)
    return lat


def points_around(lat: Lattice, rng, n: int, reach: float) -> np.ndarray:
    return lat.to_world(rng.uniform(-reach, np.array(lat.shape) - 1 + reach, (n, 3)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300))
def test_bspline_equals_report_loop(seed, n):
    lat = random_lattice(seed)
    rng = np.random.default_rng(seed)
    points = points_around(lat, rng, n, reach=4.0)
    points[: n // 3] = lat.to_world(np.round(lat.to_lattice(points[: n // 3])))  # exactly on control points
    expected = deform_loop(points, lat.offsets, lat.spacing, lat.origin, lat.rotation)
    np.testing.assert_allclose(FFD(lat).deform(points), expected, rtol=0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 200))
def test_bernstein_equals_loop(seed, n):
    lat = random_lattice(seed, low=2, high=8)
    points = points_around(lat, np.random.default_rng(seed), n, reach=0.5)
    expected = bernstein_loop(points, lat.offsets, lat.spacing, lat.origin, lat.rotation)
    np.testing.assert_allclose(FFD(lat, "bernstein").deform(points), expected, rtol=0, atol=1e-11)


def test_bernstein_blocks_and_big_lattices():
    """More points than one block (8192), and a lattice far bigger in one axis than the others."""
    lat = Lattice((13, 2, 5), (0.5, 3.0, 1.0))
    rng = np.random.default_rng(3)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape)
    points = points_around(lat, rng, 20000, reach=0.0)
    fast = FFD(lat, "bernstein").deform(points)
    cached = FFD(lat, "bernstein").bind(points, dtype=np.float64).update()
    np.testing.assert_allclose(fast, cached, rtol=0, atol=1e-12)
    some = slice(0, 20000, 997)
    np.testing.assert_allclose(fast[some], bernstein_loop(points[some], lat.offsets, lat.spacing, lat.origin),
                               rtol=0, atol=1e-12)  # fmt: skip


def test_bspline_big_lattice_uses_wide_cell_numbers():
    """A lattice with more than 2**16 cells (the 16-bit radix sort is only for smaller ones)."""
    lat = Lattice((45, 40, 40), 1.0)
    rng = np.random.default_rng(4)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape)
    points = points_around(lat, rng, 3000, reach=2.0)
    expected = deform_loop(points[:200], lat.offsets, lat.spacing, lat.origin)
    np.testing.assert_allclose(FFD(lat).deform(points)[:200], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("border", ["zero", "clamp"])
def test_bspline_chunks_and_far_points_equal_the_loop(border):
    """More points than one chunk (8192), cells cut across chunks, and points far beyond the lattice
    (their supports are moved into the padding): equal to the reference loop and the cached path."""
    lat = random_lattice(7, low=2 if border == "clamp" else 4)
    rng = np.random.default_rng(7)
    points = points_around(lat, rng, 20000, reach=3.0)
    points[::50] = lat.to_world(rng.uniform(-1e6, 1e6, (len(points[::50]), 3)))
    ffd = FFD(lat, border=border)
    fast = ffd.deform(points)
    np.testing.assert_allclose(fast, ffd.bind(points, dtype=np.float64).update(), rtol=0, atol=1e-9)
    some = slice(0, 20000, 97)
    expected = deform_loop(points[some], lat.offsets, lat.spacing, lat.origin, lat.rotation, border=border)
    np.testing.assert_allclose(fast[some], expected, rtol=0, atol=1e-9)
    assert fast.flags.c_contiguous and ffd.displacement(points[:5]).flags.c_contiguous


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_lattice_rows_are_to_lattice_transposed(seed):
    lat = random_lattice(seed)
    points = points_around(lat, np.random.default_rng(seed), 50, reach=3.0)
    np.testing.assert_allclose(lattice_rows(lat, points), lat.to_lattice(points).T, rtol=0, atol=1e-12)


def test_far_away_points_do_not_move():
    lat = random_lattice(5)
    far = np.array([[1e300, 0.0, 0.0], [-1e300, 5.0, 5.0], [1e18, -1e18, 3.0]])
    np.testing.assert_array_equal(FFD(lat).deform(far), far)


def test_only_inside_domains():
    lat = Lattice((5, 6, 7), 1.0)
    uvw = np.array([[0.0, 0.0, 0.0], [4.0, 5.0, 6.0], [1.0, 1.0, 1.0], [3.0, 4.0, 5.0], [0.5, 2, 2], [4.01, 2, 2]])
    assert in_domain("bernstein", lat.shape, uvw).tolist() == [True, True, True, True, True, False]
    assert in_domain("bspline", lat.shape, uvw).tolist() == [False, False, True, True, False, False]


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), basis=st.sampled_from(["bspline", "bernstein"]))
def test_only_inside_moves_only_the_domain(seed, basis):
    lat = random_lattice(seed)
    rng = np.random.default_rng(seed)
    affine = np.eye(4)
    affine[:3, :3] += 0.1 * rng.normal(size=(3, 3))
    inner = lat.to_world(rng.uniform(1.0, np.array(lat.shape) - 2.0, (200, 3)))  # in both bases' domains
    points = np.vstack([points_around(lat, rng, 400, reach=2.0), inner])
    everywhere = FFD(lat, basis, affine=affine)
    inside_only = FFD(lat, basis, affine=affine, only_inside=True)
    mask = in_domain(basis, lat.shape, lat.to_lattice(points))
    assert mask.any() and not mask.all()
    moved = inside_only.deform(points)
    np.testing.assert_allclose(moved[mask], everywhere.deform(points)[mask], rtol=0, atol=1e-12)
    np.testing.assert_allclose(moved[~mask], everywhere.apply_affine(points[~mask]), rtol=0, atol=1e-12)
    # the cached path and the Jacobian follow the same rule
    np.testing.assert_allclose(inside_only.bind(points, dtype=np.float64).update(), moved, rtol=0, atol=1e-12)
    jacobian = inside_only.jacobian(points)
    np.testing.assert_allclose(jacobian[~mask], np.broadcast_to(affine[:3, :3], (int((~mask).sum()), 3, 3)))
    np.testing.assert_allclose(jacobian[mask], everywhere.jacobian(points[mask]), rtol=0, atol=1e-12)


def test_deformer_rebinds_when_only_inside_changes():
    lat = random_lattice(6)
    points = points_around(lat, np.random.default_rng(6), 300, reach=2.0)
    ffd = FFD(lat)
    deformer = ffd.bind(points, dtype=np.float64)
    deformer.update()
    ffd.only_inside = True
    np.testing.assert_allclose(deformer.update(), ffd.deform(points), rtol=0, atol=1e-12)
    assert "only_inside=True" in repr(ffd)
