"""Colour volume exemplars from stacks of 2D slice images.

The liver-texture paper built its exemplar from 128 consecutive Visible Human cryosection slices,
each cropped to a 128x128 region of interest. :func:`volume_from_slices` does the same for any
stack of RGB (or grey) images. Offline, no serial sections ship with the dependencies, so
:func:`sliding_crops` makes a stand-in stack from one 2D colour image: consecutive crops whose
window moves a pixel or two per slice, so neighbouring slices are as similar as neighbouring
cryosections are (the result is a sheared extrusion of the image, not real 3D anatomy).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._util.colours import as_uint8
from ..errors import FileFormatError

__all__ = ["as_rgb8", "exemplar_volume", "sliding_crops", "volume_from_slices"]


def as_rgb8(image: Any, name: str = "image") -> NDArray[np.uint8]:
    """Convert a 2D grey, RGB or RGBA image to an ``(H, W, 3)`` uint8 array.

    The values are read by the package's one dtype policy (scikit-image's, see
    :mod:`ffd_notebook._util.colours`): uint8 levels as they are, uint16 scaled from its whole
    range, floats in [0, 1] (others refused), signed integers that are 0-255 levels. The alpha
    channel is dropped.

    Parameters
    ----------
    image : array_like
        ``(H, W)``, ``(H, W, 3)`` or ``(H, W, 4)``.
    name : str
        What error messages call it.

    Returns
    -------
    numpy.ndarray
        ``(H, W, 3)`` uint8.

    Raises
    ------
    ValueError
        Another shape, or values the policy refuses (floats outside [0, 1], NaN).

    Examples
    --------
    >>> as_rgb8(np.zeros((2, 3))).shape
    (2, 3, 3)
    >>> as_rgb8(np.full((1, 1, 4), 1.0))[0, 0].tolist(), as_rgb8(np.full((1, 1), 65535, np.uint16))[0, 0].tolist()
    ([255, 255, 255], [255, 255, 255])
    """
    a = np.asarray(image)
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] not in (3, 4):
        raise ValueError(f"{name}: expected a 2D grey, RGB or RGBA image, got an array of shape {a.shape}")
    return np.ascontiguousarray(as_uint8(a[:, :, :3], name))


def exemplar_volume(exemplar: Any, what: str = "exemplar") -> NDArray[np.uint8]:
    """A ``(Z, Y, X, 3)`` colour exemplar as uint8 by the package's dtype policy (uint16, floats in [0, 1]...).

    Examples
    --------
    >>> exemplar_volume(np.full((2, 2, 2, 3), 1.0))[0, 0, 0].tolist()
    [255, 255, 255]
    """
    ex = np.asarray(exemplar)
    if ex.ndim != 4 or ex.shape[3] != 3:
        raise ValueError(f"{what} must be a (Z, Y, X, 3) colour volume, got shape {ex.shape}")
    return np.ascontiguousarray(as_uint8(ex, what))


def _read_image(path: str | os.PathLike[str]) -> NDArray[np.uint8]:
    # Pillow (a package dependency) reads the common formats; imported only when files are given
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return as_rgb8(np.asarray(im.convert("RGB")), os.fspath(path))
    except FileNotFoundError:
        raise
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        raise FileFormatError(path, None, f"not a readable image ({exc})") from exc


def _roi_slices(roi: Any, shape: tuple[int, int]) -> tuple[slice, slice]:
    if roi is None:
        return slice(0, shape[0]), slice(0, shape[1])
    if len(roi) == 2 and all(isinstance(r, slice) for r in roi):
        rows, cols = roi
    elif len(roi) == 4:
        r0, r1, c0, c1 = (int(v) for v in roi)
        rows, cols = slice(r0, r1), slice(c0, c1)
    else:
        raise ValueError("roi must be (row_start, row_stop, col_start, col_stop) or (row_slice, col_slice)")
    for s, n, what in ((rows, shape[0], "rows"), (cols, shape[1], "columns")):
        if s.step not in (None, 1):
            raise ValueError("roi slices must have step 1")
        start, stop = s.start or 0, n if s.stop is None else s.stop
        if not 0 <= start < stop <= n:
            raise ValueError(f"roi {what} {start}:{stop} are outside the {n} {what} of the slices")
    return rows, cols


def volume_from_slices(images: Sequence[Any], roi: Any = None) -> NDArray[np.uint8]:
    """Stack 2D slice images into a ``(Z, Y, X, 3)`` uint8 colour volume.

    Parameters
    ----------
    images : sequence of array_like or path
        The slices, bottom to top: arrays (grey, RGB or RGBA; see :func:`as_rgb8`) or image
        file paths (read with Pillow). All must have the same height and width.
    roi : tuple, optional
        Region of interest cropped from every slice: ``(row_start, row_stop, col_start,
        col_stop)`` or ``(row_slice, col_slice)``. The whole slice if omitted.

    Returns
    -------
    numpy.ndarray
        ``(len(images), rows, cols, 3)`` uint8; slice ``k`` is ``volume[k]``.

    Raises
    ------
    ValueError
        No slices, slices of different sizes, or a region outside the slices.
    FileFormatError
        A file that is not a readable image (names the file).

    Examples
    --------
    >>> slices = [np.full((8, 10, 3), k, dtype=np.uint8) for k in range(4)]
    >>> vol = volume_from_slices(slices, roi=(2, 6, 0, 5))
    >>> vol.shape, int(vol[3, 0, 0, 0])
    ((4, 4, 5, 3), 3)
    """
    if isinstance(images, (str, os.PathLike)) or (isinstance(images, np.ndarray) and images.ndim < 3):
        raise ValueError("images must be a sequence of slices (a list of arrays or paths, or a (Z, Y, X[, C]) array)")
    if len(images) == 0:
        raise ValueError("volume_from_slices needs at least one slice")
    out: NDArray[np.uint8] | None = None
    rows = cols = slice(None)
    for k, item in enumerate(images):
        if isinstance(item, (str, os.PathLike)):
            rgb = _read_image(item)
            name = os.fspath(item)
        else:
            name = f"slice {k}"
            rgb = as_rgb8(item, name)
        if out is None:
            rows, cols = _roi_slices(roi, rgb.shape[:2])
            first = rgb.shape[:2]
            crop = rgb[rows, cols]
            out = np.empty((len(images), *crop.shape), dtype=np.uint8)
        elif rgb.shape[:2] != first:
            raise ValueError(f"{name} is {rgb.shape[0]}x{rgb.shape[1]}, the first slice is {first[0]}x{first[1]}")
        out[k] = rgb[rows, cols]
    assert out is not None
    return out


def sliding_crops(
    image: Any,
    n_slices: int,
    size: int | tuple[int, int],
    step: tuple[int, int] = (1, 1),
    start: tuple[int, int] = (0, 0),
) -> list[NDArray[np.uint8]]:
    """Cut ``n_slices`` crops from one image, moving the window by ``step`` pixels per slice.

    Stacked with :func:`volume_from_slices`, the crops give a stand-in for serial sections: each
    slice differs a little from the next, as consecutive cryosections do.

    Parameters
    ----------
    image : array_like
        A 2D grey or colour image.
    n_slices : int
        Number of crops.
    size : int or (int, int)
        Crop height and width.
    step : (int, int)
        Window shift (rows, columns) from one crop to the next.
    start : (int, int)
        Top-left corner of the first crop.

    Returns
    -------
    list of numpy.ndarray
        ``n_slices`` crops ``(h, w, 3)`` uint8.

    Examples
    --------
    >>> img = np.arange(100, dtype=np.uint8).reshape(10, 10)
    >>> crops = sliding_crops(img, 3, 4, step=(1, 2))
    >>> [int(c[0, 0, 0]) for c in crops]
    [0, 12, 24]
    """
    rgb = as_rgb8(image)
    h, w = (size, size) if isinstance(size, (int, np.integer)) else size
    last_r = start[0] + step[0] * (n_slices - 1)
    last_c = start[1] + step[1] * (n_slices - 1)
    if n_slices < 1 or min(start) < 0 or min(last_r, last_c) < 0:
        raise ValueError("n_slices must be >= 1 and every crop must start inside the image")
    if max(start[0], last_r) + h > rgb.shape[0] or max(start[1], last_c) + w > rgb.shape[1]:
        raise ValueError(
            f"{n_slices} crops of {h}x{w} moving by {step} do not fit in a {rgb.shape[0]}x{rgb.shape[1]} image"
        )
    return [
        rgb[start[0] + k * step[0] : start[0] + k * step[0] + h, start[1] + k * step[1] : start[1] + k * step[1] + w]
        for k in range(n_slices)
    ]
