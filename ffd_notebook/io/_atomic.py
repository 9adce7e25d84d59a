"""Atomic file replacement: write to a temporary file in the target's folder, then rename.

``os.replace`` within one folder is atomic on POSIX and Windows, so a reader (or a crash) sees
either the old file or the complete new one, never a half-written file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

__all__ = ["atomic_open", "atomic_path"]


def _default_mode() -> int:
    """File mode a plain ``open(path, "w")`` would give (``mkstemp`` uses 0o600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _real_target(path: str | os.PathLike[str]) -> Path:
    """The file a save must replace: a symbolic link is followed, so the link stays and its file changes."""
    target = Path(path)
    return Path(os.path.realpath(target)) if target.is_symlink() else target


def _fsync_path(path: Path, directory: bool = False) -> None:
    """Flush a file (or a folder's entries, after a rename) to disk where the platform allows it."""
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    if directory and not hasattr(os, "O_DIRECTORY"):
        return  # Windows cannot open a folder; its rename is durable enough
    try:
        fd = os.open(path, flags)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):  # some file systems do not support fsync on folders
            os.fsync(fd)
    finally:
        os.close(fd)


def _about_target(exc: BaseException, tmp: Path, target: Path) -> BaseException:
    """The same error, naming the target instead of the hidden temporary file (which is gone)."""
    if isinstance(exc, OSError) and exc.errno is not None and str(tmp) in (str(exc.filename), str(exc.filename2)):
        renamed = type(exc)(exc.errno, exc.strerror, os.fspath(target))
    elif isinstance(exc, Exception) and len(exc.args) == 1 and isinstance(exc.args[0], str) and tmp.name in exc.args[0]:
        try:
            renamed = type(exc)(exc.args[0].replace(str(tmp), str(target)).replace(tmp.name, target.name))
        except Exception:  # an exception class with another signature: keep the original
            return exc
    else:
        return exc
    return renamed


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it replaces ``path``.

    The temporary name keeps the extension of ``path`` so that writers choosing a format by
    extension (PyVista's ``mesh.save``) pick the right one. If the body raises, the temporary file
    is removed, ``path`` is left untouched and the error names ``path``, not the temporary file.
    A ``path`` that is a symbolic link keeps being one: the file it points to is replaced. An
    existing file keeps its permission bits. The data and then the folder are ``fsync``-ed, so
    after a power cut the folder holds the old or the new file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("new")
    >>> target.read_text()
    'new'
    >>> with atomic_path(target.parent / "no-such-folder" / "b.txt") as tmp:
    ...     pass
    Traceback (most recent call last):
    ...
    FileNotFoundError: [Errno 2] No such file or directory: '...no-such-folder/b.txt'
    """
    target = _real_target(path)
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=target.parent)
    except OSError as exc:
        raise _about_target(exc, Path(getattr(exc, "filename", "") or ""), target) from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        try:
            mode = target.stat().st_mode & 0o777  # not setuid/setgid: new content, new file
        except FileNotFoundError:
            mode = _default_mode()
        os.chmod(tmp, mode)
        _fsync_path(tmp)
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        renamed = _about_target(exc, tmp, target)
        if renamed is exc:
            raise
        raise renamed from None
    _fsync_path(target.parent, directory=True)


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w", **kwargs) -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; it replaces ``path`` when the block ends.

    The data is flushed and ``fsync``-ed before the rename. On an exception nothing changes.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "b.txt"
    >>> _ = target.write_text("old")
    >>> try:
    ...     with atomic_open(target) as f:
    ...         _ = f.write("half")
    ...         raise OSError("disk full")
    ... except OSError:
    ...     pass
    >>> target.read_text()
    'old'
    """
    if not any(c in mode for c in "wx") or "+" in mode:
        raise ValueError(f"atomic_open is for writing only, got mode {mode!r}")
    with atomic_path(path) as tmp, open(tmp, mode.replace("x", "w"), **kwargs) as f:
        yield f
        f.flush()
        os.fsync(f.fileno())
