"""Square neighbourhoods of images and of axis-aligned volume slices, and how far they are from an exemplar's.

Kopf et al. (2007) judge a solid texture by its *slices*: every ``n x n`` neighbourhood on a slice
perpendicular to x, y or z should look like some neighbourhood of the 2D exemplar. The mean
distance from slice neighbourhoods to their nearest exemplar neighbourhood is the energy their
optimisation lowers (:func:`~ffd_notebook.solidtex.exemplar_from_image`), and here it is also the
quality figure: :func:`neighbourhood_distance` measures it on random slices of any volume, and
:func:`seam_error` measures it only where blocks overlap (a feathered overlap is a blend of two
blocks, not something the exemplar contains; a cut one is mostly one block or the other).

As a quality figure it rewards blur: a smooth window is near some smooth part of the image (the
histology image blurred by one pixel scores lower than new samples of it). Judge whether slices
look like the texture with :func:`~ffd_notebook.solidtex.self_similarity` and
:func:`~ffd_notebook.solidtex.likeness`, which blur, tiling and noise all fail.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

from .seeding import RNGLike

__all__ = ["image_windows", "neighbourhood_distance", "reference_windows", "seam_error", "slice_windows"]


def image_windows(image: ArrayLike, size: int) -> NDArray[np.float32]:
    """Every ``size x size`` window of an ``(H, W, 3)`` image, flattened: ``(count, 3 * size**2)`` float32.

    Examples
    --------
    >>> image_windows(np.zeros((4, 5, 3), np.uint8), 3).shape
    (6, 27)
    """
    img = np.asarray(image, dtype=np.float32)
    w = sliding_window_view(img, (size, size), axis=(0, 1))  # (H-s+1, W-s+1, 3, s, s)
    return np.ascontiguousarray(w.transpose(0, 1, 3, 4, 2)).reshape(-1, 3 * size * size)


def slice_windows(volume: ArrayLike, axis: int, centres: ArrayLike, size: int) -> NDArray[np.float32]:
    """Windows on the slices perpendicular to ``axis``, centred on voxels: ``(N, 3 * size**2)`` float32.

    The window of voxel ``(z, y, x)`` lies in its slice along ``axis``; its rows and columns follow
    the other two axes in order (the slice's own row/column order). The volume wraps around at its
    borders (solid textures tile).

    Examples
    --------
    >>> v = np.arange(4 * 4 * 4 * 3, dtype=np.uint8).reshape(4, 4, 4, 3)
    >>> w = slice_windows(v, 0, [[2, 1, 1]], 3).reshape(3, 3, 3)
    >>> bool(np.array_equal(w, v[2, 0:3, 0:3]))
    True
    """
    v = np.asarray(volume)
    c = np.asarray(centres, dtype=np.int64).reshape(-1, 3)
    r = np.arange(size) - size // 2
    rows, cols = [a for a in range(3) if a != axis]
    idx = [np.broadcast_to(c[:, a, None, None], (len(c), size, size)) for a in range(3)]
    idx[rows] = (c[:, rows, None, None] + r[None, :, None]) % v.shape[rows]
    idx[cols] = (c[:, cols, None, None] + r[None, None, :]) % v.shape[cols]
    return v[idx[0], idx[1], idx[2]].astype(np.float32).reshape(len(c), -1)


def reference_windows(reference: ArrayLike, size: int, *, limit: int = 40000, rng: RNGLike = 0) -> NDArray[np.float32]:
    """The exemplar neighbourhoods to compare with: all windows of a 2D image, or of a volume's slices.

    A volume's slices along all three axes give windows; at most ``limit`` of them are kept (a
    random subset drawn with ``rng``, an int or a Generator: the same for an int), so two volumes
    compared with the same reference are measured alike.

    Examples
    --------
    >>> reference_windows(np.zeros((6, 6, 3), np.uint8), 5).shape
    (4, 75)
    >>> reference_windows(np.zeros((8, 8, 8, 3), np.uint8), 5, limit=100).shape
    (100, 75)
    """
    ref = np.asarray(reference)
    if ref.ndim == 3:
        windows = image_windows(ref, size)
        if len(windows) <= limit:
            return windows
        return windows[np.random.default_rng(rng).choice(len(windows), limit, replace=False)]
    if ref.ndim != 4 or ref.shape[-1] != 3:
        raise ValueError(f"reference must be an (H, W, 3) image or a (Z, Y, X, 3) volume, got shape {ref.shape}")
    rng = np.random.default_rng(rng)
    n_voxels = int(np.prod(ref.shape[:3]))
    if 3 * n_voxels <= limit:  # small: every window of every slice
        axes = np.repeat(np.arange(3), n_voxels)
        centres = np.tile(np.stack(np.unravel_index(np.arange(n_voxels), ref.shape[:3]), axis=1), (3, 1))
    else:
        axes = rng.integers(0, 3, limit)
        centres = rng.integers(0, ref.shape[:3], size=(limit, 3))
    return np.concatenate([slice_windows(ref, a, centres[axes == a], size) for a in range(3)])


def _nearest_distances(queries: NDArray[np.float32], reference: NDArray[np.float32]) -> NDArray[np.float64]:
    """Exact Euclidean distance from each query to its nearest reference row (brute force, in chunks).

    Brute force with one matrix product per chunk is exact and, for these sizes (a few thousand
    queries, tens of thousands of references, 75 dimensions), faster than a k-d tree, which
    degrades towards brute force in so many dimensions.
    """
    centre = reference.mean(axis=0, dtype=np.float64).astype(np.float32)  # smaller numbers: less float32 rounding
    ref = reference.astype(np.float32) - centre
    queries = queries - centre
    ref_sq = np.einsum("ij,ij->i", ref, ref)
    out = np.empty(len(queries))
    for start in range(0, len(queries), 512):
        q = queries[start : start + 512].astype(np.float32)
        d2 = ref_sq[None, :] - 2.0 * (q @ ref.T)
        best = d2.min(axis=1).astype(np.float64) + np.einsum("ij,ij->i", q, q)
        out[start : start + 512] = np.sqrt(np.maximum(best, 0.0))
    return out


def neighbourhood_distance(
    volume: ArrayLike,
    reference: ArrayLike,
    *,
    size: int = 5,
    n_queries: int = 3000,
    mask: ArrayLike | None = None,
    rng: RNGLike = 0,
) -> float:
    """Mean distance from neighbourhoods on random axis-aligned slices to their nearest exemplar neighbourhood.

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, 3)`` colours.
    reference : array_like
        The exemplar: an ``(H, W, 3)`` image, or a volume (see :func:`reference_windows`).
    size : int
        Window edge (odd).
    n_queries : int
        Number of random (voxel, slice axis) pairs.
    mask : array_like, optional
        ``(Z, Y, X)`` bool: draw query voxels only where it is True.
    rng : int or numpy.random.Generator
        Chooses the queries (and the reference subset of a volume reference); an int gives the
        same queries every time.

    Returns
    -------
    float
        Root-mean-square colour difference per channel value (0-255 units) between a window and
        its nearest exemplar window, averaged over the queries; 0 when every window is in the
        exemplar.

    Examples
    --------
    Stacked crops of a noise image match it on their z-slices but not on the other sections:

    >>> img = np.random.default_rng(0).integers(0, 256, (32, 32, 3)).astype(np.uint8)
    >>> stack = np.stack([img[k : k + 16, k : k + 16] for k in range(16)])
    >>> inner = np.zeros(stack.shape[:3], bool); inner[:, 2:-2, 2:-2] = True
    >>> round(neighbourhood_distance(stack, img, n_queries=300, mask=inner), 1) > 30
    True
    """
    v = np.asarray(volume)
    if v.ndim != 4 or v.shape[-1] != 3:
        raise ValueError(f"expected a (Z, Y, X, 3) volume, got shape {v.shape}")
    if size % 2 != 1 or size > min(v.shape[:3]):
        raise ValueError(f"window size {size} must be odd and fit in the volume {v.shape[:3]}")
    given, rng = rng, np.random.default_rng(rng)  # a Generator stays itself; an int seeds the reference too
    if mask is None:
        centres = rng.integers(0, v.shape[:3], size=(n_queries, 3))
    else:
        where = np.flatnonzero(np.asarray(mask, dtype=bool).ravel())
        if len(where) == 0:
            raise ValueError("the mask selects no voxel")
        centres = np.stack(np.unravel_index(rng.choice(where, n_queries), v.shape[:3]), axis=1)
    axes = rng.integers(0, 3, n_queries)
    queries = np.concatenate([slice_windows(v, a, centres[axes == a], size) for a in range(3)])
    ref = reference_windows(reference, size, rng=given)
    d = _nearest_distances(queries, ref)
    return float(np.mean(d) / np.sqrt(queries.shape[1]))


def seam_error(
    volume: ArrayLike,
    exemplar: ArrayLike,
    *,
    step: int,
    overlap: int,
    size: int = 5,
    n_queries: int = 3000,
    rng: RNGLike = 0,
) -> float:
    """:func:`neighbourhood_distance` of the voxels in block-overlap bands: how unlike the exemplar the seams are.

    A feathered overlap is a mix of two blocks, which the exemplar does not contain; a
    minimum-error cut keeps one block or the other, switching where they agree. Lower is better;
    compare with :func:`neighbourhood_distance` of the whole volume (``rng`` as there).

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, 3)`` synthesised texture.
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar.
    step : int
        Distance between block origins (block minus overlap).
    overlap : int
        Overlap in voxels.
    size : int
        Neighbourhood size.
    n_queries : int
        How many seam voxels to measure.
    rng : int or numpy.random.Generator
        The random source.

    Returns
    -------
    float
        The mean neighbourhood distance in the seam bands.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ex = rng.integers(0, 256, (16, 16, 16, 3)).astype(np.uint8)
    >>> seam_error(ex, ex, step=6, overlap=2, n_queries=100) < 0.1
    True
    """
    v = np.asarray(volume)
    if step < 1 or overlap < 1:
        raise ValueError("step and overlap must be positive")
    # voxel k is shared by two blocks when a block starts at or before it, less than `overlap` voxels back
    masks = [(np.arange(n) >= step) & (np.arange(n) % step < overlap) for n in v.shape[:3]]
    band = masks[0][:, None, None] | masks[1][None, :, None] | masks[2][None, None, :]
    return neighbourhood_distance(v, exemplar, size=size, n_queries=n_queries, mask=band, rng=rng)
