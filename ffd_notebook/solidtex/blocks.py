"""Blocks of a source volume: box means, the block size, colour classes, matching features.

Every candidate block is a cube ``source[q : q + block]`` at a position ``q``. The functions here
precompute, once per synthesis stage, what matching needs for all positions at once:

* :func:`box_mean` (a summed-volume table) gives the mean colour of every cube of a size, which is
  both the 2x2x2 (or coarser) pooling used to compare overlaps and the block mean colour used to
  classify blocks;
* :func:`classify_blocks` puts the blocks into colour classes with k-means;
* :func:`choose_block_size` picks the block size by feature inclusiveness.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.cluster.vq import kmeans2, vq

from .quality import color_histogram
from .seeding import RNGLike
from .slices import exemplar_volume

__all__ = [
    "DEFAULT_BLOCK_SIZES",
    "box_mean",
    "cell_starts",
    "choose_block_size",
    "classify_blocks",
    "feature_inclusiveness",
]

DEFAULT_BLOCK_SIZES = (8, 12, 16, 20, 24, 32, 40, 48, 64)


def box_mean(volume: ArrayLike, size: int) -> NDArray[np.float32]:
    """Mean of every ``size``-cube: ``out[q] = volume[q : q + size].mean()`` per channel.

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, C)`` values.
    size : int
        Cube edge, at most the smallest of ``Z, Y, X``.

    Returns
    -------
    numpy.ndarray
        ``(Z - size + 1, Y - size + 1, X - size + 1, C)`` float32.

    Examples
    --------
    >>> v = np.arange(4.0).reshape(1, 1, 4, 1).repeat(2, 0).repeat(2, 1)
    >>> box_mean(v, 2)[..., 0].tolist()
    [[[0.5, 1.5, 2.5]]]
    """
    v = np.asarray(volume, dtype=np.float64)
    if size < 1 or size > min(v.shape[:3]):
        raise ValueError(f"box size {size} does not fit a volume of shape {v.shape[:3]}")
    s = np.pad(v, [(1, 0), (1, 0), (1, 0), (0, 0)])
    for ax in range(3):
        np.cumsum(s, axis=ax, out=s)
    a, b = slice(size, None), slice(None, -size)
    total = s[a, a, a] - s[b, a, a] - s[a, b, a] - s[a, a, b] + s[b, b, a] + s[b, a, b] + s[a, b, b] - s[b, b, b]
    return (total / size**3).astype(np.float32)


def cell_starts(block: int, overlap: int, pool: int) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Start offsets, along one axis, of the pooled cells that describe a block, and which lie in the overlap.

    Cells are ``pool`` voxels wide: every ``pool`` voxels across the block, plus cells that fit
    exactly inside the leading ``overlap`` voxels (so the pooled overlap never reaches into voxels
    that are not synthesised yet).

    Returns
    -------
    starts : numpy.ndarray
        Sorted, unique start offsets in ``[0, block - pool]``.
    in_overlap : numpy.ndarray
        ``True`` where the cell lies entirely inside ``[0, overlap)``.

    Examples
    --------
    >>> starts, lead = cell_starts(16, 3, 2)
    >>> starts.tolist(), lead.tolist()[:3]
    ([0, 1, 2, 4, 6, 8, 10, 12, 14], [True, True, False])
    """
    if not 1 <= pool <= overlap or block % pool:
        raise ValueError(f"pool {pool} must divide the block {block} and be at most the overlap {overlap}")
    lead = set(range(0, overlap - pool + 1, pool)) | {overlap - pool}
    starts = np.array(sorted(set(range(0, block - pool + 1, pool)) | lead), dtype=np.int64)
    return starts, np.isin(starts, sorted(lead))


