"""Image files through SimpleITK: reading with clear errors, writing atomically in any format it writes.

SimpleITK picks the format by the file name (NIfTI ``.nii``/``.nii.gz``, NRRD ``.nrrd``/``.nhdr``,
MetaImage ``.mha``/``.mhd``, PNG, TIFF...). A header with a separate data file (``.mhd``,
``.nhdr``) makes two files; both are written into a temporary folder beside the target and moved
into place data first, so a reader never finds a header without its data.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from .geometry import ImageGrid

__all__ = [
    "IMAGE_WRITE_SUFFIXES",
    "MAX_IMAGE_BYTES",
    "image_data_files",
    "image_suffix",
    "read_image",
    "read_image_information",
    "write_image",
]

_MULTI_SUFFIXES = (".nii.gz", ".hdr.gz", ".img.gz")
#: the most pixel memory a header may claim (a hostile header must not make the reader allocate the machine away)
MAX_IMAGE_BYTES = 16 * 2**30
#: last extensions of the files :func:`write_image` writes (SimpleITK's formats; ``.gz`` for ``.nii.gz``)
IMAGE_WRITE_SUFFIXES = (".nii", ".gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".png", ".tif", ".tiff", ".jpg", ".bmp")


def image_suffix(path: str | os.PathLike[str]) -> str:
    """The extension SimpleITK chooses the format by: ``".nii.gz"`` for ``a.nii.gz``, else the last suffix.

    Parameters
    ----------
    path : str or os.PathLike
        An image file name (the file need not exist).

    Returns
    -------
    str
        The lower-case suffix, with its dot.

    Examples
    --------
    >>> image_suffix("scan.nii.gz"), image_suffix("labels.nrrd"), image_suffix("a.b.mha")
    ('.nii.gz', '.nrrd', '.mha')
    """
    name = Path(path).name.lower()
    for suffix in _MULTI_SUFFIXES:
        if name.endswith(suffix):
            return suffix
    return Path(name).suffix


_TEXT_HEADERS = {  # format -> (separator, dimension key, sizes key, largest dimension)
    ".mha": ("=", "ndims", "dimsize", 3),
    ".mhd": ("=", "ndims", "dimsize", 3),
    ".nrrd": (":", "dimension", "sizes", 4),  # 4: a vector image's component axis
    ".nhdr": (":", "dimension", "sizes", 4),
}


def _check_text_header(path: str) -> None:
    """The dimension and sizes of a MetaImage or NRRD header, checked before SimpleITK sees them.

    ITK's MetaImage reader loops forever on ``NDims = -1``; refusing what warping cannot use
    (more than 3 dimensions, sizes that are not positive whole numbers) keeps such headers away.
    """
    suffix = image_suffix(path)
    if suffix not in _TEXT_HEADERS:
        return
    separator, dim_key, sizes_key, largest = _TEXT_HEADERS[suffix]
    with open(path, "rb") as f:
        head = f.read(65536).decode("latin-1")
    values: dict[str, tuple[int, str]] = {}
    for number, raw in enumerate(head.splitlines(), start=1):
        key, sep, value = raw.partition(separator)
        key = key.strip().lower()
        if suffix in (".nrrd", ".nhdr") and not raw.strip():
            break  # the end of a NRRD header
        if sep and key in (dim_key, sizes_key) and key not in values:
            values[key] = (number, value.strip())
        if key.replace(" ", "") == "elementdatafile":
            break  # the end of a MetaImage header
    if dim_key not in values:
        raise FileFormatError(path, None, f"no {dim_key!r} line in the header")
    line, text = values[dim_key]
    if not re.fullmatch(r"[0-9]{1,2}", text) or not 1 <= int(text) <= largest:
        raise FileFormatError(path, line, f"{dim_key} must be a whole number from 1 to {largest}, got {text!r}")
    if sizes_key in values:
        line, text = values[sizes_key]
        sizes = text.split()
        if len(sizes) != int(values[dim_key][1]) or not all(
            re.fullmatch(r"[0-9]{1,12}", v) and int(v) > 0 for v in sizes
        ):
            raise FileFormatError(
                path, line, f"{sizes_key} must be {values[dim_key][1]} positive whole numbers, got {text!r}"
            )


def _reader(path: str | os.PathLike[str]) -> Any:
    import SimpleITK as sitk

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(2, "No such file", path)
    _check_text_header(path)
    reader = sitk.ImageFileReader()
    reader.SetFileName(path)
    try:
        reader.ReadImageInformation()
    except RuntimeError as exc:
        raise FileFormatError(path, None, f"not an image SimpleITK can read ({_itk_message(exc)})") from None
    if reader.GetDimension() not in (2, 3):
        raise FileFormatError(path, None, f"a {reader.GetDimension()}D image; only 2D and 3D images are supported")
    try:  # spacing, origin and direction as warping needs them (finite, positive, invertible)
        ImageGrid(reader.GetSize(), reader.GetSpacing(), reader.GetOrigin(), reader.GetDirection())
    except ValueError as exc:
        raise FileFormatError(path, None, f"unusable geometry: {exc}") from None
    voxels = int(np.prod(np.array(reader.GetSize(), dtype=np.float64)))
    claimed = voxels * reader.GetNumberOfComponents() * _component_bytes(reader)
    if claimed > MAX_IMAGE_BYTES:
        raise FileFormatError(path, None, f"the header claims {claimed / 2**30:.3g} GiB of pixels, more than "
                                          f"the limit of {MAX_IMAGE_BYTES / 2**30:.0f} GiB")  # fmt: skip
    return reader


def _component_bytes(reader: Any) -> int:
    """Bytes of one pixel component of the image ``reader`` describes ("32-bit float" -> 4; unknown: 8)."""
    import SimpleITK as sitk

    name = sitk.GetPixelIDValueAsString(reader.GetPixelID())
    for bits in (8, 16, 32, 64):
        if f"{bits}-bit" in name:
            return bits // 8
    return 8


def image_data_files(path: str | os.PathLike[str]) -> list[Path]:
    r"""Files other than ``path`` that its header names for the pixels (MetaImage, NRRD), resolved.

    A ``.mhd`` or ``.nhdr`` header (and even a ``.mha`` or ``.nrrd`` one) may point at any file
    for its data; a server confining its users to a folder checks these too. Only the header's
    first 64 KiB are read.

    Parameters
    ----------
    path : str or os.PathLike
        An image file (its header is read if it is a MetaImage or NRRD file).

    Returns
    -------
    list of pathlib.Path
        The resolved data files the header names; empty for a format that keeps its pixels inline.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.mhd").write_text("NDims = 3\nElementDataFile = a.raw\n")
    >>> [p.name for p in image_data_files(folder / "a.mhd")]
    ['a.raw']
    >>> image_data_files(folder / "scan.nii")
    []
    """
    target = Path(path)
    suffix = image_suffix(target)
    if suffix not in (".mha", ".mhd", ".nrrd", ".nhdr"):
        return []
    with open(target, "rb") as f:
        head = f.read(65536)
    text = head.split(b"\n\n", 1)[0] if suffix in (".nrrd", ".nhdr") else head
    found = []
    for raw in text.decode("latin-1").splitlines():
        key, sep, value = raw.partition("=" if suffix in (".mha", ".mhd") else ":")
        key = key.strip().lower().replace(" ", "")
        if not sep or key not in ("elementdatafile", "datafile"):
            continue
        value = value.strip()
        if value.upper() in ("LOCAL", "") or value.upper().startswith("LIST"):
            continue
        name = value.split()[0] if "%" in value else value  # a file-name pattern: its folder is what matters
        found.append((target.parent / name).resolve())
    return found


def _itk_message(exc: RuntimeError) -> str:
    """The useful line of an ITK exception (its first lines name C++ source files)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    described = [line for line in lines if line.startswith("Description:")]
    return (
        (described[-1].removeprefix("Description:").strip() if described else lines[-1]) if lines else "unknown error"
    )


