"""HDF5 files read safely: what the file itself holds, nothing it points to, nothing larger than asked.

HDF5 can make a file read others: a dataset's *external storage* keeps its values in any file the
dataset names (``dset.external``), a *virtual dataset* maps other files' datasets, and an *external
link* opens another file when followed. A server that confines its users to a folder cannot let
an uploaded ``.h5`` file do that, and a notebook user reading a transform does not expect it
either: every HDF5 reader of the package (ITK transforms, Statismo models) goes through
:func:`open_hdf5`, :func:`hdf5_get` and :func:`read_dataset`, which refuse all three, follow only
hard links, and check a dataset's declared shape against a limit before a value is read (a small
compressed file can declare gigabytes). :func:`open_hdf5` checks first that the path is a regular
file (a FIFO would block the HDF5 library for ever) and that the file's global heaps add up (the
HDF5 library can loop for ever on a damaged one).
"""

from __future__ import annotations

import contextlib
import mmap
import os
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import FileFormatError
from .file_access import MAX_FILE_BYTES, check_regular_file, open_regular

__all__ = ["check_global_heaps", "dataset_shape", "hdf5_get", "open_hdf5", "read_dataset"]


def check_global_heaps(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> None:
    """Refuse a damaged HDF5 global heap before the HDF5 library reads it.

    The global heap holds variable-length data such as ITK's ``TransformType`` strings, and the
    HDF5 C library can loop forever on a collection whose object sizes do not add up (found by
    fuzzing mutated SimpleITK files). A collection is ``"GCOL"``, version 1, three zero bytes, its
    size (8 bytes), then objects: index (2), reference count (2), reserved (4), size (8), data
    padded to 8 bytes; index 0 is the free space that ends it, its size (header included) all that
    is left. Lengths are 8 bytes, the HDF5 default that ITK and h5py write. This catches the damage
    fuzzing found (an object size that walks into the free space), not every possible one. The
    file is mapped, not read into memory.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "bad.h5"
    >>> _ = path.write_bytes(b"GCOL\\x01\\x00\\x00\\x00" + (64).to_bytes(8, "little") + bytes(8))
    >>> check_global_heaps(path)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...bad.h5: damaged HDF5 global heap at byte 0 (...): not read
    """
    with open_regular(path, max_bytes) as f:
        if os.fstat(f.fileno()).st_size == 0:
            return
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
            size = len(data)
            start = data.find(b"GCOL\x01\x00\x00\x00")
            while start >= 0:
                end = start + int.from_bytes(data[start + 8 : start + 16], "little")
                at = start + 16
                while at + 16 <= end <= size:
                    length = int.from_bytes(data[at + 8 : at + 16], "little")
                    if int.from_bytes(data[at : at + 2], "little") == 0:  # free space: exactly the rest
                        at = at + length if length == end - at else -1
                        break
                    at += 16 + -(-length // 8) * 8
                if at < 0 or not 0 <= end - at < 16 or end > size:
                    raise FileFormatError(path, None, f"damaged HDF5 global heap at byte {start} (its objects do "
                                          "not fill the collection): not read")  # fmt: skip
                start = data.find(b"GCOL\x01\x00\x00\x00", start + 4)


@contextlib.contextmanager
def open_hdf5(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> Iterator[Any]:
    """Open an HDF5 file for reading as an ``h5py.File``, after the checks above (a context manager).

    Raises
    ------
    FileNotFoundError
        No such file.
    FileFormatError
        A FIFO, device or folder, a file over ``max_bytes``, a damaged global heap, or not HDF5.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> _ = path.write_bytes(b"not HDF5")
    >>> with open_hdf5(path) as f:
    ...     pass
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.h5: not a readable HDF5 file (...)
    """
    import h5py

    check_regular_file(path, max_bytes)
    check_global_heaps(path, max_bytes)
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        raise FileFormatError(path, None, f"not a readable HDF5 file ({exc})") from None
    with f:
        yield f


def hdf5_get(path: str | os.PathLike[str], group: Any, name: str) -> Any:
    """``group[name]`` through hard links only, or ``None`` if a part of ``name`` is missing.

    ``name`` is a path of the file (``"/model/mean"``) or relative to ``group``. Each part is looked
    at as a link before it is followed: an external link (another file) or a soft link is refused.

    Raises
    ------
    FileFormatError
        A part of ``name`` is an external, soft or user-defined link; names the file and the link.

    Examples
    --------
    >>> import pathlib, tempfile, h5py
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> with h5py.File(path, "w") as f:
    ...     f["model/mean"] = [1.0, 2.0]
    ...     f["elsewhere"] = h5py.ExternalLink("/etc/other.h5", "/x")
    >>> with open_hdf5(path) as f:
    ...     print(hdf5_get(path, f, "/model/mean").shape, hdf5_get(path, f, "model/none"))
    (2,) None
    >>> with open_hdf5(path) as f:
    ...     hdf5_get(path, f, "elsewhere/x")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.h5: HDF5 link /elsewhere: an external link (to another file); ...
    """
    import h5py

    current = group.file if name.startswith("/") else group
    for part in (p for p in name.split("/") if p):
        if not isinstance(current, h5py.Group):
            return None
        link = current.get(part, getlink=True)
        if link is None:
            return None
        if not isinstance(link, h5py.HardLink):
            kind = {h5py.ExternalLink: "an external link (to another file)", h5py.SoftLink: "a soft link"}.get(
                type(link), "a user-defined link"
            )
            where = f"{current.name.rstrip('/')}/{part}"
            raise FileFormatError(path, None, f"HDF5 link {where}: {kind}; only objects stored under their own "
                                  "name in this file are read")  # fmt: skip
        current = current[part]
    return current


def dataset_shape(path: str | os.PathLike[str], item: Any, *, max_values: int) -> tuple[int, ...]:
    """The shape of a dataset whose values are in this file, checked against ``max_values`` (nothing read).

    Raises
    ------
    FileFormatError
        Not a dataset, a dataset stored in other files (external storage, a virtual dataset), or
        more than ``max_values`` values; names the file and the dataset.

    Examples
    --------
    >>> import pathlib, tempfile, h5py
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> with h5py.File(path, "w") as f:
    ...     _ = f.create_dataset("big", shape=(10**6, 10**6), dtype="f8", chunks=(1, 1), compression="gzip")
    >>> with open_hdf5(path) as f:
    ...     dataset_shape(path, f["big"], max_values=10**8)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.h5: HDF5 dataset /big: declares 1000000000000 values, more than ...
    """
    import h5py

    if not isinstance(item, h5py.Dataset):
        raise FileFormatError(path, None, f"HDF5 {getattr(item, 'name', item)}: expected a dataset")
    if item.is_virtual:
        raise FileFormatError(path, None, f"HDF5 dataset {item.name}: a virtual dataset (its values are in other "
                              "files): refused")  # fmt: skip
    if item.external:
        raise FileFormatError(path, None, f"HDF5 dataset {item.name}: its values are stored in another file "
                              "(external storage): refused")  # fmt: skip
    shape = tuple(int(n) for n in item.shape) if item.shape is not None else ()
    values = int(np.prod(np.array(shape, dtype=np.float64)))
    if values > max_values:
        raise FileFormatError(path, None, f"HDF5 dataset {item.name}: declares {values} values, more than the "
                              f"{max_values} accepted")  # fmt: skip
    return shape


def read_dataset(path: str | os.PathLike[str], item: Any, *, max_values: int) -> Any:
    """The values of a dataset (``item[()]``) after :func:`dataset_shape`'s checks.

    Examples
    --------
    >>> import pathlib, tempfile, h5py
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> with h5py.File(path, "w") as f:
    ...     f["x"] = [1.0, 2.0, 3.0]
    >>> with open_hdf5(path) as f:
    ...     read_dataset(path, f["x"], max_values=10).tolist()
    [1.0, 2.0, 3.0]
    """
    dataset_shape(path, item, max_values=max_values)
    return item[()]
