"""ITK's HDF5 transform files (``.h5``, ``.hdf5``), through h5py.

The layout ITK's ``HDF5TransformIO`` writes (learnt from files SimpleITK wrote): a group
``/TransformGroup`` with one subgroup per transform, named ``0``, ``1``, ... in order; each holds
``TransformType`` (a one-element string array), ``TransformParameters`` and
``TransformFixedParameters`` (1-D float arrays). A composite transform is a group holding only its
``TransformType``, followed by its children. ITK also writes ``/ITKVersion``, ``/HDFVersion``,
``/OSName`` and ``/OSVersion`` strings, which its reader does not need.

Only what the file itself holds is read (:mod:`ffd_notebook._util.hdf5`): external storage,
virtual datasets and links to other files are refused, as are a FIFO and a damaged global heap.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .._util.hdf5 import dataset_shape, hdf5_get, open_hdf5, read_dataset
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
    item = hdf5_get(path, group, name)
    if item is None or not hasattr(item, "dtype"):
        raise _fail(path, where, "missing; expected the transform type as a string")
    if item.dtype.kind not in "OSU" or dataset_shape(path, item, max_values=1) not in ((1,), ()):
        raise _fail(path, where, f"expected one string, got {item.dtype} data of shape {item.shape}")
    value = read_dataset(path, item, max_values=1)
    value = value if item.shape == () else value[0]
    if isinstance(value, bytes):
        try:
            value = value.decode("ascii")
        except UnicodeDecodeError:
            raise _fail(path, where, "the transform type is not ASCII text") from None
    return str(value).strip("\x00 ")


def _floats(path: str | os.PathLike[str], group: Any, name: str) -> np.ndarray:
    where = f"{group.name}/{name}"
    item = hdf5_get(path, group, name)
    if item is None or not hasattr(item, "dtype"):
        raise _fail(path, where, "missing; expected a 1-D array of numbers")
    if item.dtype.kind not in "fiu" or item.shape is None or len(item.shape) != 1:
        raise _fail(path, where, f"expected a 1-D array of numbers, got {item.dtype} data of shape {item.shape}")
    values = np.asarray(read_dataset(path, item, max_values=_MAX_VALUES), dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise _fail(path, where, "contains NaN or infinite values")
    return values


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
    with open_hdf5(path) as f:
        try:
            return _read_groups(path, f)
        except FileFormatError:
            raise
        except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:  # h5py on damaged data
            raise FileFormatError(path, None, f"damaged HDF5 data ({type(exc).__name__}: {exc})") from None


def _read_groups(path: str | os.PathLike[str], f: Any) -> list[RawTransform]:
    root = hdf5_get(path, f, _GROUP)
    if root is None or not hasattr(root, "keys"):
        raise _fail(path, f"/{_GROUP}", "missing; not an ITK HDF5 transform file")
    names = list(root.keys())
    if sorted(names) != sorted(str(i) for i in range(len(names))) or not names:
        raise _fail(path, f"/{_GROUP}", f"expected subgroups named 0, 1, ..., got {names[:10]}")
    out = []
    for i in range(len(names)):
        group = hdf5_get(path, root, str(i))
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
