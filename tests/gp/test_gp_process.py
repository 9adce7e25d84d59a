"""Exact Gaussian processes: scikit-learn agreement, interpolation, textbook block formulas, sampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

from ffd_notebook.gp import DiagonalKernel, ExponentialKernel, GaussianKernel, GaussianProcess


@pytest.mark.parametrize(
    ("sigma", "scale", "noise", "seed"), [(3.0, 1.0, 1e-2, 0), (5.0, 2.5, 1e-4, 1), (1.0, 0.3, 0.5, 2)]
)
def test_posterior_matches_scikit_learn(sigma, scale, noise, seed):
    rng = np.random.default_rng(seed)
    landmarks = rng.uniform(0, 10, (25, 3))
    observed = rng.normal(size=(25, 3))
    queries = rng.uniform(-1, 11, (60, 3))
    post = GaussianProcess(GaussianKernel(sigma=sigma, scale=scale)).posterior(landmarks, observed, noise)
    mean, var = post.mean(queries), post.variance(queries)
    # sklearn's RBF is exp(-d^2 / (2 l^2)): l = sigma / sqrt(2); alpha is the noise variance
    sk_kernel = ConstantKernel(scale**2, "fixed") * RBF(sigma / np.sqrt(2), "fixed")
    for a in range(3):
        reg = GaussianProcessRegressor(sk_kernel, alpha=noise, optimizer=None, normalize_y=False)
        sk_mean, sk_std = reg.fit(landmarks, observed[:, a]).predict(queries, return_std=True)
        np.testing.assert_allclose(mean[:, a], sk_mean, rtol=0, atol=1e-8)
        np.testing.assert_allclose(var[:, a], sk_std**2, rtol=0, atol=1e-8)


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(1, 8),
    seed=st.integers(0, 2**31),
    sigma=st.floats(0.3, 3.0),
    exponential=st.booleans(),
)
def test_posterior_interpolates_landmarks_as_noise_vanishes(n, seed, sigma, exponential):
    rng = np.random.default_rng(seed)
    landmarks = rng.uniform(-2, 2, (n, 3))
    # keep landmarks apart so the kernel matrix is well conditioned
    landmarks += 4 * np.arange(n)[:, None] * np.array([1.0, 0.0, 0.0])
    observed = rng.normal(size=(n, 3))
    kernel = (ExponentialKernel if exponential else GaussianKernel)(sigma=sigma, scale=1.0)
    gp = GaussianProcess(kernel)
    errors = []
    for noise in (1e-2, 1e-5, 1e-9):
        post = gp.posterior(landmarks, observed, noise)
        errors.append(np.abs(post.mean(landmarks) - observed).max())
        assert np.all(post.variance(landmarks) <= noise * (1 + 1e-6) + 1e-12)
    assert errors[-1] < 1e-6
    assert errors[0] >= errors[1] >= errors[2] - 1e-12


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31))
def test_posterior_variance_never_exceeds_prior(seed):
    rng = np.random.default_rng(seed)
    gp = GaussianProcess(GaussianKernel(sigma=1.0, scale=2.0))
    post = gp.posterior(rng.uniform(-1, 1, (5, 3)), rng.normal(size=(5, 3)), noise=0.01)
    queries = rng.uniform(-3, 3, (50, 3))
    assert np.all(post.variance(queries) <= gp.variance(queries) + 1e-12)
    assert np.all(post.variance(queries) >= 0)


def test_anisotropic_posterior_matches_the_block_matrix_formula():
    """Per-component kernels and per-component noise against the textbook (3N x 3N) formulas."""
    rng = np.random.default_rng(5)
    kernel = DiagonalKernel(GaussianKernel(1.0, 2.0), ExponentialKernel(1.5), GaussianKernel([0.5, 1, 2], 0.5))
    mean = lambda p: 0.1 * p[:, ::-1]  # noqa: E731  a non-zero prior mean
    gp = GaussianProcess(kernel, mean=mean)
    landmarks, observed = rng.uniform(-1, 1, (6, 3)), rng.normal(size=(6, 3))
    noise = rng.uniform(0.01, 0.1, (6, 3))
    queries = rng.uniform(-1.5, 1.5, (9, 3))
    post = gp.posterior(landmarks, observed, noise)

    K = kernel.matrix(landmarks) + np.diag(noise.ravel())
    Ks = kernel.matrix(queries, landmarks)
    expected_mean = mean(queries).ravel() + Ks @ np.linalg.solve(K, (observed - mean(landmarks)).ravel())
    expected_cov = kernel.matrix(queries) - Ks @ np.linalg.solve(K, Ks.T)
    np.testing.assert_allclose(post.mean(queries).ravel(), expected_mean, atol=1e-10)
    np.testing.assert_allclose(post.covariance(queries), expected_cov, atol=1e-10)
    np.testing.assert_allclose(post.variance(queries).ravel(), np.diagonal(expected_cov), atol=1e-10)


def test_conditioning_twice_equals_conditioning_once():
    rng = np.random.default_rng(6)
    gp = GaussianProcess(GaussianKernel(1.2, 1.0))
    lm, obs = rng.uniform(-1, 1, (8, 3)), rng.normal(size=(8, 3))
    once = gp.posterior(lm, obs, 0.05)
    twice = gp.posterior(lm[:3], obs[:3], 0.05).posterior(lm[3:], obs[3:], 0.05)
    queries = rng.uniform(-2, 2, (20, 3))
    np.testing.assert_allclose(twice.mean(queries), once.mean(queries), atol=1e-9)
    np.testing.assert_allclose(twice.covariance(queries), once.covariance(queries), atol=1e-9)


def test_samples_have_the_kernel_covariance_and_the_mean():
    kernel = GaussianKernel(sigma=0.8, scale=[1.0, 0.5, 2.0])
    points = np.array([[0.0, 0, 0], [0.4, 0, 0], [0, 0.9, 0.3]])
    gp = GaussianProcess(kernel, mean=lambda p: np.ones_like(p))
    samples = gp.sample(points, n=4000, rng=7)
    assert samples.shape == (4000, 3, 3)
    empirical = np.cov((samples - 1.0).reshape(4000, -1), rowvar=False)
    expected = kernel.matrix(points)
    assert np.abs(empirical - expected).max() < 5 * np.sqrt(2 / 4000) * expected.max()
    assert np.abs(samples.mean(axis=0) - 1.0).max() < 5 * 2.0 / np.sqrt(4000)


def test_sampling_is_reproducible_and_smoothness_follows_sigma():
    line = np.column_stack([np.linspace(0, 10, 200), np.zeros(200), np.zeros(200)])
    roughness = []
    for sigma in (0.5, 2.0, 8.0):
        gp = GaussianProcess(GaussianKernel(sigma=sigma))
        a, b = gp.sample(line, n=3, rng=3), gp.sample(line, n=3, rng=3)
        np.testing.assert_array_equal(a, b)
        roughness.append(np.abs(np.diff(a, 2, axis=1)).mean())
    assert roughness[0] > 5 * roughness[1] > 25 * roughness[2]


def test_bad_inputs_raise_value_errors():
    gp = GaussianProcess(GaussianKernel(1.0))
    with pytest.raises(ValueError, match="2 landmarks but 3 displacements"):
        gp.posterior(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="noise"):
        gp.posterior(np.zeros((2, 3)), np.zeros((2, 3)), noise=np.ones(5))
    with pytest.raises(ValueError, match="non-negative"):
        gp.posterior(np.zeros((2, 3)), np.zeros((2, 3)), noise=-1.0)
    with pytest.raises(ValueError, match="mean function"):
        GaussianProcess(GaussianKernel(1.0), mean=lambda p: p[:, :2]).mean(np.zeros((2, 3)))
    with pytest.raises(TypeError):
        GaussianProcess("not a kernel")
