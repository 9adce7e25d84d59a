"""Noise per landmark (3x3 covariances), log marginal likelihood and low-rank densities against outside references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

from ffd_notebook.gp import DiagonalKernel, ExponentialKernel, GaussianKernel, GaussianProcess, LowRankGP

RNG = np.random.default_rng(0)
POINTS = RNG.uniform(-1, 1, (60, 3))


def _random_covariances(rng, n, scale=0.05):
    a = rng.normal(size=(n, 3, 3))
    return scale * (a @ a.transpose(0, 2, 1) + 0.1 * np.eye(3))


def _dense_conditioning(prior_mean, prior_cov, observed_rows, observed, noise_block):
    """Textbook Gaussian conditioning of N(prior_mean, prior_cov) on rows observed with additive noise."""
    s = prior_cov[np.ix_(observed_rows, observed_rows)] + noise_block
    k = prior_cov[:, observed_rows]
    mean = prior_mean + k @ np.linalg.solve(s, observed - prior_mean[observed_rows])
    cov = prior_cov - k @ np.linalg.solve(s, k.T)
    return mean, cov


def _block_diag(covs):
    n = len(covs)
    out = np.zeros((3 * n, 3 * n))
    for i, c in enumerate(covs):
        out[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = c
    return out


def _rows(ids):
    return (3 * np.asarray(ids)[:, None] + np.arange(3)).ravel()


def test_exact_posterior_with_isotropic_covariances_equals_per_variance_noise():
    gp = GaussianProcess(GaussianKernel(0.8, 0.5), mean=lambda p: 0.1 * p)
    lms, obs = POINTS[:7], RNG.normal(scale=0.2, size=(7, 3))
    s = RNG.uniform(0.001, 0.05, 7)
    by_variance = gp.posterior(lms, obs, noise=s)
    by_covariance = gp.posterior(lms, obs, noise=s[:, None, None] * np.eye(3))
    assert by_variance.kernel.is_diagonal and not by_covariance.kernel.is_diagonal  # two different code paths
    q = POINTS[20:40]
    np.testing.assert_allclose(by_covariance.mean(q), by_variance.mean(q), atol=1e-12)
    np.testing.assert_allclose(by_covariance.covariance(q), by_variance.covariance(q), atol=1e-12)
    np.testing.assert_allclose(by_covariance.variance(q), by_variance.variance(q), atol=1e-12)


@pytest.mark.parametrize(
    "kernel",
    [GaussianKernel(0.7, 0.6), DiagonalKernel(GaussianKernel(0.5), ExponentialKernel(1.0), GaussianKernel(1.0, 0.3))],
)
def test_exact_posterior_with_general_covariances_is_dense_gaussian_conditioning(kernel):
    mean_fn = lambda p: np.sin(p)  # noqa: E731
    gp = GaussianProcess(kernel, mean=mean_fn)
    rng = np.random.default_rng(1)
    lms, obs = POINTS[:6], rng.normal(scale=0.3, size=(6, 3))
    covs = _random_covariances(rng, 6)
    post = gp.posterior(lms, obs, noise=covs)
    everything = np.vstack([lms, POINTS[30:45]])
    mean, cov = _dense_conditioning(
        mean_fn(everything).ravel(), kernel.matrix(everything), np.arange(18), obs.ravel(), _block_diag(covs)
    )
    np.testing.assert_allclose(post.mean(everything).ravel(), mean, atol=1e-10)
    np.testing.assert_allclose(post.covariance(everything), cov, atol=1e-10)
    np.testing.assert_allclose(post.variance(everything).ravel(), np.diagonal(cov), atol=1e-10)
    blocks = post.kernel(everything[:3], everything[:3])
    assert np.abs(blocks * (1 - np.eye(3))).max() > 1e-6  # the covariances couple x, y, z
    samples = post.sample(everything[:4], n=3, rng=0)
    assert samples.shape == (3, 4, 3)
    # conditioning a non-diagonal posterior again goes through the same full solve
    again = post.posterior(POINTS[50:52], rng.normal(size=(2, 3)), noise=_random_covariances(rng, 2))
    assert again.mean(POINTS[:3]).shape == (3, 3)


def test_low_rank_posterior_with_isotropic_covariances_equals_per_variance_noise():
    gp = GaussianProcess(GaussianKernel(0.6, 0.5))
    model = LowRankGP.nystrom(gp, POINTS, n_inducing=40, rng=0)
    ids = [1, 5, 9, 20]
    obs = RNG.normal(scale=0.2, size=(4, 3))
    s = np.array([1e-3, 5e-3, 2e-2, 1e-4])
    a = model.posterior(POINTS[ids], obs, noise=s)
    b = model.posterior(POINTS[ids], obs, noise=s[:, None, None] * np.eye(3))
    np.testing.assert_allclose(b.mean(), a.mean(), atol=1e-10)
    np.testing.assert_allclose(b.covariance(POINTS[:20]), a.covariance(POINTS[:20]), atol=1e-10)
    np.testing.assert_allclose(np.sort(b.eigenvalues), np.sort(a.eigenvalues), atol=1e-10)


@pytest.mark.parametrize("source", ["kernel", "examples"])
def test_low_rank_posterior_with_general_covariances_is_dense_gaussian_conditioning(source):
    rng = np.random.default_rng(2)
    pts = POINTS[:40]
    if source == "kernel":
        model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(0.6, 0.5)), pts, n_inducing=40, rng=0)
    else:  # a PCA model: its basis functions move x, y and z together
        shapes = pts + rng.normal(scale=0.1, size=(8, 1, 3)) * rng.normal(size=(8, 40, 1))
        model = LowRankGP.from_examples(pts, shapes)
    ids = np.array([2, 11, 17, 30])
    obs = rng.normal(scale=0.2, size=(4, 3))
    covs = _random_covariances(rng, 4, scale=0.01)
    post = model.posterior(pts[ids], obs, noise=covs)
    mean, cov = _dense_conditioning(
        model.mean().ravel(), model.covariance(pts), _rows(ids), obs.ravel(), _block_diag(covs)
    )
    np.testing.assert_allclose(post.mean().ravel(), mean, atol=1e-9)
    np.testing.assert_allclose(post.covariance(pts), cov, atol=1e-9)
    np.testing.assert_allclose(post.variance().ravel(), np.diagonal(cov), atol=1e-9)
    assert np.all(np.diff(post.eigenvalues) <= 1e-12)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), sigma=st.floats(0.3, 2.0), scale=st.floats(0.1, 3.0), per_landmark=st.booleans())
def test_log_marginal_likelihood_equals_scikit_learn(seed, sigma, scale, per_landmark):
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-1, 1, (12, 3)), rng.normal(size=(12, 3))
    noise = rng.uniform(0.01, 0.5, 12) if per_landmark else 0.1
    ours = GaussianProcess(GaussianKernel(sigma, scale)).log_marginal_likelihood(x, y, noise)
    sk_kernel = ConstantKernel(scale**2, "fixed") * RBF(sigma / np.sqrt(2), "fixed")  # our sigma is sqrt(2) l
    reg = GaussianProcessRegressor(sk_kernel, alpha=noise, optimizer=None).fit(x, y)
    assert ours == pytest.approx(reg.log_marginal_likelihood_value_, abs=1e-8)


def test_log_marginal_likelihood_with_covariances_equals_scipy():
    rng = np.random.default_rng(3)
    kernel = DiagonalKernel(GaussianKernel(0.8), ExponentialKernel(1.2, 0.5), GaussianKernel([0.5, 1, 2], 2.0))
    gp = GaussianProcess(kernel, mean=lambda p: 0.3 * p)
    x, y = rng.uniform(-1, 1, (9, 3)), rng.normal(size=(9, 3))
    for noise, block in [
        (covs := _random_covariances(rng, 9), _block_diag(covs)),
        (var := rng.uniform(0.01, 0.2, (9, 3)), np.diag(var.ravel())),
    ]:
        expected = multivariate_normal(0.3 * x.ravel(), kernel.matrix(x) + block).logpdf(y.ravel())
        assert gp.log_marginal_likelihood(x, y, noise) == pytest.approx(expected, abs=1e-8)


def _scipy_model_density(model):
    return multivariate_normal(model.mean().ravel(), model.covariance(model.points), allow_singular=True)


@pytest.mark.parametrize("source", ["kernel", "examples", "basis matrix"])
def test_low_rank_densities_equal_scipy(source):
    rng = np.random.default_rng(4)
    pts = POINTS[:25]
    if source == "kernel":
        model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(0.6, 0.5)), pts, n_inducing=25, rank=12, rng=0)
    elif source == "examples":
        model = LowRankGP.from_examples(pts, pts + rng.normal(scale=0.1, size=(7, 25, 3)))
    else:  # a non-orthonormal basis, as in Scalismo's files
        basis = rng.normal(size=(75, 5))
        model = LowRankGP.from_basis_matrix(pts, rng.normal(size=(25, 3)), basis, rng.uniform(0.5, 2.0, 5))
    c = rng.normal(size=model.rank)
    assert model.logpdf(c) == pytest.approx(multivariate_normal(np.zeros(model.rank)).logpdf(c), abs=1e-8)
    field = model.instance(c)
    reference = _scipy_model_density(model)
    assert model.logpdf_of(field) == pytest.approx(reference.logpdf(field.ravel()), abs=1e-8)
    # a field off the model's subspace is scored at its projection
    off = field + rng.normal(scale=0.05, size=field.shape)
    assert model.logpdf_of(off) == pytest.approx(reference.logpdf(model.project(off).ravel()), abs=1e-8)


def test_bad_noise_is_refused():
    gp = GaussianProcess(GaussianKernel(1.0))
    lms = np.zeros((2, 3))
    with pytest.raises(ValueError, match="symmetric"):
        gp.posterior(lms, lms, noise=np.broadcast_to([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]], (2, 3, 3)))
    with pytest.raises(ValueError, match="positive semi-definite"):
        gp.posterior(lms, lms, noise=np.broadcast_to(-np.eye(3), (2, 3, 3)))
    with pytest.raises(ValueError, match=r"\(2, 3, 3\)"):
        gp.posterior(lms, lms, noise=np.ones((3, 3, 3)))
    with pytest.raises(ValueError, match="finite"):
        gp.log_marginal_likelihood(lms, lms, noise=np.full((2, 3, 3), np.nan))
