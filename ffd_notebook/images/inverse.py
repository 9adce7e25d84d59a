"""``T^-1`` at a few points: Newton's method on ``T(q) = p``, for any deformation with ``deform``.

An image resampled through ``T`` (ITK's pull-back) shows at ``x`` what the input had at ``T(x)``:
the anatomy at ``q`` moves to ``T^-1(q)``. A mesh drawn on the input image therefore stays on the
warped image when its vertices are moved by ``T^-1``, which this module computes (a mesh has far
fewer points than an image has voxels, so inverting at the vertices is the cheap direction).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["invert_points"]


def _jacobian(deformation: Any, points: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """``dT/dx`` at ``points``, ``(N, 3, 3)``: the deformation's own (analytic for an FFD), else differences."""
    for owner in (deformation, getattr(deformation, "ffd", None)):
        if owner is not None and callable(getattr(owner, "jacobian", None)):
            return np.asarray(owner.jacobian(points), dtype=np.float64)
    columns = []
    for axis in range(3):
        delta = np.zeros(3)
        delta[axis] = step
        columns.append(
            (np.asarray(deformation.deform(points + delta)) - np.asarray(deformation.deform(points - delta)))
            / (2 * step)
        )
    return np.stack(columns, axis=-1)


def invert_points(
    deformation: Any, points: ArrayLike, *, tolerance: float = 1e-9, max_iterations: int = 50
) -> NDArray[np.float64]:
    """Points ``q`` with ``deformation.deform(q) == points`` (to ``tolerance``, relative to the points' extent).

    Newton's method from ``q = p - (T(p) - p)``, with the deformation's Jacobian (an
    :class:`~ffd_notebook.FFD`'s, or a sample's ``ffd``) or central differences. A fold-free
    deformation (``det J > 0`` everywhere) has one inverse; the steps are halved while they do
    not reduce the residual.

    Parameters
    ----------
    deformation : object
        Anything with ``deform((N, 3)) -> (N, 3)``: an :class:`~ffd_notebook.FFD`, a batch sample, a
        loaded transform.
    points : array_like
        ``(N, 3)`` finite deformed points.
    tolerance : float
        Largest residual ``|T(q) - p|`` accepted, as a fraction of the points' extent.
    max_iterations : int
        Newton steps at most.

    Returns
    -------
    numpy.ndarray
        ``(N, 3)`` float64 points ``q``, one per point.

    Raises
    ------
    ValueError
        If some points do not converge (a folding deformation): says how many and the worst residual.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((5, 5, 5), 1.0, origin=(-2.0, -2.0, -2.0))
    >>> lat.offsets[2, 2, 2] = (0.4, -0.2, 0.3)
    >>> ffd = FFD(lat)
    >>> p = np.random.default_rng(0).uniform(-1, 1, (100, 3))
    >>> q = invert_points(ffd, p)
    >>> float(np.abs(ffd.deform(q) - p).max()) < 1e-8    # 1e-9 of the points' extent (2)
    True
    """
    p = np.array(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or not np.isfinite(p).all():
        raise ValueError(f"expected finite (N, 3) points, got shape {p.shape}")
    if len(p) == 0:
        return p.copy()
    extent = float(np.ptp(p, axis=0).max()) or 1.0
    atol = tolerance * extent
    q = 2.0 * p - np.asarray(deformation.deform(p), dtype=np.float64)
    residual = np.asarray(deformation.deform(q), dtype=np.float64) - p
    error = np.linalg.norm(residual, axis=1)
    active = np.flatnonzero(error > atol)
    for _ in range(max_iterations):
        if active.size == 0:
            return q
        qa, ra = q[active], residual[active]
        jac = _jacobian(deformation, qa, step=1e-6 * extent)
        try:
            step = np.linalg.solve(jac, ra[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            step = ra  # a singular Jacobian: a fixed-point step instead
        scale = np.ones(len(active))
        for _halving in range(8):
            trial = qa - scale[:, None] * step
            trial_residual = np.asarray(deformation.deform(trial), dtype=np.float64) - p[active]
            trial_error = np.linalg.norm(trial_residual, axis=1)
            worse = trial_error > error[active]
            if not worse.any():
                break
            scale[worse] *= 0.5
        q[active], residual[active], error[active] = trial, trial_residual, trial_error
        active = active[error[active] > atol]
    if active.size:
        raise ValueError(
            f"the deformation could not be inverted at {active.size} of {len(p)} points "
            f"(worst residual {error[active].max():.3g}, tolerance {atol:.3g}): does it fold?"
        )
    return q
