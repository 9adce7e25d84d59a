"""The small-matrix algebra behind :class:`~ffd_notebook.gp.LowRankGP`.

A model's factor ``F`` has shape ``(3, q, r)``: component ``a`` of basis column ``k`` is the
field ``U F[a, :, k]`` over the points (see :mod:`~ffd_notebook.gp.space`). Kernel models are
*separable*: each column moves one component only, and a posterior with noise given as variances
keeps that, so each component is solved on its own (``L x L`` systems). Data models and noise
with 3x3 covariances couple the components (``3L x 3L``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from .._util.blas import one_blas_thread
from .linalg import cholesky
from .noise import observation_noise
from .space import Space

__all__ = ["condition", "eigen_form", "least_squares", "pointwise_variance", "subspace_logpdf", "weights"]

RELATIVE_FLOOR = 1e-10  # variances below this fraction of the largest are numerical noise
_LOG_2PI = float(np.log(2.0 * np.pi))


def column_axes(factor: NDArray[np.float64]) -> tuple[bool, NDArray[np.int64]]:
    """Whether every column moves at most one component, and which component each moves (most)."""
    touch = np.any(factor != 0, axis=1)  # (3, r)
    return bool(np.all(touch.sum(axis=0) <= 1)), np.argmax(touch, axis=0)


def weights(factor: NDArray[np.float64], coefficients: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vector weights ``(q, 3)`` of coefficients ``(r,)``: column ``a`` is ``F[a] @ c``."""
    return np.einsum("aqk,k->qa", factor, coefficients)


def _gram_of_columns(factor: NDArray[np.float64], gram: NDArray[np.float64]) -> NDArray[np.float64]:
    """``B^T B`` for the field matrix ``B`` of the factor's columns, ``(r, r)``."""
    return sum(factor[a].T @ gram @ factor[a] for a in range(3))


