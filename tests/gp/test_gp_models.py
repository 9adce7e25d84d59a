"""Shape models from examples (PCA), augmented models, model metrics and the pivoted-Cholesky stopping rules."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ffd_notebook import read_mesh
from ffd_notebook.gp import (
    GaussianKernel,
    GaussianProcess,
    LowRankGP,
    compactness,
    generalization,
    specificity,
)

FACE = Path(__file__).resolve().parents[3] / "shared" / "data" / "face" / "template.ply"
TRUE_RANK = 6


@pytest.fixture(scope="module")
def face():
    """Every 40th vertex of the 53k face (world units: about 1e5 across)."""
    return np.asarray(read_mesh(FACE).points, dtype=np.float64)[::40]


@pytest.fixture(scope="module")
def examples(face):
    """Random deformations of the face from a rank-6 model: the true rank of the example set is 6."""
    truth = LowRankGP.nystrom(
        GaussianProcess(GaussianKernel(sigma=5e4, scale=3e3)), face, n_inducing=100, rank=TRUE_RANK, rng=0
    )
    return truth, face + truth.sample(20, rng=1)


def test_model_from_examples_is_the_pca_of_the_examples(face):
    rng = np.random.default_rng(2)
    shapes = face + rng.normal(scale=100.0, size=(9, len(face), 3))
    model = LowRankGP.from_examples(face, shapes)
    data = (shapes - face).reshape(9, -1)
    centred = data - data.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    assert model.rank == 8  # n - 1
    np.testing.assert_allclose(model.eigenvalues, sv[:8] ** 2 / 8, rtol=1e-10)  # Scalismo divides by n - 1
    np.testing.assert_allclose(model.mean().ravel(), data.mean(axis=0), atol=1e-9)
    basis = model.basis_matrix()
    np.testing.assert_allclose(np.abs(basis.T @ vt[:8].T), np.eye(8), atol=1e-8)  # same components up to sign
    np.testing.assert_allclose(model.covariance(face[:10]), np.cov(data[:, :30], rowvar=False), atol=1e-6)


def test_true_rank_is_recovered_and_the_metrics_show_it(face, examples):
    truth, shapes = examples
    model = LowRankGP.from_examples(face, shapes)
    assert model.rank == TRUE_RANK
    # the data model spans the true model's basis functions
    for k in range(TRUE_RANK):
        phi = truth.basis_function(k)
        assert np.linalg.norm(model.project(phi + model.mean()) - model.mean() - phi) < 1e-8 * np.linalg.norm(phi)
    comp = compactness(model)
    assert comp.shape == (TRUE_RANK,) and np.all(np.diff(comp) > 0)
    np.testing.assert_allclose(comp[-1], model.kept_variance)
    assert model.captured_variance == pytest.approx(1.0)
    gen = generalization(face, shapes[:10])
    assert np.all(np.diff(gen) <= 1e-9 * gen[0])  # more components never generalize worse
    assert gen[TRUE_RANK - 1] < 1e-9 * gen[0]  # six components describe any unseen example exactly
    assert gen[TRUE_RANK - 2] > 1e-3 * gen[0]  # five do not
    spec = specificity(model, shapes, n_samples=20, rng=3)
    assert spec.shape == (TRUE_RANK,) and np.all(spec > 0)
    assert spec[-1] > spec[0]  # samples with all modes stray further from the examples than one-mode ones


def test_rank_and_variance_truncation(face, examples):
    _, shapes = examples
    model = LowRankGP.from_examples(face, shapes, rank=3)
    assert model.rank == 3
    part = LowRankGP.from_examples(face, shapes, variance=0.9)
    assert part.kept_variance / LowRankGP.from_examples(face, shapes).kept_variance >= 0.9


def test_augmented_model_adds_the_covariances(face):
    rng = np.random.default_rng(4)
    pts = face[:120]
    data = LowRankGP.from_examples(pts, pts + rng.normal(scale=50.0, size=(5, len(pts), 3)))
    bias_gp = GaussianProcess(GaussianKernel(3e4, 20.0), mean=lambda p: np.full_like(p, 5.0))
    bias = LowRankGP.nystrom(bias_gp, pts, n_inducing=len(pts), rank=30, rng=0)
    both = data.augment(bias)
    assert both.rank == data.rank + bias.rank
    np.testing.assert_allclose(both.covariance(pts), data.covariance(pts) + bias.covariance(pts), atol=1e-6)
    np.testing.assert_allclose(both.mean(), data.mean() + bias.mean(), atol=1e-9)
    assert np.all(np.diff(both.eigenvalues) <= 1e-9)
    # instance / coefficient round trip across the joined basis, and a posterior on it
    c = rng.normal(size=both.rank)
    np.testing.assert_allclose(both.coefficients(both.instance(c)), c, atol=1e-6)
    post = both.posterior(pts[:3], both.mean(pts[:3]) + 10.0, noise=1e-4)
    np.testing.assert_allclose(post.mean()[:3], both.mean()[:3] + 10.0, atol=0.05)
    with pytest.raises(ValueError, match="same points"):
        data.augment(LowRankGP.from_examples(pts[:10], [pts[:10], pts[:10] + 1.0]))


def test_data_model_extends_to_other_points_by_nearest_vertex(face):
    rng = np.random.default_rng(5)
    pts = face[:50]
    model = LowRankGP.from_examples(pts, pts + rng.normal(size=(4, 50, 3)))
    c = rng.normal(size=model.rank)
    near = pts[[3, 7]] + 1e-3
    np.testing.assert_allclose(model.instance(c, near), model.instance(c)[[3, 7]])


def test_pivoted_cholesky_stops_at_rank_or_tolerance_and_reports_the_variance(face):
    gp = GaussianProcess(GaussianKernel(3e4, 1.0))
    pts = face[:400]
    total = 3 * len(pts)  # scale 1: each point and component has variance 1
    by_rank = LowRankGP.pivoted_cholesky(gp, pts, tolerance=0.0, max_rank=7)
    assert by_rank.rank == 21
    for relative in (1e-1, 1e-3):
        model = LowRankGP.pivoted_cholesky(gp, pts, tolerance=relative)
        assert model.total_variance == pytest.approx(total)
        assert 1 - model.captured_variance <= relative * (1 + 1e-9)
    for absolute in (10.0, 0.01):
        model = LowRankGP.pivoted_cholesky(gp, pts, tolerance=0.0, absolute_tolerance=absolute)
        residual = model.total_variance - model.kept_variance
        assert residual <= 3 * absolute * (1 + 1e-9)  # the tolerance applies per scalar component
        assert model.kept_variance == pytest.approx(model.eigenvalues.sum())
    with pytest.raises(ValueError, match="absolute_tolerance"):
        LowRankGP.pivoted_cholesky(gp, pts, absolute_tolerance=-1.0)


def test_bad_examples_are_refused(face):
    with pytest.raises(ValueError, match="at least 2"):
        LowRankGP.from_examples(face, [face])
    with pytest.raises(ValueError, match="not in correspondence"):
        LowRankGP.from_examples(face, [face, face[:-1]])
    with pytest.raises(ValueError, match="at least 3"):
        generalization(face, [face, face])
