"""ITK's MATLAB transform files (``.mat``): what ANTs writes its affine transforms in (``0GenericAffine.mat``).

ITK's ``MatlabTransformIO`` (``itkMatlabTransformIO.hxx``) writes each transform as two MATLAB level-4 matrices,
each a column vector: the parameters, named by the transform type (``AffineTransform_float_3_3``), then the fixed
parameters, named ``fixed``; several transforms follow one another. A level-4 matrix is a 20-byte header of five
32-bit integers (type ``MOPT``, rows, columns, an imaginary flag, the name's length with its final NUL), the name,
then the values column by column. ``M`` is the byte order (0 little-endian, 1 big-endian), ``O`` is 0, ``P`` the
precision (0 float64, 1 float32; ITK reads both), ``T`` 0 for a numeric matrix.

Written by hand rather than with ``scipy.io.loadmat``: that returns a dictionary, which loses the order of the
matrices and every repeated ``fixed`` but the last, and allocates what a header declares before checking it.
"""

from __future__ import annotations

import os
import struct

import numpy as np

from ..errors import FileFormatError
from ._atomic import atomic_open
from ._safety import read_bytes
from .itk_model import RawTransform

__all__ = ["read_itk_matlab", "write_itk_matlab"]

_MAX_VALUES = 3 * 2**24  # as for ITK's HDF5 files: the parameters of a 256^3 grid
_MAX_NAME = 1024
_PRECISIONS = {0: "f8", 1: "f4"}


def _matrix(path: str | os.PathLike[str], data: bytes, at: int) -> tuple[str, np.ndarray, int]:
    """The name and values of the level-4 matrix starting at byte ``at``, and where the next one starts."""
    where = f"the matrix at byte {at}"
    if len(data) - at < 20:
        raise FileFormatError(path, None, f"{where}: a truncated header ({len(data) - at} of 20 bytes)")
    little = struct.unpack_from("<i", data, at)[0]
    order = "<" if 0 <= little < 1000 else ">"  # the type's thousands digit is the byte order
    mopt, rows, cols, imaginary, length = struct.unpack_from(order + "5i", data, at)
    m, o, p, t = mopt // 1000, mopt // 100 % 10, mopt // 10 % 10, mopt % 10
    if mopt < 0 or m > 1 or o != 0 or p not in _PRECISIONS or t != 0:
        raise FileFormatError(path, None, f"{where}: type {mopt} is not a MATLAB level-4 numeric matrix of "
                              "float64 or float32 (an ITK .mat transform file holds those)")  # fmt: skip
    if imaginary != 0:
        raise FileFormatError(path, None, f"{where}: a complex matrix; ITK transform parameters are real")
    if not 1 <= length <= _MAX_NAME:
        raise FileFormatError(path, None, f"{where}: a name of {length} bytes (expected 1 to {_MAX_NAME})")
    if rows < 0 or cols != 1 or rows > _MAX_VALUES:
        raise FileFormatError(path, None, f"{where}: a {rows}x{cols} matrix; ITK reads column vectors of at most "
                              f"{_MAX_VALUES} values")  # fmt: skip
    at += 20
    raw_name = data[at : at + length]
    if len(raw_name) < length or raw_name[-1:] != b"\x00":
        raise FileFormatError(path, None, f"{where}: its name is truncated or lacks its final NUL byte")
    try:
        name = raw_name[:-1].decode("ascii")
    except UnicodeDecodeError:
        raise FileFormatError(path, None, f"{where}: its name is not ASCII text") from None
    at += length
    dtype = np.dtype(order + _PRECISIONS[p])
    size = rows * dtype.itemsize
    if len(data) - at < size:
        raise FileFormatError(path, None, f"matrix {name!r}: truncated ({len(data) - at} of {size} bytes of values)")
    values = np.frombuffer(data, dtype, rows, at).astype(np.float64)
    if not np.all(np.isfinite(values)):
        raise FileFormatError(path, None, f"matrix {name!r}: contains NaN or infinite values")
    return name, values, at + size


def read_itk_matlab(path: str | os.PathLike[str]) -> list[RawTransform]:
    """The transforms of an ITK ``.mat`` transform file, in order (what ``MatlabTransformIO`` reads).

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    list of RawTransform
        One per pair of matrices: the first names the transform type and holds its parameters, the second its
        fixed parameters (ITK does not read its name; it writes ``fixed``).

    Raises
    ------
    FileFormatError
        Anything but whole pairs of real column vectors in float64 or float32; names the file and the matrix.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "affine.mat"
    >>> affine = RawTransform("AffineTransform_double_3_3", np.r_[np.eye(3).ravel(), 1.0, 2.0, 3.0], np.zeros(3))
    >>> write_itk_matlab(path, [affine])
    >>> [(t.kind, t.parameters[9:].tolist()) for t in read_itk_matlab(path)]
    [('AffineTransform_double_3_3', [1.0, 2.0, 3.0])]
    """
    data = read_bytes(path)
    matrices = []
    at = 0
    while at < len(data):
        name, values, at = _matrix(path, data, at)
        matrices.append((name, values))
    if not matrices:
        raise FileFormatError(path, None, "an empty file; expected ITK transform parameters as MATLAB matrices")
    if len(matrices) % 2:
        raise FileFormatError(path, None, f"matrix {matrices[-1][0]!r} has no fixed parameters after it (ITK writes "
                              "each transform as two matrices: parameters, then 'fixed')")  # fmt: skip
    out = []
    for i in range(0, len(matrices), 2):
        (kind, params), (_, fixed) = matrices[i], matrices[i + 1]
        where = {"kind": f"matrix {kind!r}", "parameters": f"matrix {kind!r}", "fixed": f"the 'fixed' after {kind!r}"}
        out.append(RawTransform(kind, params, fixed, where))  # type: ignore[arg-type]
    return out


def _header(name: str, rows: int) -> bytes:
    encoded = name.encode("ascii") + b"\x00"
    return struct.pack("<5i", 0, rows, 1, 0, len(encoded)) + encoded  # little-endian float64, real, full


def write_itk_matlab(path: str | os.PathLike[str], transforms: list[RawTransform]) -> None:
    """Write transforms as ITK's ``MatlabTransformIO`` does (float64, little-endian), atomically.

    A composite transform has no parameters of its own: ITK's writer lists its children, and so must
    ``transforms``.
    """
    chunks = []
    for raw in transforms:
        if raw.kind.startswith("CompositeTransform"):
            raise ValueError("an ITK .mat file holds a list of transforms, not a CompositeTransform: ITK's reader "
                             "would apply them one by one, not composed")  # fmt: skip
        for name, values in ((raw.kind, raw.parameters), ("fixed", raw.fixed)):
            array = np.ascontiguousarray(values, dtype="<f8").ravel()
            chunks.append(_header(name, len(array)) + array.tobytes())
    with atomic_open(path, "wb") as f:
        f.write(b"".join(chunks))
