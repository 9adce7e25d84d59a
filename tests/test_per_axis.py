"""Blender's controls in the engine: per-axis interpolation, "outside" mode, strength and per-point weights,
through the one-shot evaluator, the cached Deformer, the Jacobian and fit_points."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.ffd.interpolation import LATTICE_INTERPOLATIONS, interpolation_weights
from ffd_notebook.ffd.outside import outside_offsets

COMBOS = [("bspline", "catmull-rom", "linear"), ("cardinal", "linear", "bspline"), ("linear",) * 3,
          ("cardinal",) * 3, ("catmull-rom",) * 3, ("catmull-rom", "cardinal", "catmull-rom")]  # fmt: skip


def reference(lattice, basis, border, points, offsets):
    """The sum over the 4x4x4 support written out point by point (Blender's loop, clamped or zero)."""
    shape = np.array(lattice.shape)
    out = points.copy()
    for p, u in enumerate(lattice.to_lattice(points)):
        per_axis = []
        for a in range(3):
            floor = np.floor(u[a])
            per_axis.append(
                zip(int(floor) - 1 + np.arange(4), interpolation_weights(u[a] - floor, basis[a]), strict=True)
            )
        for (i, wi), (j, wj), (k, wk) in itertools.product(*[list(x) for x in per_axis]):
            ijk = np.array([i, j, k])
            if border == "zero" and (np.any(ijk < 0) or np.any(ijk >= shape)):
                continue
            i, j, k = np.clip(ijk, 0, shape - 1)
            out[p] += wi * wj * wk * offsets[i, j, k]
    return out


def random_ffd(rng, basis, *, border="clamp", outside=False, strength=1.0, shape=None):
    shape = tuple(int(n) for n in rng.integers(4, 7, 3)) if shape is None else shape
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    lat = Lattice(shape, rng.uniform(0.5, 2.0, 3), rng.normal(size=3), rotation=q)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * 0.2
    return FFD(lat, basis=basis, border=border, outside=outside, strength=strength)


def points_around(ffd, rng, n=200):
    """Points inside and up to two spacings outside the lattice."""
    return ffd.lattice.to_world(rng.uniform(-2.0, np.array(ffd.lattice.shape) + 1.0, size=(n, 3)))


@pytest.mark.parametrize("basis", COMBOS)
@pytest.mark.parametrize("border", ["clamp", "zero"])
@pytest.mark.parametrize("outside", [False, True])
def test_one_shot_and_cached_equal_the_sum_written_out(basis, border, outside):
    rng = np.random.default_rng(hash((basis, border, outside)) % 2**32)
    ffd = random_ffd(rng, basis, border=border, outside=outside)
    pts = points_around(ffd, rng)
    lat = ffd.lattice
    offsets_used = outside_offsets(lat.offsets) if outside else lat.offsets
    expected = reference(lat, basis, border, pts, offsets_used)
    np.testing.assert_allclose(ffd.deform(pts), expected, atol=1e-12)
    deformer = ffd.bind(pts, dtype=np.float64)
    np.testing.assert_allclose(deformer.update(), expected, atol=1e-12)
    # incremental: a surface point (with "outside" it moves inner points too) and an inner one
    lat.offsets[0, 1, 2] += (0.3, -0.2, 0.1)
    lat.offsets[2, 2, 1] += (0.0, 0.4, 0.0)
    expected = reference(lat, basis, border, pts, outside_offsets(lat.offsets) if outside else lat.offsets)
    np.testing.assert_allclose(deformer.update(changed=[(0, 1, 2), (2, 2, 1)]), expected, atol=1e-12)
    np.testing.assert_allclose(deformer.current(), expected, atol=1e-12)


@pytest.mark.parametrize("kind", LATTICE_INTERPOLATIONS)
def test_a_lattice_moved_as_a_whole_moves_everything_with_the_clamp_border(kind):
    """Partition of unity: with the clamp border the weights sum to one everywhere, outside the lattice too."""
    rng = np.random.default_rng(1)
    ffd = random_ffd(rng, (kind,) * 3)
    ffd.lattice.offsets[...] = (0.5, -1.0, 2.0)
    pts = points_around(ffd, rng)
    np.testing.assert_allclose(ffd.deform(pts) - pts, np.broadcast_to((0.5, -1.0, 2.0), pts.shape), atol=1e-12)


@pytest.mark.parametrize("kind", ["linear", "catmull-rom", "bspline"])
def test_offsets_on_a_linear_field_reproduce_it(kind):
    """Offsets sampled from a linear field give that field between the lattice's second and last-but-one
    points (cardinal does not reproduce lines; the clamp border does not beyond)."""
    rng = np.random.default_rng(2)
    ffd = random_ffd(rng, (kind,) * 3)
    lat = ffd.lattice
    field = rng.normal(size=(3, 3)) * 0.1
    lat.offsets[...] = lat.control_points() @ field.T
    inner = lat.to_world(rng.uniform(1.0, np.array(lat.shape) - 2.0, size=(100, 3)))
    np.testing.assert_allclose(ffd.displacement(inner), inner @ field.T, atol=1e-12)


@pytest.mark.parametrize("basis", COMBOS)
def test_jacobian_matches_finite_differences(basis):
    rng = np.random.default_rng(3)
    ffd = random_ffd(rng, basis, outside=True, strength=0.7)
    pts = points_around(ffd, rng, 50)
    weights = rng.random(len(pts))
    h = 1e-6
    numeric = np.stack(
        [
            (ffd.deform(pts + h * e, weights=weights) - ffd.deform(pts - h * e, weights=weights)) / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(ffd.jacobian(pts, weights=weights), numeric, atol=2e-7)
    deformer = ffd.bind(pts, dtype=np.float64, weights=weights)
    np.testing.assert_allclose(deformer.jacobian_determinant(), np.linalg.det(numeric), atol=1e-6)


@pytest.mark.parametrize("basis", COMBOS + [("bspline",) * 3])
@pytest.mark.parametrize("outside", [False, True])
def test_fit_points_is_the_least_squares_solve(basis, outside):
    """fit_points gives numpy's minimum-norm least-squares change of the free control points' offsets."""
    rng = np.random.default_rng(4)
    ffd = random_ffd(rng, basis, outside=outside, strength=0.8, shape=(5, 4, 5))
    lat = ffd.lattice
    pts = lat.to_world(rng.uniform(0.0, np.array(lat.shape) - 1.0, size=(6, 3)))
    targets = ffd.deform(pts) + rng.normal(size=pts.shape) * 0.05
    # the weight matrix column by column: the deformation of a unit offset on one control point
    before = lat.offsets.copy()
    n = lat.n_points
    columns = []
    for c in range(n):
        lat.offsets[...] = 0.0
        lat.offsets.reshape(-1, 3)[c] = 1.0
        columns.append((ffd.deform(pts) - pts)[:, 0])
    matrix = np.stack(columns, axis=1)
    lat.offsets[...] = before
    residual = targets - ffd.deform(pts)
    expected = np.linalg.lstsq(matrix, residual, rcond=None)[0]  # (n, 3), minimum norm
    change = ffd.fit_points(pts, targets)
    if outside:  # inner control points are not free: compare what the deformation uses
        np.testing.assert_allclose(matrix @ change.reshape(-1, 3), matrix @ expected, atol=1e-9)
        surface = np.ones(lat.shape, bool)
        surface[1:-1, 1:-1, 1:-1] = False
        assert not change[~surface].any()
    else:
        np.testing.assert_allclose(change.reshape(-1, 3), expected, atol=1e-9)
    np.testing.assert_allclose(ffd.deform(pts), targets, atol=1e-9)  # 6 points, enough control points


def test_strength_and_weights_scale_the_displacement_everywhere():
    rng = np.random.default_rng(5)
    ffd = random_ffd(rng, ("bspline", "linear", "cardinal"), strength=1.0)
    ffd.affine = np.array([[1.1, 0.1, 0, 0.2], [0, 0.9, 0, 0], [0, 0, 1, -0.1], [0, 0, 0, 1]])
    pts = points_around(ffd, rng)
    full = ffd.deform(pts)
    w = rng.random(len(pts))
    expected = pts + (-0.4 * w)[:, None] * (full - pts)
    np.testing.assert_allclose(ffd.deform(pts, strength=-0.4, weights=w), expected, atol=1e-12)
    ffd.strength, ffd.weights = -0.4, w
    np.testing.assert_allclose(ffd.deform(pts), expected, atol=1e-12)
    deformer = ffd.bind(pts, dtype=np.float64)
    np.testing.assert_allclose(deformer.update(), expected, atol=1e-12)
    ffd.strength = 1.5  # the deformer follows the FFD's strength
    np.testing.assert_allclose(deformer.update(), pts + (1.5 * w)[:, None] * (full - pts), atol=1e-12)
    deformer.weights = None
    np.testing.assert_allclose(deformer.update(), pts + 1.5 * (full - pts), atol=1e-12)
    # re-weighting keeps the grouping: the same as binding anew, "only inside" and "outside" too
    ffd.only_inside, ffd.outside = True, True
    deformer.update()
    w2 = rng.random(len(pts))
    deformer.weights = w2
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts, weights=w2), atol=1e-12)
    ffd.lattice.offsets[0, 0, 0] += 0.2
    np.testing.assert_allclose(deformer.update(changed=[(0, 0, 0)]), ffd.deform(pts, weights=w2), atol=1e-12)
    baked = FFD(ffd.lattice, ffd.basis, affine=ffd.affine, strength=0.3, outside=True).baked()
    assert baked.strength == 1.0 and not baked.outside
    np.testing.assert_allclose(
        baked.deform(pts), FFD(ffd.lattice, ffd.basis, affine=ffd.affine, strength=0.3, outside=True).deform(pts)
    )


def test_weights_from_a_mesh_point_data_array():
    pv = pytest.importorskip("pyvista")
    mesh = pv.Sphere(radius=1.0)
    lat = Lattice.around(mesh, shape=4, border="clamp")
    lat.offsets[...] = (0.0, 0.0, 1.0)
    mesh.point_data["nose"] = (mesh.points[:, 0] > 0).astype(float)  # only the +x half follows
    moved = FFD(lat).deform(mesh, weights="nose") - mesh.points
    np.testing.assert_allclose(moved[:, 2], mesh.point_data["nose"], atol=1e-12)
    deformer = FFD(lat, weights="nose").bind(mesh)
    np.testing.assert_allclose(deformer.update()[:, 2] - mesh.points[:, 2], mesh.point_data["nose"], atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"basis": ("bspline", "linear")}, "one interpolation per axis"),
        ({"basis": ("bspline", "bernstein", "linear")}, "one interpolation per axis"),
        ({"basis": "cubic"}, "one interpolation per axis"),
        ({"strength": float("inf")}, "finite"),
        ({"weights": [0.5, 1.5]}, "between 0 and 1"),
    ],
)
def test_bad_options_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FFD(Lattice((4, 4, 4), 1.0), **kwargs)


def test_weights_must_fit_the_points():
    ffd = FFD(Lattice((4, 4, 4), 1.0), weights=np.ones(5))
    with pytest.raises(ValueError, match=r"one number per point \(3\)"):
        ffd.deform(np.zeros((3, 3)))


def test_three_bsplines_are_the_bspline_basis():
    ffd = FFD(Lattice((4, 4, 4), 1.0), basis=["bspline"] * 3)
    assert ffd.basis == "bspline"
    assert FFD(Lattice((4, 4, 4), 1.0), basis="linear").basis == ("linear",) * 3
