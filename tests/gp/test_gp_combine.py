"""Kernel algebra: every combination stays positive semi-definite; the mirrored kernel gives symmetric samples."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ffd_notebook import Lattice
from ffd_notebook.gp import (
    BSplineKernel,
    DiagonalKernel,
    ExponentialKernel,
    GaussianKernel,
    GaussianProcess,
    LowRankGP,
    MirroredKernel,
    PosteriorKernel,
    ProductKernel,
)

LATTICE = Lattice((5, 5, 5), spacing=0.5, origin=(-1, -1, -1))
BASE = [
    GaussianKernel(0.7, 1.3),
    ExponentialKernel(0.8, [0.5, 1.0, 2.0]),
    GaussianKernel([0.3, 1.0, 2.0]),
    BSplineKernel(LATTICE, 0.7),
]


def _combine(op: int, a, b):
    return [
        lambda: a + b,
        lambda: a * b,
        lambda: 2.5 * a,
        lambda: [1.0, 0.2, 3.0] * (a * b),
        lambda: MirroredKernel(a + b, axis=1, center=0.2),
        lambda: MirroredKernel(a, axis=0) * b,
        lambda: (
            DiagonalKernel(GaussianKernel(0.4), ExponentialKernel(1.0) * GaussianKernel(2.0), GaussianKernel(1.0)) + a
        ),
    ][op]()


@settings(max_examples=60, deadline=None)
@given(
    op=st.integers(0, 6),
    i=st.integers(0, 3),
    j=st.integers(0, 3),
    points=arrays(np.float64, st.tuples(st.integers(1, 15), st.just(3)), elements=st.floats(-1, 1)),
)
def test_every_combination_is_positive_semidefinite(op, i, j, points):
    k = _combine(op, BASE[i], BASE[j])
    K = k.matrix(points)
    np.testing.assert_allclose(K, K.T, atol=1e-12)
    eig = np.linalg.eigvalsh(K)
    assert eig.min() >= -1e-9 * max(eig.max(), 1e-300)
    np.testing.assert_allclose(k.diagonal(points), np.stack([np.diagonal(c) for c in k.components(points, points)]))


def test_product_and_mirror_formulas():
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(4, 3)), rng.normal(size=(5, 3))
    g, e = GaussianKernel(1.0, 2.0), ExponentialKernel(1.5)
    np.testing.assert_allclose((g * e).matrix(x, y), g.matrix(x, y) * e.matrix(x, y))
    assert isinstance(g * e, ProductKernel)
    # stationary kernel: k_sym(x, y) = k(x, y) + k(x, M y) M
    m = np.diag([1.0, -1.0, 1.0])
    sym = MirroredKernel(g, axis=1, center=0.0)
    my = y * [1, -1, 1]
    expected = g(x, y) + g(x, my) @ m
    np.testing.assert_allclose(sym(x, y), expected, atol=1e-12)


def test_mirrored_samples_are_mirror_symmetric():
    rng = np.random.default_rng(1)
    half = rng.uniform([0.05, -1, -1], [1, 1, 1], (40, 3))
    mirrored = half * [-1, 1, 1]
    points = np.vstack([half, mirrored, [[0.0, 0.3, 0.2]]])  # and a point on the plane
    gp = GaussianProcess(MirroredKernel(GaussianKernel(0.5, 2.0) + ExponentialKernel(1.0), axis=0))
    u = gp.sample(points, n=5, rng=2)
    np.testing.assert_allclose(u[:, 40:80], u[:, :40] * [-1, 1, 1], atol=1e-9)
    assert np.abs(u[:, 80, 0]).max() < 1e-9  # on the plane nothing moves across it
    assert np.abs(u[:, :40]).max() > 0.1  # and the samples are not trivially zero
    # a plane off the origin: mirror pairs up to rounding still share one draw
    off = MirroredKernel(GaussianKernel(0.5), axis=2, center=0.7)
    pts = np.vstack([half, off.mirror(half)])
    v = GaussianProcess(off).sample(pts, n=2, rng=3)
    np.testing.assert_allclose(v[:, 40:], v[:, :40] * [1, 1, -1], atol=1e-9)


def test_mirrored_low_rank_model_on_a_symmetric_point_set_is_symmetric():
    rng = np.random.default_rng(4)
    half = rng.uniform([0.05, -1, -1], [1, 1, 1], (100, 3))
    pts = np.vstack([half, half * [-1, 1, 1]])
    model = LowRankGP.nystrom(GaussianProcess(MirroredKernel(GaussianKernel(0.6))), pts, n_inducing=200, rng=0)
    u = model.sample(3, rng=5)
    np.testing.assert_allclose(u[:, 100:], u[:, :100] * [-1, 1, 1], atol=1e-6 * np.abs(u).max())


def test_non_diagonal_kernels_do_not_combine_or_approximate():
    post = PosteriorKernel(GaussianKernel(1.0), np.zeros((1, 3)), noise=np.eye(3)[None] + 0.1)
    assert not post.is_diagonal
    with pytest.raises(TypeError, match="not a diagonal kernel"):
        _ = post + GaussianKernel(1.0)
    with pytest.raises(TypeError, match="diagonal kernel"):
        LowRankGP.nystrom(GaussianProcess(post), np.zeros((3, 3)), n_inducing=3)
    with pytest.raises(ValueError, match="axis"):
        MirroredKernel(GaussianKernel(1.0), axis=3)
