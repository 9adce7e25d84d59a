"""Photos in: a file (PNG, JPEG, anything Pillow reads) or an array, as an ``(H, W, 3)`` uint8 RGB array.

Pixel values follow the package's one dtype policy (scikit-image's, :mod:`ffd_notebook._util.colours`):
uint8 levels as they are; 16-bit pixels (arrays or files) scaled from their whole range, so a dark
16-bit photo stays dark; floats in [0, 1]; floats outside [0, 1] refused with the range found.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from .._util.colours import as_uint8
from ..errors import FileFormatError

__all__ = ["PHOTO_SUFFIXES", "Photo", "decode_photo", "is_photo", "read_photo"]

#: file name endings taken for photos (what the editor and ``python -m ffd_notebook`` make a face from)
PHOTO_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


class Photo:
    """An RGB photo and the name errors use for it (the path, or a description of the array).

    Parameters
    ----------
    rgb : numpy.ndarray
        The ``(H, W, 3)`` uint8 RGB pixels.
    name : str
        What error messages call the photo.
    path : str, optional
        The file it was read from, if any.

    Examples
    --------
    >>> photo = Photo.of(np.zeros((4, 6), np.uint8))
    >>> photo.rgb.shape, photo.name
    ((4, 6, 3), 'the photo (a 6x4 array)')
    """

    def __init__(self, rgb: np.ndarray, name: str, path: str | None = None) -> None:
        self.rgb = rgb
        self.name = name
        self.path = path

    @property
    def height(self) -> int:
        """Rows of pixels."""
        return int(self.rgb.shape[0])

    @property
    def width(self) -> int:
        """Columns of pixels."""
        return int(self.rgb.shape[1])

    @classmethod
    def of(cls, photo: str | os.PathLike[str] | np.ndarray | Photo) -> Photo:
        """A path is read with :func:`read_photo`; an array is checked and made RGB; a Photo is itself.

        Parameters
        ----------
        photo : str, os.PathLike, numpy.ndarray or Photo
            A photo file, an ``(H, W)``, ``(H, W, 1)``, ``(H, W, 3)`` or ``(H, W, 4)`` array (uint8, uint16,
            or floats in [0, 1]: the package's dtype policy), or a photo.

        Returns
        -------
        Photo
            The photo, RGB.

        Raises
        ------
        ValueError
            An array of another shape, or values the dtype policy refuses (floats outside [0, 1], NaN).

        Examples
        --------
        >>> rgba = np.full((2, 3, 4), 200, np.uint8)
        >>> photo = Photo.of(rgba)
        >>> photo.height, photo.width, photo.rgb.shape, Photo.of(photo) is photo
        (2, 3, (2, 3, 3), True)
        >>> Photo.of(np.full((2, 3), 0.5)).rgb[0, 0].tolist(), Photo.of(np.full((2, 3), 65535, np.uint16)).rgb[0, 0, 0]
        ([128, 128, 128], np.uint8(255))
        >>> Photo.of(np.full((2, 3), 200.0))
        Traceback (most recent call last):
        ...
        ValueError: the photo (a 3x2 array): floating-point colours must be in [0, 1] (black to white), got ...
        """
        if isinstance(photo, Photo):
            return photo
        if isinstance(photo, (str, os.PathLike)):
            return cls(read_photo(photo), os.fspath(photo), os.fspath(photo))
        array = np.asarray(photo)
        if array.ndim not in (2, 3) or (array.ndim == 3 and array.shape[2] not in (1, 3, 4)):
            raise ValueError(f"a photo array must be (H, W, 3) RGB, (H, W, 4) RGBA or (H, W) grey; got {array.shape}")
        name = f"the photo (a {array.shape[1]}x{array.shape[0]} array)"
        return cls(_as_rgb(as_uint8(array, name)), name)


def is_photo(source: object) -> bool:
    """Whether ``source`` is a photo to make a face from: a path ending as :data:`PHOTO_SUFFIXES`, an
    ``(H, W, 3)`` or ``(H, W, 4)`` uint8 or uint16 array, or a :class:`Photo` (a mesh, a point array or a mesh file
    is not; nor a float array, which could be a grid of points: give it to :meth:`Photo.of`).

    Parameters
    ----------
    source : object
        Anything offered as the source of a face.

    Returns
    -------
    bool
        True for a photo.

    Examples
    --------
    >>> is_photo("me.JPG"), is_photo("face.obj"), is_photo(np.zeros((5, 5, 3), np.uint8)), is_photo(np.zeros((5, 3)))
    (True, False, True, False)
    """
    if isinstance(source, Photo):
        return True
    if isinstance(source, (str, os.PathLike)):
        return Path(source).suffix.lower() in PHOTO_SUFFIXES
    return (
        isinstance(source, np.ndarray)
        and source.dtype in (np.uint8, np.uint16)
        and source.ndim == 3
        and source.shape[2] in (3, 4)
    )


def _as_rgb(array: np.ndarray) -> np.ndarray:
    if array.ndim == 2:
        array = array[:, :, None]
    if array.shape[2] == 1:
        array = np.repeat(array, 3, axis=2)
    return np.ascontiguousarray(array[:, :, :3])  # RGBA: the colour, without the alpha


def read_photo(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a photo file as an ``(H, W, 3)`` uint8 RGB array, upright.

    A JPEG's EXIF orientation (how a phone held sideways marks its pictures) is applied; grey-scale,
    palette and RGBA images become RGB (the alpha channel is dropped, not blended).

    Parameters
    ----------
    path : str or os.PathLike
        A photo file.

    Returns
    -------
    numpy.ndarray
        Its ``(H, W, 3)`` uint8 RGB pixels.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    FileFormatError
        If the file is not an image Pillow can read, or is damaged.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "notes.png"
    >>> _ = path.write_text("not a picture")
    >>> read_photo(path)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: .../notes.png: not an image file (PNG, JPEG, ...): ...
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    return _decode(path, path)


def decode_photo(content: bytes, name: str) -> Photo:
    """A photo from the bytes of an image file (an upload), called ``name`` in errors: as :func:`read_photo`.

    Parameters
    ----------
    content : bytes
        The bytes of an image file.
    name : str
        The name errors use for it (the uploaded file's name).

    Returns
    -------
    Photo
        The photo, RGB and upright.

    Raises
    ------
    FileFormatError
        If the bytes are not an image Pillow can read, or are damaged.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> buffer = io.BytesIO()
    >>> Image.new("L", (40, 30), 90).save(buffer, format="PNG")
    >>> photo = decode_photo(buffer.getvalue(), "me.png")
    >>> photo.rgb.shape, photo.name, int(photo.rgb[0, 0, 2])
    ((30, 40, 3), 'me.png', 90)
    >>> decode_photo(b"GIF89a...", "me.gif")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: me.gif: not an image file (PNG, JPEG, ...): ...
    """
    return Photo(_decode(io.BytesIO(bytes(content)), name), name)


def _decode(source: Path | io.BytesIO, name: str | os.PathLike[str]) -> np.ndarray:
    from PIL import Image, ImageOps, UnidentifiedImageError

    try:
        with Image.open(source) as image:
            image = ImageOps.exif_transpose(image)
            if image.mode.startswith(("I", "F")):  # 16-bit, 32-bit or float grey: the package's dtype policy
                array = _grey_levels(image, name)
            else:
                if image.mode not in ("RGB", "RGBA", "L"):
                    image = image.convert("RGBA" if "A" in image.mode or "transparency" in image.info else "RGB")
                array = np.asarray(image)
    except UnidentifiedImageError as exc:
        raise FileFormatError(name, None, f"not an image file (PNG, JPEG, ...): {exc}") from None
    except Image.DecompressionBombError as exc:  # over 2 x Image.MAX_IMAGE_PIXELS (~179 million pixels)
        raise FileFormatError(name, None, f"too large for a photo: {exc}") from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise FileFormatError(name, None, f"damaged or unreadable image: {exc}") from None
    return _as_rgb(array)


def _grey_levels(image, name: str | os.PathLike[str]) -> np.ndarray:
    """A 16-bit, 32-bit integer or float grey Pillow image as uint8 levels by the dtype policy, or refused.

    ``I;16`` pixels are uint16 (scaled from their whole range); ``F`` pixels floats, read if they
    are in [0, 1]; ``I`` (32-bit integers) are 16-bit data when the file is a PNG (which holds at
    most 16 bits; older Pillow opened 16-bit PNGs so), 0-255 levels when every value is one, and
    refused otherwise: their range is not known.
    """
    array = np.asarray(image)
    if image.mode == "I" and getattr(image, "format", None) == "PNG":
        array = array.astype(np.uint16)
    try:
        return as_uint8(array, f"{image.mode} pixels")
    except ValueError as exc:
        raise FileFormatError(name, None, str(exc)) from None
