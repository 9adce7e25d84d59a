"""Blender's per-axis interpolation weights (ffd_notebook.ffd.interpolation)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ffd_notebook.ffd.basis import bspline
from ffd_notebook.ffd.interpolation import (
    LATTICE_INTERPOLATIONS,
    interpolation_derivative,
    interpolation_second_derivative,
    interpolation_weights,
)

fractions = st.floats(min_value=0.0, max_value=1.0, exclude_max=True)
T = np.linspace(0.0, 1.0, 101)[:-1]


@pytest.mark.parametrize("kind", LATTICE_INTERPOLATIONS)
@given(t=fractions)
def test_partition_of_unity(kind, t):
    assert interpolation_weights(t, kind).sum() == pytest.approx(1.0, abs=1e-14)
    assert interpolation_derivative(t, kind).sum() == pytest.approx(0.0, abs=1e-13)


@pytest.mark.parametrize("kind", ["linear", "catmull-rom", "bspline"])
def test_linear_functions_are_reproduced(kind):
    """Control values on a line (value k at point k) interpolate to the line: sum_l (l - 1) w_l(t) == t."""
    w = interpolation_weights(T, kind)
    assert np.allclose(w @ np.array([-1.0, 0.0, 1.0, 2.0]), T, atol=1e-14)
    assert np.allclose(interpolation_derivative(T, kind) @ np.array([-1.0, 0.0, 1.0, 2.0]), 1.0, atol=1e-13)


def test_cardinal_does_not_reproduce_lines():
    """Blender's cardinal spline (tension 0.71) bends a line between the control points: not an omission."""
    error = interpolation_weights(T, "cardinal") @ np.array([-1.0, 0.0, 1.0, 2.0]) - T
    assert np.abs(error).max() > 0.01
    assert np.allclose(error[[0, 50]], 0.0, atol=1e-14)  # at the points and, by symmetry, half-way


@pytest.mark.parametrize("kind", LATTICE_INTERPOLATIONS)
def test_continuous_across_cells(kind):
    """Leaving a cell at t -> 1 is entering the next at t = 0: w_l(1) == w_{l+1}(0), and so for the slopes
    of every interpolation but linear, whose slope jumps at the points."""
    end, start = interpolation_weights(1.0, kind), interpolation_weights(0.0, kind)
    assert np.allclose(end[1:], start[:3]) and end[0] == pytest.approx(0.0) and start[3] == pytest.approx(0.0)
    if kind != "linear":
        d_end, d_start = interpolation_derivative(1.0, kind), interpolation_derivative(0.0, kind)
        assert np.allclose(d_end[1:], d_start[:3]) and d_end[0] == pytest.approx(0.0, abs=1e-14)


@pytest.mark.parametrize("kind", ["linear", "cardinal", "catmull-rom"])
def test_interpolating_kinds_pass_through_the_points(kind):
    assert interpolation_weights(0.0, kind).tolist() == [0.0, 1.0, 0.0, 0.0]


def test_bspline_is_the_engine_bspline():
    assert np.allclose(interpolation_weights(T, "bspline"), bspline(T), atol=1e-15)


@pytest.mark.parametrize("kind", LATTICE_INTERPOLATIONS)
def test_derivatives_match_finite_differences(kind):
    h = 1e-6
    t = np.linspace(0.05, 0.95, 19)
    fd = (interpolation_weights(t + h, kind) - interpolation_weights(t - h, kind)) / (2 * h)
    assert np.allclose(interpolation_derivative(t, kind), fd, atol=1e-8)
    fd2 = (interpolation_derivative(t + h, kind) - interpolation_derivative(t - h, kind)) / (2 * h)
    assert np.allclose(interpolation_second_derivative(t, kind), fd2, atol=1e-7)


def test_blender_constants():
    """The cardinal and Catmull-Rom weights at t = 0.5, computed by hand from Blender's key.cc formulas."""
    fc = 0.71
    t = 0.5
    by_hand = [
        -fc * t**3 + 2 * fc * t**2 - fc * t,
        (2 - fc) * t**3 + (fc - 3) * t**2 + 1,
        (fc - 2) * t**3 + (3 - 2 * fc) * t**2 + fc * t,
        fc * t**3 - fc * t**2,
    ]
    assert np.allclose(interpolation_weights(t, "cardinal"), by_hand)


def test_unknown_interpolation_is_refused():
    with pytest.raises(ValueError, match="catmull-rom"):
        interpolation_weights(0.5, "cubic")
