"""Moving points onto targets by changing lattice offsets: the least-norm fit.

With the affine part fixed, an FFD is linear in the offsets: ``deform(x) = A x + b + sum_c
w_c(x) offsets[c]``, the same weights ``w_c(x)`` for the three components. Putting points ``x_p``
on targets ``y_p`` is the linear system ``W delta = y - deform(x)`` for the change ``delta`` of the
offsets, ``W[p, c] = w_c(x_p)``. Only the control points that move some ``x_p`` (64 per point
for the B-spline basis) enter it, so the system is small and dense whatever the lattice size:
its least-norm least-squares solution comes from :func:`numpy.linalg.lstsq` (an SVD), and for
one point in closed form, ``delta = w r^T / |w|^2``. The whole weight matrix is never built,
which is why this is hand-written rather than a call to a sparse solver: a drag in the editor
solves it at every mouse event.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .basis import bernstein_values
from .influence import point_weights as _point_weights
from .interpolation import axis_bases
from .outside import outside_weights
from .support import axis_support, in_domain

if TYPE_CHECKING:
    from .deform import FFD

__all__ = ["control_weights", "fit_points"]


def control_weights(ffd: FFD, points: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The control points that move each point, and their weights (a sparse weight matrix's rows).

    Parameters
    ----------
    ffd : FFD
        Its basis, border rule, ``outside`` and ``only_inside`` options and lattice geometry are
        used (not the offsets): with ``only_inside`` a point outside the domain has zero weights.
    points : array_like
        ``(P, 3)`` points.

    Returns
    -------
    index : numpy.ndarray
        ``(P, K)`` flat control-point indices, ``(i * ny + j) * nz + k`` (C order, like
        ``offsets.reshape(-1, 3)``); an index may repeat in a row (the "clamp" border folds
        the weights of control points beyond the lattice onto the border one): add repeats.
        ``K`` is 64 for the B-spline basis, every control point for Bernstein.
    weight : numpy.ndarray
        ``(P, K)`` weights: ``ffd.displacement(points)[p] == sum_q weight[p, q] *
        offsets.reshape(-1, 3)[index[p, q]]``.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 1.0, border="clamp")
    >>> index, weight = control_weights(FFD(lat), [[0.0, 0.0, 0.0], [1.5, 1.5, 1.5]])
    >>> index.shape, weight.sum(axis=1).round(12).tolist()    # clamp: the weights sum to one
    ((2, 64), [1.0, 1.0])
    """
    pts = as_points(points)
    lat = ffd.lattice
    uvw = lat.to_lattice(pts)
    _, ny, nz = lat.shape
    if ffd.basis == "bernstein":
        bx, by, bz = bernstein_values(ffd.lattice.shape, uvw)
        weight = (bx[:, :, None, None] * by[:, None, :, None] * bz[:, None, None, :]).reshape(len(pts), -1)
        index = np.broadcast_to(np.arange(lat.n_points), weight.shape).copy()
    else:
        bases = axis_bases(ffd.basis)
        (iu, wu), (iv, wv), (iw, ww) = (
            axis_support(uvw[:, a], n, ffd.border, bases[a]) for a, n in enumerate(lat.shape)
        )
        index = ((iu[:, :, None, None] * ny + iv[:, None, :, None]) * nz + iw[:, None, None, :]).reshape(len(pts), 64)
        weight = (wu[:, :, None, None] * wv[:, None, :, None] * ww[:, None, None, :]).reshape(len(pts), 64)
    if ffd.outside:  # inner control points follow the surface ones: their weights go to those
        index, weight = outside_weights(lat.shape, index, weight)
    if ffd.only_inside:  # the lattice moves no point outside its domain: nothing moves those rows
        weight[~in_domain(ffd.basis, lat.shape, uvw, ffd.only_inside)] = 0.0
    return index, weight


