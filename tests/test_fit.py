"""FFD.fit_points: the least-norm offsets change that puts deformed points on targets."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_deform import random_lattice

from ffd_notebook import FFD, Lattice
from ffd_notebook.ffd.fit import control_weights

CASES = [("bspline", "zero"), ("bspline", "clamp"), ("bernstein", "zero")]


def full_weight_matrix(ffd, points):
    """(P, C) weights built from the engine's own deform, one unit control point at a time."""
    lat = ffd.lattice
    saved = lat.offsets.copy()
    columns = []
    for ijk in np.ndindex(*lat.shape):
        lat.offsets[...] = 0.0
        lat.offsets[ijk] = (1.0, 0.0, 0.0)
        columns.append(ffd.displacement(points)[:, 0])
    lat.offsets[...] = saved
    return np.column_stack(columns)


def make_ffd(seed, basis, border, shape=(5, 4, 6)):
    lat = random_lattice(seed, shape=shape if basis == "bspline" else (3, 4, 3), reflect=bool(seed % 2))
    lat.border = border
    affine = np.eye(4)
    affine[:3] = np.random.default_rng(seed).normal(size=(3, 4)) * 0.2 + np.eye(4)[:3]
    return FFD(lat, basis=basis, affine=affine)


def inside_points(ffd, rng, n):
    lo = 1.0 if (ffd.basis, ffd.border) == ("bspline", "zero") else 0.0
    return ffd.lattice.to_world(rng.uniform(lo, np.array(ffd.lattice.shape) - 1 - lo, size=(n, 3)))


@pytest.mark.parametrize("basis, border", CASES)
def test_control_weights_are_the_rows_of_the_weight_matrix(basis, border):
    ffd = make_ffd(1, basis, border)
    pts = ffd.lattice.to_world(np.random.default_rng(2).uniform(-2, 7, size=(40, 3)))  # outside too
    index, weight = control_weights(ffd, pts)
    rows = np.zeros((len(pts), ffd.lattice.n_points))
    np.add.at(rows, (np.arange(len(pts))[:, None].repeat(index.shape[1], 1), index), weight)
    np.testing.assert_allclose(rows, full_weight_matrix(ffd, pts), atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31), st.sampled_from(CASES), st.integers(1, 12))
def test_fit_equals_the_pseudo_inverse_on_the_full_weight_matrix(seed, case, n):
    """Under-determined (few points): exact and least-norm; over-determined: least squares."""
    ffd = make_ffd(seed, *case)
    rng = np.random.default_rng(seed + 1)
    pts = inside_points(ffd, rng, n)
    targets = ffd.deform(pts) + rng.normal(size=(n, 3)) * ffd.lattice.spacing.min() * 0.2
    weights = full_weight_matrix(ffd, pts)
    before = ffd.lattice.offsets.copy()
    expected = np.linalg.pinv(weights) @ (targets - ffd.deform(pts))
    change = ffd.fit_points(pts, targets)
    np.testing.assert_allclose(change.reshape(-1, 3), expected, atol=1e-8 * (1 + np.abs(expected).max()))
    np.testing.assert_array_equal(ffd.lattice.offsets, before + change)
    lstsq = np.linalg.lstsq(weights, targets - (ffd.apply_affine(pts) + weights @ before.reshape(-1, 3)), rcond=None)
    np.testing.assert_allclose(ffd.lattice.offsets.reshape(-1, 3), before.reshape(-1, 3) + lstsq[0], atol=1e-8)
    if np.linalg.matrix_rank(weights) == n:  # every target can be met
        np.testing.assert_allclose(ffd.deform(pts), targets, atol=1e-8)


@pytest.mark.parametrize("basis, border", CASES)
def test_one_point_is_the_closed_form_and_pins_stay(basis, border):
    ffd = make_ffd(3, basis, border, shape=(7, 7, 7))
    rng = np.random.default_rng(4)
    pts = inside_points(ffd, rng, 30)
    rest = ffd.deform(pts)
    target = rest[0] + (0.3, -0.2, 0.1)
    w = full_weight_matrix(ffd, pts[:1])[0]
    change = ffd.fit_points(pts[:1], [target])
    np.testing.assert_allclose(change.reshape(-1, 3), np.outer(w / (w @ w), target - rest[0]), atol=1e-12)
    np.testing.assert_allclose(ffd.deform(pts[:1])[0], target, atol=1e-12)
    # again, with pins: the grabbed point reaches its target, the pinned ones do not move
    before = ffd.deform(pts)
    ffd.fit_points(pts[:1], [target + (0.0, 0.5, 0.0)], pinned=pts[1:4])
    after = ffd.deform(pts)
    np.testing.assert_allclose(after[0], target + (0.0, 0.5, 0.0), atol=1e-9)
    np.testing.assert_allclose(after[1:4], before[1:4], atol=1e-9)


