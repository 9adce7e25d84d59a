"""Solid texture synthesis by texture optimisation against a solid exemplar, nearest blocks by PatchMatch.

Block synthesis (:func:`~ffd_notebook.solidtex.synthesize`) copies whole blocks and joins them at
seams; on a cellular texture (the stained gland of ``exemplar_from_image``) the seams cut through
cells every block, and a slice up close is a mosaic of cell fragments with straight edges, even
with every offset of the exemplar searched (by FFT), blocks of 12-24 voxels and cuts through
half-block overlaps. Matching a 3D block on three faces at once leaves few good matches.

Here the whole volume is optimised instead (Kwatra, Essa, Bobick and Kwatra, "Texture optimization
for example-based synthesis", SIGGRAPH 2005), in 3D and against the *solid* exemplar: overlapping
``n^3`` blocks of the output, on a grid with half a block's step, are each matched to the most
alike ``n^3`` block of the exemplar, and every voxel becomes the robust weighted mean of the
matched blocks that cover it (weight ``d^(r-2)`` for a block at distance ``d``, Kwatra's IRLS with
``r = 0.8``: a voxel follows its best-matching blocks). The matches are found by PatchMatch
(Barnes, Shechtman, Finkelstein and Goldman 2009) in 3D: each block tries its neighbours' matches
shifted by the grid step (so matches spread coherently, and neighbouring blocks come from
neighbouring places of the exemplar: they agree where they overlap, which is what keeps the result
sharp), then random positions in shrinking windows. Coarse to fine: the output and the exemplar
are halved ``levels - 1`` times; each level starts from the coarser one's result and matches.
After each iteration the colours get the exemplar's joint distribution back (sliced transport,
:func:`~ffd_notebook.solidtex.slice_search.transfer_colours`): averaging narrows them.

The output is periodic (its grid of blocks wraps around), so the grid never lines up with a
border; the grid is shifted by a random offset every iteration, so no seam stays on it. Only
blocks wholly inside the exemplar are matched (see ``_Exemplar``).

Hand-written, not a library's: scikit-image and SciPy have no patch matching, and the PatchMatch
packages on PyPI are 2D and image-only (compiled, or PyTorch).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from .seeding import RNGLike
from .slice_search import downsample, transfer_colours
from .slices import exemplar_volume

__all__ = ["synthesize_by_optimisation"]

_CANDIDATE_ROUNDS = 4  # rounds of neighbour propagation per iteration
_RANDOM_TRIES = 4  # random-search tries (halving windows) per round
_COLOUR_SAMPLE = 200_000  # voxels the colour transfer estimates a larger volume's quantiles on


def _box(volume: NDArray[np.float32], pool: int) -> NDArray[np.float32]:
    """Mean of the ``pool^3`` cube starting at every voxel, wrapping around: the features' pooled colours.

    :func:`~ffd_notebook.solidtex.box_mean` of the volume padded by wrapping gives the same (to 1e-7), but
    its float64 summed-area table takes 0.44 s at 128^3 against 0.05 s for these eight shifted sums (pool 2),
    and this runs every iteration.
    """
    if pool == 1:
        return volume
    out = np.zeros_like(volume)
    for shift in np.ndindex(pool, pool, pool):
        out += np.roll(volume, tuple(-d for d in shift), axis=(0, 1, 2))
    out *= 1.0 / pool**3
    return out


class _Blocks:
    """Flat-index arithmetic for the ``n^3`` blocks (features: every ``pool``-th voxel of the pooled block)."""

    def __init__(self, shape: tuple[int, ...], n: int, pool: int) -> None:
        self.strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
        feat = np.arange(0, n, pool)
        grid = np.meshgrid(feat, feat, feat, indexing="ij")
        self.feature_offsets = sum(g.ravel() * s for g, s in zip(grid, self.strides, strict=True))

    def flat(self, corners: NDArray[np.int64]) -> NDArray[np.int64]:
        return corners @ self.strides


class _Exemplar:
    """One pyramid level of the exemplar: its colours and the features of every block wholly inside it.

    Blocks never wrap around the exemplar, even one that tiles: a coherent copy that could run on
    across the border would copy the whole exemplar again and again (PatchMatch finds that perfect
    match, and a volume twice the exemplar's size came out as the exemplar tiled: self-similarity
    0.01-0.08 over whole slices).
    """

    def __init__(self, exemplar: NDArray[np.float32], n: int, pool: int) -> None:
        self.limit = np.array([s - n for s in exemplar.shape[:3]], dtype=np.int64)  # largest corner per axis
        self.colours = exemplar
        self.blocks = _Blocks(exemplar.shape, n, pool)
        pooled = _box(exemplar, pool).reshape(-1, 3)
        corners = np.stack(np.meshgrid(*[np.arange(m + 1) for m in self.limit], indexing="ij"), -1).reshape(-1, 3)
        self.index = np.zeros(tuple(self.limit + 1), dtype=np.int64)  # corner -> row of features
        self.index[tuple(corners.T)] = np.arange(len(corners))
        rows = self.blocks.flat(corners)[:, None] + self.blocks.feature_offsets[None, :]
        self.features = pooled[rows].reshape(len(corners), -1)

    def features_at(self, corners: NDArray[np.int64]) -> NDArray[np.float32]:
        return self.features[self.index[corners[..., 0], corners[..., 1], corners[..., 2]]]

    def inside(self, corners: NDArray[np.int64]) -> NDArray[np.bool_]:
        return np.all((corners >= 0) & (corners <= self.limit), axis=-1)

    def clamp(self, corners: NDArray[np.int64]) -> NDArray[np.int64]:
        return np.clip(corners, 0, self.limit)


def _output_features(volume: NDArray[np.float32], n: int, pool: int, step: int) -> NDArray[np.float32]:
    """Features of the output's blocks at corners ``k * step`` (periodic), ``(kz, ky, kx, d)``."""
    padded = np.pad(_box(volume, pool), [(0, n)] * 3 + [(0, 0)], mode="wrap")
    blocks = _Blocks(padded.shape, n, pool)
    k = [s // step for s in volume.shape[:3]]
    corners = np.stack(np.meshgrid(*[np.arange(m) * step for m in k], indexing="ij"), -1)
    rows = blocks.flat(corners)[..., None] + blocks.feature_offsets
    return padded.reshape(-1, 3)[rows].reshape(*k, -1)


def _distances(exemplar: _Exemplar, queries: NDArray[np.float32], matches: NDArray[np.int64]) -> NDArray[np.float32]:
    return np.square(exemplar.features_at(matches) - queries).sum(axis=-1)


def _patchmatch(exemplar: _Exemplar, queries, matches, step: int, rng: np.random.Generator):
    """Improve each block's match: neighbours' matches shifted by the grid step, then random tries."""
    best = _distances(exemplar, queries, matches)

    def consider(candidates):  # a candidate outside the exemplar is not one: the copy ends there
        valid = exemplar.inside(candidates)
        d = _distances(exemplar, queries, exemplar.clamp(candidates))
        better = valid & (d < best)
        matches[better], best[better] = candidates[better], d[better]

    radius = float(exemplar.limit.max() + 1) / 2
    for _ in range(_CANDIDATE_ROUNDS):
        for axis in range(3):
            for sign in (1, -1):
                shifted = np.roll(matches, sign, axis=axis)
                shifted[..., axis] += sign * step
                consider(shifted)
        r = radius
        for _ in range(_RANDOM_TRIES):
            span = max(int(r), 1)
            consider(exemplar.clamp(matches + rng.integers(-span, span + 1, matches.shape)))
            r /= 2
    return matches, best


def _aggregate(exemplar: _Exemplar, matches, weights, shape: tuple[int, ...], step: int) -> NDArray[np.float32]:
    """Weighted mean of the matched exemplar blocks at corners ``k * step`` (periodic, ``n = 2 step``)."""
    colours = exemplar.colours.reshape(-1, 3)
    k = matches.shape[:3]
    local = np.stack(np.meshgrid(*[np.arange(step)] * 3, indexing="ij"), -1).reshape(-1, 3)
    local_flat = exemplar.blocks.flat(local)
    base = matches.reshape(-1, 3)
    w = weights.reshape(-1, 1, 1)
    acc = np.zeros((*shape, 3), dtype=np.float32)
    wsum = np.zeros(shape, dtype=np.float32)
    w_tiled = np.broadcast_to(weights[:, None, :, None, :, None], (k[0], step, k[1], step, k[2], step)).reshape(shape)
    for d in np.ndindex(2, 2, 2):  # the block's eight sub-cubes tile the volume, each shifted by d * step
        start = exemplar.blocks.flat(base + np.array(d) * step)
        sub = colours[start[:, None] + local_flat[None, :]] * w  # (corners, step^3, 3)
        sub = sub.reshape(*k, step, step, step, 3).transpose(0, 3, 1, 4, 2, 5, 6).reshape(*shape, 3)
        shift = tuple(int(v) * step for v in d)
        acc += np.roll(sub, shift, axis=(0, 1, 2))
        wsum += np.roll(w_tiled, shift, axis=(0, 1, 2))
    return acc / wsum[..., None]


def synthesize_by_optimisation(
    exemplar: ArrayLike,
    shape: int | tuple[int, int, int],
    *,
    rng: RNGLike = 0,
    neighbourhood: int = 8,
    levels: int = 3,
    iterations: int = 5,
    robust: float = -1.0,
    progress: bool = True,
) -> NDArray[np.uint8]:
    """Grow a solid texture of ``shape`` from a solid exemplar by texture optimisation (see the module docstring).

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar, for example from :func:`~ffd_notebook.solidtex.exemplar_from_image` (uint8,
        uint16 or floats in [0, 1]: the package's dtype policy);
        each side at least ``neighbourhood * 2 ** (levels - 1)``.
    shape : int or (int, int, int)
        Size of the result, ``(Z, Y, X)``.
    rng : int or numpy.random.Generator
        The result is the same for the same int.
    neighbourhood : int
        Edge of the matched blocks in voxels (even, at least 4). The blocks should hold a
        feature of the texture (a cell): 8 for the bundled histology crop, whose cells are 8-12 px.
    levels : int
        Pyramid levels: 3 starts at a quarter of the size, where the layout is decided.
    iterations : int
        Match-and-average iterations per level.
    robust : float
        Kwatra's ``r``: a block at distance ``d`` weighs ``d^(r-2)``. 2 is a plain mean (it blurs);
        Kwatra's 0.8 follows the best matches more; the default -1 more still (self-similarity
        0.83-0.90 instead of 0.77-0.85 on the tests' gravel, 0.93-0.98 instead of 0.92-0.94 on the
        histology below).
    progress : bool
        Show a tqdm progress bar (one tick per iteration).

    Returns
    -------
    numpy.ndarray
        ``(Z, Y, X, 3)`` uint8; periodic when every side is a multiple of
        ``neighbourhood / 2 * 2 ** (levels - 1)``.

    Notes
    -----
    Measured here (2 cores, one BLAS thread) from the 64^3 exemplar of the notebook's histology crop
    (``immunohistochemistry()[340:404, 290:354]``): 128^3 in 12 s, self-similarity 0.94/0.98/0.98 and
    likeness 0.93 in the three orientations, colour-histogram distance 0.013; 256^3 in 145 s at a peak
    of 2.6 GB (0.96 in every orientation). Up close its slices show whole cells, brown walls round blue
    nuclei, with a few short straight edges where two copied regions meet. Block synthesis with cut
    seams scores 1.14-1.17 in 12 s, but up close it is a mosaic of cell fragments with straight edges
    (the windows of the measure are too small to see it). For 512^3 and beyond use the block synthesis
    or :class:`~ffd_notebook.solidtex.LazySolidTexture`.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> ex = np.kron(rng.integers(0, 256, (8, 8, 8, 3)), np.ones((4, 4, 4, 1))).astype(np.uint8)
    >>> out = synthesize_by_optimisation(ex, (24, 20, 40), levels=2, iterations=2, progress=False)
    >>> out.shape, out.dtype.name
    ((24, 20, 40, 3), 'uint8')
    """
    ex = exemplar_volume(exemplar)  # the dtype policy: a float exemplar in [0, 1] was clipped to {0, 1}
    target = (int(shape),) * 3 if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
    if len(target) != 3 or min(target) < 1:
        raise ValueError(f"shape must be three positive sizes, got {shape}")
    if neighbourhood < 4 or neighbourhood % 2:
        raise ValueError(f"neighbourhood must be an even number of voxels, at least 4, got {neighbourhood}")
    if levels < 1 or iterations < 1:
        raise ValueError(f"levels and iterations must be at least 1, got {levels} and {iterations}")
    if not robust < 2:
        raise ValueError(f"robust must be below 2 (2 is a plain mean), got {robust}")
    smallest = neighbourhood * 2 ** (levels - 1)
    if min(ex.shape[:3]) < smallest:
        raise ValueError(
            f"the exemplar's sides {ex.shape[:3]} must be at least neighbourhood * 2 ** (levels - 1) = {smallest}:"
            " use fewer levels or a smaller neighbourhood"
        )
    rng = np.random.default_rng(rng)
    step = neighbourhood // 2
    unit = step * 2 ** (levels - 1)
    full = tuple(unit * math.ceil(t / unit) for t in target)  # the grid of blocks tiles every level
    pyramid = [ex.astype(np.float32)]
    for _ in range(levels - 1):
        pyramid.append(downsample(pyramid[-1], 2))
    pool = 2 if neighbourhood >= 8 else 1  # features: 2x2x2 means (192 numbers for 8^3 blocks)
    out: NDArray[np.float32] | None = None
    matches: NDArray[np.int64] | None = None
    shift = np.zeros(
        3, dtype=np.int64
    )  # the grid of blocks' offset: block (i, j, k) has its corner at k * step + shift
    with tqdm(total=levels * iterations, desc="solid texture", unit="iteration", disable=not progress) as bar:
        for level in range(levels - 1, -1, -1):
            source = _Exemplar(pyramid[level], neighbourhood, pool)
            size = tuple(s // 2**level for s in full)
            k = tuple(s // step for s in size)
            if out is None:  # the coarsest level starts from the exemplar's voxels at random, matches at random
                voxels = pyramid[level].reshape(-1, 3)
                out = voxels[rng.integers(0, len(voxels), math.prod(size))].reshape(*size, 3)
                matches = source.clamp(rng.integers(0, source.limit + 1, (*k, 3)))
            else:  # twice the finer size; each block starts from its coarser block's match, twice as far in
                assert matches is not None  # made at the coarsest level
                out = np.repeat(np.repeat(np.repeat(out, 2, axis=0), 2, axis=1), 2, axis=2)
                coarse = np.stack(np.meshgrid(*[np.arange(m) // 2 for m in k], indexing="ij"), -1)
                fine = np.stack(np.meshgrid(*[np.arange(m) % 2 for m in k], indexing="ij"), -1)
                matches = source.clamp(2 * matches[coarse[..., 0], coarse[..., 1], coarse[..., 2]] + fine * step)
                shift = 2 * shift
            for _ in range(iterations):
                moved = rng.integers(0, step, 3)  # move the grid of blocks: no seam stays on it
                matches = matches + moved - shift  # each block's match moves with it (coherent)
                shift = moved
                rolled = np.roll(out, tuple(-int(v) for v in shift), axis=(0, 1, 2))
                queries = _output_features(rolled, neighbourhood, pool, step)
                matches, distance = _patchmatch(source, queries, source.clamp(matches), step, rng)
                weights = np.maximum(distance, 1e-6) ** ((robust - 2) / 2)  # d^(r-2), d the distance (not squared)
                rolled = _aggregate(source, matches, weights.astype(np.float32), size, step)
                rolled = transfer_colours(rolled, pyramid[level], 2, int(rng.integers(2**31)), sample=_COLOUR_SAMPLE)
                out = np.roll(rolled, tuple(int(v) for v in shift), axis=(0, 1, 2))
                bar.update()
    assert out is not None  # levels >= 1
    crop = tuple(slice(0, t) for t in target)
    return np.clip(np.rint(out[crop]), 0, 255).astype(np.uint8)
