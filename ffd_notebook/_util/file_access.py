"""What a reader may open: regular files of bounded size, and the files a file names, by one rule.

Every reader of the package goes through :func:`check_regular_file` (or :func:`read_bytes`, which
calls it) before a single byte is read, so a FIFO cannot freeze a server, ``/dev/zero`` cannot
fill the memory and a directory gives a clear error. The servers call it too for typed paths.

Some files name other files: an image header its pixel files (MetaImage ``ElementDataFile``, NRRD
``data file``, a NIfTI ``.hdr``'s ``.img``), an elastix parameter file the transform before it
(``InitialTransformParameterFileName``). Every such name goes through :func:`named_file`: resolved
beside the file that names it (as ITK and elastix resolve it), refused outside the folder the
reader may read from (``within``: the app's folder; ``None`` in a notebook, where a header reads
whatever it names, as ITK does), and checked as any file is. Outside ``within``, the answer is
the same whether the file exists or not, and nothing is asked of the file system about it.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

from ..errors import FileFormatError

__all__ = ["MAX_FILE_BYTES", "check_regular_file", "is_inside", "named_file", "open_regular", "read_bytes"]

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


def is_inside(path: str | os.PathLike[str], folder: str | os.PathLike[str]) -> bool:
    """Whether ``path``, symbolic links and ``..`` resolved, is ``folder`` or lies under it.

    Nothing is opened; a path that cannot be resolved (a symbolic-link loop) is not inside.

    Examples
    --------
    >>> is_inside("/srv/data/a/../b.raw", "/srv/data"), is_inside("/srv/data/../etc/passwd", "/srv/data")
    (True, False)
    """
    try:
        resolved = Path(path).resolve(strict=False)
        root = Path(folder).resolve(strict=False)
    except (OSError, RuntimeError, ValueError):
        return False
    return resolved == root or resolved.is_relative_to(root)


def named_file(owner: str | os.PathLike[str], name: str, *, within: str | os.PathLike[str] | None = None,
               what: str = "data file", line: int | None = None, max_bytes: int = MAX_FILE_BYTES) -> Path:  # fmt: skip
    """The file that ``owner`` names ``name``, checked: the one rule for files a file names.

    ``name`` is taken beside ``owner`` (the folder of ``owner`` as given, as ITK and elastix take
    it) unless it is absolute. With ``within``, a name that resolves (symbolic links and ``..``
    followed) outside that folder is refused before the file system is asked anything about it,
    with one message whether or not the file exists. Then the file must be a regular file of at
    most ``max_bytes`` (a FIFO would block the reader, ``/dev/zero`` never end).

    Parameters
    ----------
    owner : str or os.PathLike
        The file whose content names ``name`` (an image header, an elastix parameter file).
    name : str
        The name as the file writes it.
    within : str or os.PathLike, optional
        The folder every named file must be in (the app's folder, or an upload's own folder);
        ``None``: anywhere.
    what : str
        What the named file is, for messages (``"data file"``, ``"initial transform"``).
    line : int, optional
        The line of ``owner`` that names it, for messages.
    max_bytes : int
        The largest size accepted.

    Returns
    -------
    pathlib.Path
        The named file as the reader will open it (not resolved: the path ITK or elastix opens).

    Raises
    ------
    FileFormatError
        Names ``owner`` (and ``line``): an empty name, a name outside ``within``, a missing file, a
        FIFO, device, folder or oversize file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.raw").write_bytes(bytes(8))
    >>> named_file(folder / "a.mhd", "a.raw", within=folder) == folder / "a.raw"
    True
    >>> named_file(folder / "a.mhd", "../../etc/passwd", within=folder, line=5)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.mhd, line 5: names a data file outside the folder it may read from ...
    >>> named_file(folder / "a.mhd", "/dev/zero")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...a.mhd: its data file is a character device, not a regular file: ...
    """
    if not name or "\x00" in name:
        raise FileFormatError(owner, line, f"names an empty {what}" if not name else f"a {what} name with a NUL byte")
    target = Path(name) if os.path.isabs(name) else Path(owner).parent / name
    if within is not None and not is_inside(target, within):
        raise FileFormatError(owner, line, f"names a {what} outside the folder it may read from ({name!r})")
    try:
        info = os.stat(target)
    except FileNotFoundError:
        raise FileFormatError(owner, line, f"its {what} does not exist ({name!r})") from None
    except OSError as exc:
        raise FileFormatError(owner, line, f"its {what} cannot be read ({name!r}: {exc.strerror})") from None
    mode = info.st_mode
    if not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else _KINDS.get(stat.S_IFMT(mode), "not a regular file")
        raise FileFormatError(owner, line, f"its {what} is {kind}, not a regular file: refused ({name!r})")
    if info.st_size > max_bytes:
        raise FileFormatError(owner, line, f"its {what} is too large ({name!r}: {info.st_size} bytes; the limit is "
                              f"{max_bytes})")  # fmt: skip
    return target