def read_image_information(path: str | os.PathLike[str]) -> ImageGrid:
    """The :class:`~ffd_notebook.images.ImageGrid` of an image file, from its header (pixels not read).

    Parameters
    ----------
    path : str or os.PathLike
        An image file SimpleITK reads (NIfTI, NRRD, MetaImage, PNG, TIFF...).

    Returns
    -------
    ImageGrid
        Its size, spacing, origin and direction.

    Raises
    ------
    FileNotFoundError
        No such file.
    FileFormatError
        Not an image SimpleITK reads, or not 2D/3D; names the file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import SimpleITK as sitk
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.nrrd"
    >>> sitk.WriteImage(sitk.Image(4, 3, 2, sitk.sitkFloat32), str(path))
    >>> read_image_information(path).size
    (4, 3, 2)
    """
    reader = _reader(path)
    return ImageGrid(reader.GetSize(), reader.GetSpacing(), reader.GetOrigin(), reader.GetDirection())


def read_image(path: str | os.PathLike[str]) -> Any:
    """Read a 2D or 3D image file as a ``SimpleITK.Image``.

    Parameters
    ----------
    path : str or os.PathLike
        An image file SimpleITK reads (NIfTI, NRRD, MetaImage, PNG, TIFF...).

    Returns
    -------
    SimpleITK.Image
        The image, pixels and geometry.

    Raises
    ------
    FileNotFoundError
        No such file.
    FileFormatError
        Not an image SimpleITK reads, truncated pixel data, or not 2D/3D; names the file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "bad.nii"
    >>> _ = path.write_bytes(b"not an image")
    >>> read_image(path)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...bad.nii: not an image SimpleITK can read (...)
    """
    reader = _reader(path)
    try:
        return reader.Execute()
    except RuntimeError as exc:
        raise FileFormatError(os.fspath(path), None, f"cannot read the pixels ({_itk_message(exc)})") from None


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
            raise ValueError(f"{os.fspath(path)}: SimpleITK cannot write this image ({_itk_message(exc)})") from None
        written = sorted(folder.iterdir(), key=lambda p: p.name == target.name)  # the named file (header) last
        for part in written:
            _fsync(part)
            os.replace(part, target.parent / part.name)
        with contextlib.suppress(OSError):
            _fsync(target.parent)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
