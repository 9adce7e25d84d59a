"""Images deformed by a lattice (or any deformation): :func:`warp_image`, image grids and files.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook import FFD, Lattice
>>> from ffd_notebook.images import warp_image
>>> image = np.zeros((20, 30), dtype=np.float32); image[5:15, 10:20] = 1.0
>>> lat = Lattice((5, 5, 4), spacing=10.0, origin=(-5.0, -5.0, -15.0))
>>> lat.offsets[2, 2, :, 0] = 3.0           # the middle column of control points pulls from the right
>>> warped = warp_image(image, FFD(lat), spacing=(1.0, 1.0))
>>> warped.shape, float(warped.sum()) < float(image.sum())
((20, 30), True)
"""

from __future__ import annotations

from .data_files import image_data_files, image_suffix
from .files import ImageFile, open_image, read_image, read_image_information, write_image
from .geometry import ImageGrid
from .inverse import invert_points
from .pixels import IMAGE_INTERPOLATIONS
from .reference import reference_grid
from .slices import WarpedSlices
from .warp import warp_image

__all__ = [
    "IMAGE_INTERPOLATIONS",
    "ImageFile",
    "ImageGrid",
    "WarpedSlices",
    "image_data_files",
    "image_suffix",
    "invert_points",
    "open_image",
    "read_image",
    "read_image_information",
    "reference_grid",
    "warp_image",
    "write_image",
]


def __getattr__(name: str) -> object:
    if name == "INTERPOLATIONS":  # renamed: ffd_notebook.ffd.interpolation has the lattice's interpolations
        from .._util.deprecation import warn_renamed

        warn_renamed("ffd_notebook.images.INTERPOLATIONS", "ffd_notebook.images.IMAGE_INTERPOLATIONS")
        return IMAGE_INTERPOLATIONS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
