"""Statismo/Scalismo shape-model files (HDF5): :func:`load_model` and :func:`save_model`.

The layout is the one Scalismo's ``StatismoIO`` reads and writes (format 0.9):

- ``/model/mean`` ``(3N,)``: the mean *shape*, points flattened ``x0 y0 z0 x1 ...``;
- ``/model/pcaBasis`` ``(3N, r)``: basis vectors in the columns, rows in the same order;
- ``/model/pcaVariance`` ``(r,)`` and ``/model/noiseVariance`` ``(1,)``;
- ``/representer`` with string attributes ``name``, ``datasetType``, ``version/majorVersion``,
  ``version/minorVersion``, and datasets ``points`` ``(3, N)`` (one row per coordinate) and
  ``cells`` ``(3, M)`` (one column per triangle, absent for point sets);
- ``/version/majorVersion`` = 0, ``/version/minorVersion`` = 9 (scalar integers);
- ``/modelinfo``: build time and builder notes (strings; kept as read).

An instance is ``mean + pcaBasis @ (sqrt(pcaVariance) * c)``; Scalismo does not require the
basis to be orthonormal and neither does :func:`load_model` (the model keeps the file's basis).
Format 0.8 stored ``pcaBasis * sqrt(pcaVariance)``; it is divided back as Scalismo does.
Arrays are float32 and int32 in the file, float64 and int64 in memory. Only a model at the
file's root is read (Scalismo's default ``modelPath``).

Examples
--------
>>> import numpy as np, tempfile, pathlib
>>> from ffd_notebook.gp import LowRankGP, load_model, save_model
>>> ref = np.random.default_rng(0).random((50, 3))
>>> model = LowRankGP.from_examples(ref, [ref, ref + 0.1, ref - 0.05 * ref])
>>> path = pathlib.Path(tempfile.mkdtemp()) / "model.h5"
>>> save_model(path, model)
>>> back = load_model(path)
>>> back.rank, bool(np.allclose(back.instance([1.0, -1.0]), model.instance([1.0, -1.0]), atol=1e-5))
(2, True)
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .._util.hdf5 import dataset_shape, hdf5_get, open_hdf5, read_dataset
from ..errors import FileFormatError
from .lowrank import LowRankGP

__all__ = ["load_model", "save_model"]

_BUILDER_NOTE = "ffd_notebook (Python); the model was built or edited outside Statismo"


def _decode(value: object) -> object:
    """Strings as str (h5py gives bytes arrays of length 1 for Scalismo's strings), arrays as arrays."""
    arr = np.asarray(value)
    if arr.dtype.kind == "S":
        return arr.reshape(-1)[0].decode("utf-8", "replace") if arr.size else ""
    return arr


_MAX_VALUES = 2**27  #: the most numbers a model file may declare in all (1 GiB of float64): checked before reading


def _item(f, path: str, name: str):
    """``f[name]`` through hard links only (an external or soft link is refused), or None if missing."""
    return hdf5_get(path, f, name)


def _shape(f, path: str, name: str, ndim: int, kind: str = "f") -> tuple[int, ...]:
    """The shape of dataset ``name`` (``ndim`` dimensions of numbers, stored in this file), nothing read."""
    item = _item(f, path, name)
    if item is None:
        raise FileFormatError(path, None, f"dataset {name} is missing")
    shape = dataset_shape(path, item, max_values=_MAX_VALUES)
    if item.dtype.kind not in ("f", "i", "u") or (kind == "i" and item.dtype.kind == "f"):
        raise FileFormatError(path, None, f"dataset {name}: expected {'integers' if kind == 'i' else 'numbers'}")
    if len(shape) != ndim:
        raise FileFormatError(path, None, f"dataset {name}: expected {ndim} dimensions, got shape {shape}")
    return shape


def _dataset(f, path: str, name: str, kind: str = "f") -> NDArray:
    """The values of dataset ``name`` (its shape checked by :func:`_shape` first), finite if numbers."""
    arr = read_dataset(path, _item(f, path, name), max_values=_MAX_VALUES)
    if kind == "f" and not np.all(np.isfinite(arr)):
        raise FileFormatError(path, None, f"dataset {name} contains NaN or infinite values")
    return arr.astype(np.float64 if kind == "f" else np.int64)


def _version(f, path: str) -> tuple[int, int]:
    try:
        return tuple(int(read_dataset(path, _item(f, path, f"/version/{key}"), max_values=1))  # type: ignore[return-value]
                     for key in ("majorVersion", "minorVersion"))  # fmt: skip
    except (FileFormatError, TypeError, ValueError):
        raise FileFormatError(path, None, "dataset /version/majorVersion or /version/minorVersion is missing") from None


def _modelinfo(f, path: str) -> dict[str, object]:
    """Every item under /modelinfo: datasets by value, groups as None (so empty groups survive); hard links only."""
    import h5py

    out: dict[str, object] = {}

    def walk(group, prefix: str) -> None:
        for key in group:
            item = hdf5_get(path, group, key)
            name = f"{prefix}{key}"
            if isinstance(item, h5py.Group):
                out[name] = None
                walk(item, f"{name}/")
            else:
                out[name] = read_dataset(path, item, max_values=_MAX_VALUES)

    info = _item(f, path, "modelinfo")
    if isinstance(info, h5py.Group):
        walk(info, "")
    return out


def load_model(path: str | os.PathLike[str]) -> LowRankGP:
    """Read a Statismo/Scalismo shape model (HDF5) as a :class:`~ffd_notebook.gp.LowRankGP`.

    The model's ``points`` are the representer's points (the
    reference), its mean the file's mean shape minus them, :attr:`~ffd_notebook.gp.LowRankGP.cells`
    the triangles; ``model.metadata`` keeps the rest (representer attributes, noise variance,
    modelinfo) so :func:`save_model` writes it back unchanged. Only what the file holds is read:
    links to other files, external storage and virtual datasets are refused, and the datasets'
    shapes are checked against each other and a limit (2^27 numbers in all) before
    a value is read.

    Parameters
    ----------
    path : str or os.PathLike
        A Statismo/Scalismo ``.h5`` file.

    Returns
    -------
    LowRankGP
        The model, its basis as the file has it.

    Raises
    ------
    FileFormatError
        Not HDF5 (or a FIFO, a device), a dataset missing, of the wrong shape or type, too large,
        stored outside the file, or holding NaN; the message names the dataset.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from ffd_notebook.gp import LowRankGP
    >>> ref = np.random.default_rng(0).random((20, 3))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.h5"
    >>> save_model(path, LowRankGP.from_examples(ref, [ref, ref + 0.1, ref * 1.1]))
    >>> load_model(path).rank
    2
    """
    import h5py

    path = os.fspath(path)
    with open_hdf5(path) as f:
        rep = _item(f, path, "representer")
        if not isinstance(rep, h5py.Group):
            raise FileFormatError(path, None, "group /representer is missing")
        attrs = {key: _decode(value) for key, value in rep.attrs.items()}
        if attrs.get("name") in ("vtkPolyDataRepresenter", "itkMeshRepresenter") and "reference" in rep:
            raise FileFormatError(path, None, "dataset /representer/reference: VTK-file representers are not supported")
        major, minor = _version(f, path)
        if (major, minor) not in ((0, 8), (0, 9)) and major != 1:
            raise FileFormatError(path, None, f"dataset /version: unsupported Statismo version {major}.{minor}")
        # every shape is checked against the others and the limit before a single value is read
        points = _shape(f, path, "/representer/points", 2)
        if points[0] != 3:
            raise FileFormatError(path, None, f"dataset /representer/points: expected shape (3, N), got {points}")
        n = points[1]
        mean = _shape(f, path, "/model/mean", 1)
        basis = _shape(f, path, "/model/pcaBasis", 2)
        variances = _shape(f, path, "/model/pcaVariance", 1)
        if mean != (3 * n,):
            raise FileFormatError(path, None, f"dataset /model/mean: expected shape ({3 * n},), got {mean}")
        if basis[0] != 3 * n:
            raise FileFormatError(path, None, f"dataset /model/pcaBasis: expected shape ({3 * n}, r), got {basis}")
        if variances != (basis[1],):
            raise FileFormatError(
                path, None, f"dataset /model/pcaVariance: expected shape ({basis[1]},), got {variances}"
            )
        has_cells = _item(f, path, "/representer/cells") is not None
        cells_shape = _shape(f, path, "/representer/cells", 2, kind="i") if has_cells else (3, 0)
        if cells_shape[0] != 3:
            raise FileFormatError(path, None, f"dataset /representer/cells: expected (3, M) point indices below {n}, "
                                  f"got {cells_shape}")  # fmt: skip
        has_noise = _item(f, path, "/model/noiseVariance") is not None
        noise_shape = _shape(f, path, "/model/noiseVariance", 1) if has_noise else (1,)
        total = 4 * n + basis[0] * basis[1] + basis[1] + 3 * cells_shape[1] + noise_shape[0]
        if total > _MAX_VALUES:
            raise FileFormatError(path, None, f"the model declares {total} numbers, more than the {_MAX_VALUES} "
                                  "accepted")  # fmt: skip
        point_array = _dataset(f, path, "/representer/points")
        mean_array = _dataset(f, path, "/model/mean")
        basis_array = _dataset(f, path, "/model/pcaBasis")
        variance_array = _dataset(f, path, "/model/pcaVariance")
        if np.any(variance_array < 0):
            raise FileFormatError(path, None, "dataset /model/pcaVariance has negative variances")
        cells = None
        if has_cells:
            cells = _dataset(f, path, "/representer/cells", kind="i")
            if cells.size and (cells.min() < 0 or cells.max() >= n):
                raise FileFormatError(
                    path,
                    None,
                    f"dataset /representer/cells: expected (3, M) point indices below {n}, got {cells.shape}",
                )
            cells = cells.T.copy()
        noise = _dataset(f, path, "/model/noiseVariance") if has_noise else np.zeros(1)
        info = _modelinfo(f, path)
    if (major, minor) == (0, 8):  # the old format stored basis * sqrt(variance) (Scalismo divides it back)
        root = np.sqrt(variance_array)
        basis_array = basis_array * np.divide(1.0, root, out=np.zeros_like(root), where=root > 1e-8)
    reference = point_array.T.copy()
    model = LowRankGP.from_basis_matrix(reference, mean_array.reshape(n, 3) - reference, basis_array,
                                        variance_array, cells)  # fmt: skip
    model.metadata = {"representer": attrs, "noise_variance": noise, "modelinfo": info}
    return model


def _write_string_attribute(group, name: str, value: str) -> None:
    """As Scalismo's HDF5 writer: a length-1 array of a NUL-terminated fixed-length string."""
    data = value.encode("utf-8")
    group.attrs.create(name, np.array([data], dtype=f"S{len(data) + 1}"))


def _write_string(f, name: str, value: object) -> None:
    if isinstance(value, str):
        data = value.encode("utf-8")
        value = np.array([data], dtype=f"S{len(data) + 1}")
    f.create_dataset(name, data=value)


def save_model(path: str | os.PathLike[str], model: LowRankGP) -> None:
    """Write a :class:`~ffd_notebook.gp.LowRankGP` as a Statismo 0.9 file Scalismo reads.

    The mean shape is ``model.points + model.mean()``, the basis
    :meth:`~ffd_notebook.gp.LowRankGP.basis_matrix` with its variances
    :attr:`~ffd_notebook.gp.LowRankGP.eigenvalues`. A model read by :func:`load_model` keeps its
    representer attributes and modelinfo. The file is written to a temporary name in the same
    folder and renamed, so an existing file is replaced whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.h5`` file to write (atomically).
    model : LowRankGP
        The model.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib, h5py
    >>> from ffd_notebook.gp import LowRankGP
    >>> ref = np.random.default_rng(0).random((20, 3))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.h5"
    >>> save_model(path, LowRankGP.from_examples(ref, [ref, ref + 0.1, ref * 1.1]))
    >>> with h5py.File(path) as f:
    ...     f["model/pcaBasis"].shape
    (60, 2)
    """
    import h5py

    if not isinstance(model, LowRankGP):
        raise TypeError(f"model must be a LowRankGP, got {type(model).__name__}")
    meta = model.metadata or {}
    cells = model.cells
    rep_attrs = dict(meta.get("representer") or {})
    rep_attrs.setdefault("name", "itkStandardMeshRepresenter")
    rep_attrs.setdefault("version/majorVersion", "0")
    rep_attrs.setdefault("version/minorVersion", "9")
    rep_attrs.setdefault("datasetType", "POLYGON_MESH" if cells is not None else "POINT_SET")
    now = time.strftime("%a %b %d %H:%M:%S %Z %Y")
    info = meta.get("modelinfo") or {
        "build-time": now,
        "modelBuilder-0": None,
        "modelBuilder-0/buildTime": now,
        "modelBuilder-0/builderName": _BUILDER_NOTE,
        "modelBuilder-0/parameters": None,
        "modelBuilder-0/dataInfo": None,
    }
    mean_shape = (model.points + model.mean()).ravel()
    target = Path(path)
    # the model layer cannot use ffd_notebook.io's atomic helper (that package imports PyVista)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp.h5", dir=target.parent)
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f.create_dataset("model/mean", data=mean_shape.astype(np.float32))
            f.create_dataset("model/noiseVariance", data=np.asarray(meta.get("noise_variance", [0.0]), np.float32))
            f.create_dataset("model/pcaBasis", data=model.basis_matrix().astype(np.float32))
            f.create_dataset("model/pcaVariance", data=model.eigenvalues.astype(np.float32))
            for name in sorted(info, key=lambda s: s.count("/")):
                if info[name] is None:
                    f.require_group(f"modelinfo/{name}")
                else:
                    _write_string(f, f"modelinfo/{name}", info[name])
            rep = f.create_group("representer")
            for key, value in rep_attrs.items():
                _write_string_attribute(rep, key, str(value))
            rep.create_dataset("points", data=model.points.T.astype(np.float32))
            if cells is not None and len(cells):
                rep.create_dataset("cells", data=np.ascontiguousarray(cells.T, dtype=np.int32))
            f.create_dataset("version/majorVersion", data=np.int32(0))
            f.create_dataset("version/minorVersion", data=np.int32(9))
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
