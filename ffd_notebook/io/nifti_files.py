"""NIfTI files whose header gives their data a meaning ITK does not know: NiftyReg's and FSL's transformations.

ITK (and so SimpleITK) reads a NIfTI vector image as a displacement field and nothing else; NiftyReg marks its files
with the intent name ``NREG_TRANS`` and a code in ``intent_p1``, FNIRT with FSL's intent codes, SPM with its own
description, and each stores something else than ITK's displacements (control-point positions, coefficients in
scaled voxels, positions in millimetres). :func:`nifti_meaning` tells them apart from the header alone, and
:func:`read_nifti` reads such a file with nibabel (a dependency: it reads headers and extensions exactly), whole or
not at all: a regular file of bounded size, opened once and read through that one descriptor (no FIFO, no swap
after the check), the declared size checked before a byte of data is read, truncated data refused.
"""

from __future__ import annotations

import gzip
import logging
import os
import zlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import FileFormatError
from ._atomic import atomic_path
from ._safety import open_regular
from .displacement_field import DisplacementField

__all__ = ["NiftiFile", "nifti_meaning", "read_nifti", "read_nifti_header", "write_nifti"]

_MAX_VALUES = 3 * 2**26  # a 400^3 field of 3-vectors; far above any registration's
NREG_TRANS = b"NREG_TRANS"
#: NiftyReg's ``intent_p1`` codes (``NREG_TRANS_TYPE`` in ``_reg_maths.h``).
NIFTYREG_CODES = {
    0: "a deformation field (positions)",
    1: "a displacement field",
    2: "a cubic B-spline control-point grid",
    3: "a velocity field of positions",
    4: "a velocity field of displacements",
    5: "a cubic B-spline velocity grid",
    6: "a linear spline control-point grid",
}
#: FSL's intent codes (``fsl/data/constants.py`` in fslpy, FNIRT's ``fnirt_file_writer.cpp``).
FSL_INTENTS = {
    2006: "an FNIRT displacement field",
    2007: "FNIRT cubic B-spline coefficients",
    2008: "FNIRT discrete cosine transform coefficients",
    2009: "FNIRT quadratic B-spline coefficients",
    2016: "TOPUP cubic B-spline coefficients",
    2017: "TOPUP quadratic B-spline coefficients",
    2018: "a TOPUP field",
}
_UNITS = {0: "unknown", 1: "metres", 2: "millimetres", 3: "micrometres"}


@dataclass
class NiftiFile:
    """A NIfTI file read by :func:`read_nifti`: its nibabel header and its data (``None`` if not asked for)."""

    path: str
    header: Any
    data: NDArray[np.float64] | None = None

    def world(self) -> NDArray[np.float64]:
        """The voxel-to-world (RAS) matrix NiftyReg uses: the sform if its code is set, else the qform."""
        h = self.header
        return np.asarray(h.get_sform() if int(h["sform_code"]) > 0 else h.get_qform(), dtype=np.float64)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(n) for n in self.header.get_data_shape())

    def fail(self, problem: str) -> FileFormatError:
        return FileFormatError(self.path, None, problem)


def _intent_name(header: Any) -> bytes:
    return bytes(np.asarray(header["intent_name"]).tobytes()).split(b"\x00")[0].strip()


def nifti_meaning(header: Any) -> tuple[str, Any]:
    """What a NIfTI header says its data holds: ``("niftyreg", code)``, ``("fsl", intent)``, ``("spm", text)``,
    ``("unknown", text)`` or ``("itk", None)`` (no mark: a displacement field in ITK's convention).

    Examples
    --------
    >>> import nibabel as nib
    >>> header = nib.Nifti1Header(); header.set_intent("vector", name="NREG_TRANS"); header["intent_p1"] = 2
    >>> nifti_meaning(header)
    ('niftyreg', 2)
    >>> nifti_meaning(nib.Nifti1Header())
    ('itk', None)
    """
    name = _intent_name(header)
    code = int(header["intent_code"])
    if name == NREG_TRANS:
        p1 = float(header["intent_p1"])
        return "niftyreg", int(p1) if np.isfinite(p1) and p1 == round(p1) else p1
    if code in FSL_INTENTS:
        return "fsl", code
    description = bytes(np.asarray(header["descrip"]).tobytes()).split(b"\x00")[0].decode("latin-1").strip()
    if (
        name.lower() == b"mapping"
        or description.lower().endswith("deformation")
        or "deformation field" in (description.lower())
    ):
        return "spm", f"intent name {name.decode('latin-1')!r}, description {description!r}"
    if name:
        return "unknown", f"intent code {code}, intent name {name.decode('latin-1')!r}"
    return "itk", None


