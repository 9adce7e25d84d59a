"""Observation noise at landmarks: one variance, variances per landmark (and component), or 3x3 covariances.

Scalismo conditions on landmarks each with its own ``MultivariateNormalDistribution``; here the
same is ``noise`` given as ``(L, 3, 3)`` covariances. Variances (a scalar, ``(L,)`` or ``(L, 3)``)
are the diagonal special case, which lets diagonal kernels solve one small system per component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ObservationNoise", "noise_variances", "observation_noise"]


def noise_variances(noise: ArrayLike, n_landmarks: int) -> NDArray[np.float64]:
    """Observation noise variances as an ``(L, 3)`` array.

    ``noise`` is one variance for all, one per landmark ``(L,)``, or one per landmark and
    component ``(L, 3)``.

    Examples
    --------
    >>> noise_variances([0.1, 0.2], 2).tolist()
    [[0.1, 0.1, 0.1], [0.2, 0.2, 0.2]]
    """
    arr = np.asarray(noise, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == n_landmarks:
        arr = arr[:, None]
    try:
        out = np.broadcast_to(arr, (n_landmarks, 3)).copy()
    except ValueError:
        raise ValueError(
            f"noise must be a variance, (L,) or (L, 3) variances or (L, 3, 3) covariances for L={n_landmarks}"
        ) from None
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise ValueError("noise variances must be finite and non-negative")
    return out


@dataclass(frozen=True)
class ObservationNoise:
    """Per-landmark noise covariances ``(L, 3, 3)``, and the ``(L, 3)`` variances when it is diagonal."""

    covariances: NDArray[np.float64]
    variances: NDArray[np.float64] | None

    @property
    def is_diagonal(self) -> bool:
        """True when given as variances (each covariance diagonal)."""
        return self.variances is not None

    def block_matrix(self) -> NDArray[np.float64]:
        """The ``(3L, 3L)`` block-diagonal noise covariance (row ``3 i + a``)."""
        n = len(self.covariances)
        out = np.zeros((n, 3, n, 3))
        out[np.arange(n), :, np.arange(n), :] = self.covariances
        return out.reshape(3 * n, 3 * n)


def observation_noise(noise: ArrayLike, n_landmarks: int) -> ObservationNoise:
    """Parse ``noise`` for ``n_landmarks`` landmarks (see the module docstring).

    An ``(L, 3, 3)`` array is one covariance per landmark (symmetric, positive semi-definite);
    anything else goes through :func:`noise_variances`. A single shared 3x3 covariance is
    ``np.broadcast_to(cov, (L, 3, 3))`` (a bare ``(3, 3)`` array means per-component variances
    of three landmarks).

    Examples
    --------
    >>> import numpy as np
    >>> cov = np.array([[[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]]])
    >>> n = observation_noise(cov, 1)
    >>> n.is_diagonal, n.block_matrix().shape
    (False, (3, 3))
    >>> observation_noise(0.1, 2).covariances[1].diagonal().tolist()
    [0.1, 0.1, 0.1]
    """
    arr = np.asarray(noise, dtype=np.float64)
    if arr.ndim == 3:
        if arr.shape != (n_landmarks, 3, 3):
            raise ValueError(f"noise covariances must have shape ({n_landmarks}, 3, 3), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("noise covariances must be finite")
        scale = max(float(np.abs(arr).max()), 1e-300)
        if not np.allclose(arr, arr.transpose(0, 2, 1), rtol=0.0, atol=1e-12 * scale):
            raise ValueError("noise covariances must be symmetric")
        if n_landmarks and np.linalg.eigvalsh(arr).min() < -1e-12 * scale:
            raise ValueError("noise covariances must be positive semi-definite")
        return ObservationNoise(0.5 * (arr + arr.transpose(0, 2, 1)), None)
    variances = noise_variances(noise, n_landmarks)
    cov = np.zeros((n_landmarks, 3, 3))
    cov[:, [0, 1, 2], [0, 1, 2]] = variances
    return ObservationNoise(cov, variances)
