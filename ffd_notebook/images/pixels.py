"""An image's pixels read at continuous indices, with ITK's rules: the one interpolation of the package.

:func:`as_pixels` turns what a user passes (a SimpleITK image, a file, an array with its
geometry) into pixels in array order and an :class:`~.geometry.ImageGrid`. An
:class:`Interpolator` then reads them at any continuous indices with
:func:`scipy.ndimage.map_coordinates` and ITK's border rules: a point is inside if its index lies
in ``[-0.5, size - 0.5)`` on every axis (half a voxel beyond the outer voxel centres), the
interpolation there uses the border voxels (``mode="nearest"``; B-splines mirror the image, as
ITK's B-spline interpolator does), and points outside get the default value, as do positions that
are not numbers (NaN: ITK's ``IsInsideBuffer`` is false for them). ``warp_image``, the editor's
warped slices and :class:`~ffd_notebook.io.DisplacementField` (its vectors, linearly) all read through it.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from .files import read_image
from .geometry import ImageGrid, is_sitk_image

__all__ = ["IMAGE_INTERPOLATIONS", "Interpolator", "as_pixels", "check_image_interpolation"]

_HUGE = 2.0**40  # indices map_coordinates may cast to integers without overflow (any image is far smaller)

#: Interpolation names and their spline orders.
IMAGE_INTERPOLATIONS = {"nearest": 0, "linear": 1, "bspline": 3}


def check_image_interpolation(interpolation: str, default_value: float) -> None:
    """A ``ValueError`` for an unknown interpolation or a default value that is not a finite number.

    Examples
    --------
    >>> check_image_interpolation("cubic", 0)
    Traceback (most recent call last):
    ...
    ValueError: interpolation must be one of ('nearest', 'linear', 'bspline'), got 'cubic'
    """
    if interpolation not in IMAGE_INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {tuple(IMAGE_INTERPOLATIONS)}, got {interpolation!r}")
    if not np.isfinite(float(default_value)):
        raise ValueError(f"default_value must be a finite number, got {default_value!r}")


def as_pixels(
    image: Any, *, spacing: ArrayLike | None = None, origin: ArrayLike | None = None, direction: ArrayLike | None = None
) -> tuple[NDArray, ImageGrid, Any]:
    """Pixels (array order, components last), grid, and the SimpleITK image (None for an array) of ``image``.

    ``image`` is a ``SimpleITK.Image``, an image file (read with SimpleITK) or a NumPy array
    indexed ``[k, j, i]`` placed by ``spacing``/``origin``/``direction`` (their length tells a 2D
    image with components from a 3D one). The pixels of a SimpleITK image are a view of it.

    Examples
    --------
    >>> import numpy as np
    >>> pixels, grid, _ = as_pixels(np.zeros((4, 5, 3), np.uint8), spacing=(0.5, 0.5))   # a 5 x 4 RGB image
    >>> grid.size, pixels.shape
    ((5, 4), (4, 5, 3))
    """
    geometry_given = any(v is not None for v in (spacing, origin, direction))
    if isinstance(image, str | os.PathLike):
        image = read_image(image)
    if is_sitk_image(image):
        if geometry_given:
            raise ValueError("spacing, origin and direction are for a NumPy array; a SimpleITK image has its own")
        import SimpleITK as sitk

        if image.GetDimension() not in (2, 3):
            raise ValueError(f"only 2D and 3D images can be warped, got a {image.GetDimension()}D image")
        return sitk.GetArrayViewFromImage(image), ImageGrid.of(image), image
    if not isinstance(image, np.ndarray):
        raise TypeError(f"image must be a SimpleITK image, an image file or a NumPy array, got {type(image).__name__}")
    if image.dtype.kind not in "biuf":
        raise TypeError(f"image pixels must be numbers, got dtype {image.dtype}")
    dim = next((np.size(v) for v in (spacing, origin) if v is not None and np.size(v) > 1), None)
    if dim is None and direction is not None:
        dim = round(float(np.sqrt(np.size(direction))))
    dim = image.ndim if dim is None else dim
    if dim not in (2, 3) or image.ndim not in (dim, dim + 1):
        raise ValueError(
            f"a {dim}D image is an array of {dim} axes (or {dim + 1} with components last), got shape {image.shape}"
        )
    pixels = image.view(np.uint8) if image.dtype == bool else image
    return pixels, ImageGrid(image.shape[:dim][::-1], spacing, origin, direction), None


class Interpolator:
    """Read an image's pixels at continuous indices (ITK's border rules; see the module).

    Parameters
    ----------
    pixels : numpy.ndarray
        Array order, components on a last axis if ``pixels.ndim == grid.dim + 1``.
    grid : ImageGrid
        The pixels' grid.
    interpolation : {"linear", "nearest", "bspline"}
    default_value : float
        The value outside the image.

    Examples
    --------
    >>> import numpy as np
    >>> reader = Interpolator(np.array([[0.0, 10.0]]), ImageGrid((2, 1)), "linear", -1.0)
    >>> out = np.empty(4)
    >>> reader.read(np.array([[0.0, 0.0, 0.0, 0.0], [0.25, 1.2, 1.6, np.nan]]), out=out)   # rows: (j, i)
    >>> out.tolist()
    [2.5, 10.0, -1.0, -1.0]
    """

    def __init__(self, pixels: NDArray, grid: ImageGrid, interpolation: str, default_value: float) -> None:
        check_image_interpolation(interpolation, default_value)
        self.grid = grid
        self.order = IMAGE_INTERPOLATIONS[interpolation]
        self.default = float(default_value)
        vector = pixels.ndim == grid.dim + 1
        self.component_shape: tuple[int, ...] = (pixels.shape[-1],) if vector else ()
        self.dtype = pixels.dtype
        components = [pixels[..., c] for c in range(pixels.shape[-1])] if vector else [pixels]
        if self.order == 3:  # B-spline coefficients, once (ITK's mirror boundary)
            components = [ndimage.spline_filter(c, order=3, output=np.float64, mode="mirror") for c in components]
        self._components = components
        self._mode = "mirror" if self.order == 3 else "nearest"
        self._upper = np.array(grid.shape, dtype=np.float64) - 0.5
        # interpolated values of an integer image are made in float64, then rounded (nearest needs no rounding)
        self._exact = self.dtype.kind == "f" or self.order == 0

    def read(self, index: NDArray[np.float64], out: NDArray) -> None:
        """Values at continuous indices ``index`` (``(dim, ...)``, array order) into ``out`` (+ components).

        Outside the image (and at NaN indices) the default value.
        """
        inside = np.ones(index.shape[1:], dtype=bool)
        for axis in range(self.grid.dim):  # written so that NaN, for which every comparison is false, is outside
            inside &= index[axis] >= -0.5
            inside &= index[axis] < self._upper[axis]
        outside = ~inside
        if outside.any() and not (np.abs(index[:, outside]) < _HUGE).all():
            index = np.where(inside, index, 0.0)  # NaN, infinite or beyond an integer: read voxel 0 there instead
        for c, values in enumerate(self._components):
            target = out[..., c] if self.component_shape else out
            kwargs = {"order": self.order, "mode": self._mode, "prefilter": False}
            if self._exact and target.dtype == self.dtype:
                ndimage.map_coordinates(values, index, output=target, **kwargs)
            else:
                interpolated = ndimage.map_coordinates(values, index, output=np.float64, **kwargs)
                if target.dtype.kind in "iu":  # rounded and clipped into the integer type
                    info = np.iinfo(target.dtype)
                    np.rint(interpolated, out=interpolated)
                    np.clip(interpolated, info.min, info.max, out=interpolated)
                target[...] = interpolated
            target[outside] = self.default
