"""Image files through SimpleITK: read whole or refused with the reason, written atomically.

The one image reader of the package (:func:`open_image`, and :func:`read_image` /
:func:`read_image_information` on top of it) is what every image and displacement-field reader
uses: the format by the file name (NIfTI ``.nii``/``.nii.gz``, NRRD ``.nrrd``/``.nhdr``, MetaImage
``.mha``/``.mhd``, PNG, JPEG, BMP, TIFF) read by that format's ITK reader alone, the header
checked before ITK reads it (:mod:`.data_files`: the files it names, where its pixels are), the
pixels read whole or refused. A header with a separate data file (``.mhd``, ``.nhdr``) makes
two files when written; both are written into a temporary folder beside the target and moved
into place data first, so a reader never finds a header without its data.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .._util.file_access import check_regular_file
from .._util.itk_messages import itk_message
from ..errors import FileFormatError
from .data_files import HEADER_LIMIT, ImageLayout, check_whole, image_layout
from .geometry import ImageGrid

__all__ = [
    "IMAGE_WRITE_SUFFIXES",
    "MAX_IMAGE_BYTES",
    "ImageFile",
    "open_image",
    "read_image",
    "read_image_information",
    "write_image",
]

#: the most pixel memory a header may claim (a hostile header must not make the reader allocate the machine away)
MAX_IMAGE_BYTES = 16 * 2**30
#: last extensions of the files :func:`write_image` writes (SimpleITK's formats; ``.gz`` for ``.nii.gz``)
IMAGE_WRITE_SUFFIXES = (".nii", ".gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".png", ".tif", ".tiff", ".jpg", ".bmp")


class ImageFile:
    """An image file whose header is read and checked, its pixels not yet: what :func:`open_image` returns.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    layout : ImageLayout
        Where its pixels are.
    reader : SimpleITK.ImageFileReader
        The reader that read its header (with the file's ITK ImageIO).

    Attributes
    ----------
    path : pathlib.Path
        The file.
    layout : ImageLayout
        Where its pixels are (:func:`~ffd_notebook.images.data_files.image_layout`).
    grid : ImageGrid
        Its size, spacing, origin and direction.
    dimension, components : int
        2 or 3; values per pixel.
    pixel_id : int
        SimpleITK's pixel type of the file (``sitk.sitkFloat32``...).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.mha"
    >>> sitk.WriteImage(sitk.Image([4, 3], sitk.sitkVectorFloat32, 2), str(path))
    >>> image = open_image(path)
    >>> image.dimension, image.components, image.layout.format
    (2, 2, 'MetaImage')
    """

    def __init__(self, path: Path, layout: ImageLayout, reader: Any) -> None:
        self.path = path
        self.layout = layout
        self._reader = reader
        self.grid = ImageGrid(reader.GetSize(), reader.GetSpacing(), reader.GetOrigin(), reader.GetDirection())
        self.dimension = int(reader.GetDimension())
        self.components = int(reader.GetNumberOfComponents())
        self.pixel_id = int(reader.GetPixelID())

    def read(self, *, pixel_type: int | None = None, finite: bool = False) -> Any:
        """The pixels and geometry as a ``SimpleITK.Image``, read whole or refused.

        Parameters
        ----------
        pixel_type : int, optional
            A SimpleITK pixel type to convert to (``sitk.sitkVectorFloat64``...); the file's own by default.
        finite : bool
            Refuse the image if a pixel holds a NaN or an infinite value, naming how many do
            (:func:`~ffd_notebook.io.load_displacement_field` asks for it). They are counted in the
            file's data, also in NIfTI files, whose non-finite values ITK's reader turns into 0.

        Returns
        -------
        SimpleITK.Image
            The image.

        Raises
        ------
        FileFormatError
            The pixel data ends early (how many bytes of how many, or a compressed stream cut short),
            non-finite values with ``finite``, or SimpleITK cannot read it; names the file.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> import SimpleITK as sitk
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.nii.gz"
        >>> sitk.WriteImage(sitk.Image(4, 3, 2, sitk.sitkUInt8), str(path))
        >>> open_image(path).read(pixel_type=sitk.sitkFloat64).GetPixelIDTypeAsString()
        '64-bit float'
        """
        hidden = check_whole(self.layout, count_non_finite=finite)
        if hidden:
            raise self._non_finite(hidden)
        if pixel_type is not None:
            self._reader.SetOutputPixelType(pixel_type)
        try:
            image = self._reader.Execute()
        except RuntimeError as exc:
            if any(part.encoding == "text" for part in self.layout.parts):
                raise FileFormatError(self.path, None, "cannot read the pixels: the text data ends early or holds "
                                      f"something other than numbers ({itk_message(exc)})") from None  # fmt: skip
            raise FileFormatError(self.path, None, f"cannot read the pixels ({itk_message(exc)})") from None
        if finite:
            import SimpleITK as sitk

            values = sitk.GetArrayViewFromImage(image)
            if values.dtype.kind in "fc":
                bad = ~np.isfinite(values)
                count = int((bad.reshape(bad.shape[: self.dimension] + (-1,)).any(axis=-1)).sum())
                if count:
                    raise self._non_finite(count)
        return image

    def _non_finite(self, count: int) -> FileFormatError:
        what = "vectors" if self.components > 1 else "pixels"
        total = int(np.prod(self.grid.size))
        return FileFormatError(self.path, None, f"{count} of its {total} {what} hold NaN or infinite values: refused")

    def __repr__(self) -> str:
        return f"ImageFile({os.fspath(self.path)!r}, {self.layout.format}, size={self.grid.size})"


def open_image(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None) -> ImageFile:
    """Read and check an image file's header (and find its pixels) without reading the pixels.

    What every image and field reader of the package goes through: the format is chosen by the
    file's extension and read by that format's ITK reader only (no guessing by content); the
    header is read as ITK reads it and refused where it could be read two ways
    (:mod:`~ffd_notebook.images.data_files`); every file it names is checked by the one rule for
    named files (inside ``within``, a regular file: never a FIFO or a device); its geometry must
    be usable and its pixels fit :data:`MAX_IMAGE_BYTES`. :meth:`ImageFile.read` then reads the
    pixels whole or refuses.

    A header reads whatever files it names, as ITK does: in a notebook, ``within=None`` lets a
    ``.mhd`` take its pixels from anywhere; a server passes the folder its users may read.

    Parameters
    ----------
    path : str or os.PathLike
        An image file: NIfTI (``.nii``, ``.nii.gz``), NRRD (``.nrrd``, ``.nhdr``), MetaImage
        (``.mha``, ``.mhd``), PNG, JPEG, BMP or TIFF.
    within : str or os.PathLike, optional
        The folder the files its header names must be in (``None``: anywhere).

    Returns
    -------
    ImageFile
        The checked header; ``.read()`` reads the pixels.

    Raises
    ------
    FileNotFoundError
        No such file.
    IsADirectoryError
        A folder.
    FileFormatError
        Not an image of a format above, a header refused, a named file refused, not 2D/3D,
        unusable geometry, too large; names the file (and the header line).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.nrrd"
    >>> sitk.WriteImage(sitk.Image(4, 3, 2, sitk.sitkFloat32), str(path))
    >>> image = open_image(path)
    >>> image.grid.size, image.read().GetSize()
    ((4, 3, 2), (4, 3, 2))
    """
    import SimpleITK as sitk

    target = Path(path)
    check_regular_file(target, MAX_IMAGE_BYTES + HEADER_LIMIT)
    layout = image_layout(target, within=within)
    if layout.sizes is None:  # PNG, JPEG, BMP, TIFF: sized by their own structure, which ITK needs whole to begin
        check_whole(layout)
    reader = sitk.ImageFileReader()
    reader.SetFileName(os.fspath(target))
    reader.SetImageIO(layout.io)
    try:
        reader.ReadImageInformation()
    except RuntimeError as exc:
        raise FileFormatError(target, None, f"not a {layout.format} image SimpleITK can read "
                              f"({itk_message(exc)})") from None  # fmt: skip
    if reader.GetDimension() not in (2, 3):
        raise FileFormatError(target, None, f"a {reader.GetDimension()}D image; only 2D and 3D images are supported")
    try:  # spacing, origin and direction as warping needs them (finite, positive, invertible)
        ImageGrid(reader.GetSize(), reader.GetSpacing(), reader.GetOrigin(), reader.GetDirection())
    except ValueError as exc:
        raise FileFormatError(target, None, f"unusable geometry: {exc}") from None
    values = int(np.prod(np.array(reader.GetSize(), dtype=np.float64))) * reader.GetNumberOfComponents()
    written = None if layout.sizes is None else int(np.prod(np.array(layout.sizes, dtype=np.float64)))
    if written is not None and values != written * layout.components:
        raise FileFormatError(target, None, f"ITK reads {values} values from this header where its text says "
                              f"{written * layout.components}: refused")  # fmt: skip
    claimed = values * _component_bytes(reader)
    if claimed > MAX_IMAGE_BYTES:
        raise FileFormatError(target, None, f"the header claims {claimed / 2**30:.3g} GiB of pixels, more than "
                                            f"the limit of {MAX_IMAGE_BYTES / 2**30:.0f} GiB")  # fmt: skip
    return ImageFile(target, layout, reader)


def _component_bytes(reader: Any) -> int:
    """Bytes of one pixel component of the image ``reader`` describes ("32-bit float" -> 4; unknown: 8)."""
    import SimpleITK as sitk

    name = sitk.GetPixelIDValueAsString(reader.GetPixelID())
    for bits in (8, 16, 32, 64):
        if f"{bits}-bit" in name:
            return bits // 8
    return 8


def read_image_information(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None) -> ImageGrid:
    """The :class:`~ffd_notebook.images.ImageGrid` of an image file, from its header (pixels not read).

    The header is checked as :func:`open_image` checks it (a reference grid given as a path too).

    Parameters
    ----------
    path : str or os.PathLike
        An image file (see :func:`open_image` for the formats).
    within : str or os.PathLike, optional
        The folder the files its header names must be in (``None``: anywhere).

    Returns
    -------
    ImageGrid
        Its size, spacing, origin and direction.

    Raises
    ------
    FileNotFoundError
        No such file.
    FileFormatError
        See :func:`open_image`; names the file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.nrrd"
    >>> sitk.WriteImage(sitk.Image(4, 3, 2, sitk.sitkFloat32), str(path))
    >>> read_image_information(path).size
    (4, 3, 2)
    """
    return open_image(path, within=within).grid


def read_image(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None,
               pixel_type: int | None = None) -> Any:  # fmt: skip
    """Read a 2D or 3D image file as a ``SimpleITK.Image``, whole or not at all.

    ``open_image(path, within=within).read(pixel_type=pixel_type)``: the header checked (a header
    reads the files it names, as ITK does, unless ``within`` confines them), then the pixels read
    whole, or refused with a message that says the data ends early (how many bytes of how many, or
    that a compressed stream stops before its end). NaN and infinite pixel values are read as the
    format's ITK reader gives them: as they are from NRRD, MetaImage and TIFF (a float image may
    mark "no data" with NaN), as 0 from NIfTI (the NIfTI library ITK uses replaces them); a
    displacement field with any is refused (:func:`~ffd_notebook.io.load_displacement_field`).

    Parameters
    ----------
    path : str or os.PathLike
        An image file: NIfTI, NRRD, MetaImage, PNG, JPEG, BMP or TIFF (see :func:`open_image`).
    within : str or os.PathLike, optional
        The folder the files its header names must be in (``None``: anywhere).
    pixel_type : int, optional
        A SimpleITK pixel type to convert to; the file's own by default.

    Returns
    -------
    SimpleITK.Image
        The image, pixels and geometry.

    Raises
    ------
    FileNotFoundError
        No such file.
    FileFormatError
        Not an image of a format above, a refused header or named file, pixel data that ends
        early, or not 2D/3D; names the file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "bad.nii").write_bytes(b"not an image")
    >>> read_image(folder / "bad.nii")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...bad.nii: not a NIfTI file: 12 bytes, shorter than a NIfTI header
    >>> sitk.WriteImage(sitk.Image(40, 30, sitk.sitkFloat32), str(folder / "a.nii"))
    >>> _ = (folder / "cut.nii").write_bytes((folder / "a.nii").read_bytes()[:-1])
    >>> read_image(folder / "cut.nii")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...cut.nii: the pixel data ends early: the file has 5151 bytes of 5152
    """
    return open_image(path, within=within).read(pixel_type=pixel_type)


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_image(path: str | os.PathLike[str], image: Any, *, compress: bool = False) -> None:
    """Write a ``SimpleITK.Image`` to ``path`` atomically, in the format its extension names.

    The file (and the data file of a ``.mhd`` / ``.nhdr`` header) is written in a temporary
    folder beside ``path`` and renamed into place: a failed write leaves the previous file as it
    was.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write; its extension names the format.
    image : SimpleITK.Image
        The image to write.
    compress : bool, optional
        Ask SimpleITK to compress the pixel data where the format allows (default False).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.mhd"
    >>> write_image(path, sitk.Image(4, 3, sitk.sitkUInt8))
    >>> sorted(p.name for p in path.parent.iterdir()), read_image(path).GetSize()
    (['a.mhd', 'a.raw'], (4, 3))
    """
    import SimpleITK as sitk

    target = Path(path)
    folder = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        try:
            sitk.WriteImage(image, str(folder / target.name), compress)
        except RuntimeError as exc:
            raise ValueError(f"{os.fspath(path)}: SimpleITK cannot write this image ({itk_message(exc)})") from None
        written = sorted(folder.iterdir(), key=lambda p: p.name == target.name)  # the named file (header) last
        for part in written:
            _fsync(part)
            os.replace(part, target.parent / part.name)
        with contextlib.suppress(OSError):
            _fsync(target.parent)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
