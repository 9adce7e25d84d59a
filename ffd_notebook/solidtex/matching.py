"""Choosing each block: overlap agreement, and (optionally) a histogram term that keeps the colours the exemplar's.

:class:`BlockMatcher` precomputes, once per synthesis stage, the pooled candidate features of the
source volume and compares the overlap of every random candidate with what is already synthesised
(sum of squared differences of pooled colours, ``|a|^2 + |b|^2 - 2 a.b`` for all candidates at once).

The best-fitting block is not always the one the volume needs: blocks of smooth, common texture
fit overlaps more easily than blocks with rare features, so a synthesis that only minimises the
mismatch over-uses them, and over a region-doubling growth its colour histogram drifts from the
exemplar's (measured with cut seams, whose thick overlaps weigh the fit more: histogram distance
0.08 at 128^3 without ``match_statistics``, against 0.04 for feathering). :class:`HistogramTerm`
is in the spirit of Kopf et al.'s (2007) histogram matching, moved from voxels to blocks: it counts
the colours of the blocks placed so far, and a candidate's cost is multiplied by
``exp(weight * cos)``, ``cos`` being the cosine between the candidate's colour histogram minus the
exemplar's and the output's minus the exemplar's: positive when the block would add colours the
output already has too many of, negative when it brings ones the output lacks. The histogram is
the one :func:`~ffd_notebook.solidtex.histogram_distance` compares (8 bins per channel, joint
RGB), against the *original* exemplar at every stage of the growth, and the cosine follows that
L2 distance's gradient. (Kopf's own per-bin relative over-use, ``sum max(0, H_s - H_e) / H_e``,
was tried first: it weighs rare colours most, which the L2 distance hardly sees, and made the
notebook's exemplar's histogram distance worse, 0.048 against 0.039 without a term.)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .blocks import box_mean, cell_starts, classify_blocks
from .quality import color_histogram

__all__ = ["BlockMatcher", "HistogramTerm"]

_BINS = 8  # per channel, as histogram_distance
_SAMPLES = 8  # voxels per axis a block's colours are counted on (a block of 16 or 64 voxels alike)


def colour_codes(volume: NDArray[np.floating]) -> NDArray[np.int16]:
    """The joint 8x8x8-bin histogram bin of every voxel (:func:`~ffd_notebook.solidtex.color_histogram`'s bins).

    Examples
    --------
    >>> colour_codes(np.array([[0.0, 0.0, 0.0], [255.0, 0.0, 40.0]])).tolist()
    [0, 449]
    """
    q = np.clip(np.rint(volume).astype(np.int64) * _BINS // 256, 0, _BINS - 1)
    return ((q[..., 0] * _BINS + q[..., 1]) * _BINS + q[..., 2]).astype(np.int16)


class HistogramTerm:
    """Whether a candidate block moves the output's colour histogram away from the exemplar's (> 0) or towards it.

    Parameters
    ----------
    exemplar : numpy.ndarray
        The original ``(Z, Y, X, 3)`` exemplar: its histogram is the target at every stage.
    weight : float
        ``cost * exp(weight * cos)``; 0 switches the term off.

    Examples
    --------
    >>> ex = np.zeros((4, 4, 4, 3)); ex[:2] = 255  # half black, half white
    >>> term = HistogramTerm(ex, weight=1.0)
    >>> term.add(ex, (0, 0, 0), 2)  # a white block is placed: white is now over-represented
    >>> term.over(ex, np.array([[0, 0, 0], [2, 0, 0]]), 2).round(2).tolist()  # a white, a black candidate
    [1.0, -1.0]
    """

    def __init__(self, exemplar: NDArray, weight: float) -> None:
        self.weight = float(weight)
        self.target = color_histogram(np.clip(np.rint(exemplar), 0, 255).astype(np.uint8), bins=_BINS)
        self.counts = np.zeros(_BINS**3)
        self._codes: tuple[int, NDArray[np.int16]] | None = None

    def _block_codes(self, source: NDArray, corners: NDArray[np.int64], block: int) -> NDArray[np.int16]:
        """Bins of ``_SAMPLES**3`` voxels spread over each block: ``(len(corners), samples)``."""
        if self._codes is None or self._codes[0] != id(source):
            self._codes = (id(source), colour_codes(source))
        codes = self._codes[1]
        r = (np.arange(min(_SAMPLES, block)) * block) // min(_SAMPLES, block)
        z, y, x = (corners[:, a, None] + r[None, :] for a in range(3))
        return codes[z[:, :, None, None], y[:, None, :, None], x[:, None, None, :]].reshape(len(corners), -1)

    def over(self, source: NDArray, corners: NDArray[np.int64], block: int) -> NDArray[np.float64]:
        """Per candidate: the cosine between its step and the output's histogram error (-1 to 1; 0 before any block).

        Adding a candidate moves the output's histogram ``P`` towards the candidate's own ``h``;
        the squared L2 distance to the exemplar's ``E`` changes, to first order, by
        ``2 a (h - E) . (P - E)`` (``a`` the candidate's share). The cosine of those two vectors
        is positive when the candidate adds colours the output already has too many of, negative
        when it brings ones it lacks.
        """
        total = self.counts.sum()
        if total == 0:
            return np.zeros(len(corners))
        error = self.counts / total - self.target
        codes = self._block_codes(source, corners, block)
        h = np.zeros((len(corners), _BINS**3))
        np.add.at(h, (np.arange(len(corners))[:, None], codes), 1.0 / codes.shape[1])
        step = h - self.target
        norms = np.linalg.norm(step, axis=1) * np.linalg.norm(error)
        return (step @ error) / np.maximum(norms, 1e-12)

    def add(self, source: NDArray, corner: tuple[int, int, int], block: int) -> None:
        """Count the colours of the block placed at ``corner``."""
        codes = self._block_codes(source, np.asarray(corner, np.int64).reshape(1, 3), block)
        self.counts += np.bincount(codes.ravel(), minlength=_BINS**3)


class BlockMatcher:
    """Precomputed candidate features of one source volume for one stage (see the module docstring)."""

    def __init__(self, source: NDArray[np.float32], stage, seed: int, histogram: HistogramTerm | None = None) -> None:
        b, p = stage.block, stage.pool
        self.source, self.block, self.histogram = source, b, histogram
        self.pooled = box_mean(source, p)
        pshape = self.pooled.shape[:3]
        self.pstrides = np.array([pshape[1] * pshape[2], pshape[2], 1], dtype=np.int64)
        self.flat = self.pooled.reshape(-1, 3)
        means = box_mean(source, b)
        self.grid = means.shape[:3]
        labels, self.probabilities = classify_blocks(means.reshape(-1, 3), 3, rng=seed)
        members = [np.flatnonzero(labels == c) for c in range(3)]
        self.positions = [np.stack(np.unravel_index(m, self.grid), axis=1) for m in members]
        self.linear = [q @ self.pstrides for q in self.positions]
        self.starts, self.lead = cell_starts(b, stage.overlap, p)
        self._offsets: dict[tuple[bool, ...], np.ndarray] = {}

    def offsets(self, has_prev: tuple[bool, ...]) -> np.ndarray:
        """Linear offsets (into the pooled source) of the overlap cells, slab by slab."""
        if has_prev not in self._offsets:
            parts = []
            for ax in range(3):
                if has_prev[ax]:
                    axes = [self.starts[self.lead] if a == ax else self.starts for a in range(3)]
                    grid = np.meshgrid(*axes, indexing="ij")
                    parts.append(sum(g.ravel() * s for g, s in zip(grid, self.pstrides, strict=True)))
            self._offsets[has_prev] = np.concatenate(parts)
        return self._offsets[has_prev]

    def target(self, acc: np.ndarray, wsum: np.ndarray, has_prev: tuple[bool, ...], overlap: int, pool: int):
        """Pooled features of what is already synthesised in a block's overlap slabs (``acc / wsum``)."""
        parts = []
        for ax in range(3):
            if has_prev[ax]:
                slab = tuple(slice(0, overlap) if a == ax else slice(None) for a in range(3))
                current = acc[slab] / wsum[slab][..., None]  # the slab is fully covered by earlier blocks
                idx = [self.starts[self.lead] if a == ax else self.starts for a in range(3)]
                parts.append(box_mean(current, pool)[np.ix_(*idx)].reshape(-1, 3))
        return np.concatenate(parts).ravel()

    def best(
        self,
        target: np.ndarray | None,
        has_prev,
        rng: np.random.Generator,
        candidates: int,
        avoid: np.ndarray | None = None,
    ) -> np.ndarray:
        """Position of the best block among random candidates of a randomly drawn class.

        The class is drawn with the source's class probabilities (the paper's answer to the same
        block being chosen again and again), the candidates at any offset of the source. ``avoid``
        (``(k, 3)`` positions of the blocks already placed around this one) removes the candidates
        within half a block of any of them: a block next to itself (or to a copy shifted by a few
        voxels) repeats its content at the block step, a visible grid. If every candidate is that
        close, the farthest is kept.
        """
        c = rng.choice(3, p=self.probabilities)
        pick = rng.integers(0, len(self.positions[c]), size=min(candidates, len(self.positions[c])))
        corners = self.positions[c][pick]
        near = np.zeros(len(corners), dtype=bool)
        if avoid is not None and len(avoid):
            gap = np.abs(corners[:, None, :] - np.asarray(avoid)[None, :, :]).max(axis=2).min(axis=1)
            near = gap < max(1, self.block // 2)
            if near.all():
                return corners[int(np.argmax(gap))]
        if target is None:
            return corners[int(np.argmin(near))]
        feats = self.flat[self.linear[c][pick][:, None] + self.offsets(has_prev)[None, :]]
        feats = feats.reshape(len(pick), -1)
        cost = np.einsum("ij,ij->i", feats, feats) - 2.0 * (feats @ target)
        if self.histogram is not None and self.histogram.weight > 0:
            cost = np.maximum(cost + float(target @ target), 0.0)  # the whole SSD, to scale it
            cost *= np.exp(self.histogram.weight * self.histogram.over(self.source, corners, self.block))
        cost[near] = np.inf
        return corners[int(np.argmin(cost))]

    def placed(self, corner) -> None:
        """Count a placed block's colours in the histogram term (if any)."""
        if self.histogram is not None and self.histogram.weight > 0:
            z, y, x = (int(v) for v in corner)
            self.histogram.add(self.source, (z, y, x), self.block)
