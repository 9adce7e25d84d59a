"""Per-voxel pyramid synthesis of a solid texture: every voxel a function of its position, its neighbours bounded.

After Lefebvre and Hoppe, "Parallel controllable texture synthesis" (SIGGRAPH 2005), in 3D, and
Dong, Lefebvre, Tong and Drettakis, "Lazy solid texture synthesis" (EGSR 2008): the texture is a
field of *coordinates* into the solid exemplar, synthesised coarse to fine on a pyramid, and a
voxel's colour is the exemplar's colour at its coordinate. Dong et al. assemble 3D candidates from
three 2D exemplars; here the exemplar is already solid (``exemplar_from_image``), so a candidate
is simply a position in it, and its neighbourhood is precomputed once per level.

Level ``k`` of ``K`` (0 the coarsest) has grid positions ``p`` in Z^3, one step worth
``h = 2^(K-1-k)`` exemplar voxels:

1. level 0: every coordinate is drawn from a hash of ``(seed, p)``;
2. each finer level: a voxel inherits its parent's coordinate, offset by ``h * (p % 2)``
   (coherent: the children of one parent copy a ``2^3`` piece of the exemplar), jittered by a
   hashed offset at the coarse levels (``JITTER``: the layout is new at every place);
3. correction passes: every voxel compares the appearance of its ``3^3`` neighbourhood (spacing
   ``h`` in the exemplar) with that of 27 candidates, its neighbours' coordinates shifted back by
   their offsets (``S(p + d) - h d``: the coordinate that would continue each neighbour), and takes
   the best. Each pass updates the voxels of even ``sum(p)`` first, then the odd ones, which see
   their neighbours' new values (2 subpasses instead of the 8 of Lefebvre and Hoppe: the same
   look here, a quarter of the dependency). The finest level is not corrected (its passes changed
   nothing visible), so a voxel there is its parent's coordinate plus its own offset.

A voxel of level ``k`` depends only on the voxels within :data:`MARGIN` of it before the passes,
and those on a box of the coarser level: any box of the texture can be synthesised alone, with the
same colours whatever box it is part of (:func:`region`), which the lazy texture and the chunks
of a cluster rely on.

Appearance (Lefebvre and Hoppe 2006's "appearance space"): each exemplar voxel's ``5^3``
colour neighbourhood, PCA-reduced to 8 numbers; a level compares box-filtered appearance (the
level's scale) of the 27 neighbours, PCA-reduced to 16. Everything compared is integer-valued and
small enough that float32 sums are exact (:func:`_quantise`): a distance never depends on how
the work is split (BLAS may sum in another order for another number of rows), so the chosen
coordinates are identical in one process and on a cluster.

Hand-written: no library synthesises textures voxel by voxel (scikit-image, SciPy and the PyPI
texture packages are 2D image-by-image, or GPU code).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from .._util.blas import one_blas_thread
from .seeding import splitmix64

__all__ = [
    "JITTER",
    "MARGIN",
    "PyramidExemplar",
    "boxes",
    "default_levels",
    "dependency",
    "pack",
    "passes",
    "region",
    "unpack",
]

PASSES = 2  # correction passes at the coarser levels; one at the two finest
MARGIN = 2 * PASSES  # voxels of a level a voxel depends on before its passes (2 subpasses of 1 each, per pass)
JITTER = (1.0, 0.5, 0.25)  # jitter of the coarsest levels, in units of the level's step h
APPEARANCE = 8  # numbers per voxel of appearance
FEATURES = 16  # numbers per neighbourhood
_APPEARANCE_RADIUS = 2  # appearance from 5^3 colour neighbourhoods
_STENCIL = np.array(list(itertools.product((-1, 0, 1), repeat=3)), dtype=np.int64)  # 27 offsets, centre 13
# the neighbours whose continuations are candidates: the 6 faces, the 12 edges and the voxel itself (the 8 corners
# added 30% to the time and nothing visible)
_CANDIDATES = np.flatnonzero(np.abs(_STENCIL).sum(axis=1) <= 2)
_PCA_SAMPLE = 8_000  # voxels the principal axes are estimated on
_QUANTUM = 127  # appearance values are integers in [-127, 127]
_RANGE = 500  # neighbourhood features are integers in [-500, 500]: 16 squared differences sum below 2^24
_CHUNK = 16_384  # voxels corrected at once (their candidates' features: 16k * 27 * 16 float32 = 28 MB)


def default_levels(shape: tuple[int, ...]) -> int:
    """Pyramid levels for an exemplar: the coarsest step is the largest power of two at most a quarter of its side.

    Examples
    --------
    >>> default_levels((48, 48, 48)), default_levels((64, 64, 64)), default_levels((96, 96, 96))
    (4, 5, 5)
    """
    return int(math.log2(max(min(shape[:3]) // 4, 1))) + 1


def _principal_axes(sample: NDArray, count: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean and the ``count`` principal axes ``(dims, count)`` of sample rows (eigenvectors of the covariance:
    a 375 x 375 eigenproblem instead of an SVD of the whole sample, 30x faster)."""
    x = np.asarray(sample, np.float64)
    mean = x.mean(axis=0)
    centred = x - mean
    vectors = np.linalg.eigh(centred.T @ centred)[1]
    return mean, vectors[:, ::-1][:, :count]


