"""The border rule's one module: its two forms (clipped indices, padded offsets) agree, for any per-axis basis."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.ffd.basis import BSPLINE, AxisBasis
from ffd_notebook.ffd.support import (
    CellGroups,
    axis_support,
    check_border,
    clip_starts,
    outer_uv,
    pad_offsets,
    support_slots,
)


def _linear_locate(u):
    u = np.asarray(u, dtype=np.float64)
    first = np.floor(u)
    return first.astype(np.int64), u - first


# a second per-axis basis (Blender's "linear" interpolation), defined here only from its support and weights
LINEAR = AxisBasis(
    "linear",
    2,
    _linear_locate,
    lambda t: np.stack([1.0 - np.asarray(t), np.asarray(t)], axis=-1),
    lambda t: np.stack([-np.ones_like(t), np.ones_like(t)], axis=-1),
)


def _padded_form(values, u, border, basis):
    """Along one axis: read ``values`` padded by the rule through supports whose starts are clipped."""
    n, w = len(values), basis.width
    first, weight = basis.support(u)
    start = clip_starts(first, n, w)
    padded = pad_offsets(values.reshape(n, 1, 1, 1), border, w)[:, w, w, 0]
    return np.sum(weight * padded[start[:, None] + w + np.arange(w)], axis=1)


def _index_form(values, u, border, basis):
    index, weight = axis_support(u, len(values), border, basis)
    return np.sum(weight * values[index], axis=1)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(4, 9),
    u=st.lists(st.floats(-20.0, 30.0, allow_nan=False), min_size=1, max_size=20),
    border=st.sampled_from(["zero", "clamp"]),
    basis=st.sampled_from([BSPLINE, LINEAR]),
    seed=st.integers(0, 2**16),
)
def test_clipped_indices_and_padding_are_the_same_rule(n, u, border, basis, seed):
    values = np.random.default_rng(seed).normal(size=n)
    u = np.array(u)
    np.testing.assert_allclose(
        _padded_form(values, u, border, basis), _index_form(values, u, border, basis), rtol=0, atol=1e-12
    )


@pytest.mark.parametrize("basis", [BSPLINE, LINEAR], ids=lambda b: b.name)
def test_clamp_weights_sum_to_one_and_zero_drops_what_lies_outside(basis):
    u = np.linspace(-6.0, 12.0, 181)
    _, clamp = axis_support(u, 7, "clamp", basis)
    np.testing.assert_allclose(clamp.sum(axis=1), 1.0, atol=1e-12)
    index, zero = axis_support(u, 7, "zero", basis)
    assert np.all(zero[(u < -basis.width) | (u > 7 + basis.width)] == 0.0)
    inside = (u >= 1.0) & (u <= 5.0)
    np.testing.assert_allclose(zero[inside].sum(axis=1), 1.0, atol=1e-12)
    assert index.min() >= 0 and index.max() <= 6


def test_a_linear_basis_interpolates_its_control_points():
    values = np.array([3.0, -1.0, 4.0, 1.0, 5.0])
    u = np.array([0.0, 1.0, 2.5, 4.0, 9.0, -3.0])
    got = _index_form(values, u, "clamp", LINEAR)
    np.testing.assert_allclose(got, [3.0, -1.0, 2.5, 5.0, 5.0, 3.0])


@settings(max_examples=30, deadline=None)
@given(
    shape=st.tuples(*[st.integers(4, 7)] * 3),
    border=st.sampled_from(["zero", "clamp"]),
    seed=st.integers(0, 2**16),
)
def test_cell_groups_and_control_slots_follow_the_rule(shape, border, seed):
    """The grouped sum (padded form) equals the per-point index form, and so does one control point's slot weight."""
    rng = np.random.default_rng(seed)
    offsets = rng.normal(size=shape + (3,))
    uvw = rng.uniform(-6.0, np.array(shape) + 5.0, size=(200, 3))  # many points far outside
    cells = CellGroups(uvw, shape, border)
    bu, bv, bw = (BSPLINE.weights(cells.t[:, a]) for a in range(3))
    grouped = cells.unsort(cells.sum(cells.pad(offsets), outer_uv(bu, bv), bw))
    (iu, wu), (iv, wv), (iw, ww) = (axis_support(uvw[:, a], n, border) for a, n in enumerate(shape))
    weight = wu[:, :, None, None] * wv[:, None, :, None] * ww[:, None, None, :]
    picked = offsets[iu[:, :, None, None], iv[:, None, :, None], iw[:, None, None, :]]
    direct = np.einsum("plmn,plmnd->pd", weight, picked)
    np.testing.assert_allclose(grouped, direct, rtol=0, atol=1e-12)

    ijk = np.array([0, rng.integers(shape[1]), shape[2] - 1])  # a border control point on two axes
    lo, hi = support_slots(ijk, cells.run_first, shape, border)
    mine = np.zeros(len(uvw))
    buvw = bu[:, :, None, None] * bv[:, None, :, None] * bw[:, None, None, :]
    for (s, e), l0, h0 in zip(cells.runs, lo, hi, strict=True):
        if np.all(l0 <= h0):
            mine[s:e] = buvw[s:e, l0[0] : h0[0] + 1, l0[1] : h0[1] + 1, l0[2] : h0[2] + 1].sum(axis=(1, 2, 3))
    hits = (iu[:, :, None, None] == ijk[0]) & (iv[:, None, :, None] == ijk[1]) & (iw[:, None, None, :] == ijk[2])
    np.testing.assert_allclose(cells.unsort(mine), np.where(hits, weight, 0.0).sum(axis=(1, 2, 3)), atol=1e-12)


def test_check_border_names_the_choices():
    with pytest.raises(ValueError, match=r"border must be one of \('zero', 'clamp'\), got 'wrap'"):
        check_border("wrap")