def test_weights_decide_between_conflicting_targets():
    ffd = FFD(Lattice.around(np.eye(3), shape=5, border="clamp"))
    p = np.array([[0.5, 0.5, 0.5]])
    rows = np.vstack([p, p])  # the same point asked to be in two places: least squares
    goal = np.vstack([p + (1.0, 0, 0), p + (-1.0, 0, 0)])
    ffd.fit_points(rows, goal, weights=[3.0, 1.0])
    np.testing.assert_allclose(ffd.deform(p)[0], p[0] + (0.5, 0, 0), atol=1e-9)  # (3 * 1 + 1 * -1) / 4
    ffd.lattice.reset()
    ffd.fit_points(p, p + (1.0, 0, 0), pinned=p, weights=[1.0, 0.0])  # a pin of weight zero is ignored
    np.testing.assert_allclose(ffd.deform(p)[0], p[0] + (1.0, 0, 0), atol=1e-9)


def test_points_the_lattice_cannot_reach_get_no_change():
    ffd = FFD(Lattice((4, 4, 4), 1.0))  # "zero": nothing reaches beyond two cells
    change = ffd.fit_points([[50.0, 0.0, 0.0]], [[51.0, 0.0, 0.0]])
    assert not change.any() and not ffd.lattice.offsets.any()


@pytest.mark.parametrize("basis, border", CASES)
def test_only_inside_points_outside_the_domain_neither_move_nor_steer_the_fit(basis, border):
    """``only_inside``: the lattice moves no point outside its domain, so a target there asks nothing of it."""
    ffd = make_ffd(6, basis, border, shape=(6, 6, 6))
    ffd.only_inside = True
    rng = np.random.default_rng(7)
    lattice_coordinates = np.vstack([rng.uniform(1.1, 1.9, size=(1, 3)),  # inside every domain (ITK's, PyGeM's)
                                     [[0.5, 2.0, 2.0]], [[-0.4, 1.5, 2.5]]])  # fmt: skip
    if basis == "bernstein":  # its domain is the whole box: outside it is below 0
        lattice_coordinates[1, 0] = -0.2
    pts = ffd.lattice.to_world(lattice_coordinates)
    index, weight = control_weights(ffd, pts)
    rows = np.zeros((len(pts), ffd.lattice.n_points))
    np.add.at(rows, (np.arange(len(pts))[:, None].repeat(index.shape[1], 1), index), weight)
    np.testing.assert_allclose(rows, full_weight_matrix(ffd, pts), atol=1e-14)
    assert not rows[1:].any()
    before = ffd.deform(pts)
    targets = before + rng.normal(size=(3, 3)) * ffd.lattice.spacing.min() * 0.2
    change = ffd.fit_points(pts, targets)
    np.testing.assert_allclose(ffd.deform(pts[:1]), targets[:1], atol=1e-9)  # met, and the least-norm change
    w = full_weight_matrix(ffd, pts[:1])[0]
    np.testing.assert_allclose(change.reshape(-1, 3), np.outer(w / (w @ w), targets[0] - before[0]), atol=1e-12)
    np.testing.assert_array_equal(ffd.deform(pts[1:]), before[1:])


def test_bad_arguments():
    ffd = FFD(Lattice((4, 4, 4), 1.0))
    with pytest.raises(ValueError, match="targets"):
        ffd.fit_points([[1.0, 1, 1]], [[1.0, 1]])
    with pytest.raises(ValueError, match="targets"):
        ffd.fit_points([[1.0, 1, 1]], [[np.nan, 1, 1]])
    with pytest.raises(ValueError, match="weights"):
        ffd.fit_points([[1.0, 1, 1]], [[1.0, 1, 1]], weights=[-1.0])
    with pytest.raises(ValueError, match="weights"):
        ffd.fit_points([[1.0, 1, 1]], [[1.0, 1, 1]], pinned=[[2.0, 2, 2]], weights=[1.0])
    assert not ffd.lattice.offsets.any()


@pytest.mark.parametrize("border", ["zero", "clamp"])
@pytest.mark.parametrize("n_grab", [1, 6])
def test_the_editor_drag_fit_then_update_the_changed_control_points(border, n_grab):
    rng = np.random.default_rng(5)
    pts = rng.normal(size=(4000, 3))
    ffd = FFD(Lattice.around(pts, shape=(9, 8, 7), border=border))
    deformer = ffd.bind(pts, dtype=np.float64)
    grab = rng.choice(len(pts), n_grab, replace=False)
    for _ in range(5):
        change = ffd.fit_points(pts[grab], ffd.deform(pts[grab]) + rng.normal(size=(n_grab, 3)) * 0.05)
        out = deformer.update(changed=np.argwhere(change.any(axis=-1)))  # many control points: a full pass
        np.testing.assert_allclose(out, ffd.deform(pts), atol=1e-10)
        few = [(0, 0, 0), (4, 4, 3), (8, 0, 6)]  # a few at once: added incrementally
        for ijk in few:
            ffd.lattice.offsets[ijk] += rng.normal(size=3) * 0.1
        np.testing.assert_allclose(deformer.update(changed=few), ffd.deform(pts), atol=1e-10)
