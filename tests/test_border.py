"""The B-spline border rule: "zero" (the seed formula, SimpleITK) and "clamp" (Blender's lattice)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference_ffd import deform_loop
from test_deform import random_lattice

from ffd_notebook import FFD, Lattice, read_mesh
from ffd_notebook.datasets import sample_mesh
from ffd_notebook.ffd.support import axis_support

SHAPES = st.tuples(*[st.integers(2, 7)] * 3)


def clamp_lattice(seed, shape, scale=0.5):
    lat = random_lattice(seed, shape, reflect=bool(seed % 2), scale=scale)
    lat.border = "clamp"
    return lat


@settings(max_examples=40, deadline=None)
@given(st.floats(-20, 20, allow_nan=False), st.integers(2, 9))
def test_clamped_support_folds_onto_the_border_and_sums_to_one(u, n):
    index, weight = axis_support(np.array([u]), n, border="clamp")
    assert index.min() >= 0 and index.max() <= n - 1
    assert weight.sum() == pytest.approx(1.0, abs=1e-12)
    zero_index, zero_weight = axis_support(np.array([u]), n, border="zero")
    np.testing.assert_array_equal(index, zero_index)
    # "clamp" gives the same weights where the support is inside; the rest goes to the border
    inside = zero_weight > 0
    np.testing.assert_allclose(weight[inside], zero_weight[inside])
    assert set(index[~inside & (weight > 0)].tolist()) <= {0, n - 1}


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), SHAPES)
def test_clamp_equals_the_clamped_index_loop_everywhere(seed, shape):
    lat = clamp_lattice(seed, shape)
    rng = np.random.default_rng(seed + 1)
    pts = lat.to_world(rng.uniform(-4, np.array(shape) + 3, size=(60, 3)))  # inside and far outside
    affine = np.eye(4)
    affine[:3] = rng.normal(size=(3, 4))
    ref = deform_loop(pts, lat.offsets, lat.spacing, lat.origin, lat.rotation, affine, border="clamp")
    np.testing.assert_allclose(FFD(lat, affine=affine).deform(pts), ref, atol=1e-11)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31), SHAPES, st.tuples(*[st.floats(-1e3, 1e3)] * 3))
def test_uniform_offsets_translate_everything_with_clamp(seed, shape, d):
    lat = clamp_lattice(seed, shape)
    lat.offsets[...] = d
    pts = lat.to_world(np.random.default_rng(seed).uniform(-3, np.array(shape) + 2, size=(200, 3)))
    ffd = FFD(lat)
    np.testing.assert_allclose(ffd.deform(pts), pts + d, rtol=0, atol=1e-9 * (1 + np.abs(d).max()))
    np.testing.assert_allclose(ffd.bind(pts, dtype=np.float64).update(), pts + d, atol=1e-9 * (1 + np.abs(d).max()))
    if min(shape) >= 4 and any(d):  # the seed formula does not: far from the lattice nothing moves
        far = lat.to_world([[-5.0, 0.0, 0.0]])
        np.testing.assert_allclose(FFD(lat, border="zero").deform(far), far)


@pytest.mark.parametrize("shape", [(5, 6, 4), (2, 3, 4)])
def test_clamp_jacobian_matches_finite_differences(shape):
    lat = clamp_lattice(11, shape, scale=0.3)
    ffd = FFD(lat, affine=np.diag([1.2, 0.9, 1.0, 1.0]))
    rng = np.random.default_rng(12)
    # across the border and outside too: the clamped spline is C2 everywhere
    u = rng.uniform(-2, np.array(shape) + 1, size=(60, 3))
    u = u[np.all(np.abs(u - np.round(u)) > 1e-3, axis=1)]  # finite differences straddling a knot lose digits
    pts = lat.to_world(u)
    h = 1e-6
    fd = np.stack([(ffd.deform(pts + h * e) - ffd.deform(pts - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(ffd.jacobian(pts), fd, atol=1e-6)
    np.testing.assert_allclose(ffd.jacobian_determinant(pts), np.linalg.det(fd), atol=1e-5)
    np.testing.assert_allclose(ffd.bind(pts).jacobian_determinant(), np.linalg.det(fd), atol=1e-5)


@pytest.mark.parametrize("border", ["zero", "clamp"])
@pytest.mark.parametrize("dtype, tol", [(np.float64, 1e-11), (np.float32, 2e-6)])
def test_bind_and_incremental_update_equal_deform(border, dtype, tol):
    rng = np.random.default_rng(13)
    pts = rng.normal(size=(3000, 3))
    pts[:50] *= 5  # some outside the lattice
    lat = Lattice.around(pts[50:], shape=(6, 5, 7), border=border)
    ffd = FFD(lat, affine=np.diag([1.0, 2.0, 1.0, 1.0]))
    deformer = ffd.bind(pts, dtype=dtype)
    tol *= 1 + np.abs(ffd.deform(pts) - pts).max() + 2
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts), atol=tol)
    corners = [(0, 0, 0), (5, 4, 6), (0, 4, 3), (5, 2, 0)]  # border control points stand in for many slots
    for step in range(30):
        ijk = corners[step] if step < len(corners) else tuple(int(rng.integers(n)) for n in lat.shape)
        lat.offsets[ijk] += rng.normal(size=3) * 0.3
        np.testing.assert_allclose(deformer.update(changed=[ijk]), ffd.deform(pts), atol=tol * 10)
    np.testing.assert_allclose(deformer.jacobian_determinant(), ffd.jacobian_determinant(pts), rtol=1e-4, atol=1e-4)


def test_border_lives_on_the_lattice_and_ffd_can_override_it():
    pts = np.random.default_rng(0).normal(size=(500, 3))
    lat = Lattice.around(pts, shape=5, border="clamp")
    assert lat.border == "clamp" and "border='clamp'" in repr(lat)
    assert FFD(lat).border == "clamp" and FFD(lat, border="zero").border == "zero"
    assert lat.copy() == lat and lat.copy().border == "clamp"
    other = lat.copy()
    other.border = "zero"
    assert other != lat
    ffd = FFD(lat)
    deformer = ffd.bind(pts, dtype=np.float64)
    lat.offsets[...] = 1.0
    np.testing.assert_allclose(deformer.update(), pts + 1.0, atol=1e-12)
    lat.border = "zero"  # the FFD follows the lattice; the deformer notices and rebinds
    np.testing.assert_allclose(deformer.update(), FFD(lat, border="zero").deform(pts), atol=1e-12)
    assert not np.allclose(deformer.update(), pts + 1.0)
    with pytest.raises(ValueError, match="border"):
        lat.border = "mirror"
    with pytest.raises(ValueError, match="border"):
        FFD(lat, border="wrap")
    with pytest.raises(ValueError, match="border"):
        Lattice.around(pts, border="edge")
    with pytest.raises(ValueError, match="at least 4"):
        FFD(Lattice((3, 4, 4), 1.0))
    FFD(Lattice((3, 2, 4), 1.0, border="clamp"))  # clamp needs no outer ring


def test_around_with_clamp_hugs_the_points():
    pts = np.random.default_rng(1).normal(size=(1000, 3)) * (3.0, 1.0, 0.2)
    lo, hi = pts.min(0), pts.max(0)
    lat = Lattice.around(pts, shape=(5, 6, 4), border="clamp")
    box = lat.bounds().reshape(3, 2)
    assert np.all(box[:, 0] <= lo) and np.all(box[:, 1] >= hi)
    assert np.all(box[:, 1] - box[:, 0] <= 1.02 * (hi - lo) * (1 + 1e-12))
    zero = Lattice.around(pts, shape=(5, 6, 4))  # today's rule, unchanged: a spacing outside a 5% margin
    np.testing.assert_allclose(zero.origin, lo - 0.05 * (hi - lo).max() - zero.spacing)
    tight = Lattice.around(pts, shape=4, margin=0.0, border="clamp")
    np.testing.assert_allclose(tight.bounds().reshape(3, 2), np.column_stack([lo, hi]))


def _max_move_fraction(ffd, points):
    """For each control point: the largest move of a vertex when it moves, over its own move."""
    lat = ffd.lattice
    deformer = ffd.bind(points, dtype=np.float64)
    rest = deformer.update().copy()
    out = np.zeros(lat.shape)
    for ijk in np.ndindex(*lat.shape):
        lat.offsets[ijk] = (lat.spacing[0], 0.0, 0.0)
        out[ijk] = np.abs(deformer.update(changed=[ijk])[:, 0] - rest[:, 0]).max() / lat.spacing[0]
        lat.offsets[ijk] = 0.0
        deformer.update(changed=[ijk])
    return out


@pytest.fixture(scope="module", params=["sample", "face"])
def mesh_points(request, shared_data):
    mesh = sample_mesh() if request.param == "sample" else read_mesh(shared_data / "face" / "template.ply")
    return np.asarray(mesh.points, dtype=np.float64)


def test_fitted_clamp_lattice_moves_the_mesh_from_its_outer_spheres(mesh_points):
    """Every sphere the mesh passes close to moves it by at least a quarter of its own move.

    A control point's pull on a vertex is a product of three per-axis weights, each at most
    2/3 inside and 5/6 on the border, so a quarter needs a vertex within about 0.2 spacings of
    it on every axis: around a surface mesh the spheres deep inside or in empty corners of the
    box have none (that is geometry, no border rule changes it). With "clamp" the outer spheres
    sit on the mesh's bounding box and pull it; with "zero" they sit a spacing outside.
    """
    lattices = {b: Lattice.around(mesh_points, shape=5, border=b) for b in ("zero", "clamp")}
    moves = {b: _max_move_fraction(FFD(lat), mesh_points) for b, lat in lattices.items()}
    lat = lattices["clamp"]
    uvw = lat.to_lattice(mesh_points)
    near = np.zeros(lat.shape, bool)
    for ijk in np.ndindex(*lat.shape):
        near[ijk] = np.any(np.all(np.abs(uvw - ijk) <= 0.2, axis=1))
    assert near.sum() >= 12  # not vacuous: 24 such spheres for the sample mesh, 15 for the face
    assert np.all(moves["clamp"][near] >= 0.25)
    hull = np.ones(lat.shape, bool)
    hull[1:-1, 1:-1, 1:-1] = False
    # the outer spheres: most move the mesh visibly with "clamp", almost none with "zero"
    assert (moves["clamp"][hull] >= 0.25).sum() >= 15 and (moves["zero"][hull] >= 0.25).sum() == 0
    assert (moves["clamp"] >= 0.10).sum() >= 2.5 * (moves["zero"] >= 0.10).sum()
    assert np.median(moves["clamp"]) >= 5 * np.median(moves["zero"])
    # and moving every sphere by d moves every vertex by exactly d
    lat.offsets[...] = (1.0, -2.0, 3.0)
    np.testing.assert_allclose(FFD(lat).deform(mesh_points), mesh_points + (1.0, -2.0, 3.0), atol=1e-9)