def _quantise(values: NDArray, limit: float, scale: float | None = None) -> tuple[NDArray[np.float32], float]:
    """Round ``values / scale`` to integers within ``[-limit, limit]`` (float32); ``scale`` defaults to fit them."""
    if scale is None:
        scale = max(float(np.abs(values).max()) / limit, 1e-12)
    return np.clip(np.rint(values / scale), -limit, limit).astype(np.float32), scale


class _Level:
    """One pyramid level of the exemplar: its step, appearance, neighbourhood projection and features."""

    def __init__(self, h: int, appearance: NDArray[np.float32], exemplar: PyramidExemplar, rng) -> None:
        self.h = h
        m = exemplar.shape
        flat = appearance.reshape(-1, APPEARANCE)
        picks = exemplar.coords(rng.integers(0, len(flat), _PCA_SAMPLE))
        sample = np.concatenate([flat[exemplar.lin((picks + h * d) % m)] for d in _STENCIL], axis=1)
        basis = _principal_axes(sample, FEATURES)[1]  # (27 * A, F)
        self.projection, _ = _quantise(basis, _QUANTUM)  # integers: the products below are exact
        self.appearance = flat.astype(np.int8)  # (M, A), integers in [-127, 127]: a quarter of float32's gathers
        features = np.zeros((len(flat), FEATURES), np.float32)
        for i, d in enumerate(_STENCIL):  # exact: integers below 2^24 at every step
            rolled = np.roll(appearance, tuple(-h * d), axis=(0, 1, 2)).reshape(-1, APPEARANCE)
            features += rolled @ self.projection[i * APPEARANCE : (i + 1) * APPEARANCE]
        quantised, self.scale = _quantise(features, _RANGE)
        self.features = quantised.astype(np.int16)  # (M, F), integers in [-500, 500]

    def query(self, neighbours: NDArray[np.int32]) -> NDArray[np.float32]:
        """Features of synthesised neighbourhoods: ``(V, 27)`` linear indices of each voxel's neighbours."""
        gathered = self.appearance[neighbours].reshape(len(neighbours), -1).astype(np.float32)
        return _quantise(gathered @ self.projection, _RANGE, self.scale)[0]


