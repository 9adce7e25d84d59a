"""Low-rank models: exactness at full rank, error against rank, posterior against the dense one."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.gp import DiagonalKernel, ExponentialKernel, GaussianKernel, GaussianProcess, LowRankGP

POINTS = np.random.default_rng(0).uniform(0, 1, (400, 3))
GP = GaussianProcess(GaussianKernel(sigma=0.4, scale=0.7))


def _dense_covariance(model: LowRankGP) -> np.ndarray:
    """The model's (3N x 3N) covariance, assembled from its eigenfunctions."""
    phi = np.stack([model.basis_function(k).ravel() for k in range(model.rank)], axis=1)
    return (phi * model.eigenvalues) @ phi.T


@pytest.mark.parametrize("method", ["nystrom", "pivoted_cholesky"])
def test_full_rank_model_is_the_exact_eigendecomposition(method):
    pts = POINTS[:120]
    if method == "nystrom":
        model = LowRankGP.nystrom(GP, pts, n_inducing=len(pts), rng=0)
    else:
        model = LowRankGP.pivoted_cholesky(GP, pts, tolerance=0.0, max_rank=len(pts))
    exact = np.sort(np.linalg.eigvalsh(GP.kernel.components(pts, pts)[0]))[::-1]
    # each scalar eigenvalue appears three times (x, y, z)
    n = model.rank // 3
    np.testing.assert_allclose(model.eigenvalues[: 3 * n : 3], exact[:n], atol=1e-8 * exact[0])
    assert np.all(np.diff(model.eigenvalues) <= 1e-12)
    np.testing.assert_allclose(_dense_covariance(model), GP.covariance(pts), atol=1e-6)


@settings(max_examples=8, deadline=None)
@given(sigma=st.floats(0.15, 1.0), seed=st.integers(0, 1000))
def test_approximation_error_decreases_with_rank(sigma, seed):
    pts = np.random.default_rng(seed).uniform(0, 1, (80, 3))
    gp = GaussianProcess(GaussianKernel(sigma=sigma))
    exact = gp.covariance(pts)
    model_all = LowRankGP.nystrom(gp, pts, n_inducing=80, rng=seed)
    errors = []
    for rank in (3, 15, 60, 120):
        model = LowRankGP.nystrom(gp, pts, n_inducing=80, rank=rank, rng=seed)
        np.testing.assert_allclose(model.eigenvalues, model_all.eigenvalues[:rank])
        errors.append(np.linalg.norm(exact - _dense_covariance(model)))
    assert all(a >= b - 1e-9 for a, b in itertools.pairwise(errors))
    assert errors[-1] < errors[0]


def test_pivoted_cholesky_meets_its_relative_error_target():
    for tolerance in (1e-1, 1e-3, 1e-6):
        model = LowRankGP.pivoted_cholesky(GP, POINTS, tolerance=tolerance)
        assert 1 - model.captured_variance <= tolerance * (1 + 1e-9)
    loose = LowRankGP.pivoted_cholesky(GP, POINTS, tolerance=1e-1)
    tight = LowRankGP.pivoted_cholesky(GP, POINTS, tolerance=1e-6)
    assert loose.rank < tight.rank


def test_rank_by_count_or_by_captured_variance():
    model = LowRankGP.nystrom(GP, POINTS, n_inducing=100, variance=0.95, rng=1)
    assert model.captured_variance >= 0.95
    smaller = LowRankGP.nystrom(GP, POINTS, n_inducing=100, rank=model.rank - 1, rng=1)
    assert smaller.captured_variance < 0.95
    assert LowRankGP.nystrom(GP, POINTS, n_inducing=100, rank=7, rng=1).rank == 7
    with pytest.raises(ValueError, match="either rank or variance"):
        LowRankGP.nystrom(GP, POINTS, rank=5, variance=0.9)


def test_instance_project_and_coefficients_round_trip():
    model = LowRankGP.nystrom(GP, POINTS, n_inducing=80, rank=40, rng=2)
    coef = np.random.default_rng(3).normal(size=40)
    field = model.instance(coef)
    np.testing.assert_allclose(model.coefficients(field), coef, atol=1e-8)
    np.testing.assert_allclose(model.project(field), field, atol=1e-10)
    # projection is the closest instance: the residual of any field is orthogonal to the basis
    other = np.random.default_rng(4).normal(size=POINTS.shape)
    residual = (other - model.project(other)).ravel()
    basis = np.stack([model.basis_function(k).ravel() for k in range(model.rank)])
    assert np.abs(basis @ residual).max() < 1e-9


