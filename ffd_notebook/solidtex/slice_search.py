"""What both solid optimisations share: the image pyramid, image windows in a k-d tree, slice windows.

:func:`~ffd_notebook.solidtex.exemplar_from_image` (Kopf et al. 2007, ``method="kopf"``) and
:func:`~ffd_notebook.solidtex.exemplar_by_transport` both compare the windows of a volume's axis-aligned
slices with the windows of one image: these are the pieces they have in common (the image's
``2 x 2`` block-mean pyramid, its windows PCA-reduced in a SciPy k-d tree, slice windows centred on a
sparse periodic grid and the voxels each window offset lands on, Kopf's histogram over-use penalty,
and the sliced optimal-transport colour transfer). Implementation only: the public names are the
two functions above.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.stats import special_ortho_group

from .neighbourhoods import image_windows

__all__ = [
    "BINS",
    "LARGEST_DEFAULT",
    "ImageNeighbourhoods",
    "channel_histograms",
    "default_size",
    "downsample",
    "histogram_penalty",
    "optimise_step",
    "proposals",
    "slice_queries",
    "transfer_colours",
    "window_offsets",
]

BINS = 16  # per-channel histogram bins of the histogram matching


def downsample(image: NDArray[np.float32], factor: int) -> NDArray[np.float32]:
    """Mean of ``factor``-wide pixel (or voxel) blocks: an image ``(H, W, C)`` or a volume ``(Z, Y, X, C)`` at a
    coarser pyramid level (sides that do not divide lose their last pixels)."""
    if factor == 1:
        return image
    kept = [s - s % factor for s in image.shape[:-1]]
    split = [n for k in kept for n in (k // factor, factor)]
    blocks = image[tuple(slice(0, k) for k in kept)].reshape(*split, image.shape[-1])
    return blocks.mean(axis=tuple(range(1, 2 * len(kept), 2)))


class ImageNeighbourhoods:
    """All ``n x n`` windows of one pyramid level of the image, PCA-reduced into a k-d tree."""

    def __init__(self, image: NDArray[np.float32], n: int, dims: int, rng: np.random.Generator) -> None:
        self.n = n
        self.windows = image_windows(image, n)  # (M, 3 n^2), order (row, col, channel)
        sample = self.windows[rng.choice(len(self.windows), min(len(self.windows), 6000), replace=False)]
        self.mean = sample.mean(axis=0)
        _, _, vt = np.linalg.svd(sample - self.mean, full_matrices=False)
        self.basis = vt[: min(dims, vt.shape[0])].T.astype(np.float32)
        self.tree = cKDTree((self.windows - self.mean) @ self.basis)

    def nearest(self, queries: NDArray[np.float32]) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
        """Index of the nearest window and the true (full-dimensional) distance to it."""
        _, idx = self.tree.query((queries - self.mean) @ self.basis, k=1, eps=0.5, workers=-1)
        d = np.linalg.norm(self.windows[idx] - queries, axis=1)
        return idx, d


def slice_queries(volume: NDArray[np.float32], axis: int, n: int, stride: int, offset: int) -> NDArray[np.float32]:
    """Windows on the slices perpendicular to ``axis``, centred on a grid with ``stride`` in the slice (periodic)."""
    h = n // 2
    vol = np.moveaxis(volume, axis, 0)  # (S, R, C, 3): slices, rows, columns
    pad = np.pad(vol, ((0, 0), (h, h), (h, h), (0, 0)), mode="wrap")
    rows = np.arange(offset, vol.shape[1], stride)
    cols = np.arange(offset, vol.shape[2], stride)
    r = rows[:, None] + np.arange(n)[None, :]  # padded coordinates of each window's rows
    c = cols[:, None] + np.arange(n)[None, :]
    w = pad[:, r[:, None, :, None], c[None, :, None, :]]  # (S, nr, nc, n, n, 3)
    return w.reshape(-1, 3 * n * n)


def histogram_penalty(volume: NDArray[np.float32], target: NDArray[np.float64]) -> NDArray[np.float32]:
    """Per channel and bin, how much more of the volume falls in the bin than of the image (>= 0)."""
    q = np.clip(volume.reshape(-1, 3) * (BINS / 256.0), 0, BINS - 1).astype(np.int64)
    h = np.stack([np.bincount(q[:, c], minlength=BINS) for c in range(3)]) / len(q)
    return np.maximum(h - target, 0.0).astype(np.float32) * BINS  # scaled: a fully doubled bin costs ~1


def window_offsets(shape, axis, n, stride, offset):
    """For each window offset (dy, dx): the voxels (in the volume moved so ``axis`` is first) it lands on."""
    h = n // 2
    moved = (shape[axis], *(shape[a] for a in range(3) if a != axis))
    rows0, cols0 = np.arange(offset, moved[1], stride), np.arange(offset, moved[2], stride)
    grid = (moved[0], len(rows0), len(cols0))
    for dy in range(n):
        for dx in range(n):
            # each (row, col) pair appears once for a fixed offset: fancy-index updates are exact
            yield dy, dx, grid, np.ix_(np.arange(moved[0]), (rows0 + dy - h) % moved[1], (cols0 + dx - h) % moved[2])


_TABLE = 4096  # segments of the piecewise-linear quantile maps of transfer_colours(sample=...)


def _on_grid(values: NDArray[np.float64], lo: float, hi: float, table: NDArray[np.float64]) -> NDArray[np.float64]:
    """``np.interp(values, linspace(lo, hi, len(table)), table)`` by index arithmetic: O(n) for values in any
    order (``np.interp``'s search is slow for millions of unsorted values)."""
    t = (values - lo) * ((len(table) - 1) / max(hi - lo, 1e-12))
    i = np.clip(t.astype(np.int64), 0, len(table) - 2)
    f = np.clip(t - i, 0.0, 1.0)
    return table[i] * (1.0 - f) + table[i + 1] * f


def _quantile_map(values, some, ranks, quantiles, target) -> NDArray[np.float64]:
    """Each value to the target's quantile at its rank, the ranks estimated on the sorted sample ``some``."""
    lo, hi = float(values.min()), float(values.max())
    cdf = np.interp(np.linspace(lo, hi, _TABLE + 1), some, ranks)
    inverse = np.interp(np.linspace(0.0, 1.0, _TABLE + 1), quantiles, target)
    return _on_grid(_on_grid(values, lo, hi, cdf), 0.0, 1.0, inverse)


def transfer_colours(
    volume: NDArray[np.float32], image: NDArray[np.float32], rounds: int, seed: int, sample: int | None = None
):
    """Give the volume's colours the image's joint RGB distribution (sliced optimal transport).

    Each round rotates the colour space at random and matches each rotated channel's
    distribution exactly (rank by rank), after Pitie, Kokaram and Dawson (2005); a few rounds
    match the joint distribution, which per-channel matching alone does not. Averaging proposals
    narrows the colours; this restores them without moving any structure.

    With ``sample``, a volume of more voxels than that is matched through its quantiles estimated
    on ``sample`` random voxels (a monotone piecewise-linear map of each channel instead of a sort):
    at 128^3 the exact ranks were two thirds of ``synthesize_by_optimisation``'s time.
    """
    x = volume.reshape(-1, 3).astype(np.float64)
    y = image.reshape(-1, 3).astype(np.float64)
    n = sample if sample is not None and len(x) > sample else len(x)
    estimate = n < len(x)
    ranks = (np.arange(n) + 0.5) / n
    quantiles = (np.arange(len(y)) + 0.5) / len(y)
    rng = np.random.default_rng(seed)
    picks = np.random.default_rng([seed, 1])  # the samples' own stream: the same rotations with or without them
    for _ in range(rounds):
        rotation = special_ortho_group.rvs(3, random_state=rng)
        px, py = x @ rotation, y @ rotation
        for c in range(3):
            target = np.sort(py[:, c])
            if estimate:
                some = np.sort(px[picks.integers(0, len(x), n), c])
                px[:, c] = _quantile_map(px[:, c], some, ranks, quantiles, target)
            else:
                px[np.argsort(px[:, c], kind="stable"), c] = np.interp(ranks, quantiles, target)
        x = px @ rotation.T
    return x.reshape(volume.shape).astype(np.float32)


LARGEST_DEFAULT = 160  # px: the largest image side taken as the default size (160^3 takes minutes here)


def default_size(shape: tuple[int, ...], scale: int) -> int:
    """The default edge of an exemplar: the image's smaller side, rounded down to a multiple of ``scale``.

    An image larger than :data:`LARGEST_DEFAULT` on its smaller side raises a :class:`ValueError`
    that says what to do: a whole photograph as the texture would make a 512^3 optimisation (hours
    and gigabytes), where a crop a few features across is what the method needs.
    """
    side = min(shape[:2])
    if side > LARGEST_DEFAULT:
        raise ValueError(
            f"the image is {shape[1]}x{shape[0]} px: by default the exemplar is as large as the image "
            f"({side}^3 voxels, hours of work); pass a crop of the texture a few of its features across "
            f"(64-128 px), or the size you want (size=...)"
        )
    return side // scale * scale


def channel_histograms(image: NDArray[np.float32]) -> NDArray[np.float64]:
    """Per channel, the share of the image's pixels in each of :data:`BINS` bins: ``(3, BINS)``, the target of
    :func:`histogram_penalty`."""
    q = np.clip(image * (BINS / 256.0), 0, BINS - 1).astype(np.int64).reshape(-1, 3)
    return np.stack([np.bincount(q[:, c], minlength=BINS) for c in range(3)]) / len(q)


def proposals(volume, index, stride, offset, r=0.8):
    """For each slice orientation: the matched image windows, their distances and IRLS weights ``|s - e|^(r - 2)``."""
    n = index.n
    for axis in range(3):
        queries = slice_queries(volume, axis, n, stride, offset)
        idx, dist = index.nearest(queries)
        weight = np.power(dist / np.sqrt(3 * n * n) + 0.05, r - 2.0).astype(np.float32)  # IRLS (Kopf: r = 0.8)
        yield axis, index.windows[idx].reshape(-1, n, n, 3), dist.astype(np.float32), weight


def optimise_step(
    volume: NDArray[np.float32],
    index: ImageNeighbourhoods,
    target_hist: NDArray[np.float64],
    stride: int,
    it: int,
    vote: str = "best",
    r: float = 0.8,
) -> NDArray[np.float32]:
    """One search + optimise step: each voxel takes the colour of its best window, or the weighted mean of all.

    Every matched image window proposes colours for the voxels it covers (from all three slice
    orientations). ``vote="mean"`` is Kopf's update: the IRLS-weighted mean of the proposals
    (exponent ``r``; Kopf's 0.8, lower follows the best windows more).
    ``vote="best"``: the voxel takes the proposal of the window that matched best (least distance,
    times the histogram over-use of the colour it brings): it follows its best neighbourhood
    instead of averaging neighbourhoods that disagree, which is what blurs the mean.
    """
    shape = volume.shape[:3]
    penalty = histogram_penalty(volume, target_hist)
    offset = it % stride  # move the sparse grid between iterations so every voxel gets centred
    num = np.zeros((*shape, 3), np.float32)
    den = np.zeros(shape, np.float32) if vote == "mean" else np.full(shape, np.inf, np.float32)
    for axis, patches, dist, weight in proposals(volume, index, stride, offset, r):
        numv, denv = np.moveaxis(num, axis, 0), np.moveaxis(den, axis, 0)
        for dy, dx, grid, sub in window_offsets(shape, axis, index.n, stride, offset):
            colour = patches[:, dy, dx]
            bins = np.clip(colour * (BINS / 256.0), 0, BINS - 1).astype(np.int64)
            over = penalty[0, bins[:, 0]] + penalty[1, bins[:, 1]] + penalty[2, bins[:, 2]]
            if vote == "mean":
                w = (weight / (1.0 + over)).reshape(grid)
                numv[sub] += w[..., None] * colour.reshape(*grid, 3)
                denv[sub] += w
            else:
                score = (dist * (1.0 + over)).reshape(grid)
                better = score < denv[sub]
                denv[sub] = np.where(better, score, denv[sub])
                numv[sub] = np.where(better[..., None], colour.reshape(*grid, 3), numv[sub])
    if vote == "mean":  # a voxel no window covers keeps its colour
        mean = (num / np.maximum(den, np.float32(1e-30))[..., None]).astype(np.float32, copy=False)
        return np.where((den > 0)[..., None], mean, volume)
    return np.where(np.isfinite(den)[..., None], num, volume)
