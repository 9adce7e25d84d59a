"""The one reading of "a reference grid": every function that takes a ``reference`` (or a grid ``region``) uses it.

``warp_image(reference=)``, :func:`~ffd_notebook.io.sample_displacement_field`,
:func:`~ffd_notebook.io.save_displacement_field`, :func:`~ffd_notebook.io.fit_lattice` (``region=``) and
``python -m ffd_notebook convert --region`` accept the same things, through :func:`reference_grid`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from .files import read_image_information
from .geometry import ImageGrid, is_sitk_image

__all__ = ["is_reference_grid", "reference_grid"]

_KEYS = {"size", "spacing", "origin", "direction"}


def is_reference_grid(value: Any) -> bool:
    """Whether ``value`` has a form :func:`reference_grid` reads (not whether its values are usable).

    ``fit_lattice(region=)`` uses it to tell a grid from points or a mask.

    Examples
    --------
    >>> is_reference_grid({"size": (2, 2, 2)}), is_reference_grid([[0.0, 0.0, 0.0]])
    (True, False)
    """
    return (
        isinstance(value, ImageGrid | str | os.PathLike | Mapping)
        or is_sitk_image(value)
        or isinstance(getattr(value, "grid", None), ImageGrid)
    )


def reference_grid(reference: Any) -> ImageGrid:
    """The voxel grid of a reference, whatever form it takes.

    Parameters
    ----------
    reference : ImageGrid, SimpleITK.Image, path, DisplacementField or mapping
        An :class:`~ffd_notebook.images.ImageGrid`; a ``SimpleITK.Image``; an image file (its header is
        read, not its pixels: :func:`~ffd_notebook.images.read_image_information`); anything with a
        ``grid`` attribute that is an ``ImageGrid`` (a :class:`~ffd_notebook.io.DisplacementField`); or a
        mapping with ``"size"`` (x first) and optionally ``"spacing"``, ``"origin"``, ``"direction"``
        (ITK's meaning, as :class:`~ffd_notebook.images.ImageGrid` takes them).

    Returns
    -------
    ImageGrid
        Its size, spacing, origin and direction.

    Raises
    ------
    TypeError
        For anything else (the message lists what is accepted).
    ValueError
        A mapping with unknown keys or unusable values.
    FileNotFoundError, FileFormatError
        A file that is missing or not an image.

    Examples
    --------
    >>> import SimpleITK as sitk
    >>> reference_grid(sitk.Image(5, 4, 3, sitk.sitkUInt8)).size
    (5, 4, 3)
    >>> reference_grid({"size": (4, 5, 6), "spacing": 2.0}).spacing.tolist()
    [2.0, 2.0, 2.0]
    >>> reference_grid(3.0)
    Traceback (most recent call last):
    ...
    TypeError: a reference grid is an ImageGrid, a SimpleITK image, an image file, ... got float
    """
    if isinstance(reference, ImageGrid) or is_sitk_image(reference):
        return ImageGrid.of(reference)
    if isinstance(reference, str | os.PathLike):
        return read_image_information(reference)
    grid = getattr(reference, "grid", None)
    if isinstance(grid, ImageGrid):
        return grid
    if isinstance(reference, Mapping):
        unknown = sorted(set(reference) - _KEYS)
        if "size" not in reference or unknown:
            raise ValueError(
                "a reference grid given as a mapping needs 'size' and may have 'spacing', 'origin', "
                f"'direction' (got {sorted(reference)})"
            )
        return ImageGrid(
            reference["size"], reference.get("spacing"), reference.get("origin"), reference.get("direction")
        )
    raise TypeError(
        "a reference grid is an ImageGrid, a SimpleITK image, an image file, a DisplacementField or a mapping "
        f"with size/spacing/origin/direction, got {type(reference).__name__}"
    )
