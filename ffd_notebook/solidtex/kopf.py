"""A solid texture from one 2D image by neighbourhood optimisation (Kopf et al. 2007).

Kopf, Fu, Cohen-Or, Deussen, Lischinski and Wong, "Solid texture synthesis from 2D exemplars"
(SIGGRAPH 2007): a volume whose slices along x, y and z all look like the image. The volume is
optimised coarse to fine; at each level it alternates two steps, a few times:

* **search**: for voxels on a sparse grid of every slice orientation, find the image neighbourhood
  nearest to the slice neighbourhood around the voxel (on PCA-reduced neighbourhoods, with a SciPy
  k-d tree: nearest-neighbour search is the whole cost, and a tree on ~16 dimensions is fast);
* **optimise**: every voxel becomes the weighted mean of the colours that the matched image
  neighbourhoods covering it (from all three orientations) put there. The weights
  ``|s - e|^(r - 2)`` (``r = 0.8``) make it a robust (IRLS) minimisation of ``sum |s - e|^r``, and
  the paper's *histogram matching* divides each weight by how over-represented the colour it
  brings already is in the volume, which keeps the volume's colour statistics those of the image.

Before every step, and once at the end, a sliced optimal-transport colour transfer gives the
volume the image's joint colour distribution: averaging narrows it, and the per-bin weights alone
do not undo that (measured: histogram distance 0.23 with them alone). Transferring only once at
the end stretched the contrast of a volume optimised blurred, which undid most of the
optimisation (mean slice-neighbourhood distance 4.8 before, 7.1 after, on the notebook's image);
transferring before every step lets each step repair the structure at the right contrast (5.6
after the final transfer, same histogram distance). Measured per step, the energy falls at
every step of the finer levels; at the coarsest it rises slightly after the first step, which
the histogram matching causes (without it, it falls and then stays flat): matching the colours
costs some neighbourhood fit.

The fit stops near 0.8x the extrusion's distance on the notebook's image (5.6 against 7.0), and
what would lower it further lowers it by blurring: the optimised volume is smooth where the image
has pixel-scale grain (5x5 windows with a colour standard deviation of 3-8 against the image's
7-19), and a smooth window is nearer to some grainy image window than a wrongly grainy one is
(the image blurred by a 1-pixel Gaussian is 5.2 from its own windows). Measured at 64^3, not
kept: 4 levels (5.39, but features laid out 8x larger: washed-out blobs), a half-strength final
transfer (5.44, low contrast), per-voxel robust weights (sharper, 5.9), more finest-level
iterations (5.53 after 6 instead of 3), exact nearest neighbours in 32 PCA dimensions, 7x7 coarse
neighbourhoods, k-coherence candidates, sparser or denser proposal grids (each by less than 0.1).

Also measured (issue 14's 0.7x target, 4.9), not the default: ``discrete_sweeps`` (a final discrete
pass: voxels take real image colours that lower ``sum ||window - match||``) reaches 0.78-0.79x over
3 seeds (4 sweeps, +15-20 s) but moves the histogram distance from 0.010 to 0.019-0.021 (the
extrusion: 0.025), and most of its gain is that drift: a colour transfer after it gives 5.8, worse
than without it; dense windows instead of the sparse grid gain 0.02 more at 3x the time; a
histogram penalty on the choice made both worse; a sweep after every finest-level step instead gave
5.66. Chen and Wang's (2010) position and index histograms (over-used image windows penalised in
the search and in the weights) gave 5.68-5.69 against 5.61. The measure has a floor that isotropic
synthesis does not seem able to pass: the image's own windows are 8.1 from their nearest window
3 px or more away (6.6 from the nearest other window at all), so any slice window that is not a
near-copy of the image scores ~6-8 and only smooth windows (5.2-5.5 for the image blurred by one
pixel) or verbatim copies score less; 4.9 needs verbatim copies in every orientation at once, which
a volume gets only along one axis (the extrusion's z slices: 0, its other slices: 10.5).

The volume wraps around (its neighbourhoods are taken periodically), so the result tiles, and it
is the exemplar :func:`~ffd_notebook.solidtex.synthesize` grows larger volumes from. Hand-written
on NumPy/SciPy because no maintained library implements the method.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree
from scipy.stats import special_ortho_group
from tqdm.auto import tqdm

from .._util.deprecation import renamed_keyword
from .neighbourhoods import image_windows
from .seeding import RNGLike, integer_seed
from .slices import as_rgb8

__all__ = ["exemplar_from_image"]

_BINS = 16  # per-channel histogram bins of the histogram matching


def _downsample(image: NDArray[np.float32], factor: int) -> NDArray[np.float32]:
    """Mean of ``factor x factor`` pixel blocks (the image at a coarser pyramid level)."""
    if factor == 1:
        return image
    h, w = (s - s % factor for s in image.shape[:2])
    return image[:h, :w].reshape(h // factor, factor, w // factor, factor, 3).mean(axis=(1, 3))


class _ImageNeighbourhoods:
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


def _slice_queries(volume: NDArray[np.float32], axis: int, n: int, stride: int, offset: int) -> NDArray[np.float32]:
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


def _histogram_penalty(volume: NDArray[np.float32], target: NDArray[np.float64]) -> NDArray[np.float32]:
    """Per channel and bin, how much more of the volume falls in the bin than of the image (>= 0)."""
    q = np.clip(volume.reshape(-1, 3) * (_BINS / 256.0), 0, _BINS - 1).astype(np.int64)
    h = np.stack([np.bincount(q[:, c], minlength=_BINS) for c in range(3)]) / len(q)
    return np.maximum(h - target, 0.0).astype(np.float32) * _BINS  # scaled: a fully doubled bin costs ~1


def _proposals(volume, index, stride, offset):
    """For each slice orientation: the matched image windows, their weights, and where they go."""
    n = index.n
    for axis in range(3):
        queries = _slice_queries(volume, axis, n, stride, offset)
        idx, dist = index.nearest(queries)
        weight = np.power(dist / np.sqrt(3 * n * n) + 0.05, 0.8 - 2.0).astype(np.float32)  # IRLS, r = 0.8
        yield axis, index.windows[idx].reshape(-1, n, n, 3), weight


def _offsets(shape, axis, n, stride, offset):
    """For each window offset (dy, dx): the voxels (in the volume moved so ``axis`` is first) it lands on."""
    h = n // 2
    moved = (shape[axis], *(shape[a] for a in range(3) if a != axis))
    rows0, cols0 = np.arange(offset, moved[1], stride), np.arange(offset, moved[2], stride)
    grid = (moved[0], len(rows0), len(cols0))
    for dy in range(n):
        for dx in range(n):
            # each (row, col) pair appears once for a fixed offset: fancy-index updates are exact
            yield dy, dx, grid, np.ix_(np.arange(moved[0]), (rows0 + dy - h) % moved[1], (cols0 + dx - h) % moved[2])


def _optimise(
    volume: NDArray[np.float32], index: _ImageNeighbourhoods, target_hist: NDArray[np.float64], stride: int, it: int
) -> NDArray[np.float32]:
    """One search + optimise step: each voxel becomes the weighted mean of the colours proposed for it.

    (A "discrete" variant that keeps the proposal nearest to the mean was tried: sharper-looking
    but farther from the image by the method's own energy and by colour histogram.)
    """
    shape = volume.shape[:3]
    num = np.zeros((*shape, 3), np.float32)
    den = np.zeros(shape, np.float32)
    penalty = _histogram_penalty(volume, target_hist)
    offset = it % stride  # move the sparse grid between iterations so every voxel gets centred
    for axis, patches, weight in _proposals(volume, index, stride, offset):
        numv, denv = np.moveaxis(num, axis, 0), np.moveaxis(den, axis, 0)
        for dy, dx, grid, sub in _offsets(shape, axis, index.n, stride, offset):
            colour = patches[:, dy, dx]
            bins = np.clip(colour * (_BINS / 256.0), 0, _BINS - 1).astype(np.int64)
            over = penalty[0, bins[:, 0]] + penalty[1, bins[:, 1]] + penalty[2, bins[:, 2]]
            w = (weight / (1.0 + over)).reshape(grid)
            numv[sub] += w[..., None] * colour.reshape(*grid, 3)
            denv[sub] += w
    return num / np.maximum(den, 1e-12)[..., None]


def _discrete_sweep(
    volume: NDArray[np.float32], index: _ImageNeighbourhoods, stride: int, offset: int, rng: np.random.Generator
) -> NDArray[np.float32]:
    """One discrete step at the finest level: voxels take a real image colour that lowers the energy.

    The windows are those of the search step (centred on a sparse grid of every slice
    orientation). Each voxel's candidates are its current colour and, per orientation, the colour
    the nearest covering window's match puts on it; it keeps the one with the least
    ``sum ||window - match||`` over the windows covering it, the matches fixed (the method's
    energy with ``r = 1``, the measure of :func:`~ffd_notebook.solidtex.neighbourhood_distance`,
    rather than the weighted mean of :func:`_optimise`). A random half of the voxels moves per
    sweep, so that neighbours do not all jump at once (iterated conditional modes).
    """
    n, h = index.n, index.n // 2
    shape = volume.shape[:3]
    vol = np.ascontiguousarray(np.moveaxis(volume, 3, 0))  # channels first: cheaper sums over colours
    matches = []
    for axis in range(3):
        idx, dist = index.nearest(_slice_queries(volume, axis, n, stride, offset))
        matches.append((axis, index.windows[idx].reshape(-1, n, n, 3), np.square(dist)))
    cands = np.repeat(vol[None], 4, axis=0)  # the current colour, then one proposal per orientation
    for axis, patches, _ in matches:
        mine = np.moveaxis(cands[1 + axis], axis + 1, 1)
        for dy, dx, grid, sub in _offsets(shape, axis, n, stride, offset):
            if h <= dy < h + stride and h <= dx < h + stride:  # the window whose centre is nearest
                mine[(slice(None), *sub)] = np.moveaxis(patches[:, dy, dx].reshape(*grid, 3), 3, 0)
    cost = np.zeros((4, *shape), np.float32)
    for axis, patches, r2 in matches:
        own, costs = np.moveaxis(vol, axis + 1, 1), np.moveaxis(cost, axis + 1, 1)
        options = np.moveaxis(cands, axis + 2, 2)
        for dy, dx, grid, sub in _offsets(shape, axis, n, stride, offset):
            e = np.moveaxis(patches[:, dy, dx].reshape(*grid, 3), 3, 0)
            rest = np.maximum(r2.reshape(grid) - _sq(own[(slice(None), *sub)] - e), 0.0)
            for k in range(4):
                costs[k][sub] += np.sqrt(rest + _sq(options[k][(slice(None), *sub)] - e))
    best = np.argmin(cost, axis=0)
    best[rng.random(shape) < 0.5] = 0  # half the voxels keep their colour this sweep
    return np.moveaxis(np.take_along_axis(cands, best[None, None], axis=0)[0], 0, 3)


def _sq(d: NDArray[np.float32]) -> NDArray[np.float32]:
    """Squared colour distance of channel-first differences."""
    return d[0] * d[0] + d[1] * d[1] + d[2] * d[2]


def _transfer_colours(volume: NDArray[np.float32], image: NDArray[np.float32], rounds: int, seed: int):
    """Give the volume's colours the image's joint RGB distribution (sliced optimal transport).

    Each round rotates the colour space at random and matches each rotated channel's
    distribution exactly (rank by rank), after Pitie, Kokaram and Dawson (2005); a few rounds
    match the joint distribution, which per-channel matching alone does not. Averaging proposals
    narrows the colours; this restores them without moving any structure.
    """
    x = volume.reshape(-1, 3).astype(np.float64)
    y = image.reshape(-1, 3).astype(np.float64)
    ranks = (np.arange(len(x)) + 0.5) / len(x)
    quantiles = (np.arange(len(y)) + 0.5) / len(y)
    rng = np.random.default_rng(seed)
    for _ in range(rounds):
        rotation = special_ortho_group.rvs(3, random_state=rng)
        px, py = x @ rotation, y @ rotation
        for c in range(3):
            px[np.argsort(px[:, c], kind="stable"), c] = np.interp(ranks, quantiles, np.sort(py[:, c]))
        x = px @ rotation.T
    return x.reshape(volume.shape).astype(np.float32)


def exemplar_from_image(
    image: Any,
    size: int = 64,
    *,
    levels: int = 3,
    neighbourhood: int = 5,
    iterations: tuple[int, ...] = (4, 3, 3),
    pca_dims: int = 16,
    discrete_sweeps: int = 0,
    rng: RNGLike = 0,
    progress: bool = False,
    seed: int | None = None,
) -> NDArray[np.uint8]:
    """A cubic colour volume whose axis-aligned slices look like ``image`` (Kopf et al. 2007).

    Parameters
    ----------
    image : array_like
        A 2D grey or colour image (see :func:`~ffd_notebook.solidtex.as_rgb8`); its pixels become
        voxels at the finest level, so features keep their size in pixels.
    size : int
        Edge of the result; a multiple of ``2**(levels - 1)``.
    levels : int
        Pyramid levels (coarse to fine; each halves the size and the image).
    neighbourhood : int
        Edge of the slice neighbourhoods compared (odd).
    iterations : tuple of int
        Search/optimise steps per level, coarsest first (the last value repeats if short).
    pca_dims : int
        Dimensions the neighbourhoods are reduced to for the nearest-neighbour search.
    discrete_sweeps : int
        Discrete sweeps after the optimisation (0: none): each voxel may take the colour that one
        of its matched image windows gives it, where that lowers the sum of window distances
        (about 2 s per sweep at 64^3; see the module notes for what it gains and costs).
    rng : int or numpy.random.Generator
        The result is the same for the same int. The optimisation needs an integer root seed (its
        colour transfers are seeded ``seed + iteration``): a Generator gives one 63-bit draw
        (:func:`~ffd_notebook.solidtex.seeding.integer_seed`).
    progress : bool
        Show a tqdm bar (one tick per step).
    seed : int, optional
        Deprecated alias of ``rng`` (a :class:`DeprecationWarning`).

    Returns
    -------
    numpy.ndarray
        ``(size, size, size, 3)`` uint8; it tiles periodically.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> stripes = np.kron(rng.integers(0, 2, (8, 1)) * 200, np.ones((4, 32))).astype(np.uint8)
    >>> vol = exemplar_from_image(stripes, size=16, levels=2, neighbourhood=5, iterations=(2, 2))
    >>> vol.shape, vol.dtype.name
    ((16, 16, 16, 3), 'uint8')
    """
    img = as_rgb8(image).astype(np.float32)
    if neighbourhood % 2 != 1 or neighbourhood < 3:
        raise ValueError(f"neighbourhood must be an odd number >= 3, got {neighbourhood}")
    scale = 2 ** (levels - 1)
    if levels < 1 or size % scale or size // scale < neighbourhood:
        raise ValueError(f"size {size} must be a multiple of {scale} and at least {neighbourhood * scale}")
    if min(img.shape[:2]) // scale < neighbourhood + 1:
        raise ValueError(f"the image ({img.shape[0]}x{img.shape[1]}) is too small for {levels} levels")
    if seed is not None:
        rng = renamed_keyword({"seed": seed}, "seed", "rng", rng, "exemplar_from_image")
    seed = integer_seed(rng)
    rng = np.random.default_rng(seed)
    iters = [iterations[min(k, len(iterations) - 1)] for k in range(levels)]
    volume = None
    with tqdm(total=sum(iters), desc="exemplar from image", disable=not progress) as bar:
        for level in range(levels):
            factor = 2 ** (levels - 1 - level)
            level_img = _downsample(img, factor)
            n_side = size // factor
            if volume is None:  # start from the image's own colours, shuffled
                pixels = level_img.reshape(-1, 3)
                volume = pixels[rng.integers(0, len(pixels), n_side**3)].reshape(n_side, n_side, n_side, 3)
            else:
                volume = ndimage.zoom(volume, (2, 2, 2, 1), order=1, mode="grid-wrap", grid_mode=True)
            index = _ImageNeighbourhoods(level_img, neighbourhood, pca_dims, rng)
            target_hist = np.stack(
                [
                    np.bincount(
                        np.clip(level_img[..., c] * (_BINS / 256.0), 0, _BINS - 1).astype(int).ravel(), None, _BINS
                    )
                    for c in range(3)
                ]
            ) / (level_img.shape[0] * level_img.shape[1])
            for it in range(iters[level]):
                if it or level:  # the shuffled start already has the image's colours
                    volume = _transfer_colours(volume, level_img, 5, seed + it)
                volume = _optimise(volume.astype(np.float32), index, target_hist, 2, it)
                bar.update()
    volume = _transfer_colours(volume, img, 20, seed)
    if discrete_sweeps:  # ``index`` is the finest level's: the full image
        for sweep in range(discrete_sweeps):  # the sparse grid moves between sweeps, as in the optimisation
            volume = _discrete_sweep(volume.astype(np.float32), index, 2, sweep % 2, rng)
    return np.clip(np.rint(volume), 0, 255).astype(np.uint8)
