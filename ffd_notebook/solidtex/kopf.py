"""A solid texture from one 2D image by neighbourhood optimisation (Kopf et al. 2007).

Kopf, Fu, Cohen-Or, Deussen, Lischinski and Wong, "Solid texture synthesis from 2D exemplars"
(SIGGRAPH 2007): a volume whose slices along x, y and z all look like the image. The volume is
optimised coarse to fine; at each level it alternates two steps, a few times:

* **search**: for voxels on a sparse grid of every slice orientation, find the image neighbourhood
  nearest to the slice neighbourhood around the voxel (on PCA-reduced neighbourhoods, with a SciPy
  k-d tree: nearest-neighbour search is the whole cost, and a tree on ~16 dimensions is fast);
* **update**: every matched image window proposes colours for the voxels it covers (from all three
  orientations). Kopf's update takes their weighted mean, the weights ``|s - e|^(r - 2)``
  (``r = 0.8``, IRLS) divided by how over-represented the colour already is in the volume (the
  paper's *histogram matching*). Here, by default (``vote="best"``), a voxel instead takes the
  colour of the one window that matched best (least distance, times the same over-use factor):
  it follows its best neighbourhood instead of averaging neighbourhoods that disagree.

Before every step, and once at the end, a sliced optimal-transport colour transfer gives the volume
the image's joint colour distribution.

Why "best": the mean blurs. Judged by :func:`~ffd_notebook.solidtex.self_similarity` (issue 26's
measure: new samples of the texture score ~1, the image blurred by one pixel ~0.6-0.7), the mean
gave slices at 0.48-0.62 on a 96 px crop of the histology image (96^3, 5x5 neighbourhoods). Measured
on that crop, 96^3, per slice orientation (``tests/benchmarks/bench_solidtex.py --only exemplar``
prints the defaults' figures):

* mean-shift to the proposals' mode (Wexler, Shechtman and Irani 2007; 3 passes, bandwidth 20):
  0.52-0.64, a little sharper, not kept;
* stronger robust weights, ``r = -4``: 0.62-0.73; ``r = -20`` (nearly one window wins): 0.85-0.94
  on the histology image but 0.64-0.68 on gravel, whose stones are larger than 5x5 windows;
* with 9x9 neighbourhoods: ``r = -6`` 0.85-1.12 (histology) but 0.73-0.84 (gravel); the best
  window alone (this default): 1.11-1.28 (histology) and 1.02-1.09 (gravel), colour histogram
  distance 0.0068 against the mean's 0.0073.

What it costs: a voxel takes the window of one orientation, and its neighbours along another axis
may take windows of another, so slices show short straight streaks and small blocks where the
orientations disagree (visible at 3x zoom; the mean averages them away into blur). The slices are
sharp and their windows are as varied as the image's, but they are not a 3D-consistent tissue:
no round nuclei as the image has.

The earlier measure, the mean distance from slice windows to their nearest image window
(:func:`~ffd_notebook.solidtex.neighbourhood_distance`), rewarded blur (a smooth window is near
some smooth part of the image); the notes that tuned the mean against it (issue 14) are in the
project's history.

``discrete_sweeps`` (a final discrete pass: voxels take real image colours that lower
``sum ||window - match||``) is kept for the mean.

The volume wraps around (its neighbourhoods are taken periodically), so the result tiles, and it
is the exemplar :func:`~ffd_notebook.solidtex.synthesize` grows larger volumes from. Hand-written
on NumPy/SciPy because no maintained library implements the method.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from tqdm.auto import tqdm

from .._util.deprecation import renamed_keyword
from .seeding import RNGLike, integer_seed
from .slice_search import (
    ImageNeighbourhoods,
    channel_histograms,
    default_size,
    downsample,
    optimise_step,
    slice_queries,
    transfer_colours,
    window_offsets,
)
from .slices import as_rgb8
from .transport import exemplar_by_transport

__all__ = ["exemplar_from_image"]


def _discrete_sweep(
    volume: NDArray[np.float32], index: ImageNeighbourhoods, stride: int, offset: int, rng: np.random.Generator
) -> NDArray[np.float32]:
    """One discrete step at the finest level: voxels take a real image colour that lowers the energy.

    The windows are those of the search step (centred on a sparse grid of every slice
    orientation). Each voxel's candidates are its current colour and, per orientation, the colour
    the nearest covering window's match puts on it; it keeps the one with the least
    ``sum ||window - match||`` over the windows covering it, the matches fixed (the method's
    energy with ``r = 1``, the measure of :func:`~ffd_notebook.solidtex.neighbourhood_distance`,
    rather than the weighted mean of :func:`~ffd_notebook.solidtex.slice_search.optimise_step`). A
    random half of the voxels moves per sweep, so that neighbours do not all jump at once (iterated conditional modes).
    """
    n, h = index.n, index.n // 2
    shape = volume.shape[:3]
    vol = np.ascontiguousarray(np.moveaxis(volume, 3, 0))  # channels first: cheaper sums over colours
    matches = []
    for axis in range(3):
        idx, dist = index.nearest(slice_queries(volume, axis, n, stride, offset))
        matches.append((axis, index.windows[idx].reshape(-1, n, n, 3), np.square(dist)))
    cands = np.repeat(vol[None], 4, axis=0)  # the current colour, then one proposal per orientation
    for axis, patches, _ in matches:
        mine = np.moveaxis(cands[1 + axis], axis + 1, 1)
        for dy, dx, grid, sub in window_offsets(shape, axis, n, stride, offset):
            if h <= dy < h + stride and h <= dx < h + stride:  # the window whose centre is nearest
                mine[(slice(None), *sub)] = np.moveaxis(patches[:, dy, dx].reshape(*grid, 3), 3, 0)
    cost = np.zeros((4, *shape), np.float32)
    for axis, patches, r2 in matches:
        own, costs = np.moveaxis(vol, axis + 1, 1), np.moveaxis(cost, axis + 1, 1)
        options = np.moveaxis(cands, axis + 2, 2)
        for dy, dx, grid, sub in window_offsets(shape, axis, n, stride, offset):
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


def exemplar_from_image(
    image: Any,
    size: int | None = None,
    *,
    levels: int = 3,
    neighbourhood: int = 9,
    iterations: tuple[int, ...] = (4, 3, 3),
    pca_dims: int = 16,
    discrete_sweeps: int = 0,
    vote: str = "best",
    method: str = "transport",
    rng: RNGLike = 0,
    progress: bool = False,
    seed: int | None = None,
) -> NDArray[np.uint8]:
    """A cubic colour volume whose axis-aligned slices look like ``image``.

    By default (``method="transport"``) the slices' patch distributions are matched to the image's
    by sliced optimal transport with robust neighbourhood steps
    (:func:`~ffd_notebook.solidtex.transport.exemplar_by_transport`: coherent cells and stones, no
    streaks or blocks); ``method="kopf"`` is the nearest-neighbour optimisation of Kopf et al. 2007
    described in this module (sharp at ``vote="best"`` but streaky, blurred at ``vote="mean"``).

    Parameters
    ----------
    image : array_like
        A 2D grey or colour image (see :func:`~ffd_notebook.solidtex.as_rgb8`); its pixels become
        voxels at the finest level, so features keep their size in pixels.
    size : int, optional
        Edge of the result; a multiple of ``2**(levels - 1)``. Default: the image's own size (its
        smaller side, rounded down to that multiple), so a slice shows as much as the image; an
        image over 160 px raises a ``ValueError`` (pass a crop of the texture, or ``size``).
    levels : int
        Pyramid levels (coarse to fine; each halves the size and the image).
    neighbourhood : int
        Edge of the slice neighbourhoods compared (odd). The default 9 is about the size of the
        histology image's nuclei; 5 (the old default) lets slices drift into blobs unlike any part
        of the image (self-similarity 0.65-0.68 on gravel with 7, ~1 with 9, best voting).
    iterations : tuple of int
        Search/optimise steps per level, coarsest first (the last value repeats if short).
    pca_dims : int
        Dimensions the neighbourhoods are reduced to for the nearest-neighbour search.
    discrete_sweeps : int
        Discrete sweeps after the optimisation (0: none): each voxel may take the colour that one
        of its matched image windows gives it, where that lowers the sum of window distances
        (about 2 s per sweep at 64^3; see the module notes for what it gains and costs).
    vote : {"best", "mean"}
        How a voxel combines the colours its matched windows propose: ``"best"`` takes the one of
        the best-matching window (sharp; default), ``"mean"`` Kopf's IRLS-weighted mean (smooth:
        slices at 0.5-0.6 self-similarity on the histology image). See the module notes.
        ``method="kopf"`` only, as are ``neighbourhood``, ``iterations``, ``pca_dims`` and
        ``discrete_sweeps``.
    method : {"transport", "kopf"}
        ``"transport"`` (default): :func:`~ffd_notebook.solidtex.transport.exemplar_by_transport`
        with its defaults and ``levels``; ``"kopf"``: the optimisation of this module, whose options
        are ``neighbourhood``, ``iterations``, ``pca_dims``, ``discrete_sweeps`` and ``vote`` (set
        with the default method, they raise a :class:`ValueError` rather than do nothing).
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
        ``(size, size, size, 3)`` uint8; it tiles periodically. Judge it with
        :func:`~ffd_notebook.solidtex.self_similarity` against the image (0.8-1.6 in every
        orientation for a sharp, non-repeating result).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> stripes = np.kron(rng.integers(0, 2, (8, 1)) * 200, np.ones((4, 32))).astype(np.uint8)
    >>> vol = exemplar_from_image(stripes, size=16, levels=2, neighbourhood=5, iterations=(2, 2), method="kopf")
    >>> vol.shape, vol.dtype.name
    ((16, 16, 16, 3), 'uint8')
    """
    if method not in ("transport", "kopf"):
        raise ValueError(f"method must be 'transport' or 'kopf', got {method!r}")
    if seed is not None:
        rng = renamed_keyword({"seed": seed}, "seed", "rng", rng, "exemplar_from_image")
    if method == "transport":
        kopf_only = {
            "neighbourhood": neighbourhood != 9,
            "iterations": tuple(iterations) != (4, 3, 3),
            "pca_dims": pca_dims != 16,
            "discrete_sweeps": discrete_sweeps != 0,
            "vote": vote != "best",
        }
        if any(kopf_only.values()):  # they would do nothing: say so rather than ignore them
            given = ", ".join(name for name, changed in kopf_only.items() if changed)
            raise ValueError(
                f"{given}: options of method='kopf' (the default method is 'transport'; "
                "exemplar_by_transport has its own options)"
            )
        return exemplar_by_transport(image, size, levels=levels, rng=rng, progress=progress)
    img = as_rgb8(image).astype(np.float32)
    if vote not in ("best", "mean"):
        raise ValueError(f"vote must be 'best' or 'mean', got {vote!r}")
    if size is None:
        size = default_size(img.shape, 2 ** (levels - 1))
    if neighbourhood % 2 != 1 or neighbourhood < 3:
        raise ValueError(f"neighbourhood must be an odd number >= 3, got {neighbourhood}")
    scale = 2 ** (levels - 1)
    if levels < 1 or size % scale or size // scale < neighbourhood:
        raise ValueError(f"size {size} must be a multiple of {scale} and at least {neighbourhood * scale}")
    if min(img.shape[:2]) // scale < neighbourhood + 1:
        raise ValueError(f"the image ({img.shape[0]}x{img.shape[1]}) is too small for {levels} levels")
    seed = integer_seed(rng)
    rng = np.random.default_rng(seed)
    iters = [iterations[min(k, len(iterations) - 1)] for k in range(levels)]
    volume = None
    with tqdm(total=sum(iters), desc="exemplar from image", disable=not progress) as bar:
        for level in range(levels):
            factor = 2 ** (levels - 1 - level)
            level_img = downsample(img, factor)
            n_side = size // factor
            if volume is None:  # start from the image's own colours, shuffled
                pixels = level_img.reshape(-1, 3)
                volume = pixels[rng.integers(0, len(pixels), n_side**3)].reshape(n_side, n_side, n_side, 3)
            else:
                volume = ndimage.zoom(volume, (2, 2, 2, 1), order=1, mode="grid-wrap", grid_mode=True)
            index = ImageNeighbourhoods(level_img, neighbourhood, pca_dims, rng)
            target_hist = channel_histograms(level_img)
            for it in range(iters[level]):
                if it or level:  # the shuffled start already has the image's colours
                    volume = transfer_colours(volume, level_img, 5, seed + it)
                volume = optimise_step(volume.astype(np.float32), index, target_hist, 2, it, vote)
                bar.update()
    assert volume is not None  # levels >= 1 (checked above)
    volume = transfer_colours(volume, img, 20, seed)
    if discrete_sweeps:  # ``index`` is the finest level's: the full image
        for sweep in range(discrete_sweeps):  # the sparse grid moves between sweeps, as in the optimisation
            volume = _discrete_sweep(volume.astype(np.float32), index, 2, sweep % 2, rng)
    return np.clip(np.rint(volume), 0, 255).astype(np.uint8)
