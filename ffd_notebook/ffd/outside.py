"""Blender's "outside" lattice: only the surface control points are free, the inner ones follow.

With ``use_outside`` on, Blender (``outside_lattice()`` in ``lattice.cc``) places each inner
control point ``(i, j, k)`` (one not on the lattice's surface) at the mean of three linear
interpolations between opposite faces: between ``(0, j, k)`` and ``(nx - 1, j, k)`` at ``i / (nx - 1)``,
and likewise along ``j`` and ``k``. Rest positions are affine in the indices, so the rule holds for
the displacements (``offsets``) too. It is linear: each control point's effective offset is a
combination of at most six offsets (:func:`outside_sources`), which the evaluators apply to the
offsets (:func:`outside_offsets`) and the fit applies to its weights (:func:`outside_weights`).

Examples
--------
>>> import numpy as np
>>> offsets = np.zeros((3, 3, 3, 3))
>>> offsets[2, 1, 1] = (3.0, 0.0, 0.0)                 # a face centre moves along +x ...
>>> offsets[1, 1, 1] = (9.0, 9.0, 9.0)                 # ... the centre's own offset is ignored
>>> outside_offsets(offsets)[1, 1, 1].tolist()          # (1/2 * 3 + 0 + 0) / 3
[0.5, 0.0, 0.0]
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["outside_offsets", "outside_sources", "outside_weights"]


@lru_cache(maxsize=32)
def _sources(shape: tuple[int, int, int]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    n = int(np.prod(shape))
    src = np.repeat(np.arange(n)[:, None], 6, axis=1)
    coef = np.zeros((n, 6))
    coef[:, 0] = 1.0
    i, j, k = np.unravel_index(np.arange(n), shape)
    idx = np.stack([i, j, k], axis=1)
    dims = np.array(shape)
    inner = np.all((idx > 0) & (idx < dims - 1), axis=1)
    for axis in range(3):
        lo, hi = idx[inner].copy(), idx[inner].copy()
        lo[:, axis], hi[:, axis] = 0, dims[axis] - 1
        f = idx[inner, axis] / (dims[axis] - 1)
        src[inner, 2 * axis] = np.ravel_multi_index(tuple(lo.T), shape)
        src[inner, 2 * axis + 1] = np.ravel_multi_index(tuple(hi.T), shape)
        coef[inner, 2 * axis] = (1.0 - f) / 3.0
        coef[inner, 2 * axis + 1] = f / 3.0
    src.flags.writeable = False
    coef.flags.writeable = False
    return src, coef


def outside_sources(shape: tuple[int, int, int]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """For each control point (flat C-order index), the six control points and weights that place it.

    Returns
    -------
    src : numpy.ndarray
        ``(N, 6)`` flat indices: a surface point lists itself (weight 1, then zeros); an inner one
        the two ends of its row along x, then y, then z.
    coef : numpy.ndarray
        ``(N, 6)`` weights (``(1 - f) / 3`` and ``f / 3`` per axis for an inner point).

    Examples
    --------
    >>> src, coef = outside_sources((3, 3, 3))
    >>> src[13].tolist(), coef[13].round(4).tolist()     # the centre (1, 1, 1)
    ([4, 22, 10, 16, 12, 14], [0.1667, 0.1667, 0.1667, 0.1667, 0.1667, 0.1667])
    """
    return _sources(tuple(int(s) for s in shape))


def outside_offsets(offsets: NDArray[np.float64]) -> NDArray[np.float64]:
    """The offsets Blender's "outside" lattice uses: inner ones replaced by their faces' interpolation.

    Parameters
    ----------
    offsets : numpy.ndarray
        ``(nx, ny, nz, 3)``.

    Returns
    -------
    numpy.ndarray
        A new array; the surface offsets are copied unchanged.
    """
    shape = offsets.shape[:3]
    if min(shape) < 3:  # no inner point
        return offsets.copy()
    src, coef = outside_sources(shape)
    flat = offsets.reshape(-1, offsets.shape[-1])
    return np.einsum("ns,nsd->nd", coef, flat[src]).reshape(offsets.shape)


def outside_weights(
    shape: tuple[int, int, int], index: NDArray[np.int64], weight: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Rows of control weights (``index``, ``weight``, each ``(P, K)``) onto the free control points.

    ``sum_q weight[p, q] * outside_offsets(offsets)[index[p, q]]`` equals ``sum_q weight'[p, q] *
    offsets[index'[p, q]]`` for the returned ``(P, 6K)`` rows, which name surface points only.

    Examples
    --------
    >>> import numpy as np
    >>> index, weight = outside_weights((3, 3, 3), np.array([[13]]), np.array([[1.0]]))
    >>> sorted(set(index[0].tolist())), round(float(weight.sum()), 12)
    ([4, 10, 12, 14, 16, 22], 1.0)
    """
    if min(shape) < 3:
        return index, weight
    src, coef = outside_sources(shape)
    p = len(index)
    return src[index].reshape(p, -1), (weight[..., None] * coef[index]).reshape(p, -1)
