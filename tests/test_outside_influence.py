"""Blender's "outside" lattice rule and the strength / per-point weights (ffd/outside.py, ffd/influence.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.ffd.influence import blend, check_strength, influence, point_weights
from ffd_notebook.ffd.outside import outside_offsets, outside_sources, outside_weights


def blender_outside_positions(positions):
    """Blender's outside_lattice() as its C loop reads: positions (not offsets), inner points only."""
    nx, ny, nz, _ = positions.shape
    out = positions.copy()
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            for k in range(1, nz - 1):
                fu, fv, fw = i / (nx - 1), j / (ny - 1), k / (nz - 1)
                p = (1 - fu) * out[0, j, k] + fu * out[nx - 1, j, k]
                p = p + (1 - fv) * out[i, 0, k] + fv * out[i, ny - 1, k]
                p = p + (1 - fw) * out[i, j, 0] + fw * out[i, j, nz - 1]
                out[i, j, k] = p / 3.0
    return out


shapes = st.tuples(*[st.integers(2, 6)] * 3)


@settings(max_examples=40, deadline=None)
@given(shape=shapes, seed=st.integers(0, 2**31))
def test_outside_offsets_are_blenders_rule_on_positions(shape, seed):
    rng = np.random.default_rng(seed)
    spacing, origin = rng.uniform(0.2, 2.0, 3), rng.normal(size=3)
    rest = origin + np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1) * spacing
    offsets = rng.normal(size=shape + (3,))
    expected = blender_outside_positions(rest + offsets) - rest
    assert np.allclose(outside_offsets(offsets), expected, atol=1e-12)
    surface = np.ones(shape, bool)
    surface[1:-1, 1:-1, 1:-1] = False
    assert np.array_equal(outside_offsets(offsets)[surface], offsets[surface])


@settings(max_examples=30, deadline=None)
@given(shape=shapes, seed=st.integers(0, 2**31))
def test_outside_weights_apply_the_rule_to_weight_rows(shape, seed):
    rng = np.random.default_rng(seed)
    n = int(np.prod(shape))
    index = rng.integers(0, n, size=(7, 5))
    weight = rng.normal(size=(7, 5))
    offsets = rng.normal(size=shape + (3,))
    flat, eff = offsets.reshape(-1, 3), outside_offsets(offsets).reshape(-1, 3)
    index2, weight2 = outside_weights(shape, index, weight)
    direct = np.einsum("pq,pqd->pd", weight, eff[index])
    assert np.allclose(np.einsum("pq,pqd->pd", weight2, flat[index2]), direct)
    if min(shape) >= 3:
        inner = np.zeros(shape, bool)
        inner[1:-1, 1:-1, 1:-1] = True
        assert not inner.reshape(-1)[index2[weight2 != 0]].any()


def test_outside_sources_rows_sum_to_one():
    src, coef = outside_sources((4, 5, 6))
    assert np.allclose(coef.sum(axis=1), 1.0)
    assert src.shape == (120, 6)


def test_point_weights_from_a_mesh_array():
    pv = pytest.importorskip("pyvista")
    mesh = pv.Sphere()
    mesh.point_data["nose"] = np.linspace(0, 1, mesh.n_points)
    assert np.array_equal(point_weights("nose", mesh.n_points, mesh), mesh.point_data["nose"])
    with pytest.raises(ValueError, match="no point-data array 'eyes'"):
        point_weights("eyes", mesh.n_points, mesh)
    with pytest.raises(ValueError, match="not a mesh"):
        point_weights("nose", 3, np.zeros((3, 3)))


@pytest.mark.parametrize(
    ("weights", "message"),
    [([0.5, 0.5], "one number per point"), ([0.1, np.nan, 0.2], "NaN"), ([0.1, -0.1, 1.0], "down to -0.1")],
)
def test_bad_weights_are_refused(weights, message):
    with pytest.raises(ValueError, match=message):
        point_weights(weights, 3)


def test_strength_and_weights_scale_the_displacement():
    rest = np.zeros((3, 3))
    moved = np.array([[1.0, 2.0, 3.0]] * 3)
    out = blend(rest, moved.copy(), influence(-0.5, np.array([0.0, 0.5, 1.0]), 3))
    assert np.allclose(out, [[0, 0, 0], [-0.25, -0.5, -0.75], [-0.5, -1.0, -1.5]])
    assert influence(1.0, None, 3) is None
    assert check_strength("1.5") == 1.5
    with pytest.raises(ValueError, match="finite"):
        check_strength("strong")
