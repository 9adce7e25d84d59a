import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reference_ffd import report_bspline

from ffd_notebook.ffd.basis import (
    BSPLINE_MATRIX,
    bernstein,
    bernstein_derivative,
    bspline,
    bspline_derivative,
    bspline_second_derivative,
)

unit = st.floats(0.0, 1.0, allow_nan=False)


@given(unit)
def test_bspline_matches_report_formula_and_sums_to_one(t):
    values = bspline(t)
    np.testing.assert_allclose(values, report_bspline(t), atol=1e-15)
    assert abs(values.sum() - 1.0) < 1e-14
    assert np.all(values >= 0)


@given(unit)
def test_power_matrix_form(t):
    np.testing.assert_allclose(np.array([1, t, t * t, t**3]) @ BSPLINE_MATRIX, bspline(t), atol=1e-15)


@given(st.floats(0.001, 0.999))
def test_derivatives_match_finite_differences(t):
    h = 1e-6
    np.testing.assert_allclose(bspline_derivative(t), (bspline(t + h) - bspline(t - h)) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(
        bspline_second_derivative(t), (bspline_derivative(t + h) - bspline_derivative(t - h)) / (2 * h), atol=1e-7
    )


def test_bspline_pieces_join_with_c2_continuity():
    # piece l on [0,1] continues as piece l-1 on the next cell: values, slopes and curvature agree
    for fn in (bspline, bspline_derivative, bspline_second_derivative):
        end, start = fn(1.0), fn(0.0)
        np.testing.assert_allclose(end[1:], start[:-1], atol=1e-14)


@settings(max_examples=50)
@given(unit, st.integers(0, 8))
def test_bernstein_partition_of_unity_and_derivative(t, n):
    assert abs(bernstein(t, n).sum() - 1.0) < 1e-12
    h = 1e-6
    if 1e-3 < t < 1 - 1e-3:
        np.testing.assert_allclose(
            bernstein_derivative(t, n), (bernstein(t + h, n) - bernstein(t - h, n)) / (2 * h), atol=1e-6
        )


def test_bad_degree_is_rejected():
    for bad in (-1, 1.5):
        try:
            bernstein(0.5, bad)
        except ValueError as err:
            assert "degree" in str(err)
        else:
            raise AssertionError("expected ValueError")