class PyramidExemplar:
    """A solid exemplar prepared for pyramid synthesis: its levels' appearance and neighbourhood features.

    Made once per exemplar (a second or two for 64^3); what :func:`region` and the lazy texture
    read. Picklable, so a cluster's workers get the very same tables.

    Parameters
    ----------
    exemplar : numpy.ndarray
        ``(Z, Y, X, 3)`` uint8, best periodic (``exemplar_from_image``'s are): coordinates wrap
        around it.
    levels : int, optional
        Pyramid levels (default :func:`default_levels`).
    seed : int
        Seed of the PCA samples.

    Examples
    --------
    >>> ex = np.random.default_rng(0).integers(0, 256, (16, 16, 16, 3), dtype=np.uint8)
    >>> prepared = PyramidExemplar(ex, levels=2)
    >>> [level.h for level in prepared.levels], prepared.levels[0].features.shape
    ([2, 1], (4096, 16))
    """

    def __init__(self, exemplar: NDArray[np.uint8], levels: int | None = None, seed: int = 0) -> None:
        with one_blas_thread():  # products with 8 to 375 columns: a second thread waiting for a busy core costs 5x
            self._prepare(exemplar, levels, seed)

    def _prepare(self, exemplar: NDArray[np.uint8], levels: int | None, seed: int) -> None:
        self.colours = np.ascontiguousarray(exemplar).reshape(-1, 3)
        self.shape = np.array(exemplar.shape[:3], dtype=np.int64)
        self.size = int(self.shape.prod())
        self.n_levels = default_levels(exemplar.shape) if levels is None else int(levels)
        rng = np.random.default_rng(seed)
        # each voxel's appearance: its 5^3 colour neighbourhood (wrapping around), PCA-reduced
        e = exemplar.astype(np.float32)
        r = range(-_APPEARANCE_RADIUS, _APPEARANCE_RADIUS + 1)
        offsets = [np.array(d) for d in itertools.product(r, r, r)]
        picks = rng.integers(0, self.size, _PCA_SAMPLE)
        flat = e.reshape(-1, 3)
        sample = np.concatenate([flat[self.lin((self.coords(picks) + d) % self.shape)] for d in offsets], axis=1)
        mean, basis = _principal_axes(sample, APPEARANCE)
        appearance = np.zeros((*exemplar.shape[:3], APPEARANCE), np.float32)
        for i, d in enumerate(offsets):
            appearance += (np.roll(e, tuple(-d), axis=(0, 1, 2)) - mean[3 * i : 3 * i + 3]) @ basis[3 * i : 3 * i + 3]
        self.levels: list[_Level] = []
        scale = _quantise(appearance, _QUANTUM)[1]  # one scale for all levels: the finest has the widest range
        for k in range(self.n_levels):
            h = 2 ** (self.n_levels - 1 - k)
            blurred = appearance if h == 1 else ndimage.uniform_filter(appearance, (h, h, h, 1), mode="wrap")
            quantised, _ = _quantise(blurred, _QUANTUM, scale)
            self.levels.append(_Level(h, quantised.reshape(blurred.shape), self, rng))

    def lin(self, zyx: NDArray) -> NDArray[np.int32]:
        """Linear index of exemplar coordinates ``(..., 3)`` (already within the exemplar)."""
        s1, s2 = int(self.shape[1]), int(self.shape[2])
        return ((zyx[..., 0] * s1 + zyx[..., 1]) * s2 + zyx[..., 2]).astype(np.int32, copy=False)

    def coords(self, lin: NDArray) -> NDArray[np.int32]:
        """Coordinates ``(..., 3)`` of linear indices."""
        return np.stack(np.unravel_index(lin, tuple(self.shape)), axis=-1).astype(np.int32)

    def index(self, codes: NDArray[np.int32]) -> NDArray[np.int32]:
        """Linear indices (rows of the tables and colours) of packed coordinates (see :func:`pack`)."""
        z, y, x = unpack(codes)
        s1, s2 = int(self.shape[1]), int(self.shape[2])
        return (z * s1 + y) * s2 + x

    def colour(self, codes: NDArray[np.int32]) -> NDArray[np.uint8]:
        """The exemplar's colours ``(..., 3)`` at packed coordinates."""
        return self.colours[self.index(codes)]

    @property
    def nbytes(self) -> int:
        """Memory of the prepared tables."""
        return int(sum(lv.features.nbytes + lv.appearance.nbytes for lv in self.levels) + self.colours.nbytes)


_BITS = 10  # bits per axis of a packed coordinate: exemplars up to 1024 voxels a side
_MASK = (1 << _BITS) - 1


def pack(z: NDArray, y: NDArray, x: NDArray) -> NDArray[np.int32]:
    """Exemplar coordinates packed into one int32 each, ``z << 20 | y << 10 | x``: what the synthesis holds.

    A voxel's neighbours' coordinates are then one gather, and unpacked by shifts and masks (a table
    of coordinates by linear index cost a third of the synthesis in its gathers).

    Examples
    --------
    >>> codes = pack(np.array([3]), np.array([1000]), np.array([7]))
    >>> [int(v[0]) for v in unpack(codes)]
    [3, 1000, 7]
    """
    return ((z.astype(np.int32) << (2 * _BITS)) | (y.astype(np.int32) << _BITS) | x.astype(np.int32)).astype(
        np.int32, copy=False
    )


