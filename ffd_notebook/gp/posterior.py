"""The exact posterior of a Gaussian process after noisy observations at landmarks.

:class:`PosteriorKernel` holds the Cholesky factorisation of ``K(X, X) + noise`` and is reused
for the posterior mean and the log marginal likelihood. A diagonal prior with noise given as
variances factorises one ``L x L`` matrix per distinct component; 3x3 noise covariances (or a
non-diagonal prior) couple the components and factorise the full ``3L x 3L`` matrix, and the
posterior kernel is then not diagonal.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .kernels import Kernel
from .linalg import cholesky
from .noise import observation_noise

__all__ = ["PosteriorKernel", "PosteriorMean"]

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class _Group:
    """Output components that share one kernel component and one noise column (one factorisation)."""

    outputs: tuple[int, ...]  # displacement components 0..2 solved together
    kernel_index: int  # which of the prior kernel's components
    factor: NDArray[np.float64]  # lower Cholesky factor of K(X, X) + noise


def _factor_groups(kernel: Kernel, landmarks: NDArray[np.float64], noise: NDArray[np.float64]) -> list[_Group]:
    comps = kernel.components(landmarks, landmarks)
    if kernel.n_components == 1 and np.all(noise == noise[:, :1]):
        return [_Group((0, 1, 2), 0, cholesky(comps[0] + np.diag(noise[:, 0])))]
    return [
        _Group((a,), a if kernel.n_components == 3 else 0, cholesky(comps[a % len(comps)] + np.diag(noise[:, a])))
        for a in range(3)
    ]


def _variance_rows(kernel: Kernel, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Prior variance of each component, ``(3, N)``."""
    diag = kernel.diagonal(x)
    return np.broadcast_to(diag, (3, diag.shape[1]))


