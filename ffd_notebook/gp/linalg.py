"""Small linear-algebra helpers shared by the GP modules."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

__all__ = ["as_generator", "cholesky"]


def as_generator(rng: int | np.random.Generator | None) -> np.random.Generator:
    """A NumPy ``Generator`` from a seed, a generator (returned as is) or ``None`` (fresh entropy)."""
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def cholesky(matrix: NDArray[np.float64], max_tries: int = 8) -> NDArray[np.float64]:
    """Lower Cholesky factor, adding the smallest diagonal jitter that makes it succeed.

    Kernel matrices of smooth kernels are numerically singular (their eigenvalues decay
    faster than machine precision); a jitter of ``1e-12``, ``1e-11``, ... times the mean
    diagonal is tried in turn.

    Parameters
    ----------
    matrix : numpy.ndarray
        A symmetric positive semi-definite ``(n, n)`` matrix.
    max_tries : int
        How many times the jitter may grow (tenfold each time) before giving up.

    Returns
    -------
    numpy.ndarray
        ``(n, n)`` lower-triangular ``L`` with ``L @ L.T`` = ``matrix`` + jitter.

    Examples
    --------
    >>> import numpy as np
    >>> L = cholesky(np.ones((3, 3)))            # rank one: needs jitter
    >>> bool(np.allclose(L @ L.T, np.ones((3, 3)), atol=1e-9))
    True
    """
    try:
        return sla.cholesky(matrix, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        pass
    scale = float(np.mean(np.diagonal(matrix))) or 1.0
    eye = np.eye(len(matrix))
    for power in range(max_tries):
        try:
            return sla.cholesky(matrix + (10.0 ** (power - 12) * scale) * eye, lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            continue
    raise ValueError("matrix is not positive semi-definite (Cholesky failed even with jitter)")