def eigen_form(factor: NDArray[np.float64], gram: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """An equivalent factor whose columns are orthogonal fields sorted by decreasing variance, and the variances."""
    separable, axes = column_axes(factor)
    out = np.zeros_like(factor)
    eig = np.zeros(factor.shape[2])
    groups = [np.flatnonzero(axes == a) for a in range(3)] if separable else [np.arange(factor.shape[2])]
    for cols in groups:
        if len(cols) == 0:
            continue
        sub = factor[:, :, cols]
        w, v = np.linalg.eigh(_gram_of_columns(sub, gram))
        out[:, :, cols] = sub @ v
        eig[cols] = np.maximum(w, 0.0)
    order = np.argsort(-eig, kind="stable")
    return out[:, :, order], eig[order]


def pointwise_variance(factor: NDArray[np.float64], vectors_t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Variance of each component at each point, ``(N, 3)``, for vectors ``(q, N)`` there."""
    out = np.empty((vectors_t.shape[1], 3))
    done: list[tuple[NDArray, int]] = []
    for a in range(3):
        t = factor[a][:, np.any(factor[a] != 0, axis=0)]
        same = next((b for f, b in done if f.shape == t.shape and np.array_equal(f, t)), None)
        if same is None:
            tu = t.T @ vectors_t
            out[:, a] = np.einsum("kn,kn->n", tu, tu)
            done.append((t, a))
        else:  # isotropic models: the three components share one factor
            out[:, a] = out[:, same]
    return out


def _projections(factor: NDArray, space: Space, residual: NDArray) -> tuple[NDArray, NDArray]:
    """``B^T r`` ``(r,)`` and ``B^T B`` ``(r, r)`` for a residual field ``(N, 3)``."""
    projected = space.vectors_t @ residual  # (q, 3)
    return sum(factor[a].T @ projected[:, a] for a in range(3)), _gram_of_columns(factor, space.gram)


def least_squares(factor: NDArray, space: Space, residual: NDArray, noise: float) -> NDArray[np.float64]:
    """Coefficients minimising ``|B c - r|^2 + noise |c|^2``."""
    rhs, gram = _projections(factor, space, residual)
    return np.linalg.lstsq(gram + noise * np.eye(len(gram)), rhs, rcond=None)[0]


def subspace_logpdf(factor: NDArray, space: Space, residual: NDArray) -> float:
    """Log density of ``N(0, B B^T)`` on its support at the projection of the residual.

    With ``B^T B = W diag(lambda) W^T`` the projection's coordinates on the orthonormal basis
    ``B W lambda^-1/2`` are ``lambda^-1/2 W^T B^T r``, independent ``N(0, lambda_k)``.
    """
    rhs, gram = _projections(factor, space, residual)
    lam, w = np.linalg.eigh(gram)
    keep = lam > RELATIVE_FLOOR * max(lam.max(initial=0.0), 0.0)
    z = w[:, keep].T @ rhs
    lam = lam[keep]
    return float(np.sum(-0.5 * z**2 / lam**2 - 0.5 * np.log(lam)) - 0.5 * len(lam) * _LOG_2PI)


def _shrunk(t: NDArray[np.float64], g: NDArray[np.float64]) -> NDArray[np.float64]:
    """``t @ sqrt(I - g^T g)`` through the thin SVD of ``g`` (its singular values are at most 1)."""
    _, sv, vt = np.linalg.svd(g, full_matrices=False)
    shrink = 1.0 - np.sqrt(np.clip(1.0 - sv**2, 0.0, 1.0))
    return t - ((t @ vt.T) * shrink) @ vt


def condition(
    factor: NDArray[np.float64], at_landmarks: NDArray[np.float64], residual: NDArray[np.float64], noise: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Posterior factor and mean-weight step after observing ``residual (L, 3)`` where the vectors are ``(L, q)``.

    The coefficients' posterior is ``N(G^T C^-1 r, I - G^T G)`` with ``C`` the Cholesky factor of
    ``Q Q^T + noise`` and ``G = C^-1 Q``, ``Q`` the factor at the landmarks. Every matrix here is
    landmark- or rank-sized, so the BLAS runs on one thread (:func:`ffd_notebook._util.blas.one_blas_thread`:
    20 landmarks with 3x3 noise on a rank-49 model, 292 ms with OpenBLAS's threads on a busy
    2-core machine, 12 ms on one).
    """
    with one_blas_thread():
        return _condition(factor, at_landmarks, residual, noise)


def _condition(
    factor: NDArray[np.float64], at_landmarks: NDArray[np.float64], residual: NDArray[np.float64], noise: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    n_lm = len(residual)
    nz = observation_noise(noise, n_lm)
    separable, axes = column_axes(factor)
    new = factor.copy()
    step = np.zeros((factor.shape[1], 3))
    if nz.is_diagonal and separable:
        assert nz.variances is not None  # diagonal noise is given by its variances
        for a in range(3):
            cols = np.flatnonzero(axes == a)
            if len(cols) == 0:
                continue
            t = factor[a][:, cols]
            q = at_landmarks @ t
            chol = cholesky(q @ q.T + np.diag(nz.variances[:, a]))
            g = sla.solve_triangular(chol, q, lower=True)
            step[:, a] = t @ (g.T @ sla.solve_triangular(chol, residual[:, a], lower=True))
            new[a][:, cols] = _shrunk(t, g)
        return new, step
    q = np.stack([at_landmarks @ factor[a] for a in range(3)], axis=1).reshape(3 * n_lm, -1)  # row 3 i + a
    chol = cholesky(q @ q.T + nz.block_matrix())
    g = sla.solve_triangular(chol, q, lower=True)
    coef = g.T @ sla.solve_triangular(chol, residual.ravel(), lower=True)
    for a in range(3):
        step[:, a] = factor[a] @ coef
        new[a] = _shrunk(factor[a], g)
    return new, step