class PosteriorKernel(Kernel):
    """``k(x, y) - k(x, X) (K(X, X) + noise)^-1 k(X, y)``: the covariance after observing at ``X``.

    Built by :meth:`GaussianProcess.posterior <ffd_notebook.gp.GaussianProcess.posterior>`; it is
    a kernel like any other (a posterior can be conditioned again). ``noise`` is anything
    :func:`~ffd_notebook.gp.noise.observation_noise` takes.

    Parameters
    ----------
    prior : Kernel
        The kernel before the observations.
    landmarks : array_like
        ``(L, 3)`` observed points ``X``.
    noise : array_like
        A variance, variances per landmark (``(L,)`` or ``(L, 3)``) or ``(L, 3, 3)`` covariances.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel, PosteriorKernel
    >>> k = PosteriorKernel(GaussianKernel(1.0), [[0.0, 0.0, 0.0]], noise=0.01)
    >>> float(k.matrix([[0.0, 0.0, 0.0]])[0, 0].round(4))   # 1 - 1 / 1.01: little left at a landmark
    0.0099
    """

    def __init__(self, prior: Kernel, landmarks: ArrayLike, noise: ArrayLike = 0.0) -> None:
        self.prior = prior
        self.landmarks = as_points(landmarks, "landmarks")
        self.noise = observation_noise(noise, len(self.landmarks))
        self.is_diagonal = prior.is_diagonal and self.noise.is_diagonal
        if self.is_diagonal:
            assert self.noise.variances is not None  # diagonal noise is given by its variances
            self.groups = _factor_groups(prior, self.landmarks, self.noise.variances)
            self.n_components = len(self.groups)
        else:
            self.groups = []
            self.factor = cholesky(prior.matrix(self.landmarks) + self.noise.block_matrix())
            self.n_components = 3

    # ---------------------------------------------------------------- diagonal case
    def _whitened(self, x: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """``L_g^-1 K(X, x)`` per group, each ``(L, N)``."""
        kx = self.prior.components(self.landmarks, x)
        return [sla.solve_triangular(g.factor, kx[g.kernel_index], lower=True, check_finite=False) for g in self.groups]

    def components(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        if not self.is_diagonal:
            raise TypeError("this posterior kernel is not diagonal (3x3 noise covariances): use matrix() or blocks")
        x, y = as_points(x, "x"), as_points(y, "y")
        prior = self.prior.components(x, y)
        vx = self._whitened(x)
        vy = vx if y is x else self._whitened(y)
        return np.stack([prior[g.kernel_index] - a.T @ b for g, a, b in zip(self.groups, vx, vy, strict=True)])

    # ---------------------------------------------------------------- full case
    def _whitened_full(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """``L^-1 K(X, x)``, ``(3L, 3N)``."""
        return sla.solve_triangular(self.factor, self.prior.matrix(self.landmarks, x), lower=True, check_finite=False)

    def matrix(self, x: ArrayLike, y: ArrayLike | None = None) -> NDArray[np.float64]:
        if self.is_diagonal:
            return super().matrix(x, y)
        x = as_points(x, "x")
        y = x if y is None else as_points(y, "y")
        vx = self._whitened_full(x)
        vy = vx if y is x else self._whitened_full(y)
        return self.prior.matrix(x, y) - vx.T @ vy

    def __call__(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        if self.is_diagonal:
            return super().__call__(x, y)
        x, y = as_points(x, "x"), as_points(y, "y")
        return self.matrix(x, y).reshape(len(x), 3, len(y), 3).transpose(0, 2, 1, 3)

    def diagonal(self, x: ArrayLike) -> NDArray[np.float64]:
        x = as_points(x)
        prior = _variance_rows(self.prior, x)
        if self.is_diagonal:
            out = [
                prior[g.kernel_index] - np.einsum("ln,ln->n", v, v)
                for g, v in zip(self.groups, self._whitened(x), strict=True)
            ]
            return np.maximum(np.stack(out), 0.0)
        v = self._whitened_full(x)
        explained = np.einsum("ln,ln->n", v, v).reshape(len(x), 3).T
        return np.maximum(prior - explained, 0.0)

    def sample(self, points: NDArray[np.float64], n: int, rng: np.random.Generator) -> NDArray[np.float64]:
        if self.is_diagonal:
            return super().sample(points, n, rng)
        z = rng.standard_normal((3 * len(points), n))
        return (cholesky(self.matrix(points)) @ z).T.reshape(n, len(points), 3)

    # ---------------------------------------------------------------- solves
    def solve(self, residual: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """``(K + noise)^-1 r`` for residuals ``(L, 3)``: per group ``(L, len(outputs))``, or one ``(3L,)``.

        Parameters
        ----------
        residual : numpy.ndarray
            ``(L, 3)`` residuals.

        Returns
        -------
        list of numpy.ndarray
            Per group of output components ``(L, len(outputs))``, or one ``(3L,)`` for 3x3 noise.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, PosteriorKernel
        >>> k = PosteriorKernel(GaussianKernel(1.0), [[0.0, 0.0, 0.0]], noise=0.01)
        >>> [a.round(4).tolist() for a in k.solve(np.ones((1, 3)))]
        [[[0.9901, 0.9901, 0.9901]]]
        """
        if self.is_diagonal:
            return [sla.cho_solve((g.factor, True), residual[:, g.outputs], check_finite=False) for g in self.groups]
        return [sla.cho_solve((self.factor, True), residual.ravel(), check_finite=False)]

    def log_likelihood(self, residual: NDArray[np.float64]) -> float:
        """``log N(r; 0, K + noise)`` of residuals ``(L, 3)`` (the log marginal likelihood).

        Parameters
        ----------
        residual : numpy.ndarray
            ``(L, 3)`` observed displacements minus the prior mean at the landmarks.

        Returns
        -------
        float
            The log density.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.gp import GaussianKernel, PosteriorKernel
        >>> k = PosteriorKernel(GaussianKernel(1.0), [[0.0, 0.0, 0.0]], noise=0.01)
        >>> round(k.log_likelihood(np.zeros((1, 3))), 4)   # 3 * log N(0; 0, 1.01)
        -2.7717
        """
        n = len(self.landmarks)
        if not self.is_diagonal:
            alpha = self.solve(residual)[0]
            half_logdet = np.log(np.diagonal(self.factor)).sum()
            return float(-0.5 * residual.ravel() @ alpha - half_logdet - 1.5 * n * _LOG_2PI)
        total = 0.0
        for g, alpha in zip(self.groups, self.solve(residual), strict=True):
            fit = np.einsum("lo,lo->", residual[:, g.outputs], alpha)
            total += -0.5 * fit - len(g.outputs) * (np.log(np.diagonal(g.factor)).sum() + 0.5 * n * _LOG_2PI)
        return float(total)

    def __repr__(self) -> str:
        return f"PosteriorKernel({self.prior!r}, {len(self.landmarks)} landmarks)"


class PosteriorMean:
    """``m(x) + k(x, X) alpha`` with ``alpha = (K + noise)^-1 (y - m(X))``."""

    def __init__(
        self,
        prior_mean: Callable[[NDArray[np.float64]], NDArray[np.float64]],
        kernel: PosteriorKernel,
        residual: NDArray[np.float64],
    ) -> None:
        self.prior_mean = prior_mean
        self.kernel = kernel
        self.alpha = kernel.solve(residual)

    def __call__(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        out = self.prior_mean(points)
        if not self.kernel.is_diagonal:
            return out + (self.kernel.prior.matrix(points, self.kernel.landmarks) @ self.alpha[0]).reshape(-1, 3)
        kx = self.kernel.prior.components(points, self.kernel.landmarks)
        for g, alpha in zip(self.kernel.groups, self.alpha, strict=True):
            out[:, g.outputs] += kx[g.kernel_index] @ alpha
        return out