def classify_blocks(
    means: ArrayLike, n_classes: int = 3, *, rng: RNGLike = 0, sample: int = 4096
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Cluster block mean colours into ``n_classes`` classes (k-means), ordered dark to bright.

    Parameters
    ----------
    means : array_like
        ``(N, 3)`` mean colour of each candidate block.
    n_classes : int
        Number of classes (the paper uses three).
    rng : int or numpy.random.Generator
        Seeds k-means++ (the result is deterministic for an int).
    sample : int
        k-means runs on at most this many means; all are then assigned to the nearest centre.

    Returns
    -------
    labels : numpy.ndarray
        ``(N,)`` class of each block, 0 = darkest centre.
    probabilities : numpy.ndarray
        ``(n_classes,)`` fraction of blocks in each class.

    Examples
    --------
    >>> m = np.array([[0, 0, 0], [1, 1, 1], [200, 200, 200], [100, 100, 100], [101, 99, 100]], float)
    >>> labels, p = classify_blocks(m)
    >>> labels.tolist(), p.round(2).tolist()
    ([0, 0, 2, 1, 1], [0.4, 0.4, 0.2])
    """
    m = np.asarray(means, dtype=np.float64).reshape(-1, 3)
    rng = np.random.default_rng(rng)
    train = m if len(m) <= sample else m[rng.choice(len(m), sample, replace=False)]
    k = min(n_classes, len(np.unique(train, axis=0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # an empty cluster is fine: that class just gets probability 0
        centres, _ = kmeans2(train, k, seed=rng, minit="++")
    centres = centres[np.argsort(centres.sum(axis=1), kind="stable")]
    labels, _ = vq(m, centres)
    probabilities = np.bincount(labels, minlength=n_classes)[:n_classes] / len(m)
    return labels.astype(np.int64), probabilities


def feature_inclusiveness(
    exemplar: ArrayLike, size: int, *, n_blocks: int = 64, bins: int = 4, rng: RNGLike = 0
) -> float:
    """Mean L2 distance between the colour histograms of random ``size``-blocks and of the exemplar.

    Small values mean a block of this size already contains the exemplar's features (its colour
    statistics); the distance falls as blocks grow. ``rng`` (an int or a Generator) places the
    blocks.

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` uint8 colour volume.
    size : int
        The block size.
    n_blocks : int
        How many random blocks to compare.
    bins : int
        Histogram bins per channel.
    rng : int or numpy.random.Generator
        The random source.

    Returns
    -------
    float
        The mean distance (0: every block has the exemplar's colours).

    Examples
    --------
    >>> noise = np.random.default_rng(0).integers(0, 256, (32, 32, 32, 3)).astype(np.uint8)
    >>> feature_inclusiveness(noise, 8) < 0.1
    True
    """
    ex = exemplar_volume(exemplar)
    if size > min(ex.shape[:3]):
        raise ValueError(f"block size {size} is larger than the exemplar {ex.shape[:3]}")
    rng = np.random.default_rng(rng)
    whole = color_histogram(ex, bins=bins)
    hi = np.array(ex.shape[:3]) - size + 1
    corners = rng.integers(0, hi, size=(n_blocks, 3))
    d = [
        np.linalg.norm(color_histogram(ex[z : z + size, y : y + size, x : x + size], bins=bins) - whole)
        for z, y, x in corners
    ]
    return float(np.mean(d))


def choose_block_size(
    exemplar: ArrayLike, *, sizes: Sequence[int] | None = None, tolerance: float = 0.2, rng: RNGLike = 0
) -> int:
    """The smallest block size whose feature inclusiveness is within ``tolerance``.

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` uint8 exemplar.
    sizes : sequence of int, optional
        Candidate sizes (even); by default :data:`DEFAULT_BLOCK_SIZES` up to half the exemplar's
        smallest side (so each class keeps many candidate positions).
    tolerance : float
        Largest acceptable mean histogram distance (:func:`feature_inclusiveness`, 4 bins per
        channel). If no size reaches it, the largest candidate is used.
    rng : int or numpy.random.Generator
        Places the random blocks measured (an int: the same blocks for every size).

    Returns
    -------
    int
        The block size chosen.

    Examples
    --------
    >>> noise = np.random.default_rng(0).integers(0, 256, (48, 48, 48, 3)).astype(np.uint8)
    >>> choose_block_size(noise)
    8
    """
    ex = exemplar_volume(exemplar)
    limit = min(ex.shape[:3]) // 2
    candidates = sorted(s for s in (sizes or DEFAULT_BLOCK_SIZES) if 2 <= s <= max(limit, 2) and s % 2 == 0)
    if not candidates:
        raise ValueError(f"no even block size fits an exemplar of shape {ex.shape[:3]}")
    for s in candidates:
        if feature_inclusiveness(ex, s, rng=rng) <= tolerance:
            return s
    return candidates[-1]
