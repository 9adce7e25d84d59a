"""Lazy block synthesis (the seed's method): only the blocks a surface or a cut samples, the same whatever is asked
first. :class:`~ffd_notebook.solidtex.LazySolidTexture` (per-voxel pyramid synthesis) is the default; this one is
kept by name, :class:`LazyBlockTexture`: cut open and seen up close, it is a mosaic of block fragments.

After the idea of Dong, Lefebvre, Tong and Drettakis, "Lazy solid texture synthesis" (EGSR 2008): a surface or a cut
plane needs the colours of a thin layer of voxels, not of the whole box around the organ. Raster-
order block synthesis (:func:`~ffd_notebook.solidtex.synthesize`) cannot stop early, because every
block is matched against all blocks before it; here the dependency order is fixed and short:

* blocks sit on a grid (edge ``block``, neighbours sharing ``overlap`` voxels, as in ``synthesize``);
  a block's *pass* is the number of its odd grid coordinates (0 to 3);
* a block is matched only against its face neighbours along its odd axes, which are one pass
  lower, and never takes a position within half a block of theirs (as in ``synthesize``: a block
  next to itself is a visible repetition); pass-0 blocks are drawn at random (with the exemplar's
  colour-class probabilities). So a block depends on blocks at most one step away along each axis,
  whatever the texture's size;
* every random draw of a block comes from a hash of ``(seed, iz, iy, ix)`` (SplitMix64, vectorised
  over all the blocks a cut needs): the same seed gives the same block wherever and whenever it is
  computed.

Candidates are a fixed pool of exemplar blocks whose overlap features (slab means on a coarse
grid) are computed once, so a block's choice is a few small array operations and a cut's new
blocks are chosen in one vectorised step per pass. Colours are kept per *tile* (the ``step``-cube
each block owns; a tile blends its own block with up to seven earlier neighbours by feathering) in
a growing atlas, so memory follows the sampled area, not the box. Overlaps are feathered:
minimum-error cuts (``synthesize(seams="cut")``) decide each seam against what was placed
before, which a block synthesised out of order does not have.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .blending import axis_ramp
from .blocks import box_mean, choose_block_size, classify_blocks
from .lazy import LazyTexture
from .seeding import RNGLike, integer_seed, splitmix64
from .slices import exemplar_volume
from .synthesis import overlap_voxels

__all__ = ["LazyBlockTexture"]


def _slab_features(exemplar: NDArray[np.uint8], positions: NDArray[np.int64], block: int, overlap: int, cells: int):
    """Mean colours of each overlap slab of each pool block on a ``cells x cells`` grid: {(axis, side): (P, F)}."""
    step = block - overlap
    edges = np.linspace(0, block, cells + 1).round().astype(int)
    feats: dict[tuple[int, int], list[np.ndarray]] = {(a, s): [] for a in range(3) for s in range(2)}
    r = np.arange(block)
    for start in range(0, len(positions), 128):
        q = positions[start : start + 128]
        blocks = exemplar[
            q[:, 0, None, None, None] + r[None, :, None, None],
            q[:, 1, None, None, None] + r[None, None, :, None],
            q[:, 2, None, None, None] + r[None, None, None, :],
        ].astype(np.float32)  # (p, b, b, b, 3)
        for a in range(3):
            moved = np.moveaxis(blocks, a + 1, 1)
            for side, thick in ((0, slice(0, overlap)), (1, slice(step, block))):
                slab = moved[:, thick].mean(axis=1)  # (p, b, b, 3)
                rows = np.add.reduceat(slab, edges[:-1], axis=1) / np.diff(edges)[None, :, None, None]
                grid = np.add.reduceat(rows, edges[:-1], axis=2) / np.diff(edges)[None, None, :, None]
                feats[(a, side)].append(grid.reshape(len(q), -1))
    return {k: np.concatenate(v) for k, v in feats.items()}


class LazyBlockTexture(LazyTexture):
    """A solid texture whose blocks are synthesised when a point near them is first sampled (block synthesis).

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar (e.g. :func:`~ffd_notebook.solidtex.exemplar_from_image`): uint8, uint16 or
        floats in [0, 1] (the package's dtype policy).
    shape : int or (int, int, int)
        Voxels ``(Z, Y, X)`` the texture covers (it may be far too large to hold whole).
    spacing : float
        Voxel edge in world units.
    origin : array_like
        World ``(x, y, z)`` of voxel ``[0, 0, 0]``'s centre.
    block : int, optional
        Block edge (chosen by :func:`~ffd_notebook.solidtex.choose_block_size` if omitted).
    overlap : float
        Overlap of neighbouring blocks as a fraction of the block.
    rng : int or numpy.random.Generator
        Same int, same colours, whatever is sampled first. Each block's draws are a hash of one
        integer root seed and the block's index, and a Generator's state cannot be hashed
        reproducibly: a Generator gives one 63-bit draw as the root seed
        (:func:`~ffd_notebook.solidtex.seeding.integer_seed`), kept as ``seed``.
    candidates : int
        Pool blocks compared per block.
    pool : int
        Number of exemplar blocks to choose from (random positions, fixed by the root seed).
    cells : int
        Overlap slabs are compared as ``cells x cells`` mean colours.
    match_statistics : bool
        Give each colour channel the exemplar's mean and standard deviation, as ``synthesize``
        does: feathering averages blocks and lowers the contrast. The correction is measured once,
        on the tiles of the grid's first corner (at most ``4 x 4 x 4``), so it does not depend on
        what is sampled first.

    Attributes
    ----------
    seed : int
        The integer root seed.
    tiles_synthesised, blocks_chosen : int
        How much has been synthesised so far.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ex = np.kron(rng.integers(0, 256, (4, 4, 4, 3)), np.ones((4, 4, 4, 1))).astype(np.uint8)
    >>> tex = LazyBlockTexture(ex, shape=1000, block=8)         # a billion voxels, none made yet
    >>> colours = tex.sample([[10.0, 20.0, 30.0], [500.5, 2.0, 999.0]])
    >>> colours.shape, tex.tiles_synthesised <= 16
    ((2, 3), True)
    >>> other = LazyBlockTexture(ex, shape=1000, block=8)
    >>> _ = other.sample([[500.5, 2.0, 999.0]])                 # the other point first
    >>> bool(np.array_equal(other.sample([[10.0, 20.0, 30.0], [500.5, 2.0, 999.0]]), colours))
    True
    """

    def __init__(
        self,
        exemplar: ArrayLike,
        shape: int | tuple[int, int, int],
        *,
        spacing: float = 1.0,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        block: int | None = None,
        overlap: float = 1 / 6,
        rng: RNGLike = 0,
        candidates: int = 64,
        pool: int = 4096,
        cells: int = 4,
        match_statistics: bool = True,
    ) -> None:
        ex = exemplar_volume(exemplar)
        target = (int(shape),) * 3 if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
        seed = integer_seed(rng)
        b = int(block) if block is not None else choose_block_size(ex, rng=seed)
        if len(target) != 3 or min(target) < 1 or not 4 <= b <= min(ex.shape[:3]):
            raise ValueError(f"shape {shape} or block {b} does not fit an exemplar of shape {ex.shape[:3]}")
        self.exemplar, self.block, self.seed = ex, b, seed
        self._flat = ex.reshape(-1, 3).astype(np.float32)
        self.overlap = overlap_voxels(b, overlap)
        self.step = b - self.overlap
        self.spacing, self.origin = float(spacing), np.asarray(origin, dtype=np.float64).reshape(3)
        self.n_blocks = tuple(max(1, math.ceil(t / self.step)) for t in target)
        self.shape = tuple(n * self.step for n in self.n_blocks)
        self.candidates = int(candidates)
        rng = np.random.default_rng(seed)
        self._pool = rng.integers(0, np.array(ex.shape[:3]) - b + 1, size=(int(pool), 3))
        means = box_mean(ex, b)[tuple(self._pool.T)]
        labels, self._probabilities = classify_blocks(means, 3, rng=seed)
        members = [np.flatnonzero(labels == c) for c in range(3)]
        self._counts = np.array([max(len(m), 1) for m in members])
        self._members = np.zeros((3, self._counts.max()), dtype=np.int64)
        for c, m in enumerate(members):
            self._members[c, : len(m)] = m
        self._features = _slab_features(ex, self._pool, b, self.overlap, cells)
        self._choice = np.full(self.n_blocks, -1, dtype=np.int64)
        self._slot = np.full(self.n_blocks, -1, dtype=np.int64)
        self._atlas = np.zeros((0, self.step, self.step, self.step, 3), dtype=np.uint8)
        self.tiles_synthesised = 0
        grid = np.indices(self.n_blocks)
        self._odd = (grid % 2).astype(bool)  # (3, nz, ny, nx)
        self._pass = self._odd.sum(axis=0)
        ramp = axis_ramp(b, self.overlap, True, True)
        self._fade_in, self._fade_out = ramp[: self.step], ramp[self.step :]
        self._gain, self._bias = np.ones(3, np.float32), np.zeros(3, np.float32)
        if match_statistics:
            corner = np.argwhere(np.ones([min(n, 4) for n in self.n_blocks], dtype=bool))
            needed = np.zeros(self.n_blocks, dtype=bool)
            needed[tuple(corner.T)] = True
            self._ensure_blocks(needed)
            probe = self._colours(corner).reshape(-1, 3).astype(np.float64)
            flat = ex.reshape(-1, 3).astype(np.float64)
            gain = np.divide(flat.std(axis=0), probe.std(axis=0), out=np.ones(3), where=probe.std(axis=0) > 1e-6)
            self._gain = gain.astype(np.float32)
            self._bias = (flat.mean(axis=0) - gain * probe.mean(axis=0)).astype(np.float32)

    @property
    def blocks_chosen(self) -> int:
        """Blocks whose exemplar position is decided (those sampled and those they depend on)."""
        return int(np.count_nonzero(self._choice >= 0))

    @property
    def voxels_synthesised(self) -> int:
        """Voxels whose colours are held: every synthesised tile's ``step**3``."""
        return self.tiles_synthesised * self.step**3

    @property
    def nbytes(self) -> int:
        """Memory held by the synthesised colours and the block grids."""
        return int(self._atlas[: self.tiles_synthesised].nbytes + self._choice.nbytes + self._slot.nbytes)

    # -- block choices ---------------------------------------------------------------------------

    def _draws(self, blocks: NDArray[np.int64]) -> NDArray[np.uint32]:
        """Each block's own random words, a hash of the seed and its grid index.

        A ``SeedSequence`` per block cost a Python call each (40% of a new cut's sampling at
        512^3); the SplitMix64 hash runs on all blocks at once.
        """
        h = splitmix64(np.full(len(blocks), self.seed, dtype=np.uint64))
        for a in range(3):
            h = splitmix64(h ^ blocks[:, a].astype(np.uint64))
        words = splitmix64(h[:, None] + np.arange(self.candidates + 1, dtype=np.uint64)[None, :])
        return (words >> np.uint64(32)).astype(np.uint32)

    def _choose(self, blocks: NDArray[np.int64], level: int) -> None:
        words = self._draws(blocks)
        u = words[:, 0] / 2.0**32
        cls = np.minimum(np.searchsorted(np.cumsum(self._probabilities), u, side="right"), 2)
        cand = self._members[cls[:, None], words[:, 1:] % self._counts[cls][:, None]]  # (B, C) pool indices
        if level == 0:
            self._choice[tuple(blocks.T)] = cand[:, 0]
            return
        score = np.zeros(cand.shape, dtype=np.float32)
        positions = self._pool[cand]  # (B, C, 3)
        for a in range(3):
            odd = self._odd[(a, *blocks.T)]
            for side, shift in ((0, -1), (1, 1)):
                nb = blocks.copy()
                nb[:, a] += shift
                use = odd & (nb[:, a] >= 0) & (nb[:, a] < self.n_blocks[a])
                if not use.any():
                    continue
                neighbour = self._choice[tuple(nb[use].T)]
                target = self._features[(a, 1 - side)][neighbour]  # the neighbour's side
                diff = self._features[(a, side)][cand[use]] - target[:, None, :]
                score[use] += np.einsum("bcf,bcf->bc", diff, diff)
                # no block next to itself (as synthesize): candidates within half a block of the neighbour's
                gap = np.abs(positions[use] - self._pool[neighbour][:, None, :]).max(axis=2)
                score[use] += np.where(gap < self.block // 2, np.float32(1e30), np.float32(0))
        self._choice[tuple(blocks.T)] = cand[np.arange(len(cand)), np.argmin(score, axis=1)]

    def _ensure_blocks(self, needed: NDArray[np.bool_]) -> None:
        """Choose every block in ``needed`` and the blocks they depend on, pass by pass."""
        needed = needed.copy()
        for _ in range(3):  # dependencies are at most three passes deep
            for a in range(3):
                dep = needed & self._odd[a]
                lo, hi = [slice(None)] * 3, [slice(None)] * 3
                lo[a], hi[a] = slice(0, -1), slice(1, None)
                needed[tuple(lo)] |= dep[tuple(hi)]
                needed[tuple(hi)] |= dep[tuple(lo)]
        for level in range(4):
            todo = np.argwhere(needed & (self._choice < 0) & (self._pass == level))
            if len(todo):
                self._choose(todo, level)

    # -- tiles -----------------------------------------------------------------------------------

    def _ensure_tiles(self, tiles: NDArray[np.int64]) -> None:
        tiles = tiles[self._slot[tuple(tiles.T)] < 0]
        if len(tiles) == 0:
            return
        needed = np.zeros(self.n_blocks, dtype=bool)
        for d in itertools.product((0, -1), repeat=3):
            t = tiles + d
            needed[tuple(t[(t >= 0).all(axis=1)].T)] = True
        self._ensure_blocks(needed)
        start = self.tiles_synthesised
        end = start + len(tiles)
        if end > len(self._atlas):
            grown = np.zeros((max(end, 2 * len(self._atlas)), *self._atlas.shape[1:]), dtype=np.uint8)
            grown[:start] = self._atlas[:start]
            self._atlas = grown
        for k in range(0, len(tiles), 256):
            chunk = tiles[k : k + 256]
            self._atlas[start + k : start + k + len(chunk)] = self._colours(chunk)
        self._slot[tuple(tiles.T)] = np.arange(start, end)
        self.tiles_synthesised = end

    def _colours(self, tiles: NDArray[np.int64]) -> NDArray[np.uint8]:
        """Feathered colours of tiles: each tile's block and, in its first ``overlap`` voxels, the earlier ones."""
        s, o = self.step, self.overlap
        out = np.zeros((len(tiles), s, s, s, 3), dtype=np.float32)
        for d in itertools.product((0, -1), repeat=3):
            t = tiles + d
            ok = (t >= 0).all(axis=1)
            if not ok.any():
                continue
            q = self._pool[self._choice[tuple(t[ok].T)]]
            idx, weights = [], []
            for a in range(3):
                if d[a] == 0:  # the tile's own block: fades in where an earlier block exists
                    r = np.arange(s)
                    w = np.where((tiles[ok, a] > 0)[:, None], self._fade_in[None, :], 1.0)
                else:  # the earlier block's trailing overlap fades out
                    r = np.arange(s, s + o)
                    w = np.broadcast_to(self._fade_out[None, :], (int(ok.sum()), o))
                idx.append(q[:, a, None] + r[None, :])
                weights.append(w.astype(np.float32))
            _, sy, sx = self.exemplar.shape[:3]
            rows = (idx[0] * (sy * sx))[:, :, None, None] + (idx[1] * sx)[:, None, :, None] + idx[2][:, None, None, :]
            src = self._flat[rows]  # one gather of whole rows: much faster than four index arrays
            w = weights[0][:, :, None, None] * weights[1][:, None, :, None] * weights[2][:, None, None, :]
            lz, ly, lx = (idx[a].shape[1] for a in range(3))
            out[ok, :lz, :ly, :lx] += w[..., None] * src
        return np.clip(np.rint(out * self._gain + self._bias), 0, 255).astype(np.uint8)

    # -- sampling --------------------------------------------------------------------------------

    def voxels(self, indices: ArrayLike) -> NDArray[np.uint8]:
        """Colours of integer voxels ``(N, 3)`` ``(k, j, i)``, synthesising the tiles they lie in.

        Parameters
        ----------
        indices : array_like
            ``(N, 3)`` integer voxel indices ``(k, j, i)``.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.solidtex import LazyBlockTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazyBlockTexture.fit(exemplar, [0, 10, 0, 10, 0, 10], resolution=24, rng=0)
        >>> bool((lazy.voxels([[0, 0, 0]]) == lazy.volume()[0, 0, 0]).all())
        True
        """
        v = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
        tile = v // self.step
        mark = np.zeros(self.n_blocks, dtype=bool)
        mark[tuple(tile.T)] = True
        self._ensure_tiles(np.argwhere(mark))
        local = v - tile * self.step
        return self._atlas[(self._slot[tuple(tile.T)], *local.T)]

    def volume(self) -> NDArray[np.uint8]:
        """The whole ``shape`` volume (synthesises every tile: for small textures and tests).

        Returns
        -------
        numpy.ndarray
            ``(Z, Y, X, 3)`` uint8.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.solidtex import LazyBlockTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazyBlockTexture.fit(exemplar, [0, 10, 0, 10, 0, 10], resolution=24, rng=0)
        >>> lazy.volume().shape == (*lazy.shape, 3)
        True
        """
        self._ensure_tiles(np.argwhere(np.ones(self.n_blocks, dtype=bool)))
        s = self.step
        nz, ny, nx = self.n_blocks
        tiles = self._atlas[self._slot.ravel()].reshape(nz, ny, nx, s, s, s, 3)
        return tiles.transpose(0, 3, 1, 4, 2, 5, 6).reshape(nz * s, ny * s, nx * s, 3)
