"""``warp_image``: resample an image through a deformation, ITK's convention (a pull-back).

The output voxel at physical point ``x`` of the reference grid takes the input's value at
``T(x)``, as ``sitk.Resample(image, reference, transform)`` does. ``T(x)`` is evaluated a slab of
output rows at a time (:mod:`.sample`) and the input is interpolated there with
:func:`scipy.ndimage.map_coordinates`, with ITK's rules at the border: a point is inside if its
continuous index lies in ``[-0.5, size - 0.5)`` on every axis (half a voxel beyond the outer
voxel centres), the interpolation there uses the border voxels (``mode="nearest"``; B-splines
mirror the image, as ITK's B-spline interpolator does), and points outside get
``default_value``.

SciPy rather than SimpleITK's resampler with a displacement field: measured on a 256^3 float32
image here (``tests/benchmarks/bench_images.py``), ``map_coordinates`` on precomputed indices took
about 3/4 of the time of ``sitk.Resample`` with a ``DisplacementFieldTransform`` slab by slab (which
also interpolates the field it is given), and it needs no field image per slab.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from .files import read_image, read_image_information
from .geometry import ImageGrid, is_sitk_image
from .sample import Deformation, IndexSampler, slab_rows

__all__ = ["INTERPOLATIONS", "warp_image"]

#: Interpolation names and their spline orders.
INTERPOLATIONS = {"nearest": 0, "linear": 1, "bspline": 3}


def _source(image: Any, spacing: ArrayLike, origin: ArrayLike, direction: ArrayLike) -> tuple[NDArray, ImageGrid, Any]:
    """Pixels (array order, components last), grid and the SimpleITK image (None for an array) of ``image``."""
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


def _output_dtype(dtype: np.dtype, order: int) -> np.dtype:
    return np.dtype(dtype) if dtype.kind == "f" or order == 0 else np.dtype(np.float64)


def _store(values: NDArray, out: NDArray) -> None:
    """Values interpolated in floating point into an integer output: rounded and clipped to its range."""
    info = np.iinfo(out.dtype)
    np.rint(values, out=values)
    np.clip(values, info.min, info.max, out=values)
    out[...] = values


def warp_image(
    image: Any,
    deformation: Deformation,
    *,
    reference: Any = None,
    interpolation: str = "linear",
    default_value: float = 0,
    spacing: ArrayLike = None,
    origin: ArrayLike = None,
    direction: ArrayLike = None,
) -> Any:
    """Resample ``image`` through ``deformation``: the output at ``x`` is the input at ``T(x)`` (ITK's convention).

    Parameters
    ----------
    image : SimpleITK.Image, path or numpy.ndarray
        A 2D or 3D image, scalar or multi-component (RGB...). A path is read with SimpleITK
        (NIfTI, NRRD, MetaImage, PNG...). An array is indexed ``[k, j, i]`` (``[row, column]``
        in 2D, components on a last axis), as ``sitk.GetArrayFromImage`` gives it, and placed
        by ``spacing``, ``origin`` and ``direction``.
    deformation : object with ``deform(points)``
        ``T``: an :class:`~ffd_notebook.FFD` or anything that maps ``(N, 3)`` physical points
        to ``(N, 3)`` points. A 2D image lies in the plane ``z = 0``; ``T``'s z component is
        not used for it (a lattice in the image's plane moves nothing out of it).
    reference : SimpleITK.Image, path or ImageGrid, optional
        The output grid; the input's own grid by default.
    interpolation : {"linear", "nearest", "bspline"}
        ``"nearest"`` for label maps (no new values), ``"linear"``, or cubic ``"bspline"``.
    default_value : float
        Output value where ``T(x)`` falls outside the input.
    spacing, origin, direction : array_like, optional
        Geometry of an array ``image`` (ITK's meaning, x first: ``spacing=(sx, sy, sz)``);
        unit spacing, zero origin and identity direction by default. The number of values
        tells a 2D image with components from a 3D one (``spacing=(1, 1)`` for a photo).

    Returns
    -------
    SimpleITK.Image or numpy.ndarray
        A SimpleITK image on the reference grid for a SimpleITK image or a file, an array of
        the reference grid's shape (components last) for an array. Pixel type: the input's
        (linear and B-spline values rounded and clipped into an integer type).

    Raises
    ------
    ValueError
        Unknown interpolation, an array whose shape does not fit its geometry, a deformation
        that does not return ``(N, 3)`` points.
    FileFormatError
        An image file SimpleITK cannot read.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> labels = np.zeros((8, 8, 8), dtype=np.uint8); labels[2:6, 2:6, 2:6] = 3
    >>> lat = Lattice((4, 4, 4), spacing=4.0, origin=(-2.0, -2.0, -2.0))
    >>> lat.offsets[1, 1, 1] = (1.5, 0.5, 0.0)
    >>> warped = warp_image(labels, FFD(lat), interpolation="nearest", spacing=1.0)
    >>> warped.dtype.name, sorted(np.unique(warped).tolist())
    ('uint8', [0, 3])
    """
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {tuple(INTERPOLATIONS)}, got {interpolation!r}")
    order = INTERPOLATIONS[interpolation]
    default = float(default_value)
    if not np.isfinite(default):
        raise ValueError(f"default_value must be a finite number, got {default_value!r}")
    pixels, source, sitk_image = _source(image, spacing, origin, direction)
    if reference is None:
        grid = source
    elif isinstance(reference, str | os.PathLike):
        grid = read_image_information(reference)
    else:
        grid = ImageGrid.of(reference)
    if grid.dim != source.dim:
        raise ValueError(f"the reference grid is {grid.dim}D and the image {source.dim}D")
    vector = pixels.ndim == source.dim + 1
    components = [pixels[..., c] for c in range(pixels.shape[-1])] if vector else [pixels]
    if order == 3:  # B-spline coefficients, once (ITK's mirror boundary)
        components = [ndimage.spline_filter(c, order=3, output=np.float64, mode="mirror") for c in components]
    out = np.empty(grid.shape + ((pixels.shape[-1],) if vector else ()), dtype=pixels.dtype)
    work_dtype = _output_dtype(pixels.dtype, order)
    sampler = IndexSampler(deformation, grid, source)
    step = slab_rows(grid)
    upper = np.array(source.shape, dtype=np.float64) - 0.5
    mode = "mirror" if order == 3 else "nearest"
    for start in range(0, grid.shape[0], step):
        stop = min(start + step, grid.shape[0])
        index = sampler.rows(start, stop)
        outside = np.zeros(index.shape[1:], dtype=bool)
        for axis in range(source.dim):
            outside |= index[axis] < -0.5
            outside |= index[axis] >= upper[axis]
        slab = out[start:stop]
        for c, values in enumerate(components):
            target = slab[..., c] if vector else slab
            if work_dtype == target.dtype:
                ndimage.map_coordinates(values, index, output=target, order=order, mode=mode, prefilter=False)
            else:
                buffer = ndimage.map_coordinates(
                    values, index, output=work_dtype, order=order, mode=mode, prefilter=False
                )
                _store(buffer, target)
            target[outside] = default
    if sitk_image is None:
        return out
    import SimpleITK as sitk

    result = sitk.GetImageFromArray(out, isVector=vector)
    del out
    return grid.to_sitk(result)
