"""Does a slice look like new tissue? Self-similarity and likeness, two figures that blur, tiling and noise all fail.

A genuinely new sample of a stochastic texture has windows that resemble each other about as much
as the source image's windows resemble each other: some are alike, none are copies. So:

* :func:`self_similarity`: for a slice, the median over its ``8 x 8`` windows (step 2) of the
  distance to the nearest *other* window of the same slice at least 16 px away, divided by the
  same figure of the source at the same pixel size (both measured on crops of the same size). New
  samples of the texture score about 1; blur scores low (smooth windows are near each other: the
  histology image blurred by one pixel scores ~0.6-0.7); a repeated tile scores 0 (every window
  has a copy one period away); noise scores high (shuffled pixels: ~2).
* :func:`likeness`: the median distance from a slice's windows to their nearest *source* window,
  divided by the source's own figure (its windows to their nearest window 16 px away, what a new
  sample of the texture is from the source). About 1 for new samples; copies of the source score
  near 0, another texture or noise well above 1.

Together they pass what looks like the tissue and fail blur (low self-similarity), repetition (low
self-similarity), noise (high both) and a foreign texture (high likeness). They replace
:func:`~ffd_notebook.solidtex.neighbourhood_distance` as a quality figure: that one (the distance
from a slice's windows to the nearest source window, alone) rewards blur, because a smooth window
is near some smooth part of the image.

A third figure looks for what both miss, a grid of block seams: :func:`block_grid`, the mean
colour step between neighbouring columns of a slice folded by every period from 8 to 32 px, the
highest phase over the mean (about 1.2-1.4 for the tissue image, 2 and more for a block mosaic).

Slices are judged whole by default: a crop no larger than the source cannot see a region repeated
further away than the crop (block synthesis that copied one region over a 192 px slice scored
0.00 whole and 1.37-1.46 in 96 px crops). A larger image has more windows, so its nearest windows
are nearer: new samples of a texture twice the source's size score about 0.9 of the source's
figure, four times about 0.85 (the histology, gravel and grass images of scikit-image, 48 to 384
px). The source's figure is therefore scaled to the slice's number of windows ``N`` (less those
within the gap) as ``N^-0.055``, the law measured on those textures (exponents 0.04-0.07;
:data:`COUNT_EXPONENT`), so that new samples score about 1 whatever the slice's size.

Windows are compared by Euclidean distance over their ``3 * 8 * 8`` colour values, by brute force
(one float32 matrix product per chunk: exact, and for a few thousand windows in 192 dimensions
faster than a tree), in chunks whose memory is bounded (:data:`_BUDGET`). Colours are read by the
package's dtype policy (:mod:`ffd_notebook._util.colours`): uint8, uint16 or floats in [0, 1],
all measured in 0-255 levels.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

from .._util.colours import as_float

__all__ = ["COUNT_EXPONENT", "block_grid", "likeness", "self_similarity", "self_similarity_figure", "volume_slices"]

_BUDGET = 2**24  # float32 distances held at once by _nearest (64 MB), whatever the images' sizes
#: how the median nearest-window distance of new samples of a texture falls with the windows compared, ``N^-e``
COUNT_EXPONENT = 0.055


class _Windows:
    """The ``window``-square windows of an ``(H, W, 3)`` image every ``step`` px, flattened, on their grid."""

    def __init__(self, image: NDArray, window: int, step: int) -> None:
        w = sliding_window_view(np.asarray(image, np.float32), (window, window), axis=(0, 1))[::step, ::step]
        self.rows, self.cols = w.shape[:2]
        self.step = step
        self.values = np.ascontiguousarray(w).reshape(self.rows * self.cols, -1)

    @classmethod
    def stack(cls, parts: list[_Windows]) -> _Windows:
        """The windows of several images together (a reference to search, with no grid of its own)."""
        out = cls.__new__(cls)
        out.values = np.concatenate([p.values for p in parts])
        out.rows, out.cols, out.step = len(out.values), 1, parts[0].step
        return out


def _nearest(queries: _Windows, reference: _Windows | None = None, gap: int = 0) -> NDArray[np.float64]:
    """Distance from each query window to its nearest reference window (RMS over the window's values).

    ``reference=None``: the queries' own image, ignoring the windows whose corner is less than
    ``gap`` px away along both rows and columns (the window itself and its overlapping neighbours).
    Exact, by brute force in chunks of queries: one float32 matrix product each (for a few thousand
    windows in 192 dimensions faster than a tree), the gap a band of grid rows and columns (a
    boolean of the chunk's size). At most :data:`_BUDGET` distances are held at once: memory is
    bounded whatever the sizes; the time grows with queries x references (a 192 px slice's 8,649
    windows against themselves: about 1 s here).
    """
    own = reference is None
    ref = queries if reference is None else reference
    centre = ref.values.mean(axis=0, dtype=np.float64).astype(np.float32)  # smaller numbers: less rounding
    r = ref.values - centre
    r_sq = np.einsum("ij,ij->i", r, r)
    r *= -2.0  # |q - r|^2 = |q|^2 + (|r|^2 - 2 q.r): the product then one addition per distance
    n = len(queries.values)
    out = np.empty(n)
    chunk = max(1, _BUDGET // max(len(r), 1))
    if own and gap:  # each window's own neighbours: a square of grid offsets closer than the gap
        band = np.arange(1 - -(-gap // ref.step), -(-gap // ref.step))
        rows, cols = np.divmod(np.arange(n), queries.cols)
        near_r, near_c = rows[:, None, None] + band[:, None], cols[:, None, None] + band[None, :]
        inside = (near_r >= 0) & (near_r < ref.rows) & (near_c >= 0) & (near_c < ref.cols)
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        q = queries.values[start:stop] - centre
        d2 = q @ r.T
        d2 += r_sq[None, :]
        if own and gap:
            which = inside[start:stop]
            hit = np.nonzero(which)
            flat = (near_r[start:stop] * ref.cols + near_c[start:stop])[which]
            d2[hit[0], flat] = np.inf
        best = d2.min(axis=1)
        best += np.einsum("ij,ij->i", q, q)
        out[start:stop] = np.sqrt(np.maximum(best, 0.0))
    return out / np.sqrt(queries.values.shape[1])


def _crops(image: NDArray, crop: int) -> list[NDArray]:
    """Non-overlapping ``crop``-square crops of an image, from its top-left corner."""
    rows, cols = image.shape[0] // crop, image.shape[1] // crop
    return [image[r * crop : (r + 1) * crop, c * crop : (c + 1) * crop] for r in range(rows) for c in range(cols)]


def volume_slices(volume: ArrayLike, axis: int, count: int = 4) -> list[NDArray]:
    """``count`` slices perpendicular to ``axis``, evenly spread: each an ``(rows, cols, 3)`` image.

    The slice perpendicular to axis 0 of a ``(Z, Y, X, 3)`` volume is ``volume[k]`` (rows y,
    columns x); perpendicular to axis 1, ``volume[:, k]`` (rows z, columns x); to axis 2,
    ``volume[:, :, k]`` (rows z, columns y).

    Parameters
    ----------
    volume : array_like
        A ``(Z, Y, X, 3)`` colour volume.
    axis : int
        0, 1 or 2: the axis the slices are perpendicular to.
    count : int
        Slices wanted (fewer if the volume is thinner than that along ``axis``).

    Returns
    -------
    list of numpy.ndarray
        The slices (copies), in increasing position along ``axis``.

    Raises
    ------
    ValueError
        If ``volume`` is not ``(Z, Y, X, 3)``.

    Examples
    --------
    >>> v = np.zeros((8, 6, 4, 3), np.uint8)
    >>> [s.shape for s in volume_slices(v, 1, count=2)]
    [(8, 4, 3), (8, 4, 3)]
    """
    v = np.asarray(volume)
    if v.ndim != 4 or v.shape[-1] != 3:
        raise ValueError(f"expected a (Z, Y, X, 3) volume, got shape {v.shape}")
    n = v.shape[axis]
    picks = np.unique(((np.arange(count) + 0.5) * n / count).astype(int))
    return [np.take(v, int(k), axis=axis) for k in picks]


def _images(sample: ArrayLike, what: str, slices: int) -> list[NDArray[np.float32]]:
    a = np.asarray(sample)
    if a.ndim == 4:
        if a.shape[-1] != 3:
            raise ValueError(f"{what}: expected a (Z, Y, X, 3) volume, got shape {a.shape}")
        return [_image(s, what) for axis in range(3) for s in volume_slices(a, axis, slices)]
    if a.ndim in (2, 3):
        return [_image(a, what)]
    raise ValueError(f"{what} must be an (H, W[, 3]) image or a (Z, Y, X, 3) volume, got shape {a.shape}")


def _image(image: ArrayLike, what: str = "image") -> NDArray[np.float32]:
    """An ``(H, W, 3)`` float32 image in 0-255 levels from a grey, RGB or RGBA one (the dtype policy's)."""
    a = np.asarray(image)
    if a.ndim == 2:
        a = a[:, :, None].repeat(3, axis=2)
    if a.ndim != 3 or a.shape[2] not in (3, 4):
        raise ValueError(f"{what}: expected a grey, RGB or RGBA image, got an array of shape {a.shape}")
    return as_float(a[:, :, :3], what) * np.float32(255)


def _per_axis(values: list, count: int) -> list[list]:
    """A volume's per-slice values grouped by orientation (``_images`` lists them axis by axis)."""
    return [values[k * count : (k + 1) * count] for k in range(3)]


def _window_count(shape: tuple[int, ...], window: int, step: int, gap: int) -> float:
    """The mean number of windows of an image that a window's nearest-window search compares (those at least
    ``gap`` px away along rows or columns).

    Examples
    --------
    >>> round(_window_count((96, 96), 8, 2, 16)), round(_window_count((192, 192), 8, 2, 16))
    (1836, 8442)
    """
    band = -(-gap // step)  # grid steps closer than the gap

    def near(n: int) -> float:  # the mean number of positions within the band of each position, borders included
        i = np.arange(n)
        return float(np.mean(np.minimum(i + band, n) - np.maximum(i - band + 1, 0)))

    rows, cols = ((n - window) // step + 1 for n in shape[:2])
    return rows * cols - near(rows) * near(cols)


def _check(window: int, step: int, gap: int, crop: int) -> None:
    if window < 2 or step < 1 or gap < 1:
        raise ValueError(f"window must be >= 2, step and gap >= 1, got {window}, {step}, {gap}")
    if crop < window + gap + step:
        raise ValueError(f"crop {crop} px is too small for {window} px windows at least {gap} px apart")


def self_similarity_figure(image: ArrayLike, *, window: int = 8, step: int = 2, gap: int = 16) -> float:
    """The median distance from an image's windows to their nearest other window at least ``gap`` px away.

    The unnormalised figure behind :func:`self_similarity`: RMS colour difference per value
    (0-255 units), so windows as far apart as the image's contrast score tens.

    Parameters
    ----------
    image : array_like
        An ``(H, W, 3)`` (or grey, or RGBA) image.
    window, step, gap : int
        Window edge, window spacing, and the least distance (px, between corners, along rows or
        columns) at which another window counts (see :func:`self_similarity`).

    Returns
    -------
    float
        The median nearest-window distance, RMS per colour value.

    Examples
    --------
    >>> tile = np.random.default_rng(0).integers(0, 256, (16, 16, 3))
    >>> self_similarity_figure(np.tile(tile, (4, 4, 1)))  # every window has a copy 16 px away
    0.0
    """
    img = _image(image)
    _check(window, step, gap, min(img.shape[:2]))
    return _own_figure(img, window, step, gap)


def _own_figure(levels: NDArray[np.float32], window: int, step: int, gap: int) -> float:
    """:func:`self_similarity_figure` of an image already in 0-255 float levels."""
    return float(np.median(_nearest(_Windows(levels, window, step), gap=gap)))


def _figure(images: list[NDArray], crop: int | None, window: int, step: int, gap: int) -> float:
    """The median figure of whole images (``crop=None``) or of their ``crop``-square crops."""
    pieces = images if crop is None else [c for img in images for c in _crops(img, crop)]
    return float(np.median([_own_figure(c, window, step, gap) for c in pieces]))


def _crop_size(samples: list[NDArray], sources: list[NDArray], crop: int | None) -> int:
    if crop is None:
        crop = min(min(s.shape[:2]) for s in [*samples, *sources])
    if crop > min(min(s.shape[:2]) for s in [*samples, *sources]):
        raise ValueError(f"crop {crop} px is larger than a slice or the source")
    return int(crop)


def self_similarity(
    sample: ArrayLike,
    source: Any,
    *,
    window: int = 8,
    step: int = 2,
    gap: int = 16,
    crop: int | None = None,
    slices: int = 4,
) -> float | NDArray[np.float64]:
    """How alike a slice's windows are to each other, relative to the source texture's: about 1 for new tissue.

    For every ``window``-square window (every ``step`` px) of a slice, the distance to the nearest
    other window of the same slice whose corner is at least ``gap`` px away (RMS colour difference);
    the median over the windows, divided by the same figure of the source. By default slices are
    judged whole, and the source's figure (of the whole source) is scaled to the slice's number of
    windows (``N^-0.055``, see the module docstring): a region repeated anywhere in the slice is
    seen. With ``crop``, slice and source are both measured on non-overlapping ``crop``-square
    crops instead (the median over crops): the same pixel size and number of windows, but blind
    to repeats further apart than the crop.

    Parameters
    ----------
    sample : array_like
        An ``(H, W, 3)`` (or grey) image, or a ``(Z, Y, X, 3)`` volume: then ``slices`` slices per
        orientation (:func:`volume_slices`) are measured and one ratio per orientation returned.
    source : array_like or float
        The texture's image (or a volume, all of whose orientations count), or its figure already
        measured (:func:`self_similarity_figure`), used as it is: measure it on an image of the
        slices' size (or at ``crop``).
    window, step, gap : int
        Window edge, window spacing, and the least distance (px, between corners, along rows or
        columns) at which another window counts.
    crop : int, optional
        Measure crops of this edge instead of whole slices.
    slices : int
        Slices per orientation of a volume.

    Returns
    -------
    float or numpy.ndarray
        The ratio; for a volume, ``(3,)``: slices perpendicular to axis 0, 1 and 2. New samples of
        the histology image ``skimage.data.immunohistochemistry()`` score 0.97-1.3 (96 px crops),
        the image blurred by one pixel ~0.7, a repeated tile 0, shuffled pixels ~2.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.integers(0, 256, (48, 48, 3))
    >>> float(self_similarity(np.tile(noise[:24, :24], (4, 4, 1)), noise))  # a tile repeated
    0.0
    >>> round(float(self_similarity(rng.integers(0, 256, (48, 48, 3)), noise)), 1)  # new noise
    1.0
    """
    samples = _images(sample, "sample", slices)
    sources = [] if np.isscalar(source) else _images(source, "source", slices)
    if crop is not None:
        crop = _crop_size(samples, sources, crop)
    _check(window, step, gap, min(min(s.shape[:2]) for s in [*samples, *sources]) if crop is None else crop)
    if np.isscalar(source):
        ref, ref_count = float(cast(float, source)), None
    else:
        ref = _figure(sources, crop, window, step, gap)
        ref_count = float(np.median([_window_count(s.shape, window, step, gap) for s in sources]))
    if ref <= 0:
        raise ValueError("the source has no variation between its windows (figure 0): nothing to compare with")

    def ratio(images: list[NDArray]) -> float:
        scale = 1.0
        if crop is None and ref_count is not None:  # the source's figure at the slices' number of windows
            count = float(np.median([_window_count(s.shape, window, step, gap) for s in images]))
            scale = (count / ref_count) ** -COUNT_EXPONENT
        return _figure(images, crop, window, step, gap) / (ref * scale)

    if np.asarray(sample).ndim != 4:
        return ratio(samples)
    return np.array([ratio(group) for group in _per_axis(samples, len(samples) // 3)])


def likeness(
    sample: ArrayLike,
    source: ArrayLike,
    *,
    window: int = 8,
    step: int = 2,
    gap: int = 16,
    crop: int | None = None,
    slices: int = 4,
) -> float | NDArray[np.float64]:
    """How near a slice's windows are to the source's, relative to how near new samples are: about 1 for new tissue.

    The median over a slice's windows (every ``step`` px) of the distance to the nearest window of
    the source (every window, every ``step`` px), divided by :func:`self_similarity`'s source
    figure: how far a window of the texture is from the source's windows ``gap`` px or more away,
    what a window of a new sample is from them. Options and volumes as in :func:`self_similarity`
    (here the whole source is searched; ``crop`` only sets the source figure's crops, by default
    the source's smallest side).

    Parameters
    ----------
    sample : array_like
        An ``(H, W, 3)`` (or grey) image, or a ``(Z, Y, X, 3)`` volume: then ``slices`` slices per
        orientation are measured and one ratio per orientation returned.
    source : array_like
        The texture's image (or a volume, all of whose orientations count).
    window, step, gap : int
        Window edge, window spacing, and the least distance (px) at which another window counts
        in the source's own figure.
    crop : int, optional
        Crop edge of the source figure; default the smallest side of the source.
    slices : int
        Slices per orientation of a volume.

    Returns
    -------
    float or numpy.ndarray
        About 1 for new samples of the texture (0.8-1.05 for the histology image's); near 0 for
        copies of the source; well above 1 for another texture, noise or wrong colours.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.integers(0, 256, (48, 48, 3))
    >>> round(float(likeness(noise[8:40, 8:40], noise)), 2)  # a piece of the source
    0.0
    >>> float(likeness(np.full((48, 48, 3), 128), noise)) < 0.8  # grey: near everything, like no sample
    True
    """
    samples = _images(sample, "sample", slices)
    sources = _images(source, "source", slices)
    crop = _crop_size(sources, sources, crop)
    _check(window, step, gap, crop)
    ref = _figure(sources, crop, window, step, gap)
    if ref <= 0:
        raise ValueError("the source has no variation between its windows (figure 0): nothing to compare with")
    reference = _Windows.stack([_Windows(s, window, step) for s in sources])

    def figure(images: list[NDArray]) -> float:
        return float(np.median(np.concatenate([_nearest(_Windows(s, window, step), reference) for s in images])))

    if np.asarray(sample).ndim != 4:
        return figure(samples) / ref
    return np.array([figure(group) / ref for group in _per_axis(samples, len(samples) // 3)])


def _grid_score(image: NDArray[np.float32], periods: tuple[int, int]) -> float:
    """The highest folded colour-step profile over its mean, along rows and columns of one image."""
    best = 0.0
    for axis in (0, 1):
        steps = np.sqrt(np.square(np.diff(image, axis=axis)).sum(axis=-1))
        profile = steps.mean(axis=1 - axis, dtype=np.float64)  # the mean step across each line between pixels
        mean = profile.mean()
        if mean <= 0:
            continue
        for period in range(periods[0], min(periods[1], len(profile) // 2) + 1):
            phase = np.arange(len(profile)) % period
            folded = np.bincount(phase, weights=profile, minlength=period) / np.bincount(phase, minlength=period)
            best = max(best, float(folded.max() / mean))
    return best


def block_grid(
    sample: ArrayLike, *, periods: tuple[int, int] = (8, 32), slices: int = 4
) -> float | NDArray[np.float64]:
    """How strongly a slice's colour steps line up on a grid: block seams every ``period`` px.

    Along each axis of a slice, the mean colour step (the RGB distance between neighbouring pixels)
    across every line between two columns (or rows) is a profile; folded by each period from
    ``periods[0]`` to ``periods[1]`` px (at most half the slice), its highest phase over the
    profile's mean is the score, the largest over both axes and all periods. Seams of blocks laid
    on a grid all fall on one phase of the block step: the score rises well above the texture's own
    (192 px regions of the histology image and of gravel score 1.2-1.4; a block mosaic 2 and more).

    Parameters
    ----------
    sample : array_like
        An ``(H, W, 3)`` (or grey) image, or a ``(Z, Y, X, 3)`` volume: then ``slices`` slices per
        orientation are scored and the median per orientation returned.
    periods : (int, int)
        The shortest and longest period tried, in px.
    slices : int
        Slices per orientation of a volume.

    Returns
    -------
    float or numpy.ndarray
        The score (1 when the steps show no period); for a volume ``(3,)``, slices perpendicular
        to axis 0, 1 and 2.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.integers(0, 256, (96, 96, 3))
    >>> blocks = np.kron(rng.integers(0, 256, (6, 6, 3)), np.ones((16, 16, 1), int))  # 16 px tiles of colour
    >>> round(float(block_grid(noise)), 1), float(block_grid(blocks)) > 10
    (1.1, True)
    """
    lo, hi = (int(p) for p in periods)
    if not 2 <= lo <= hi:
        raise ValueError(f"periods must be (shortest, longest) with 2 <= shortest <= longest, got {periods}")
    images = _images(sample, "sample", slices)
    if min(min(s.shape[:2]) for s in images) < 2 * lo + 1:
        raise ValueError(f"a slice of {min(min(s.shape[:2]) for s in images)} px is too small for periods from {lo} px")
    scores = [_grid_score(s, (lo, hi)) for s in images]
    if np.asarray(sample).ndim != 4:
        return scores[0]
    return np.array([float(np.median(group)) for group in _per_axis(scores, len(scores) // 3)])