def _stream(raw: Any, path: str | os.PathLike[str]) -> Any:
    return gzip.GzipFile(fileobj=raw, mode="rb") if os.fspath(path).lower().endswith(".gz") else raw


def _image_class(first: bytes, path: str | os.PathLike[str]) -> Any:
    import nibabel as nib

    if len(first) < 4:
        raise FileFormatError(path, None, "not a NIfTI file (shorter than a header)")
    sizes = {int.from_bytes(first[:4], "little"), int.from_bytes(first[:4], "big")}
    if 348 in sizes:
        return nib.Nifti1Image
    if 540 in sizes:
        return nib.Nifti2Image
    raise FileFormatError(path, None, "not a NIfTI-1 or NIfTI-2 file (its header size is neither 348 nor 540)")


_READ_ERRORS = (OSError, EOFError, ValueError, zlib.error, KeyError, TypeError, IndexError, MemoryError)


def read_nifti(path: str | os.PathLike[str], *, data: bool = True) -> NiftiFile:
    """Read a NIfTI file's header, and its data as float64 unless ``data=False``, whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii`` or ``.nii.gz`` file (one file: header and data together).
    data : bool
        Read the data too (scaled by the header's slope and intercept, as nibabel does).

    Returns
    -------
    NiftiFile

    Raises
    ------
    FileFormatError
        Not a NIfTI file, a header nibabel refuses, more than 3 * 2^26 values, or data that is not all there or
        not finite; names the file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import nibabel as nib, numpy as np
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "v.nii.gz"
    >>> nib.save(nib.Nifti1Image(np.ones((2, 3, 4, 1, 3), np.float32), np.eye(4)), path)
    >>> read_nifti(path).data.shape
    (2, 3, 4, 1, 3)
    """
    from nibabel.fileholders import FileHolder

    if os.fspath(path).lower().endswith((".hdr", ".img", ".hdr.gz", ".img.gz")):
        raise FileFormatError(path, None, "a NIfTI pair (.hdr/.img) is not read here; expected one .nii or .nii.gz")
    with open_regular(path) as raw:
        try:
            stream = _stream(raw, path)
            first = stream.read(4)
            stream.seek(0)
            kind = _image_class(first, path)
            _check_header(kind, stream, path)
            stream.seek(0)
            holder = FileHolder(fileobj=stream)
            image = kind.from_file_map({"header": holder, "image": holder}, mmap=False, keep_file_open=False)
            header = image.header
            shape = header.get_data_shape()
            if int(np.prod(shape, dtype=np.float64)) > _MAX_VALUES:
                raise FileFormatError(path, None, f"an image of shape {tuple(shape)} is larger than the "
                                      f"{_MAX_VALUES} values accepted")  # fmt: skip
            values = np.asarray(image.dataobj, dtype=np.float64) if data else None
        except FileFormatError:
            raise
        except _READ_ERRORS as exc:  # nibabel's HeaderDataError and ImageFileError are ValueErrors (or Exception)
            raise FileFormatError(path, None, f"not a NIfTI file nibabel can read whole: {_short(exc)}") from None
        except Exception as exc:  # nibabel.filebasedimages.ImageFileError and kin
            if type(exc).__module__.startswith("nibabel"):
                raise FileFormatError(path, None, f"not a NIfTI file nibabel can read: {_short(exc)}") from None
            raise
    if values is not None and not np.all(np.isfinite(values)):
        raise FileFormatError(path, None, "the data contain NaN or infinite values")
    return NiftiFile(os.fspath(path), header, values)


def _check_header(kind: Any, stream: Any, path: str | os.PathLike[str]) -> None:
    """Refuse a header nibabel would repair on reading (a negative voxel size made positive, an invalid sform
    code set to 0, a wrong header size...): what it holds would then be a guess. Warnings that change nothing
    (a data offset SPM would not like) pass, and so does a ``qfac`` (``pixdim[0]``) of 0, which the NIfTI-1
    standard reads as 1 (NiftyReg writes it so)."""
    header_class = kind.header_class
    size = header_class.template_dtype.itemsize
    block = stream.read(size)
    if len(block) < size:
        raise FileFormatError(path, None, f"a truncated NIfTI header ({len(block)} of {size} bytes)")
    header = header_class(block, check=False)
    if float(header["pixdim"][0]) == 0.0:
        header["pixdim"][0] = 1.0  # a qfac of 0 is 1 by the standard's own reading (NiftyReg writes it so)
    repaired = header.copy()
    problems: list[str] = []
    collect = logging.getLogger(f"{__name__}.header_check")
    collect.propagate = False
    collect.setLevel(1)  # every problem a check reports (level 0 is "no problem")
    handler = _Collect(problems)
    collect.addHandler(handler)
    try:  # nibabel's own battery of checks, the one it runs with fixes when it reads a file
        repaired.check_fix(logger=collect, error_level=100)
    finally:
        collect.removeHandler(handler)
    if repaired.binaryblock != header.binaryblock:
        raise FileFormatError(path, None, "a NIfTI header nibabel would have to repair, so what it holds would be "
                              f"a guess: {'; '.join(problems) or 'its fields are inconsistent'}")  # fmt: skip


