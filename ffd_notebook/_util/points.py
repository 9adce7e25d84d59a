"""Point sets as ``(N, 3)`` arrays: the one check every model function applies to its points."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["as_points"]


def as_points(points: Any, name: str = "points") -> NDArray[np.float64]:
    """An ``(N, 3)`` float64 array of at least one finite point.

    Accepts an array (one point may be given as a 3-vector) or anything with a ``points``
    attribute (a PyVista mesh). ``name`` is what the error messages call the argument.

    Examples
    --------
    >>> as_points([[0, 1, 2]]).dtype.name
    'float64'
    >>> as_points([1.0, 2.0, 3.0]).shape
    (1, 3)
    >>> as_points([[0.0, float("nan"), 0.0]], "landmarks")
    Traceback (most recent call last):
    ...
    ValueError: landmarks contain NaN or infinite values
    >>> as_points(np.zeros((0, 3)))
    Traceback (most recent call last):
    ...
    ValueError: points must be a non-empty (N, 3) array, got shape (0, 3)
    """
    arr = np.asarray(getattr(points, "points", points), dtype=np.float64)
    if arr.shape == (3,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3 or len(arr) == 0:
        raise ValueError(f"{name} must be a non-empty (N, 3) array, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contain NaN or infinite values")
    return arr
