"""ITK's HDF5 transform files (``.h5``, ``.hdf5``), through h5py.

The layout ITK's ``HDF5TransformIO`` writes (learnt from files SimpleITK wrote): a group
``/TransformGroup`` with one subgroup per transform, named ``0``, ``1``, ... in order; each holds
``TransformType`` (a one-element string array), ``TransformParameters`` and
``TransformFixedParameters`` (1-D float arrays). A composite transform is a group holding only its
``TransformType``, followed by its children. ITK also writes ``/ITKVersion``, ``/HDFVersion``,
``/OSName`` and ``/OSVersion`` strings, which its reader does not need.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from ._atomic import atomic_path
from .itk_model import RawTransform

__all__ = ["read_itk_h5", "write_itk_h5"]

_GROUP = "TransformGroup"
_MAX_VALUES = 3 * 2**24  # parameters of a 256^3 grid: a bigger dataset is refused before it is read


def _fail(path: str | os.PathLike[str], dataset: str, problem: str) -> FileFormatError:
    return FileFormatError(path, None, f"HDF5 dataset {dataset}: {problem}")


def _string(path: str | os.PathLike[str], group: Any, name: str) -> str:
    where = f"{group.name}/{name}"
    item = group.get(name)
    if item is None or not hasattr(item, "dtype"):
        raise _fail(path, where, "missing; expected the transform type as a string")
    if item.dtype.kind not in "OSU" or item.shape not in ((1,), ()):
        raise _fail(path, where, f"expected one string, got {item.dtype} data of shape {item.shape}")
    value = item[()] if item.shape == () else item[0]
    if isinstance(value, bytes):
        try:
            value = value.decode("ascii")
        except UnicodeDecodeError:
            raise _fail(path, where, "the transform type is not ASCII text") from None
    return str(value).strip("\x00 ")


def _floats(path: str | os.PathLike[str], group: Any, name: str) -> np.ndarray:
    where = f"{group.name}/{name}"
    item = group.get(name)
    if item is None or not hasattr(item, "dtype"):
        raise _fail(path, where, "missing; expected a 1-D array of numbers")
    if item.dtype.kind not in "fiu" or len(item.shape) != 1:
        raise _fail(path, where, f"expected a 1-D array of numbers, got {item.dtype} data of shape {item.shape}")
    if item.shape[0] > _MAX_VALUES:
        raise _fail(path, where, f"{item.shape[0]} values, more than the {_MAX_VALUES} accepted")
    values = np.asarray(item[()], dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise _fail(path, where, "contains NaN or infinite values")
    return values


def _check_global_heaps(path: str | os.PathLike[str]) -> None:
    """Refuse a damaged HDF5 global heap before the HDF5 library reads it.

    The global heap holds variable-length data such as ITK's ``TransformType`` strings, and the
    HDF5 C library can loop forever on a collection whose object sizes do not add up (found by
    fuzzing mutated SimpleITK files). A collection is ``"GCOL"``, version 1, three zero bytes, its
    size (8 bytes), then objects: index (2), reference count (2), reserved (4), size (8), data
    padded to 8 bytes; index 0 is the free space that ends it, its size (header included) all that
    is left. Lengths are 8 bytes, the HDF5 default that ITK and h5py write. This catches the damage
    fuzzing found (an object size that walks into the free space), not every possible one.
    """
    data = Path(path).read_bytes()
    start = data.find(b"GCOL\x01\x00\x00\x00")
    while start >= 0:
        end = start + int.from_bytes(data[start + 8 : start + 16], "little")
        at = start + 16
        while at + 16 <= end <= len(data):
            size = int.from_bytes(data[at + 8 : at + 16], "little")
            if int.from_bytes(data[at : at + 2], "little") == 0:  # free space: exactly the rest of the collection
                at = at + size if size == end - at else -1
                break
            at += 16 + -(-size // 8) * 8
        if at < 0 or not 0 <= end - at < 16 or end > len(data):
            raise FileFormatError(path, None, f"damaged HDF5 global heap at byte {start} (its objects do not fill "
                                  "the collection): not read")  # fmt: skip
        start = data.find(b"GCOL\x01\x00\x00\x00", start + 4)


def read_itk_h5(path: str | os.PathLike[str]) -> list[RawTransform]:
    """The transforms of an ITK HDF5 transform file, in order.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.h5"
    >>> write_itk_h5(p, [RawTransform("TranslationTransform_double_3_3", np.array([1.0, 2, 3]), np.zeros(0))])
    >>> [(t.kind, t.parameters.tolist(), t.where["parameters"]) for t in read_itk_h5(p)]
    [('TranslationTransform_double_3_3', [1.0, 2.0, 3.0], '/TransformGroup/0/TransformParameters')]
    """
    import h5py

    _check_global_heaps(path)
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        raise FileFormatError(path, None, f"not a readable HDF5 file ({exc})") from None
    with f:
        try:
            return _read_groups(path, f)
        except FileFormatError:
            raise
        except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:  # h5py on damaged data
            raise FileFormatError(path, None, f"damaged HDF5 data ({type(exc).__name__}: {exc})") from None


def _read_groups(path: str | os.PathLike[str], f: Any) -> list[RawTransform]:
    root = f.get(_GROUP)
    if root is None or not hasattr(root, "keys"):
        raise _fail(path, f"/{_GROUP}", "missing; not an ITK HDF5 transform file")
    names = list(root.keys())
    if sorted(names) != sorted(str(i) for i in range(len(names))) or not names:
        raise _fail(path, f"/{_GROUP}", f"expected subgroups named 0, 1, ..., got {names[:10]}")
    out = []
    for i in range(len(names)):
        group = root[str(i)]
        if not hasattr(group, "keys"):
            raise _fail(path, group.name, "expected a group")
        kind = _string(path, group, "TransformType")
        if kind.startswith("CompositeTransform"):  # a composite's group holds only its type
            params, fixed = np.zeros(0), np.zeros(0)
        else:
            params = _floats(path, group, "TransformParameters")
            fixed = _floats(path, group, "TransformFixedParameters")
        where = {"kind": "TransformType", "parameters": "TransformParameters", "fixed": "TransformFixedParameters"}
        out.append(RawTransform(kind, params, fixed, {k: f"{group.name}/{v}" for k, v in where.items()}))
    return out


def write_itk_h5(path: str | os.PathLike[str], transforms: list[RawTransform]) -> None:
    """Write transforms in ITK's HDF5 layout, atomically (a temporary file, then rename)."""
    import h5py

    text = h5py.string_dtype("ascii")
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.create_dataset("ITKVersion", data=np.array(["ffd_notebook"], dtype=object), dtype=text)
        for index, raw in enumerate(transforms):
            group = f.create_group(f"/{_GROUP}/{index}")
            group.create_dataset("TransformType", data=np.array([raw.kind], dtype=object), dtype=text)
            if not raw.kind.startswith("CompositeTransform"):
                group.create_dataset("TransformParameters", data=np.asarray(raw.parameters, dtype=np.float64))
                group.create_dataset("TransformFixedParameters", data=np.asarray(raw.fixed, dtype=np.float64))