class _Collect(logging.Handler):
    """Keeps the messages of nibabel's header checks that made a fix."""

    def __init__(self, into: list[str]) -> None:
        super().__init__(level=logging.DEBUG)
        self.into = into

    def emit(self, record: logging.LogRecord) -> None:
        self.into.append(record.getMessage())


def read_nifti_header(path: str | os.PathLike[str]) -> Any:
    """The nibabel header of a NIfTI file (see :func:`read_nifti`), without its data."""
    return read_nifti(path, data=False).header


#: RAS (NIfTI's world) <-> LPS (ITK's physical space): x and y change sign (the map is its own inverse).
RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])
#: The same on homogeneous coordinates.
RAS_TO_LPS_4 = np.diag([-1.0, -1.0, 1.0, 1.0])


def lps_matrix(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """A RAS-to-RAS 4x4 affine map as the LPS-to-LPS one (and back: the flip is its own inverse)."""
    return RAS_TO_LPS_4 @ matrix @ RAS_TO_LPS_4


def voxel_positions(world: NDArray[np.float64], shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``(nx, ny, nz, 3)`` positions of a grid's voxels by its 4x4 voxel-to-world matrix (nibabel's i, j, k order)."""
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij"), -1)
    return index @ world[:3, :3].T + world[:3, 3]


def lps_field(nifti: NiftiFile, displacements: NDArray[np.float64], *, outside: str = "zero") -> DisplacementField:
    """RAS displacements on the file's own grid (``(nx, ny, nz, 3)``) as an ITK displacement field (LPS)."""
    world = nifti.world()
    axes = RAS_TO_LPS @ world[:3, :3]
    spacing = np.linalg.norm(axes, axis=0)
    try:
        vectors_kji = (displacements @ RAS_TO_LPS.T).transpose(2, 1, 0, 3)  # nibabel's (i, j, k) to array order
        return DisplacementField(vectors_kji, spacing, RAS_TO_LPS @ world[:3, 3], axes / spacing, outside=outside)
    except ValueError as exc:
        raise nifti.fail(str(exc)) from None


def _short(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:200] or type(exc).__name__


def vector_data(nifti: NiftiFile) -> NDArray[np.float64]:
    """A file's data as ``(nx, ny, nz, 3)`` vectors: NiftyReg's and ITK's ``(nx, ny, nz, 1, 3)`` or FSL's
    ``(nx, ny, nz, 3)``; anything else refused with what was found."""
    assert nifti.data is not None
    values = nifti.data
    if values.ndim == 5 and values.shape[3] == 1:
        values = values[:, :, :, 0, :]
    if values.ndim != 4 or values.shape[3] != 3:
        raise nifti.fail(f"expected 3D vectors, (nx, ny, nz, 1, 3) or (nx, ny, nz, 3), got data of shape "
                         f"{nifti.shape}")  # fmt: skip
    return values


def check_millimetres(nifti: NiftiFile) -> None:
    """Refuse spatial units other than millimetres (or unknown, which NiftyReg and FSL take as millimetres)."""
    units = int(nifti.header["xyzt_units"]) & 0x07
    if units not in (0, 2):
        raise nifti.fail(f"spatial units are {_UNITS.get(units, units)}; NiftyReg and FSL files are in "
                         "millimetres (NiftyReg rescales the voxel size, not the sform): not read")  # fmt: skip


def write_nifti(path: str | os.PathLike[str], image: Any) -> None:
    """Save a nibabel image atomically: through a temporary file in the same folder (nibabel chooses compression
    by the file name's suffix, so the temporary file has the target's ``.nii`` or ``.nii.gz``)."""
    import nibabel as nib

    name = os.fspath(path).lower()
    if not name.endswith((".nii", ".nii.gz")):
        raise ValueError(f"{os.fspath(path)}: expected a .nii or .nii.gz file name")
    with atomic_path(path) as tmp:
        staging = tmp.with_name("." + tmp.name.replace(".", "_") + (".nii.gz" if name.endswith(".gz") else ".nii"))
        try:
            nib.save(image, staging)
            os.replace(staging, tmp)
        finally:
            staging.unlink(missing_ok=True)