def unpack(codes: NDArray[np.int32]) -> tuple[NDArray[np.int32], NDArray[np.int32], NDArray[np.int32]]:
    """The ``(z, y, x)`` of packed coordinates (see :func:`pack`)."""
    return codes >> (2 * _BITS), (codes >> _BITS) & _MASK, codes & _MASK


def box_positions(lo: NDArray[np.int64], size) -> list[NDArray[np.int64]]:
    """Absolute positions along each axis of boxes ``[lo, lo + size)`` (``lo`` is ``(N, 3)``), broadcastable to
    ``(N, *size)``."""
    out = []
    for a in range(3):
        shape = [len(lo), 1, 1, 1]
        shape[a + 1] = int(size[a])
        out.append((lo[:, a, None] + np.arange(size[a], dtype=np.int64)[None, :]).reshape(shape))
    return out


def _hash(seed: int, level: int, salt: int, z, y, x) -> NDArray[np.uint64]:
    """A hash of ``(seed, level, salt, z, y, x)`` for broadcastable position arrays."""
    root = splitmix64(np.array([seed], np.uint64) ^ splitmix64(np.array([level * 64 + salt], np.uint64)))
    h = splitmix64(root ^ z.astype(np.uint64))
    h = splitmix64(h ^ y.astype(np.uint64))
    return splitmix64(h ^ x.astype(np.uint64))


def _uniform(words: NDArray[np.uint64], salt: int) -> NDArray[np.float64]:
    """Uniform numbers in [0, 1) from hash words, one stream per ``salt``."""
    return (splitmix64(words ^ np.uint64(salt)) >> np.uint64(11)).astype(np.float64) / 2.0**53


def _initial(ex: PyramidExemplar, seed: int, lo: NDArray[np.int64], size) -> NDArray[np.int32]:
    words = _hash(seed, 0, 0, *box_positions(lo, size))
    return pack(*[(_uniform(words, a) * ex.shape[a]).astype(np.int32) for a in range(3)])


def _upsampled(ex: PyramidExemplar, k: int, seed: int, coarse, lo: NDArray[np.int64], size) -> NDArray[np.int32]:
    """Level ``k``'s coordinates over boxes at ``lo`` before its passes, from level ``k - 1``'s ``coarse =
    (clo, coordinates)``: ``(N, ...)`` boxes at ``clo`` that hold every parent."""
    h = ex.levels[k].h
    clo, parents = coarse
    pos = box_positions(lo, size)
    index = [(p >> 1) - clo[:, a].reshape(-1, 1, 1, 1) for a, p in enumerate(pos)]
    zyx = [c.astype(np.int64) for c in unpack(parents[np.arange(len(lo)).reshape(-1, 1, 1, 1), *index])]
    for a in range(3):
        zyx[a] = zyx[a] + h * (pos[a] & 1)
    if k < len(JITTER):
        words = _hash(seed, k, 1, *pos)
        for a in range(3):
            zyx[a] = zyx[a] + np.floor(h * JITTER[k] * (2 * _uniform(words, a) - 1) + 0.5).astype(np.int64)
    return pack(*[c % int(ex.shape[a]) for a, c in enumerate(zyx)])


def _correct(ex: PyramidExemplar, k: int, state: NDArray[np.int32], lo: NDArray[np.int64], parity: int):
    """One subpass over boxes ``state`` (``(N, a, b, c)`` at ``lo``): the voxels of ``sum(p) % 2 == parity``
    take their best candidate. The result covers the boxes shrunk by one voxel on every side."""
    level = ex.levels[k]
    n, *size = state.shape
    inner = tuple(s - 2 for s in size)
    out = state[:, 1:-1, 1:-1, 1:-1].copy()
    pz, py, px = box_positions(lo + 1, inner)
    todo = np.flatnonzero(((pz + py + px) % 2 == parity).ravel())
    b, z, y, x = np.unravel_index(todo, (n, *inner))
    # flat indices into the state: each voxel's own (the box shifted by one), and its 27 neighbours' offsets
    strides = np.array([size[1] * size[2], size[2], 1])
    centre = ((b * size[0] + z + 1) * size[1] + y + 1) * size[2] + x + 1
    around = _STENCIL @ strides
    flat_state, flat_out = state.reshape(-1), out.reshape(-1)
    shifts = (level.h * _STENCIL).astype(np.int32)
    m = [int(v) for v in ex.shape]
    for start in range(0, len(todo), _CHUNK):
        sl = slice(start, start + _CHUNK)
        neighbours = flat_state[centre[sl, None] + around]  # (v, 27) packed coordinates
        query = level.query(ex.index(neighbours))
        zyx = []
        for a, c in enumerate(unpack(neighbours[:, _CANDIDATES])):  # continue each: S(p + d) - h d, in (-m, 2m)
            c = c - shifts[_CANDIDATES, a]
            c += np.where(c < 0, m[a], 0).astype(np.int32)
            c -= np.where(c >= m[a], m[a], 0).astype(np.int32)
            zyx.append(c)
        rows = (zyx[0] * m[1] + zyx[1]) * m[2] + zyx[2]
        diff = level.features[rows].astype(np.float32) - query[:, None, :]
        distance = np.einsum("vcf,vcf->vc", diff, diff)  # exact: integers below 2^24
        best = distance.argmin(axis=1)
        pick = np.arange(len(best))
        flat_out[todo[sl]] = pack(zyx[0][pick, best], zyx[1][pick, best], zyx[2][pick, best])
    return out


