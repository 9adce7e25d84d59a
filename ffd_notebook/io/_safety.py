"""Refuse what no reader should open: special files (FIFO, device, socket), directories, huge files.

Every reader of the package goes through :func:`check_regular_file` (or :func:`read_bytes`, which
calls it) before a single byte is read, so a FIFO cannot freeze a server, ``/dev/zero`` cannot
fill the memory and a directory gives a clear error. The servers call it too for typed paths.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterator
from typing import BinaryIO

from ..errors import FileFormatError

__all__ = ["MAX_FILE_BYTES", "check_regular_file", "open_regular", "read_bytes"]

#: Largest file the readers accept (1 GiB): far above any mesh or lattice of this project.
MAX_FILE_BYTES = 1 << 30

_KINDS = {
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def _check_stat(path: str | os.PathLike[str], info: os.stat_result, max_bytes: int) -> None:
    mode = info.st_mode
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(21, "is a directory, expected a file", os.fspath(path))
    if not stat.S_ISREG(mode):
        kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
        raise FileFormatError(path, None, f"refused to read {kind}: expected a regular file")
    if info.st_size > max_bytes:
        raise FileFormatError(path, None, f"file too large to read ({info.st_size} bytes; the limit is {max_bytes})")


def check_regular_file(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> int:
    """Check, without opening it, that ``path`` is a regular file of at most ``max_bytes``.

    Symbolic links are followed (the file they point to is checked).

    Parameters
    ----------
    path : str or os.PathLike
        The file to check.
    max_bytes : int
        The largest size accepted (:data:`MAX_FILE_BYTES` by default).

    Returns
    -------
    int
        The size of the file in bytes.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    IsADirectoryError
        If ``path`` is a directory.
    FileFormatError
        If it is a FIFO, a device or a socket, or larger than ``max_bytes``; names the path.

    Examples
    --------
    >>> check_regular_file("/dev/zero")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: /dev/zero: refused to read a character device: expected a regular file
    """
    info = os.stat(path)
    _check_stat(path, info, max_bytes)
    return info.st_size


@contextlib.contextmanager
def open_regular(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> Iterator[BinaryIO]:
    """Open a regular file of at most ``max_bytes`` for reading in binary (see :func:`check_regular_file`).

    The file is checked before it is opened, opened without blocking (a FIFO swapped in after the
    check cannot stall the open) and checked again on the open descriptor, so what is read is the
    file that was checked.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> _ = path.write_bytes(b"abc")
    >>> with open_regular(path) as f:
    ...     f.read(2)
    b'ab'
    """
    check_regular_file(path, max_bytes)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_BINARY", 0)
    fd = os.open(path, flags)
    with open(fd, "rb", closefd=True) as f:
        _check_stat(path, os.fstat(fd), max_bytes)
        yield f


def read_bytes(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> bytes:
    """The whole content of a regular file of at most ``max_bytes`` (see :func:`open_regular`).

    At most ``max_bytes`` are read even if the file grows meanwhile.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> _ = path.write_bytes(b"abc")
    >>> read_bytes(path)
    b'abc'
    >>> read_bytes(path, max_bytes=2)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.txt: file too large to read (3 bytes; the limit is 2)
    """
    with open_regular(path, max_bytes) as f:
        data = f.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise FileFormatError(path, None, f"file too large to read (more than {max_bytes} bytes)")
    return data
