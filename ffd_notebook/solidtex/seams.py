"""Minimum-error boundary cuts through block overlaps (Efros and Freeman 2001, in 3D slice by slice).

Where a new block overlaps what is already synthesised, feathering averages the two across the
whole overlap, which blurs and ghosts. A cut instead keeps the old voxels on one side of a surface
and the new block's on the other, and puts the surface where the two agree most. The surface is
found by dynamic programming, independently on each slice through the overlap slab: on a slice,
a path crosses the overlap's length, moving at most one voxel in depth per step, with the least
summed squared colour difference (Efros and Freeman's quilting seam). A 3D graph cut (Kwatra et
al. 2003) would join the slices into one optimal surface; the maintained max-flow package for
Python, PyMaxflow, is GPL, so the per-slice DP (a few NumPy lines, no dependency) is used instead.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

__all__ = ["cut_depths", "new_side"]


def cut_depths(error: NDArray[np.floating]) -> NDArray[np.int64]:
    """Least-error paths through a stack of 2D error slices, one depth per path step.

    Parameters
    ----------
    error : numpy.ndarray
        ``(S, D, R)``: for ``S`` slices, the error at each depth ``0..D-1`` across the overlap and
        each step ``0..R-1`` along it.

    Returns
    -------
    numpy.ndarray
        ``(S, R)`` depth of each slice's path at each step; consecutive depths differ by at most 1
        and the path's summed error is the least possible.

    Examples
    --------
    >>> e = np.array([[[5, 5, 0, 5], [0, 0, 5, 0], [5, 5, 5, 5]]], float)   # one slice, depth 3, length 4
    >>> cut_depths(e).tolist()
    [[1, 1, 0, 1]]
    """
    e = np.asarray(error, dtype=np.float64)
    s, d, r = e.shape
    cost = np.empty_like(e)
    cost[:, :, 0] = e[:, :, 0]
    for k in range(1, r):
        prev = cost[:, :, k - 1]
        best = prev.copy()
        best[:, 1:] = np.minimum(best[:, 1:], prev[:, :-1])
        best[:, :-1] = np.minimum(best[:, :-1], prev[:, 1:])
        cost[:, :, k] = e[:, :, k] + best
    path = np.empty((s, r), dtype=np.int64)
    path[:, -1] = np.argmin(cost[:, :, -1], axis=1)
    rows = np.arange(s)
    for k in range(r - 2, -1, -1):
        here = path[:, k + 1]
        options = np.stack([here - 1, here, here + 1], axis=1).clip(0, d - 1)
        path[:, k] = options[rows, np.argmin(cost[rows[:, None], options, k], axis=1)]
    return path


def new_side(
    old: NDArray[np.floating], new: NDArray[np.floating], overlap: int, has_prev, coupling: int = 1
) -> NDArray[np.bool_]:
    """Which voxels of a block take the new block's colours, cutting each leading overlap along its least-error seams.

    Parameters
    ----------
    old, new : numpy.ndarray
        ``(b, b, b, 3)`` what is already there and the new block (``old`` is only read in the
        overlaps).
    overlap : int
        Voxels shared with the previous block along each axis.
    has_prev : (bool, bool, bool)
        Per axis, whether a previous block overlaps the first ``overlap`` voxels.
    coupling : int
        Each slice's seam follows the errors averaged over this many neighbouring slices: slices
        cut independently may put their seams at different depths, and the steps between them
        are seams too.

    Returns
    -------
    numpy.ndarray
        ``(b, b, b)`` bool; True beyond every seam (and wherever there is no overlap).

    Examples
    --------
    Old and new agree on the second and third layers along z: the seam passes between them.

    >>> old = np.zeros((6, 6, 6, 3)); new = np.ones((6, 6, 6, 3)); new[1:3] = 0
    >>> mask = new_side(old, new, 3, (True, False, False))
    >>> mask[:, 0, 0].astype(int).tolist()
    [0, 0, 1, 1, 1, 1]
    """
    b = old.shape[0]
    mask = np.ones(old.shape[:3], dtype=bool)
    for axis in range(3):
        if not has_prev[axis] or overlap < 1:
            continue
        slab = [slice(None)] * 3
        slab[axis] = slice(0, overlap)
        err = np.square(old[tuple(slab)] - new[tuple(slab)]).sum(-1)
        others = [a for a in range(3) if a != axis]
        # (slices along the first other axis, depth along `axis`, steps along the second other axis)
        stack = np.transpose(err, (others[0], axis, others[1]))
        if overlap < 2:  # no face inside the overlap to cut along: the new block starts at the border
            depth = np.zeros((b, b), dtype=np.int64)
        else:
            # a seam between depths k - 1 and k shows both blocks' mismatch at those two voxels
            # (Kwatra et al.'s seam cost); it stays inside the overlap, where both blocks exist
            face = stack[:, :-1] + stack[:, 1:]
            if coupling > 1:  # neighbouring slices see much the same costs: their seams stay close
                face = ndimage.uniform_filter1d(face, coupling, axis=0, mode="nearest")
            depth = cut_depths(face) + 1  # (b, b): first voxel of the new block
        index = np.arange(b).reshape([-1 if a == axis else 1 for a in range(3)])
        depth3 = np.expand_dims(depth, axis)
        mask &= index >= depth3
    return mask
