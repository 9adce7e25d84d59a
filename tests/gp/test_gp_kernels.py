"""Kernels: formulas, symmetry and positive semi-definiteness, the B-spline kernel as random FFDs."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ffd_notebook import FFD, Lattice
from ffd_notebook.gp import (
    BSplineKernel,
    DiagonalKernel,
    ExponentialKernel,
    GaussianKernel,
    GaussianProcess,
    bspline_weights,
)

LATTICE = Lattice((5, 6, 5), spacing=(0.4, 0.3, 0.45), origin=(-0.5, -0.6, -0.4))

KERNELS = {
    "gaussian": GaussianKernel(sigma=0.7, scale=1.3),
    "exponential": ExponentialKernel(sigma=0.8, scale=0.5),
    "anisotropic": GaussianKernel(sigma=[0.3, 1.0, 2.0], scale=[1.0, 0.5, 2.0]),
    "bspline": BSplineKernel(LATTICE, scale=0.7),
    "sum and scaled": 2.0 * GaussianKernel(0.5) + [1.0, 0.1, 3.0] * ExponentialKernel(1.0),
    "diagonal": DiagonalKernel(GaussianKernel(0.3), ExponentialKernel(1.0), BSplineKernel(LATTICE)),
}

point_sets = arrays(np.float64, st.tuples(st.integers(1, 12), st.just(3)), elements=st.floats(-1, 1))


@pytest.mark.parametrize("name", KERNELS)
@settings(max_examples=25, deadline=None)
@given(points=point_sets)
def test_kernel_matrix_is_symmetric_positive_semidefinite(name, points):
    k = KERNELS[name]
    K = k.matrix(points)
    assert K.shape == (3 * len(points), 3 * len(points))
    np.testing.assert_allclose(K, K.T, atol=1e-12)
    assert np.linalg.eigvalsh(K).min() > -1e-9 * max(1.0, np.abs(K).max())
    np.testing.assert_allclose(k.diagonal(points), np.stack([np.diagonal(c) for c in k.components(points, points)]))


@pytest.mark.parametrize("name", KERNELS)
def test_blocks_and_matrix_layout_agree(name):
    k = KERNELS[name]
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-1, 1, (4, 3)), rng.uniform(-1, 1, (5, 3))
    blocks, K = k(x, y), k.matrix(x, y)
    assert blocks.shape == (4, 5, 3, 3)
    for i, j, a, b in [(0, 0, 0, 0), (3, 4, 2, 2), (1, 2, 0, 1), (2, 3, 1, 1)]:
        assert K[3 * i + a, 3 * j + b] == blocks[i, j, a, b]
    off_diagonal = blocks * (1 - np.eye(3))
    assert not off_diagonal.any()


def test_gaussian_and_exponential_formulas():
    rng = np.random.default_rng(2)
    x, y = rng.normal(size=(6, 3)), rng.normal(size=(7, 3))
    d = np.linalg.norm(x[:, None] - y[None], axis=-1)
    np.testing.assert_allclose(GaussianKernel(1.5, 2.0).components(x, y)[0], 4.0 * np.exp(-(d**2) / 1.5**2))
    np.testing.assert_allclose(ExponentialKernel(1.5, 2.0).components(x, y)[0], 4.0 * np.exp(-d / 1.5**2))
    sig = np.array([0.5, 1.0, 2.0])
    d2 = (((x[:, None] - y[None]) / sig) ** 2).sum(-1)
    np.testing.assert_allclose(GaussianKernel(sig).components(x, y)[0], np.exp(-d2))


def test_sum_and_scaling_combine_covariances():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(5, 3))
    a, b = GaussianKernel(0.5), ExponentialKernel(1.0, scale=2.0)
    np.testing.assert_allclose((a + b).matrix(x), a.matrix(x) + b.matrix(x))
    np.testing.assert_allclose((3.0 * a).matrix(x), 3.0 * a.matrix(x))
    per_component = [1.0, 2.0, 0.5] * a
    assert per_component.n_components == 3
    np.testing.assert_allclose(per_component(x, x)[..., 1, 1], 2.0 * a.components(x, x)[0])


@pytest.mark.parametrize("bad", [0.0, -1.0, [1.0, 2.0], np.nan])
def test_bad_parameters_are_rejected(bad):
    with pytest.raises(ValueError, match="sigma"):
        GaussianKernel(sigma=bad)


def test_points_must_be_n_by_3():
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        GaussianKernel(1.0).components(np.zeros((4, 2)), np.zeros((4, 3)))


# ---------------------------------------------------------------------- B-spline kernel = random FFD
def _points_in_and_around(lattice, n, seed):
    """Points filling the lattice box and a little beyond (outside points must get zero weight)."""
    uvw = np.random.default_rng(seed).uniform(-1.5, np.array(lattice.shape) + 0.5, (n, 3))
    return lattice.to_world(uvw)


@pytest.mark.parametrize("border", ["zero", "clamp"])
@pytest.mark.parametrize("rotation", [None, np.diag([1.0, 1.0, -1.0]) @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])])
def test_bspline_weights_reproduce_the_ffd_engine(rotation, border):
    lattice = Lattice((5, 4, 6), spacing=(1.0, 2.0, 0.5), origin=(3.0, -1.0, 2.0), rotation=rotation, border=border)
    lattice.offsets[...] = np.random.default_rng(4).normal(size=lattice.offsets.shape)
    points = _points_in_and_around(lattice, 300, seed=5)
    W = bspline_weights(lattice, points)
    np.testing.assert_allclose(W @ lattice.offsets.reshape(-1, 3), FFD(lattice).displacement(points), atol=1e-12)


@pytest.mark.parametrize("border", ["zero", "clamp"])
@pytest.mark.parametrize("seed", [0, 7, 123])
def test_bspline_gp_sample_is_the_ffd_of_the_same_random_offsets(seed, border):
    lattice = LATTICE.copy()
    lattice.border = border  # the kernel follows the lattice's border rule, as FFD(lattice) does
    kernel = BSplineKernel(lattice, scale=0.25)
    points = _points_in_and_around(lattice, 200, seed)
    sample = GaussianProcess(kernel).sample(points, n=1, rng=seed)[0]
    random_ffd = FFD(kernel.random_lattice(seed))
    assert random_ffd.border == border
    np.testing.assert_allclose(sample, random_ffd.displacement(points), atol=1e-12)
    assert np.abs(sample).max() > 0.05  # a real deformation, not zeros
    diagonal = np.diagonal(kernel.components(points, points), axis1=1, axis2=2)
    np.testing.assert_allclose(kernel.diagonal(points), diagonal, atol=1e-12)


def test_bspline_kernel_is_the_covariance_of_random_ffds():
    # empirical covariance of 3000 random FFDs (offsets i.i.d. N(0, s^2), drawn outside the GP code)
    scale, n = 0.5, 3000
    points = _points_in_and_around(LATTICE, 6, seed=8)
    lattice = LATTICE.copy()
    rng = np.random.default_rng(9)
    ffd = FFD(lattice)
    fields = np.empty((n, len(points), 3))
    for i in range(n):
        lattice.offsets[...] = rng.normal(0.0, scale, lattice.offsets.shape)
        fields[i] = ffd.displacement(points)
    empirical = np.cov(fields.reshape(n, -1), rowvar=False)  # (3N, 3N), same layout as Kernel.matrix
    expected = BSplineKernel(LATTICE, scale).matrix(points)
    # standard error of a covariance estimate ~ var * sqrt(2 / n) ~ 0.026 var: allow 5 of them
    assert np.abs(empirical - expected).max() < 5 * np.sqrt(2 / n) * expected.max()