def passes(ex: PyramidExemplar, level: int) -> int:
    """Correction passes of a level: one at the two finest, :data:`PASSES` at the others.

    A second pass at the two finest changed nothing visible and doubles the voxels a lazy surface
    needs there. None at the finest looked the same too, but left its parents' seams every second
    voxel (block-grid score 1.37-1.48 at 96^3 against 1.22-1.33 with one pass).
    """
    return 1 if level >= ex.n_levels - 2 else PASSES


def parent_box(lo: NDArray[np.int64], hi: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The box of the coarser level whose voxels are the parents of ``[lo, hi)``."""
    return lo >> 1, ((hi - 1) >> 1) + 1


def boxes(ex: PyramidExemplar, seed: int, level: int, lo: NDArray[np.int64], size, coarse=None) -> NDArray[np.int32]:
    """Coordinates (packed, :func:`pack`) of level ``level`` over boxes ``[lo, lo + size)``.

    ``lo`` is ``(N, 3)``, the result ``(N, *size)``. Synthesises the coarser levels over the boxes
    they depend on, unless ``coarse = (clo, coordinates)`` gives level ``level - 1`` over boxes
    that hold them (:func:`dependency`).
    """
    lo = np.asarray(lo, np.int64).reshape(-1, 3)
    size = np.asarray(size, np.int64)
    margin = 2 * passes(ex, level)
    plo, psize = lo - margin, size + 2 * margin
    if level == 0:
        state = _initial(ex, seed, plo, psize)
    else:
        if coarse is None:
            clo, chi = parent_box(plo, plo + psize)
            coarse = (clo, boxes(ex, seed, level - 1, clo, chi[0] - clo[0]))
        state = _upsampled(ex, level, seed, coarse, plo, psize)
    for p in range(passes(ex, level)):
        for parity in (0, 1):
            state = _correct(ex, level, state, plo + 2 * p + parity, parity)
    return state


def dependency(ex: PyramidExemplar, level: int, lo: NDArray[np.int64], hi: NDArray[np.int64]):
    """The box of level ``level - 1`` that level ``level``'s voxels over ``[lo, hi)`` depend on."""
    margin = 2 * passes(ex, level)
    return parent_box(np.asarray(lo) - margin, np.asarray(hi) + margin)


def region(ex: PyramidExemplar, seed: int, level: int, lo, hi) -> NDArray[np.int32]:
    """Coordinates (packed, :func:`pack`: :meth:`PyramidExemplar.colour` gives their colours) of level ``level``
    over the box ``[lo, hi)``.

    Examples
    --------
    >>> ex = PyramidExemplar(np.random.default_rng(0).integers(0, 256, (16, 16, 16, 3), dtype=np.uint8), levels=2)
    >>> whole = region(ex, 3, 1, (0, 0, 0), (12, 12, 12))
    >>> part = region(ex, 3, 1, (4, 5, 6), (9, 12, 10))
    >>> bool(np.array_equal(whole[4:9, 5:12, 6:10], part))
    True
    """
    lo, hi = np.asarray(lo, np.int64), np.asarray(hi, np.int64)
    with one_blas_thread():
        return boxes(ex, seed, level, lo[None], hi - lo)[0]
