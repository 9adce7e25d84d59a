"""Feathered blending weights for overlapping blocks.

A block's weight is the product of one ramp per axis. Along an axis, a block fades in over the
voxels it shares with its predecessor and fades out over those it shares with its successor, and
the two ramps over the same voxels sum to 1. Because the weights are separable, every overlap
shape sums to 1 as well: faces (2 blocks), edges (4 blocks) and corners (8 blocks) alike.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["axis_ramp", "block_weights"]


def axis_ramp(block: int, overlap: int, fade_in: bool, fade_out: bool) -> NDArray[np.float32]:
    """Weights of a block along one axis.

    Parameters
    ----------
    block, overlap : int
        Block edge and the number of voxels shared with each neighbour (``overlap <= block / 2``).
    fade_in, fade_out : bool
        Whether a neighbour shares the first / last ``overlap`` voxels.

    Returns
    -------
    numpy.ndarray
        ``(block,)`` float32 weights in [0, 1].

    Examples
    --------
    >>> axis_ramp(6, 2, True, True).tolist()
    [0.25, 0.75, 1.0, 1.0, 0.75, 0.25]
    >>> (axis_ramp(6, 2, False, True)[-2:] + axis_ramp(6, 2, True, False)[:2]).tolist()
    [1.0, 1.0]
    """
    if not 0 <= 2 * overlap <= block:
        raise ValueError(f"overlap {overlap} must be between 0 and half the block {block}")
    w = np.ones(block, dtype=np.float32)
    if overlap:
        up = (np.arange(overlap, dtype=np.float32) + 0.5) / overlap
        if fade_in:
            w[:overlap] = up
        if fade_out:
            w[block - overlap :] = 1.0 - up
    return w


@lru_cache(maxsize=128)
def _weights(block: int, overlap: int, flags: tuple[bool, ...]) -> NDArray[np.float32]:
    rz, ry, rx = (axis_ramp(block, overlap, flags[a], flags[a + 3]) for a in range(3))
    w = rz[:, None, None] * ry[None, :, None] * rx[None, None, :]
    w.setflags(write=False)
    return w


def block_weights(
    block: int, overlap: int, fade_in: tuple[bool, ...], fade_out: tuple[bool, ...]
) -> NDArray[np.float32]:
    """``(block, block, block)`` feathering weights of a block (read-only, cached).

    Parameters
    ----------
    block, overlap : int
        Block edge and overlap in voxels.
    fade_in, fade_out : (bool, bool, bool)
        Per axis (z, y, x): whether there is a neighbour before / after the block.

    Returns
    -------
    numpy.ndarray
        ``(block, block, block)`` float32 weights (read-only).

    Examples
    --------
    >>> w = block_weights(4, 1, (True, True, True), (False, False, False))
    >>> float(w[0, 0, 0]), float(w[1, 1, 1])
    (0.125, 1.0)
    """
    return _weights(int(block), int(overlap), tuple(bool(f) for f in (*fade_in, *fade_out)))
