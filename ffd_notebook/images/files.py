"""Image files through SimpleITK: reading with clear errors, writing atomically in any format it writes.

SimpleITK picks the format by the file name (NIfTI ``.nii``/``.nii.gz``, NRRD ``.nrrd``/``.nhdr``,
MetaImage ``.mha``/``.mhd``, PNG, TIFF...). A header with a separate data file (``.mhd``,
``.nhdr``) makes two files; both are written into a temporary folder beside the target and moved
into place data first, so a reader never finds a header without its data.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..errors import FileFormatError
from .geometry import ImageGrid

__all__ = ["IMAGE_WRITE_SUFFIXES", "image_suffix", "read_image", "read_image_information", "write_image"]

_MULTI_SUFFIXES = (".nii.gz", ".hdr.gz", ".img.gz")
#: last extensions of the files :func:`write_image` writes (SimpleITK's formats; ``.gz`` for ``.nii.gz``)
IMAGE_WRITE_SUFFIXES = (".nii", ".gz", ".nrrd", ".nhdr", ".mha", ".mhd", ".png", ".tif", ".tiff", ".jpg", ".bmp")


def image_suffix(path: str | os.PathLike[str]) -> str:
    """The extension SimpleITK chooses the format by: ``".nii.gz"`` for ``a.nii.gz``, else the last suffix.

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


def _reader(path: str | os.PathLike[str]) -> Any:
    import SimpleITK as sitk

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(2, "No such file", path)
    reader = sitk.ImageFileReader()
    reader.SetFileName(path)
    try:
        reader.ReadImageInformation()
    except RuntimeError as exc:
        raise FileFormatError(path, None, f"not an image SimpleITK can read ({_itk_message(exc)})") from None
    if reader.GetDimension() not in (2, 3):
        raise FileFormatError(path, None, f"a {reader.GetDimension()}D image; only 2D and 3D images are supported")
    return reader


def _itk_message(exc: RuntimeError) -> str:
    """The useful line of an ITK exception (its first lines name C++ source files)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    described = [line for line in lines if line.startswith("Description:")]
    return (
        (described[-1].removeprefix("Description:").strip() if described else lines[-1]) if lines else "unknown error"
    )


def read_image_information(path: str | os.PathLike[str]) -> ImageGrid:
    """The :class:`~ffd_notebook.images.ImageGrid` of an image file, from its header (pixels not read).

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
