"""The package's one dtype policy for colours and intensities: scikit-image's.

Every function that takes colours or grey levels (a photo, an image to make a solid exemplar
from, an exemplar volume, a texture, the quality measures) reads its input with :func:`as_uint8`
or :func:`as_float`, which follow scikit-image's ``img_as_ubyte`` / ``img_as_float32`` (and call
them):

* ``uint8``: levels 0-255, as they are;
* ``uint16`` (and other unsigned integers): the dtype's whole range is black to white, so a
  16-bit photo's 65535 is 255 (not stretched by its own maximum: a dark 16-bit picture stays dark);
* ``bool``: ``False`` black, ``True`` white;
* floating point: 0 to 1 is black to white; values outside [0, 1] (beyond rounding, 1e-6) are
  refused with the range found, as scikit-image refuses them, because they cannot be read
  without a guess (0-255 values in a float array? a photometric scale?); NaN and infinities too;
* other (signed) integers: taken as levels 0-255 when every value is in that range (what
  ``rng.integers(0, 256, ...)`` or a literal list gives, and what scikit-image does too), and
  refused otherwise (their range is not known).

So ``np.uint16`` data becomes the levels of its top 8 bits (``>> 8``), a float image in [0, 1]
is scaled by 255 and rounded, and nothing is clipped or rescaled silently.

Examples
--------
>>> as_uint8(np.array([0, 32768, 65535], np.uint16)).tolist()
[0, 128, 255]
>>> as_uint8(np.array([0.0, 0.5, 1.0])).tolist()
[0, 128, 255]
>>> as_uint8(np.array([0.0, 200.0]), "the image")
Traceback (most recent call last):
...
ValueError: the image: floating-point colours must be in [0, 1] (black to white), got values from 0 to 200: ...
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["as_float", "as_uint8", "check_colours"]

_TOLERANCE = 1e-6  # floats this far outside [0, 1] are rounding, clipped; further is refused


def check_colours(values: Any, what: str = "the colours") -> np.ndarray:
    """The array, checked against the policy (see the module docstring), in its own dtype.

    Parameters
    ----------
    values : array_like
        Colours or grey levels of any shape.
    what : str
        What error messages call them.

    Returns
    -------
    numpy.ndarray
        ``values`` as an array; a float array outside [0, 1] by rounding only is clipped.

    Raises
    ------
    ValueError
        Floats outside [0, 1], NaN or infinite; signed integers outside 0-255; a dtype that is
        not a number.

    Examples
    --------
    >>> check_colours([1, 2, 300], "the photo")
    Traceback (most recent call last):
    ...
    ValueError: the photo: int64 values from 1 to 300 are not 0-255 levels, and an int64 array has no known range: ...
    """
    a = np.asarray(values)
    if a.dtype == np.uint8 or a.dtype == np.bool_ or np.issubdtype(a.dtype, np.unsignedinteger):
        return a
    if a.size == 0:
        return a
    if np.issubdtype(a.dtype, np.floating):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{what}: colours must be finite numbers, got NaN or infinite values")
        lo, hi = float(a.min()), float(a.max())
        if lo < -_TOLERANCE or hi > 1.0 + _TOLERANCE:
            raise ValueError(
                f"{what}: floating-point colours must be in [0, 1] (black to white), got values from {lo:.4g} to "
                f"{hi:.4g}: divide 0-255 levels by 255, or rescale the range you mean "
                "(skimage.exposure.rescale_intensity)"
            )
        return np.clip(a, 0.0, 1.0) if lo < 0 or hi > 1 else a
    if np.issubdtype(a.dtype, np.signedinteger):
        lo, hi = int(a.min()), int(a.max())
        if lo < 0 or hi > 255:
            raise ValueError(
                f"{what}: {a.dtype} values from {lo} to {hi} are not 0-255 levels, and an {a.dtype} array has no "
                "known range: convert it to uint8 (levels 0-255), uint16 (16-bit data) or floats in [0, 1]"
            )
        return a
    raise ValueError(f"{what}: colours must be numbers (uint8, uint16, float in [0, 1] or bool), got {a.dtype}")


def as_uint8(values: Any, what: str = "the colours") -> NDArray[np.uint8]:
    """Colours as uint8 levels 0-255 by the package's policy (scikit-image's ``img_as_ubyte``).

    Parameters
    ----------
    values : array_like
        Colours or grey levels of any shape: uint8, uint16, bool, floats in [0, 1], or signed
        integers that are 0-255 levels.
    what : str
        What error messages call them.

    Returns
    -------
    numpy.ndarray
        uint8, the same shape (``values`` itself when it is uint8 already).

    Raises
    ------
    ValueError
        As :func:`check_colours`.

    Examples
    --------
    >>> as_uint8(np.array([[0, 65535]], np.uint16)).tolist(), as_uint8([True, False]).tolist()
    ([[0, 255]], [255, 0])
    >>> as_uint8(np.array([7, 255], np.int64)).dtype.name
    'uint8'
    """
    a = check_colours(values, what)
    if a.dtype == np.uint8:
        return a
    if np.issubdtype(a.dtype, np.signedinteger):
        return a.astype(np.uint8)  # 0-255 levels, checked
    from skimage.util import img_as_ubyte

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "precision loss": the point of the conversion
        return img_as_ubyte(a)


def as_float(values: Any, what: str = "the colours") -> NDArray[np.float32]:
    """Colours as float32 in [0, 1] by the package's policy (scikit-image's ``img_as_float32``).

    Parameters
    ----------
    values : array_like
        As :func:`as_uint8`.
    what : str
        What error messages call them.

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1], the same shape.

    Raises
    ------
    ValueError
        As :func:`check_colours`.

    Examples
    --------
    >>> [round(float(v), 3) for v in as_float(np.array([0, 51, 255], np.uint8))]
    [0.0, 0.2, 1.0]
    >>> as_float(np.array([0, 51, 255])).tolist() == as_float(np.array([0, 51, 255], np.uint8)).tolist()
    True
    """
    a = check_colours(values, what)
    if np.issubdtype(a.dtype, np.signedinteger):
        a = a.astype(np.uint8)  # 0-255 levels, checked
    from skimage.util import img_as_float32

    return img_as_float32(a)
