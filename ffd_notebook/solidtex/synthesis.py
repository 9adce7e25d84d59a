"""Solid texture synthesis: :func:`synthesize` (the default method, per-voxel pyramid synthesis, or another by
name) and the seed's block synthesis with region-doubling reuse, :func:`synthesize_by_blocks`.

Block synthesis is the method of the liver volume-texture paper, in 3D:

1. choose the block size by feature inclusiveness (:func:`~ffd_notebook.solidtex.blocks.choose_block_size`);
2. place blocks in raster-scan order (z, then y, then x), overlapping their predecessors by 1/6
   of the block; for each block draw a colour class with the source's class probabilities (so the
   same tiles are not picked again and again), then take, among random candidate positions of that
   class (at any offset of the source, not only block-aligned ones), the block whose pooled overlap
   best matches what is already there (sum of squared differences of 2x2x2-pooled colours,
   ``|a|^2 + |b|^2 - 2 a.b`` for all candidates at once), never one within half a block of a block
   it touches (a block next to itself repeats its content at the block step: a visible grid);
3. feather the overlaps (:mod:`~ffd_notebook.solidtex.blending`), or, with ``seams="cut"``, cut
   them along minimum-error seams (graph cuts, :mod:`~ffd_notebook.solidtex.seams`; not in the paper);
4. with ``reuse=True``, synthesise only a small initial region from the exemplar, then repeatedly
   double the region, drawing blocks twice as large from the region already synthesised (which is
   kept where it is), until the target is covered. Each doubling places about as many blocks as
   the first stage, so the cost grows with the volume's size far more slowly than with fixed
   blocks; the pooling grows with the block so a match costs the same at every stage.
5. after each stage, restore each channel's mean and standard deviation to the exemplar's
   (``match_statistics``; not in the paper): feathering averages colours, and over several
   doublings the texture would otherwise wash out (histogram distance 0.19 instead of 0.05 at 256^3).

:func:`plan_stages` describes the stages without running them (the benchmarks use it to locate
block borders).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from .._util.deprecation import renamed_keyword
from .blending import block_weights
from .blocks import choose_block_size
from .lazy import LazySolidTexture
from .matching import BlockMatcher, HistogramTerm
from .optimisation import synthesize_by_optimisation
from .seams import graph_cut_side
from .seeding import RNGLike
from .slices import exemplar_volume

__all__ = [
    "DEFAULT_HISTOGRAM_WEIGHT",
    "DEFAULT_OVERLAP",
    "METHODS",
    "Stage",
    "plan_stages",
    "synthesize",
    "synthesize_by_blocks",
]

DEFAULT_OVERLAP = {"feather": 1 / 6, "cut": 1 / 3}  # synthesize's overlap for each kind of seam (see there)
DEFAULT_HISTOGRAM_WEIGHT = {"feather": 0.0, "cut": 0.5}  # and its histogram_weight


@dataclass(frozen=True)
class Stage:
    """One pass of block placement.

    Parameters
    ----------
    region : tuple of int
        ``(Z, Y, X)`` size synthesised in this stage.
    block, overlap, pool : int
        Block edge, voxels shared by neighbours, and pooling factor of the matching features.
    n_blocks : tuple of int
        Blocks along each axis.
    source_shape : tuple of int
        Shape of the volume blocks are drawn from: the exemplar, or the previous stage's region.

    Examples
    --------
    >>> stage = plan_stages((32, 32, 32, 3), (64, 64, 64), 16)[-1]
    >>> stage.region, stage.step == stage.block - stage.overlap
    ((64, 64, 64), True)
    """

    region: tuple[int, ...]
    block: int
    overlap: int
    pool: int
    n_blocks: tuple[int, ...]
    source_shape: tuple[int, ...]

    @property
    def step(self) -> int:
        """Distance between the origins of neighbouring blocks."""
        return self.block - self.overlap

    @property
    def count(self) -> int:
        """Number of blocks placed."""
        return math.prod(self.n_blocks)


def overlap_voxels(block: int, overlap: float) -> int:
    """Voxels of overlap between neighbouring blocks of size ``block`` for a fraction ``overlap`` in (0, 0.5].

    Examples
    --------
    >>> overlap_voxels(16, 0.25)
    4
    """
    if not 0 < overlap <= 0.5:
        raise ValueError(f"overlap is a fraction of the block in (0, 0.5], got {overlap}")
    return int(min(max(1, round(block * overlap)), block // 2))


def _pool(block: int, overlap: int, wanted: int) -> int:
    p = max(1, min(wanted, overlap))
    while block % p:
        p -= 1
    return p


def _stage(region, block, overlap, pool_wanted, source_shape) -> Stage:
    o = overlap_voxels(block, overlap)
    step = block - o
    n = tuple(max(1, math.ceil((r - o) / step)) for r in region)
    return Stage(tuple(int(r) for r in region), block, o, _pool(block, o, pool_wanted), n, tuple(source_shape))


def plan_stages(
    exemplar_shape: tuple[int, ...], shape: tuple[int, ...], block: int, overlap: float = 1 / 6, reuse: bool = True
) -> list[Stage]:
    """The synthesis stages for a target ``shape``.

    Without reuse: one stage with fixed blocks. With reuse: an initial region no larger than the
    exemplar (the target halved until it fits), then one stage per doubling, each with twice the
    previous block (and pooling), drawing from the previous region.

    Parameters
    ----------
    exemplar_shape : tuple of int
        ``(Z, Y, X, 3)`` of the exemplar.
    shape : tuple of int
        ``(Z, Y, X)`` of the texture to make.
    block : int
        Block size in voxels.
    overlap : float
        Overlap as a fraction of the block.
    reuse : bool
        Grow by region doubling (each stage draws from the previous stage's result).

    Returns
    -------
    list of Stage
        The passes, the last one making ``shape``.

    Examples
    --------
    >>> [(s.region, s.block, s.overlap, s.count) for s in plan_stages((64, 64, 64), (128,) * 3, 16)]
    [((64, 64, 64), 16, 3, 125), ((128, 128, 128), 32, 5, 125)]
    >>> [(s.block, s.count) for s in plan_stages((64, 64, 64), (128,) * 3, 16, reuse=False)]
    [(16, 1000)]
    """
    ex = tuple(int(s) for s in exemplar_shape[:3])
    target = tuple(int(s) for s in shape)
    if len(target) != 3 or min(target) < 1:
        raise ValueError(f"shape must be three positive sizes, got {shape}")
    if block < 2 or block > min(ex):
        raise ValueError(f"block {block} must be between 2 and the exemplar's smallest side {min(ex)}")
    if not reuse:
        return [_stage(target, block, overlap, 2, ex)]
    doublings = max(0, max(math.ceil(math.log2(t / e)) for t, e in zip(target, ex, strict=True)))
    regions = [tuple(math.ceil(t / 2 ** (doublings - k)) for t in target) for k in range(doublings + 1)]
    stages = [_stage(regions[0], block, overlap, 2, ex)]
    for k in range(1, doublings + 1):
        b = min(block * 2**k, min(regions[k - 1]))
        b -= b % 2
        stages.append(_stage(regions[k], max(b, 2), overlap, 2 ** (k + 1), regions[k - 1]))
    return stages


def _run_stage(
    source: NDArray[np.float32],
    stage: Stage,
    rng: np.random.Generator,
    keep: tuple[int, ...] | None,
    candidates,
    bar,
    cut: bool = False,
    mismatch: list[float] | None = None,
    histogram: HistogramTerm | None = None,
    positions: list | None = None,
) -> NDArray[np.float32]:
    b, o, step = stage.block, stage.overlap, stage.step
    matcher = BlockMatcher(source, stage, seed=int(rng.integers(2**31)), histogram=histogram)
    padded = tuple(n * step + o for n in stage.n_blocks)
    acc = np.zeros((*padded, 3), dtype=np.float32)
    wsum = np.zeros(padded, dtype=np.float32)  # with cuts: 1 where synthesised, and acc holds the colours
    nz, ny, nx = stage.n_blocks
    chosen = np.full((nz, ny, nx, 3), -(10**9), dtype=np.int64)  # source position of each placed block
    for iz in range(nz):
        for iy in range(ny):
            for ix in range(nx):
                index = (iz, iy, ix)
                origin = np.array(index) * step
                has_prev = tuple(bool(i > 0) for i in index)
                has_next = tuple(bool(i < n - 1) for i, n in zip(index, stage.n_blocks, strict=True))
                region = tuple(slice(s, s + b) for s in origin)
                # the blocks placed before this one that touch it (faces, edges, corners)
                around = chosen[max(iz - 1, 0) : iz + 1, max(iy - 1, 0) : iy + 2, max(ix - 1, 0) : ix + 2]
                around = around.reshape(-1, 3)
                if keep is not None and np.all(origin + b <= np.array(keep)):
                    q = origin  # inside the region already synthesised: keep it where it is
                elif not any(has_prev):
                    q = matcher.best(None, has_prev, rng, candidates, around)
                else:
                    target = matcher.target(acc[region], wsum[region], has_prev, o, stage.pool)
                    q = matcher.best(target, has_prev, rng, candidates, around)
                chosen[index] = q
                matcher.placed(q)
                new = source[q[0] : q[0] + b, q[1] : q[1] + b, q[2] : q[2] + b]
                covered = wsum[region].copy()
                measure = mismatch is not None and any(has_prev)
                if cut or measure:  # what is there (its own weights sum to 1)
                    old = acc[region] / np.maximum(covered, 1e-12)[..., None]
                if cut:
                    w = graph_cut_side(old, new, covered > 0, _cut_pool(o)).astype(np.float32)
                    acc[region] = np.where(w[..., None] > 0, new, old)
                    wsum[region] = 1.0
                else:
                    weights = block_weights(b, o, has_prev, has_next)
                    w = weights / np.maximum(covered + weights, 1e-12)  # the new block's share once added
                    acc[region] += weights[..., None] * new
                    wsum[region] += weights
                if measure:
                    assert mismatch is not None  # measure implies it
                    mismatch[0] += _transition_energy(w, np.square(new - old).sum(-1), covered > 0, has_prev)
                    mismatch[1] += b * b * sum(has_prev)
                bar.update()
    if positions is not None:
        positions.append(chosen)
    crop = tuple(slice(0, r) for r in stage.region)
    return acc[crop] / wsum[crop][..., None]


def _cut_pool(overlap: int) -> int:
    """Cube size of the coarsest cut of an overlap: at least 4 cubes thick, the cut then refined voxel by voxel.

    A whole 8-voxel overlap cut in one graph was 90% of the synthesis time; cut on 2-cubes and
    refined in a band around the coarse seam, it costs 1-2% more mismatch at a fifth of the time.
    """
    pool = 1
    while overlap >= 8 * pool and pool < 8:
        pool *= 2
    return pool


def _transition_energy(share: NDArray[np.float32], error: NDArray[np.float32], covered, has_prev) -> float:
    """Seam energy of one placed block: the blocks' mismatch wherever the result moves from one to the other.

    Each voxel face across which the new block's share changes by ``dw`` costs ``dw`` times the
    squared difference between the blocks at its voxels (the mean over those both blocks cover).
    Before the block, along an axis with a previous block, the share is 0: a feathered ramp's
    first step, at the block's border, counts too. A hard cut costs Kwatra et al.'s seam cost (the
    mismatch beside the seam); feathering spreads the same unit change across the overlap,
    costing the mismatch averaged over it.
    """
    total = 0.0
    c = covered.astype(np.float64)
    for ax in range(3):
        w, e, cov = share, error, c
        if has_prev[ax]:  # the old texture lies before the block: share 0 there
            first = [slice(None)] * 3
            first[ax] = slice(0, 1)
            w = np.concatenate([np.zeros_like(share[tuple(first)]), share], axis=ax)
            e = np.concatenate([error[tuple(first)], error], axis=ax)
            cov = np.concatenate([c[tuple(first)], c], axis=ax)
        n = w.shape[ax]
        lo = [np.take(x, range(n - 1), axis=ax) for x in (w, e, cov)]
        hi = [np.take(x, range(1, n), axis=ax) for x in (w, e, cov)]
        pair = (lo[1] * lo[2] + hi[1] * hi[2]) / np.maximum(lo[2] + hi[2], 1.0)
        total += float(np.sum(np.abs(hi[0] - lo[0]) * pair, dtype=np.float64))
    return total


def _match_statistics(volume: NDArray[np.float32], mean: np.ndarray, std: np.ndarray) -> NDArray[np.float32]:
    """Give each channel the exemplar's mean and standard deviation (undoes the contrast feathering removes)."""
    flat = volume.reshape(-1, 3)
    m, s = flat.mean(axis=0, dtype=np.float64), flat.std(axis=0, dtype=np.float64)  # float32 sums drift
    scale = np.divide(std, s, out=np.ones(3), where=s > 1e-6)
    return ((volume - m) * scale + mean).astype(np.float32)


def synthesize_by_blocks(
    exemplar: ArrayLike,
    shape: int | tuple[int, int, int],
    *,
    block: int | None = None,
    overlap: float | None = None,
    rng: RNGLike = 0,
    reuse: bool = True,
    candidates: int = 200,
    match_statistics: bool = True,
    progress: bool = True,
    seams: str = "feather",
    histogram_weight: float | None = None,
    stats: dict | None = None,
    seed: int | None = None,
) -> NDArray[np.uint8]:
    """Grow a solid texture of ``shape`` from a colour exemplar by block synthesis (the seed's method).

    ``synthesize(..., method="blocks")`` calls it. Up close its slices are a mosaic of block
    fragments on a cellular texture; :func:`synthesize` by default makes the texture voxel by voxel.

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar (see :func:`volume_from_slices`): uint8, uint16 or floats in [0, 1] (the
        package's dtype policy).
    shape : int or (int, int, int)
        Size of the result, ``(Z, Y, X)``.
    block : int, optional
        Block edge in voxels (even). Chosen by :func:`choose_block_size` if omitted.
    overlap : float, optional
        Overlap between neighbouring blocks as a fraction of the block. Default: 1/6 (the paper's)
        when feathering, 1/3 with cuts (:data:`DEFAULT_OVERLAP`): a minimum-error boundary needs
        room to find agreement (seam energy at 128^3 with fixed 16-voxel blocks, 3 seeds, with
        the histogram term: 0.74x feathering's at 1/4, 0.62x at 1/3).
    rng : int or numpy.random.Generator
        The result is the same for the same int (a Generator is drawn from, so it moves on).
    reuse : bool
        ``True``: region-doubling growth (fast); ``False``: fixed blocks over the whole target.
    candidates : int
        Random candidate positions compared per block.
    match_statistics : bool
        After each stage, restore each colour channel's mean and standard deviation to the
        exemplar's. Feathering averages overlapping blocks, which lowers the contrast a little at
        every stage; without this the reuse growth washes out over several doublings.
    progress : bool
        Show a tqdm progress bar (one tick per block).
    seams : {"feather", "cut"}
        ``"feather"`` (the paper's method): overlapping blocks are averaged with weights that
        ramp across the overlap. ``"cut"``: each overlap is cut where the blocks agree most (a
        minimum-error boundary found by a graph cut, :mod:`~ffd_notebook.solidtex.seams`), so
        every voxel comes from one block: no blur or ghosting in the overlaps. Thick overlaps are
        cut coarse to fine (:func:`_cut_pool`); several times feathering's time (3-8x measured).
    histogram_weight : float, optional
        Weight of a histogram term in the block choice (:class:`~ffd_notebook.solidtex.matching.HistogramTerm`):
        a candidate's overlap mismatch is multiplied by ``exp(weight * cos)``, ``cos`` (-1 to 1)
        saying whether its colours would move the output's histogram away from the exemplar's or
        towards it; 0 ranks by mismatch alone. Default (:data:`DEFAULT_HISTOGRAM_WEIGHT`): 0 when
        feathering (the paper's method), 0.5 with cuts, whose thick overlaps otherwise favour
        easy-to-fit blocks. Measured at 128^3, 3 seeds, cuts from the benchmark's sheared
        extrusion: with reuse, histogram distance 0.027 at weight 0.5, 0.023 at 1 (0.046 with no
        term and 1/4 overlaps; feathering 0.039) and seam energy 0.62x feathering's at both; with
        fixed blocks, 0.021 and 0.014 (feathering 0.031) at seam energy 0.66x and 0.71x; 256^3 with
        reuse at 0.5: 0.029 (feathering 0.045) at 0.58x. From the
        notebook's optimised exemplar (reuse) it does not help: 0.039 with no term, 0.045 at 1
        (feathering 0.033).
    stats : dict, optional
        Filled with ``"seam_mismatch"``: per stage, the seam energy in the sense of Efros-Freeman
        and Kwatra et al.: the squared colour difference between overlapping blocks where the
        result passes from one to the other, per voxel of overlap face (see ``_transition_energy``;
        a cut pays it at the seam, feathering across the whole overlap), relative to that of two
        unrelated voxels of the stage's source (twice its colour variance): 1 is as bad as
        joining blocks at random, 0 a perfect fit. Also ``"positions"``: per stage, the
        ``(*n_blocks, 3)`` corner in the stage's source of every block placed.
    seed : int, optional
        Deprecated alias of ``rng`` (a :class:`DeprecationWarning`).

    Returns
    -------
    numpy.ndarray
        ``(Z, Y, X, 3)`` uint8.

    See Also
    --------
    synthesize : The default method, per-voxel pyramid synthesis: without the blocks (on a cellular
        texture whose cells are as large as a block, block synthesis is a mosaic of cell fragments up
        close), and at any size.
    synthesize_by_optimisation : Texture optimisation: cells whole too, but minutes at 256^3.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> ex = np.kron(rng.integers(0, 256, (4, 4, 4, 3)), np.ones((4, 4, 4, 1))).astype(np.uint8)
    >>> out = synthesize_by_blocks(ex, (24, 20, 40), block=8, progress=False)
    >>> out.shape, out.dtype.name
    ((24, 20, 40, 3), 'uint8')
    >>> bool(np.array_equal(out, synthesize_by_blocks(ex, (24, 20, 40), block=8, progress=False)))
    True
    """
    if seed is not None:
        rng = renamed_keyword({"seed": seed}, "seed", "rng", rng, "synthesize_by_blocks")
    if seams not in ("feather", "cut"):
        raise ValueError(f"seams must be 'feather' or 'cut', got {seams!r}")
    ex = exemplar_volume(exemplar)
    target = (int(shape),) * 3 if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
    if block is None:
        block = choose_block_size(ex, rng=rng)
    if overlap is None:
        overlap = DEFAULT_OVERLAP[seams]
    if histogram_weight is None:
        histogram_weight = DEFAULT_HISTOGRAM_WEIGHT[seams]
    if histogram_weight < 0:
        raise ValueError(f"histogram_weight must be >= 0, got {histogram_weight}")
    stages = plan_stages(ex.shape, target, int(block), overlap, reuse)
    rng = np.random.default_rng(rng)
    source = ex.astype(np.float32)
    mean, std = (
        source.reshape(-1, 3).mean(axis=0, dtype=np.float64),
        source.reshape(-1, 3).std(axis=0, dtype=np.float64),
    )
    keep = None
    with tqdm(total=sum(s.count for s in stages), desc="solid texture", unit="block", disable=not progress) as bar:
        for stage in stages:
            tally = [0.0, 0]
            # two unrelated voxels of the source differ by twice its colour variance, on average
            unrelated = 2.0 * float(source.reshape(-1, 3).var(axis=0, dtype=np.float64).sum())
            term = HistogramTerm(ex, histogram_weight) if histogram_weight > 0 else None
            placed = None if stats is None else stats.setdefault("positions", [])
            source = _run_stage(source, stage, rng, keep, candidates, bar, seams == "cut", tally, term, placed)
            if stats is not None:
                stats.setdefault("seam_mismatch", []).append(tally[0] / max(tally[1], 1) / max(unrelated, 1e-12))
            if match_statistics:
                source = _match_statistics(source, mean, std)
            keep = stage.region
    return np.clip(np.rint(source), 0, 255).astype(np.uint8)


#: the methods of :func:`synthesize`, the default first
METHODS = ("pyramid", "optimisation", "blocks")
_BLOCK_OPTIONS = {
    "block", "overlap", "reuse", "candidates", "match_statistics", "seams", "histogram_weight", "stats"
}  # fmt: skip
_PYRAMID_OPTIONS = {
    "levels": "texture",
    "prepared": "texture",
    "chunk": "volume",
    "scheduler": "volume",
    "client": "volume",
}


def synthesize(
    exemplar: ArrayLike,
    shape: int | tuple[int, int, int],
    *,
    method: str | None = None,
    rng: RNGLike = 0,
    progress: bool = True,
    seed: int | None = None,
    **options: Any,
) -> NDArray[np.uint8]:
    """Grow a solid texture of ``shape`` from a solid exemplar: whole cells, no tiles, no block grid, any size.

    By default (``method="pyramid"``) the texture is synthesised voxel by voxel on a pyramid
    (:mod:`~ffd_notebook.solidtex.pyramid`): the whole volume of a
    :class:`~ffd_notebook.solidtex.LazySolidTexture`, so a volume and the lazy texture of an organ
    with the same ``rng`` have the same colours. Why this one: it looks like the tissue (whole cells
    in every orientation, no straight seams: whole-slice self-similarity 0.96-1.02 and block-grid
    score 1.2-1.3 on the histology and gravel tests' exemplars, where the image's own regions score
    1.2-1.4), never repeats a region, and is the only method that scales: 128^3 in a few seconds,
    512^3 in chunks on a cluster (``scheduler=``). The other methods, by name:

    * ``"optimisation"``: :func:`~ffd_notebook.solidtex.synthesize_by_optimisation` (Kwatra's texture
      optimisation: cells whole, with a few straight edges; 106 s at 192^3, 2.6 GB at 256^3);
    * ``"blocks"``: :func:`synthesize_by_blocks`, the seed's block synthesis (a mosaic of block
      fragments up close, fast).

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar (e.g. :func:`~ffd_notebook.solidtex.exemplar_from_image`): uint8,
        uint16 or floats in [0, 1] (the package's dtype policy).
    shape : int or (int, int, int)
        Size of the result, ``(Z, Y, X)``.
    method : {"pyramid", "optimisation", "blocks"}, optional
        The method (default ``"pyramid"``).
    rng : int or numpy.random.Generator
        The result is the same for the same int.
    progress : bool
        Show a progress bar.
    seed : int, optional
        Deprecated alias of ``rng`` (a :class:`DeprecationWarning`).
    **options
        The method's own options: ``levels``, ``chunk``, ``scheduler``, ``client`` for the pyramid
        (:class:`~ffd_notebook.solidtex.LazySolidTexture` and its ``volume``); those of
        :func:`~ffd_notebook.solidtex.synthesize_by_optimisation` or of :func:`synthesize_by_blocks`.
        Block options (``seams=``, ``block=``, ...) without ``method`` run the block method, as
        before, with a :class:`DeprecationWarning`: say ``method="blocks"``.

    Returns
    -------
    numpy.ndarray
        ``(Z, Y, X, 3)`` uint8.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> ex = rng.integers(0, 256, (16, 16, 16, 3), dtype=np.uint8)
    >>> out = synthesize(ex, (24, 20, 40), progress=False)
    >>> out.shape, out.dtype.name
    ((24, 20, 40, 3), 'uint8')
    >>> blocks = synthesize(ex, 24, method="blocks", block=8, seams="cut", progress=False)
    >>> synthesize(ex, 24, method="mosaic")
    Traceback (most recent call last):
    ...
    ValueError: method must be one of ('pyramid', 'optimisation', 'blocks'), got 'mosaic'
    """
    if seed is not None:
        rng = renamed_keyword({"seed": seed}, "seed", "rng", rng, "synthesize")
    if method is None:
        given = sorted(_BLOCK_OPTIONS & set(options))
        method = "pyramid"
        if given:
            warnings.warn(
                f"synthesize({', '.join(f'{k}=...' for k in given)}) runs the block method: the default method is "
                "now 'pyramid' (per-voxel synthesis); say method='blocks' (or call synthesize_by_blocks)",
                DeprecationWarning,
                stacklevel=2,
            )
            method = "blocks"
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "blocks":
        return synthesize_by_blocks(exemplar, shape, rng=rng, progress=progress, **options)
    if method == "optimisation":
        return synthesize_by_optimisation(exemplar, shape, rng=rng, progress=progress, **options)
    unknown = sorted(set(options) - set(_PYRAMID_OPTIONS))
    if unknown:
        raise TypeError(f"synthesize(method='pyramid') has no option {', '.join(unknown)}")
    texture_options = {k: v for k, v in options.items() if _PYRAMID_OPTIONS[k] == "texture"}
    volume_options = {k: v for k, v in options.items() if _PYRAMID_OPTIONS[k] == "volume"}
    texture = LazySolidTexture(exemplar, shape, rng=rng, **texture_options)
    return texture.volume(progress=progress, **volume_options)
