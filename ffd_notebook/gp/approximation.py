"""Eigenpairs of a kernel matrix over a point set without forming it: Nystrom and pivoted Cholesky.

Both approximate the ``N x N`` matrix of one scalar kernel component by ``B B^T`` with a thin
``B``; the eigenpairs then come from the small ``B^T B``. Used by :class:`~ffd_notebook.gp.LowRankGP`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray
from tqdm.auto import tqdm

from .kernels import Kernel

__all__ = ["ScalarBasis", "choose_rank", "nystrom_basis", "pivoted_cholesky_basis", "select"]

_CHUNK = 4096  # rows of K(X, Z) evaluated at once: bounded temporary memory
_RELATIVE_FLOOR = 1e-10  # eigenvalues below this fraction of the largest are numerical noise


@dataclass(frozen=True)
class ScalarBasis:
    """Eigen-decomposition of one scalar component's approximate kernel matrix ``B B^T``.

    ``B = F @ P`` over the point set and ``B(x) = k(x, Z) @ X`` anywhere: Nystrom keeps
    ``F = K_XZ`` and ``P = X = K_ZZ^(-1/2)`` (one big product fewer than forming ``B``),
    pivoted Cholesky keeps ``F = B = L`` with ``P = I`` and ``X = L_ZZ^-T``.
    """

    kernel_index: int
    matrix: NDArray[np.float64]  # F (N, m)
    right: NDArray[np.float64] | None  # P (m, m'), None for the identity
    to_factor: NDArray[np.float64]  # X (m, m')
    inducing: NDArray[np.float64]
    eigenvalues: NDArray[np.float64]  # of B^T B, descending
    eigenvectors: NDArray[np.float64]  # columns

    @classmethod
    def build(
        cls,
        kernel_index: int,
        matrix: NDArray[np.float64],
        right: NDArray[np.float64] | None,
        to_factor: NDArray[np.float64],
        inducing: NDArray[np.float64],
    ) -> ScalarBasis:
        """Eigen-decompose the small ``P^T F^T F P`` and keep the eigenpairs above the noise floor."""
        gram = matrix.T @ matrix
        if right is not None:
            gram = right.T @ gram @ right
        s, w = np.linalg.eigh(gram)
        s, w = s[::-1], w[:, ::-1]
        keep = s > _RELATIVE_FLOOR * max(s[0], 0.0)
        return cls(kernel_index, matrix, right, to_factor, inducing, s[keep], w[:, keep])

    def vectors(self, used: NDArray[np.int64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Orthonormal eigenvectors as rows ``(len(used), N)`` over the point set, and their extension."""
        w = self.eigenvectors[:, used] / np.sqrt(self.eigenvalues[used])
        if self.right is not None:
            w = self.right @ w
            return w.T @ self.matrix.T, w
        return w.T @ self.matrix.T, self.to_factor @ w


def nystrom_basis(
    kernel: Kernel, c: int, points: NDArray[np.float64], inducing: NDArray[np.float64], progress: bool
) -> ScalarBasis:
    """Nystrom basis of kernel component ``c``: ``K ~= K_XZ K_ZZ^+ K_ZX`` (``K_XZ`` evaluated in chunks)."""
    kzz = kernel.components(inducing, inducing)[c]
    w, v = np.linalg.eigh(kzz)
    keep = w > _RELATIVE_FLOOR * w.max()
    inv_sqrt = v[:, keep] / np.sqrt(w[keep])
    kxz = np.empty((len(points), len(inducing)))
    for s in tqdm(range(0, len(points), _CHUNK), desc="K(X, Z)", disable=not progress, leave=False):
        kxz[s : s + _CHUNK] = kernel.components(points[s : s + _CHUNK], inducing)[c]
    return ScalarBasis.build(c, kxz, inv_sqrt, inv_sqrt, inducing)


def pivoted_cholesky_basis(
    kernel: Kernel,
    c: int,
    points: NDArray[np.float64],
    tolerance: float,
    max_rank: int,
    progress: bool,
    absolute_tolerance: float = 0.0,
) -> ScalarBasis:
    """Pivoted-Cholesky basis of kernel component ``c``.

    Stops at ``max_rank`` pivots or when ``trace(residual)`` is at most ``tolerance * trace(K)``
    or at most ``absolute_tolerance``.
    """
    residual = kernel.diagonal(points)[c].copy()
    stop = max(tolerance * residual.sum(), absolute_tolerance)
    factor = np.zeros((max_rank, len(points)))  # row k is column k of L: contiguous updates
    pivots = []
    bar = tqdm(total=max_rank, desc="pivoted Cholesky", disable=not progress, leave=False)
    for k in range(max_rank):
        if residual.sum() <= stop:
            break
        p = int(np.argmax(residual))
        col = kernel.components(points, points[p : p + 1])[c][:, 0] - factor[:k, p] @ factor[:k]
        factor[k] = col / np.sqrt(residual[p])
        residual -= factor[k] ** 2
        residual[p] = 0.0
        np.maximum(residual, 0.0, out=residual)
        pivots.append(p)
        bar.update()
    bar.close()
    factor = factor[: len(pivots)].T
    lzz = factor[pivots]  # lower triangular in pivot order: K_ZZ = lzz lzz^T
    to_factor = sla.solve_triangular(lzz, np.eye(len(pivots)), lower=True).T
    return ScalarBasis.build(c, factor, None, to_factor, points[pivots])


def select(bases: list[ScalarBasis], n_components: int) -> tuple[NDArray, NDArray, NDArray]:
    """All 3D basis functions sorted by eigenvalue: (eigenvalues, output axis, (basis, vector) index)."""
    eigs, axes, whichs = [], [], []
    for b, basis in enumerate(bases):
        outputs = (0, 1, 2) if n_components == 1 else (b,)
        for a in outputs:
            eigs.append(basis.eigenvalues)
            axes.append(np.full(len(basis.eigenvalues), a))
            whichs.append(np.column_stack([np.full(len(basis.eigenvalues), b), np.arange(len(basis.eigenvalues))]))
    eig, axis, which = np.concatenate(eigs), np.concatenate(axes), np.concatenate(whichs)
    order = np.lexsort((axis, which[:, 1], -eig))
    return eig[order], axis[order], which[order]


def choose_rank(eigenvalues: NDArray, total: float, rank: int | None, variance: float | None) -> int:
    """How many sorted ``eigenvalues`` to keep: ``rank``, the fewest holding ``variance`` of ``total``, or all."""
    if rank is not None and variance is not None:
        raise ValueError("give either rank or variance, not both")
    if rank is not None:
        if rank < 1:
            raise ValueError(f"rank must be at least 1, got {rank}")
        return min(int(rank), len(eigenvalues))
    if variance is not None:
        if not 0 < variance <= 1:
            raise ValueError(f"variance must be a fraction in (0, 1], got {variance}")
        captured = np.cumsum(eigenvalues) / total
        return min(int(np.searchsorted(captured, variance * (1 - 1e-12))) + 1, len(eigenvalues))
    return len(eigenvalues)
