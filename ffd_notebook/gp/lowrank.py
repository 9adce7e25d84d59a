"""Low-rank Gaussian processes on a point set (a mesh's vertices).

The process is approximated as ``u = mean + sum_k sqrt(lambda_k) alpha_k phi_k`` with
``alpha_k ~ N(0, 1)``, ``phi_k`` orthonormal eigenfunctions over the point set and
``lambda_k`` sorted eigenvalues (Scalismo's ``LowRankGaussianProcess``). Two ways to get the
eigenpairs of the ``N x N`` kernel matrix without forming it:

- :meth:`LowRankGP.nystrom`: ``m`` random inducing points ``Z``; ``K ~= K_XZ K_ZZ^+ K_ZX``.
- :meth:`LowRankGP.pivoted_cholesky`: greedy pivots until the trace of the residual is below a
  relative tolerance (the same approximation with pivots chosen where the error is largest).

Both give a factor ``B`` with ``B B^T`` the approximation, then the eigenpairs from the small
``B^T B``. With a kernel that is isotropic in the output (``k_s I3``) only the scalar problem is
solved; each scalar eigenvector gives three basis fields (x, y, z). Diagonal kernels solve one
scalar problem per component.

The eigenfunctions extend to any point through the inducing points (``phi(x) = k(x, Z) E``), so
landmarks need not be vertices.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP
>>> pts = np.random.default_rng(0).random((2000, 3))
>>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(0.5)), pts, n_inducing=100, rank=30, rng=0)
>>> model.rank, bool(np.all(np.diff(model.eigenvalues) <= 0))
(30, True)
>>> model.sample(n=2, rng=1).shape
(2, 2000, 3)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from .approximation import choose_rank, nystrom_basis, pivoted_cholesky_basis, select
from .kernels import Kernel, as_points
from .linalg import as_generator, cholesky
from .process import GaussianProcess, noise_variances

__all__ = ["LowRankGP"]


@dataclass(frozen=True)
class _Extension:
    """Scalar eigenvectors of one kernel component as functions: ``U(x) = k_c(x, Z) @ E``."""

    kernel_index: int
    inducing: NDArray[np.float64]  # (m, 3)
    extension: NDArray[np.float64]  # (m, q_c)
    columns: slice  # where these vectors sit among the model's scalar vectors


@dataclass(frozen=True)
class _Space:
    """What a model and its posteriors share: the point set, its scalar vectors, the prior mean."""

    points: NDArray[np.float64]
    # U^T (q, N): orthonormal rows within each kernel component. Stored transposed because
    # products with a few columns, W^T U^T, run several times faster that way in OpenBLAS.
    vectors_t: NDArray[np.float64]
    extensions: list[_Extension]
    kernel: Kernel
    base_mean: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    base_values: NDArray[np.float64]  # base_mean(points)
    total_variance: float

    def vectors_at(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty((len(points), self.vectors_t.shape[0]))
        for ext in self.extensions:
            out[:, ext.columns] = self.kernel.components(points, ext.inducing)[ext.kernel_index] @ ext.extension
        return out


class LowRankGP:
    """A Gaussian process on a point set, approximated by its leading eigenfunctions.

    Build one with :meth:`nystrom` or :meth:`pivoted_cholesky`. Coefficients index the basis
    functions in order of decreasing :attr:`eigenvalues`. Internally the displacement is
    ``mean + U T alpha`` with ``U`` orthonormal scalar vectors over the points and a small
    factor ``T``; a posterior only changes ``T`` and the mean (cheap), and is put back in
    eigen form (sorted eigenvalues) only when eigenvalues or coefficients are asked for.

    Attributes
    ----------
    points : (N, 3) ndarray
        The point set.
    total_variance : float
        Sum of the exact prior variance over the points and components (the trace of ``K``).
    """

    def __init__(
        self,
        space: _Space,
        factor: NDArray[np.float64],
        axes: NDArray[np.int64],
        mean_shift: NDArray[np.float64],
        eigen_form: bool = False,
    ) -> None:
        self._space = space
        self.points = space.points
        self.total_variance = space.total_variance
        self._factor, self._axes = factor, axes  # T (q, rank) and the displacement axis of each column
        self._mean_shift = mean_shift  # M (q, 3): mean = base mean + U M
        self._mean_values = space.base_values + (mean_shift.T @ space.vectors_t).T
        self._eigen = (factor, axes, np.einsum("qk,qk->k", factor, factor)) if eigen_form else None

    # ------------------------------------------------------------------ construction
    @classmethod
    def nystrom(
        cls,
        process: GaussianProcess,
        points: ArrayLike,
        n_inducing: int = 500,
        rank: int | None = None,
        variance: float | None = None,
        rng: int | np.random.Generator | None = None,
        progress: bool = False,
    ) -> LowRankGP:
        """Nystrom approximation from ``n_inducing`` points drawn at random from ``points``.

        Parameters
        ----------
        process : GaussianProcess
            The process to approximate (its kernel and mean).
        points : (N, 3) array_like
            The point set (a mesh's vertices).
        n_inducing : int
            Inducing points ``m``; the rank is at most ``3 m``.
        rank, variance : optional
            Keep ``rank`` basis functions, or the fewest that capture the fraction ``variance``
            of the total variance; by default all numerically non-zero ones.
        rng : int or Generator, optional
            Chooses the inducing points.
        progress : bool
            Show a progress bar while the kernel matrix is evaluated.
        """
        pts = as_points(points)
        gen = as_generator(rng)
        inducing = pts[np.sort(gen.choice(len(pts), size=min(n_inducing, len(pts)), replace=False))]
        bases = [nystrom_basis(process.kernel, c, pts, inducing, progress) for c in range(process.kernel.n_components)]
        return cls._from_bases(process, pts, bases, rank, variance)

    @classmethod
    def pivoted_cholesky(
        cls,
        process: GaussianProcess,
        points: ArrayLike,
        tolerance: float = 1e-2,
        max_rank: int = 1000,
        rank: int | None = None,
        variance: float | None = None,
        progress: bool = False,
    ) -> LowRankGP:
        """Pivoted Cholesky approximation, stopped at a target relative error.

        Pivots are added greedily (largest remaining variance first) until
        ``trace(K - L L^T) <= tolerance * trace(K)`` or ``max_rank`` pivots. Costs
        ``O(N r^2)`` for ``r`` pivots. ``rank`` and ``variance`` then truncate the eigenbasis as
        in :meth:`nystrom`.
        """
        pts = as_points(points)
        if not 0 <= tolerance < 1:
            raise ValueError(f"tolerance must be in [0, 1), got {tolerance}")
        kernel = process.kernel
        bases = [
            pivoted_cholesky_basis(kernel, c, pts, tolerance, max_rank, progress) for c in range(kernel.n_components)
        ]
        return cls._from_bases(process, pts, bases, rank, variance)

    @classmethod
    def _from_bases(cls, process, pts, bases, rank, variance) -> LowRankGP:
        kernel = process.kernel
        total = float(np.broadcast_to(kernel.diagonal(pts), (3, len(pts))).sum())
        eig, axes, which = select(bases, kernel.n_components)
        r = choose_rank(eig, total, rank, variance)
        eig, axes, which = eig[:r], axes[:r], which[:r]
        vectors, extensions, column_of = [], [], {}
        for b, basis in enumerate(bases):
            used = np.unique(which[which[:, 0] == b, 1])
            start = sum(len(v) for v in vectors)
            u, extension = basis.vectors(used)
            vectors.append(u)
            extensions.append(_Extension(b, basis.inducing, extension, slice(start, start + len(used))))
            column_of.update({(b, int(j)): start + i for i, j in enumerate(used)})
        u_t = np.vstack(vectors)
        factor = np.zeros((len(u_t), r))
        factor[[column_of[(int(b), int(j))] for b, j in which], np.arange(r)] = np.sqrt(eig)
        space = _Space(pts, u_t, extensions, kernel, process.mean, process.mean(pts), total)
        return cls(space, factor, axes, np.zeros((len(u_t), 3)), eigen_form=True)

    # ------------------------------------------------------------------ eigen form
    def _eigen_form(self) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
        """Factor with orthogonal columns sorted by decreasing norm, their axes and eigenvalues."""
        if self._eigen is None:
            factor = np.zeros_like(self._factor)
            for a in range(3):
                cols = np.flatnonzero(self._axes == a)
                left, sing, _ = np.linalg.svd(self._factor[:, cols], full_matrices=False)
                factor[:, cols[: len(sing)]] = left * sing
            eig = np.einsum("qk,qk->k", factor, factor)
            order = np.argsort(-eig, kind="stable")
            self._eigen = (factor[:, order], self._axes[order], eig[order])
        return self._eigen

    @property
    def eigenvalues(self) -> NDArray[np.float64]:
        """Variances of the basis functions, descending, ``(rank,)``."""
        return self._eigen_form()[2]

    @property
    def axes(self) -> NDArray[np.int64]:
        """The displacement component (0, 1, 2) each basis function moves, ``(rank,)``."""
        return self._eigen_form()[1]

    @property
    def rank(self) -> int:
        """Number of basis functions."""
        return self._factor.shape[1]

    @property
    def captured_variance(self) -> float:
        """Fraction of the total prior variance the basis functions hold."""
        return float(self.eigenvalues.sum() / self.total_variance)

    # ------------------------------------------------------------------ fields
    def _fields(self, weights: NDArray[np.float64] | None, points: ArrayLike | None) -> NDArray[np.float64]:
        """``mean + U W`` for weights ``W (q, 3)`` at the point set or at other points."""
        space = self._space
        if points is None:
            return self._mean_values.copy() if weights is None else self._mean_values + (weights.T @ space.vectors_t).T
        pts = as_points(points)
        shift = self._mean_shift if weights is None else self._mean_shift + weights
        return space.base_mean(pts) + space.vectors_at(pts) @ shift

    @staticmethod
    def _weights(coefficients: NDArray, factor: NDArray, axes: NDArray) -> NDArray[np.float64]:
        """Map coefficients ``(rank,)`` to vector weights ``(q, 3)``, one column per axis."""
        weights = np.zeros((factor.shape[0], 3))
        for a in range(3):
            cols = axes == a
            weights[:, a] = factor[:, cols] @ coefficients[cols]
        return weights

    def mean(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """Mean displacement ``(N, 3)`` at the point set (default) or at other points."""
        return self._fields(None, points)

    def instance(self, coefficients: ArrayLike, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """The displacement field ``mean + sum_k sqrt(lambda_k) c_k phi_k``, ``(N, 3)``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((300, 3))
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), pts, n_inducing=50, rank=10, rng=0)
        >>> c = np.zeros(10); c[0] = 1.0
        >>> u = model.instance(c)
        >>> bool(np.isclose(np.sum(u**2), model.eigenvalues[0]))       # sqrt(lambda_0) * unit vector
        True
        """
        coef = np.asarray(coefficients, dtype=np.float64)
        if coef.shape != (self.rank,):
            raise ValueError(f"expected {self.rank} coefficients, got shape {coef.shape}")
        factor, axes, _ = self._eigen_form()
        return self._fields(self._weights(coef, factor, axes), points)

    def sample(
        self, n: int = 1, rng: int | np.random.Generator | None = None, points: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Draw ``n`` random displacement fields, ``(n, N, 3)``, at the point set or other points."""
        coefs = as_generator(rng).standard_normal((n, self.rank))
        # any factor of the covariance gives the same distribution: no need for the eigen form
        return np.stack([self._fields(self._weights(c, self._factor, self._axes), points) for c in coefs])

    def variance(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """Pointwise variance of each displacement component held by the model, ``(N, 3)``."""
        u_t = self._space.vectors_t if points is None else self._space.vectors_at(as_points(points)).T
        out = np.empty((u_t.shape[1], 3))
        done: list[tuple[NDArray, int]] = []
        for a in range(3):
            t = self._factor[:, self._axes == a]
            same = next((b for f, b in done if f.shape == t.shape and np.array_equal(f, t)), None)
            if same is None:
                tu = t.T @ u_t
                out[:, a] = np.einsum("kn,kn->n", tu, tu)
                done.append((t, a))
            else:
                out[:, a] = out[:, same]
        return out

    def covariance(self, points: ArrayLike | None = None) -> NDArray[np.float64]:
        """The model's ``(3M, 3M)`` covariance matrix at points (row ``3 i + a``), like a dense process's.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((50, 3))
        >>> gp = GaussianProcess(GaussianKernel(1.0))
        >>> model = LowRankGP.nystrom(gp, pts, n_inducing=50, rng=0)      # full rank: exact
        >>> bool(np.allclose(model.covariance(pts[:5]), gp.covariance(pts[:5]), atol=1e-8))
        True
        """
        u_t = self._space.vectors_t if points is None else self._space.vectors_at(as_points(points)).T
        out = np.zeros((3 * u_t.shape[1], 3 * u_t.shape[1]))
        for a in range(3):
            tu = self._factor[:, self._axes == a].T @ u_t
            out[a::3, a::3] = tu.T @ tu
        return out

    def basis_function(self, k: int) -> NDArray[np.float64]:
        """Unit-norm eigenfunction ``phi_k`` over the point set, ``(N, 3)``."""
        factor, axes, eig = self._eigen_form()
        out = np.zeros((len(self.points), 3))
        out[:, axes[k]] = factor[:, k] @ self._space.vectors_t / np.sqrt(eig[k])
        return out

    def coefficients(self, displacements: ArrayLike, noise: float = 0.0) -> NDArray[np.float64]:
        """Coefficients of the model instance closest to a displacement field on the point set.

        Minimises ``|instance(c) - d|^2 + noise * |c|^2`` (``noise > 0`` pulls towards the mean).
        """
        d = np.asarray(displacements, dtype=np.float64)
        if d.shape != self.points.shape:
            raise ValueError(f"displacements must have shape {self.points.shape}, got {d.shape}")
        factor, axes, _ = self._eigen_form()
        projected = self._space.vectors_t @ (d - self._mean_values)  # (q, 3)
        coef = np.zeros(self.rank)
        for a in range(3):
            cols = axes == a
            t = factor[:, cols]
            coef[cols] = np.linalg.solve(t.T @ t + noise * np.eye(t.shape[1]), t.T @ projected[:, a])
        return coef

    def project(self, displacements: ArrayLike, noise: float = 0.0) -> NDArray[np.float64]:
        """The model instance closest to a displacement field, ``(N, 3)``."""
        return self.instance(self.coefficients(displacements, noise))

    # ------------------------------------------------------------------ conditioning
    def posterior(self, landmarks: ArrayLike, displacements: ArrayLike, noise: ArrayLike = 0.0) -> LowRankGP:
        """The model conditioned on displacements observed at landmarks (any points).

        With ``Q`` the covariance factor at the landmarks and ``A = Q Q^T + noise``, the
        coefficients' posterior is ``N(Q^T A^-1 r, I - Q^T A^-1 Q)`` (``r`` the observed minus
        the mean displacement; Scalismo's low-rank regression). Only ``L x L`` and ``L x rank``
        systems are solved; the result has the same basis and rank.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
        >>> pts = np.random.default_rng(0).random((500, 3))
        >>> model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), pts, n_inducing=60, rng=0)
        >>> post = model.posterior(pts[:2], [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]], noise=1e-8)
        >>> post.mean(pts[:2]).round(4).tolist()
        [[0.0, 0.0, 0.1], [0.0, 0.0, -0.1]]
        """
        lms = as_points(landmarks, "landmarks")
        obs = as_points(displacements, "displacements")
        if len(obs) != len(lms):
            raise ValueError(f"got {len(lms)} landmarks but {len(obs)} displacements")
        var = noise_variances(noise, len(lms))
        u_l = self._space.vectors_at(lms)
        residual = obs - self._space.base_mean(lms) - u_l @ self._mean_shift
        shift = self._mean_shift.copy()
        factor = np.empty_like(self._factor)
        for a in range(3):
            cols = self._axes == a
            t = self._factor[:, cols]
            q = u_l @ t
            chol = cholesky(q @ q.T + np.diag(var[:, a]))
            g = sla.solve_triangular(chol, q, lower=True)  # A^-1 = chol^-T chol^-1
            shift[:, a] += t @ (g.T @ sla.solve_triangular(chol, residual[:, a], lower=True))
            _, sv, vt = np.linalg.svd(g, full_matrices=False)
            shrink = 1.0 - np.sqrt(np.clip(1.0 - sv**2, 0.0, 1.0))
            factor[:, cols] = t - ((t @ vt.T) * shrink) @ vt  # t @ sqrt(I - g^T g)
        return LowRankGP(self._space, factor, self._axes, shift)

    def __repr__(self) -> str:
        return (
            f"LowRankGP({len(self.points)} points, rank={self.rank}, "
            f"captured variance={self.captured_variance:.4f}, kernel={self._space.kernel!r})"
        )