def fit_points(
    ffd: FFD,
    points: ArrayLike,
    targets: ArrayLike,
    pinned: ArrayLike | None = None,
    weights: ArrayLike | None = None,
    *,
    point_weights: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Change the lattice offsets by the least-norm amount that puts ``deform(points)`` on ``targets``.

    Among all changes of the offsets (the affine part stays) that move the points exactly onto
    their targets, the one with the smallest sum of squared control-point moves; if no change
    can (more conditions than the control points around them allow), the least-squares one,
    and among those the smallest. ``lattice.offsets`` is updated in place.

    Parameters
    ----------
    ffd : FFD
        The deformation whose lattice offsets change.
    points : array_like
        ``(P, 3)`` rest positions (the points before the deformation, as given to ``deform``).
    targets : array_like
        ``(P, 3)`` where ``deform(points)`` should be.
    pinned : array_like, optional
        ``(Q, 3)`` rest positions of points that should stay where they are now: rows whose
        target is their current deformed position (e.g. the editor's pinned points).
    weights : array_like, optional
        ``(P + Q,)`` non-negative weights of the rows (``points`` then ``pinned``) in the
        least-squares sense; they matter only when not every target can be met.
    point_weights : array_like, optional
        ``(P + Q,)`` weights in [0, 1] of the rows in the deformation itself (Blender's vertex
        weights: each row moves by ``strength * weight`` times the lattice's displacement); 1 by
        default. The FFD's strength applies to every row.

    Returns
    -------
    numpy.ndarray
        The change, ``(nx, ny, nz, 3)``, zero for every control point that moves none of the
        points (so ``np.argwhere(change.any(axis=-1))`` lists the ones to update).

    Notes
    -----
    Points the lattice does not reach (with the "zero" border, beyond the support of every
    control point) cannot be moved: they get no change. Points with a zero weight are ignored.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> pts = np.random.default_rng(0).random((200, 3))
    >>> ffd = FFD(Lattice.around(pts, shape=6, border="clamp"))
    >>> change = ffd.fit_points(pts[:1], pts[:1] + (0.0, 0.0, 0.1), pinned=pts[1:3])
    >>> moved = ffd.deform(pts[:3]) - pts[:3]
    >>> moved.round(12).tolist()[0], float(np.abs(moved[1:]).max()) < 1e-12
    ([0.0, 0.0, 0.1], True)
    """
    pts = as_points(points)
    goal = np.asarray(targets, dtype=np.float64)
    if goal.shape != pts.shape or not np.isfinite(goal).all():
        raise ValueError(f"targets must be finite and shaped like points {pts.shape}, got {goal.shape}")
    rows = pts if pinned is None else np.vstack([pts, as_points(pinned)])
    # per-row weights of the deformation (not the FFD's own, which belong to the point set it deforms)
    given = None if point_weights is None else _point_weights(point_weights, len(rows))
    row_influence = np.ones(len(rows)) if given is None else given
    now = ffd.deform(rows, weights=row_influence)
    residual = np.vstack([goal, now[len(pts) :]]) - now  # pinned rows: exactly zero
    index, weight = control_weights(ffd, rows)
    weight = weight * (ffd.strength * row_influence)[:, None]  # a row moves by strength * weight times that
    if weights is not None:
        root = np.sqrt(_row_weights(weights, len(rows)))
        weight, residual = weight * root[:, None], residual * root[:, None]
    shape = ffd.lattice.offsets.shape
    change = np.zeros(shape)
    delta, used = _least_norm(index, weight, residual)
    change.reshape(-1, 3)[used] = delta
    ffd.lattice.offsets += change
    return change


def _row_weights(weights: Any, n: int) -> NDArray[np.float64]:
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(w) != n or not np.isfinite(w).all() or (w < 0).any():
        raise ValueError(f"weights must be {n} finite non-negative numbers (points, then pinned), got {len(w)}")
    return w


def _least_norm(
    index: NDArray[np.int64], weight: NDArray[np.float64], residual: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Least-norm least-squares ``delta`` of ``W delta = residual`` over the control points ``used``."""
    nonzero = weight != 0
    used = np.unique(index[nonzero])
    if len(used) == 0:
        return np.zeros((0, 3)), used
    rows = np.broadcast_to(np.arange(len(index))[:, None], index.shape)
    matrix = np.zeros((len(index), len(used)))
    # add, not assign: with the clamp border one control point can fill several slots of a row
    np.add.at(matrix, (rows[nonzero], np.searchsorted(used, index[nonzero])), weight[nonzero])
    if len(matrix) == 1:  # one point: closed form w r^T / |w|^2
        w = matrix[0]
        return np.outer(w / (w @ w), residual[0]), used
    return cast("NDArray[np.float64]", np.linalg.lstsq(matrix, residual, rcond=None)[0]), used
