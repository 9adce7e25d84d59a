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

Windows are compared by Euclidean distance over their ``3 * 8 * 8`` colour values, by brute force
(one float32 matrix product per chunk: exact, and for a few thousand windows in 192 dimensions
faster than a tree).
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

__all__ = ["likeness", "self_similarity", "self_similarity_figure", "volume_slices"]

_CHUNK = 1024


def _windows(image: NDArray, window: int, step: int) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """The ``window``-square windows of an ``(H, W, 3)`` image every ``step`` px: flattened, and their corners."""
    w = sliding_window_view(np.asarray(image, np.float32), (window, window), axis=(0, 1))[::step, ::step]
    rows, cols = w.shape[:2]
    corners = np.stack(np.divmod(np.arange(rows * cols), cols), axis=1) * step
    return np.ascontiguousarray(w).reshape(rows * cols, -1), corners


def _nearest(
    queries: NDArray[np.float32],
    reference: NDArray[np.float32],
    gap: int = 0,
    q_corners: NDArray[np.int64] | None = None,
    r_corners: NDArray[np.int64] | None = None,
) -> NDArray[np.float64]:
    """Distance from each query to its nearest reference row, ignoring those whose corner is < ``gap`` px away."""
    centre = reference.mean(axis=0, dtype=np.float64).astype(np.float32)  # smaller numbers: less rounding
    ref = reference - centre
    ref_sq = np.einsum("ij,ij->i", ref, ref)
    out = np.empty(len(queries))
    for start in range(0, len(queries), _CHUNK):
        q = queries[start : start + _CHUNK] - centre
        d2 = ref_sq[None, :] - 2.0 * (q @ ref.T) + np.einsum("ij,ij->i", q, q)[:, None]
        if gap:
            assert q_corners is not None and r_corners is not None  # a gap needs the corners
            near = np.abs(q_corners[start : start + _CHUNK, None, :] - r_corners[None, :, :]).max(axis=2) < gap
            d2[near] = np.inf
        out[start : start + _CHUNK] = np.sqrt(np.maximum(d2.min(axis=1), 0.0))
    return out


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


def _images(sample: ArrayLike, what: str, slices: int) -> list[NDArray]:
    a = np.asarray(sample)
    if a.ndim == 4:
        return [s for axis in range(3) for s in volume_slices(a, axis, slices)]
    if a.ndim in (2, 3):
        return [_image(a, what)]
    raise ValueError(f"{what} must be an (H, W[, 3]) image or a (Z, Y, X, 3) volume, got shape {a.shape}")


def _image(image: ArrayLike, what: str = "image") -> NDArray[np.float32]:
    """An ``(H, W, 3)`` float32 image from a grey, RGB or RGBA one, values kept as they are (any units)."""
    a = np.asarray(image)
    if a.ndim == 2:
        a = a[:, :, None].repeat(3, axis=2)
    if a.ndim != 3 or a.shape[2] not in (3, 4):
        raise ValueError(f"{what}: expected a grey, RGB or RGBA image, got an array of shape {a.shape}")
    return a[:, :, :3].astype(np.float32)


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
    w, corners = _windows(img, window, step)
    return float(np.median(_nearest(w, w, gap, corners, corners)) / np.sqrt(w.shape[1]))


def _figure(images: list[NDArray], crop: int, window: int, step: int, gap: int) -> float:
    crops = [c for img in images for c in _crops(img, crop)]
    return float(np.median([self_similarity_figure(c, window=window, step=step, gap=gap) for c in crops]))


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
    the median over the windows, divided by the same figure of the source. Both are measured on
    non-overlapping ``crop``-square crops (the median over crops), so a slice and a source of
    different sizes are compared at the same pixel size and the same number of windows.

    Parameters
    ----------
    sample : array_like
        An ``(H, W, 3)`` (or grey) image, or a ``(Z, Y, X, 3)`` volume: then ``slices`` slices per
        orientation (:func:`volume_slices`) are measured and one ratio per orientation returned.
    source : array_like or float
        The texture's image (or a volume, all of whose orientations count), or its figure already
        measured (:func:`self_similarity_figure` at the same ``crop``, a median over crops).
    window, step, gap : int
        Window edge, window spacing, and the least distance (px, between corners, along rows or
        columns) at which another window counts.
    crop : int, optional
        Crop edge; default the smallest side of the slices and the source.
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
    >>> float(self_similarity(np.tile(noise[:24, :24], (2, 2, 1)), noise))  # a tile repeated
    0.0
    >>> round(float(self_similarity(rng.integers(0, 256, (48, 48, 3)), noise)), 1)  # new noise
    1.0
    """
    samples = _images(sample, "sample", slices)
    sources = [] if np.isscalar(source) else _images(source, "source", slices)
    crop = _crop_size(samples, sources, crop)
    _check(window, step, gap, crop)
    ref = float(cast(float, source)) if np.isscalar(source) else _figure(sources, crop, window, step, gap)
    if ref <= 0:
        raise ValueError("the source has no variation between its windows (figure 0): nothing to compare with")
    if np.asarray(sample).ndim != 4:
        return _figure(samples, crop, window, step, gap) / ref
    per_axis = [samples[k * (len(samples) // 3) : (k + 1) * (len(samples) // 3)] for k in range(3)]
    return np.array([_figure(s, crop, window, step, gap) / ref for s in per_axis])


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
    (here the whole source is searched; ``crop`` only sets the source figure's crops).

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
    reference = np.concatenate([_windows(s, window, step)[0] for s in sources])

    def figure(images: list[NDArray]) -> float:
        queries = np.concatenate([_windows(s, window, step)[0] for s in images])
        return float(np.median(_nearest(queries, reference)) / np.sqrt(reference.shape[1]))

    if np.asarray(sample).ndim != 4:
        return figure(samples) / ref
    per_axis = [samples[k * (len(samples) // 3) : (k + 1) * (len(samples) // 3)] for k in range(3)]
    return np.array([figure(s) / ref for s in per_axis])