def test_samples_have_the_model_variance():
    model = LowRankGP.nystrom(GP, POINTS, n_inducing=60, rank=30, rng=5)
    samples = model.sample(n=3000, rng=6)
    assert samples.shape == (3000, len(POINTS), 3)
    np.testing.assert_allclose(samples.var(axis=0), model.variance(), rtol=0.15, atol=1e-3)


def test_fields_extend_to_other_points():
    model = LowRankGP.nystrom(GP, POINTS, n_inducing=100, rank=60, rng=7)
    coef = np.random.default_rng(8).normal(size=60)
    subset = POINTS[::7]
    np.testing.assert_allclose(model.instance(coef, points=subset), model.instance(coef)[::7], atol=1e-9)
    np.testing.assert_allclose(model.variance(subset), model.variance()[::7], atol=1e-9)
    # between the vertices the extension is a smooth interpolant: close to a dense model's field
    between = POINTS[:50] + 0.01
    assert (
        np.abs(model.instance(coef, between) - model.instance(coef)[:50]).max()
        < 0.2 * np.abs(model.instance(coef)).max()
    )


@pytest.mark.parametrize(
    "kernel",
    [
        GaussianKernel(sigma=0.5, scale=0.8),
        DiagonalKernel(GaussianKernel(0.5), ExponentialKernel(0.8), GaussianKernel(1.0, 0.3)),
    ],
    ids=["isotropic", "diagonal"],
)
def test_full_rank_posterior_equals_the_dense_posterior(kernel):
    pts = POINTS[:150]
    gp = GaussianProcess(kernel, mean=lambda p: 0.1 * p)
    model = LowRankGP.nystrom(gp, pts, n_inducing=len(pts), rng=0)
    rng = np.random.default_rng(9)
    ids = rng.choice(len(pts), 6, replace=False)
    observed = rng.normal(scale=0.3, size=(6, 3))
    noise = np.full((6, 3), 1e-3)
    noise[:, 2] = 1e-2  # per-component noise: components solved separately
    dense = gp.posterior(pts[ids], observed, noise)
    low = model.posterior(pts[ids], observed, noise)
    np.testing.assert_allclose(low.mean(), dense.mean(pts), atol=1e-6)
    np.testing.assert_allclose(low.variance(), dense.variance(pts), atol=1e-6)
    np.testing.assert_allclose(_dense_covariance(low), dense.covariance(pts), atol=1e-6)
    np.testing.assert_allclose(low.covariance(pts[:40]), dense.covariance(pts[:40]), atol=1e-6)
    assert np.all(np.diff(low.eigenvalues) <= 1e-12)


def test_posterior_at_landmarks_between_vertices_and_uncertainty():
    model = LowRankGP.nystrom(GP, POINTS, n_inducing=200, rng=10)
    landmarks = np.array([[0.5, 0.5, 0.5], [0.1, 0.9, 0.2]])  # not vertices
    observed = np.array([[0.0, 0.0, 0.3], [0.2, 0.0, 0.0]])
    post = model.posterior(landmarks, observed, noise=1e-6)
    np.testing.assert_allclose(post.mean(landmarks), observed, atol=1e-3)
    near = np.linalg.norm(POINTS - landmarks[0], axis=1).argmin()
    far = np.linalg.norm(POINTS - landmarks[0], axis=1).argmax()
    assert post.variance()[near].sum() < 0.2 * model.variance()[near].sum()
    assert post.variance()[far].sum() > 0.5 * model.variance()[far].sum()
    # the posterior can be sampled and conditioned again
    assert post.sample(2, rng=0).shape == (2, len(POINTS), 3)
    third = np.array([[0.9, 0.1, 0.8]])
    again = post.posterior(third, [[0.0, -0.2, 0.0]], noise=1e-6)
    np.testing.assert_allclose(again.mean(np.vstack([landmarks, third])), [*observed, [0.0, -0.2, 0.0]], atol=1e-3)
    # observing the same point twice with equal noise averages the two observations
    twice = post.posterior(landmarks[:1], 2 * observed[:1], noise=1e-6)
    np.testing.assert_allclose(twice.mean(landmarks[:1]), 1.5 * observed[:1], atol=1e-3)
