"""Atomic file replacement: write to a temporary file in the target's folder, then rename.

``os.replace`` within one folder is atomic on POSIX and Windows, so a reader (or a crash) sees
either the old file or the complete new one, never a half-written file.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import IO

__all__ = ["atomic_open", "atomic_path", "folder_syncs_deferred"]

# folders whose fsync is put off until the innermost folder_syncs_deferred block ends (None: sync at once)
_DEFERRED: ContextVar[set[Path] | None] = ContextVar("ffd_notebook_deferred_folder_syncs", default=None)


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
    """Flush a file's data (or a folder's entries, after a rename) to disk where the platform allows it.

    A file's failure to flush (no space left, an I/O error) is raised: its data may be lost. A
    folder's is not (some file systems cannot fsync folders, and Windows cannot open them).
    """
    if not directory:
        fd = os.open(path, os.O_RDWR)  # Windows flushes only a writable handle; the file is ours (mkstemp)
        try:
            os.fsync(fd)
        except OSError as exc:
            if exc.errno != errno.EINVAL:  # EINVAL: this file system does not support fsync at all
                raise
        finally:
            os.close(fd)
        return
    if not hasattr(os, "O_DIRECTORY"):
        return  # Windows cannot open a folder; its rename is durable enough
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
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
        renamed: BaseException = type(exc)(exc.errno, exc.strerror, os.fspath(target))
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
    after a power cut the folder holds the old or the new file (the folder's fsync may be put
    off to the end of a :func:`folder_syncs_deferred` block).

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
        # the data first, while the file is still ours to read (mkstemp's 0o600): one journal commit; the
        # mode change is metadata, committed in order with the rename (fsync after it would commit twice)
        _fsync_path(tmp)
        try:
            mode = target.stat().st_mode & 0o777  # not setuid/setgid: new content, new file
        except FileNotFoundError:
            mode = _default_mode()
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        renamed = _about_target(exc, tmp, target)
        if renamed is exc:
            raise
        raise renamed from None
    deferred = _DEFERRED.get()
    if deferred is None:
        _fsync_path(target.parent, directory=True)
    else:
        deferred.add(target.parent)


@contextlib.contextmanager
def folder_syncs_deferred() -> Iterator[None]:
    """Atomic writes in the block fsync their data at once and their folders once, when it ends.

    Each file's data is still flushed before its rename, so a file that exists after a crash is
    complete; what is put off is making the renames themselves durable (one folder fsync per
    folder instead of one per file: each is a journal commit, ~5 ms on a busy disk). A write
    whose rename is lost in a crash is simply absent afterwards. Callers that need "B only
    if A" after a crash write A inside the block and B after it. Per thread (a context variable).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with folder_syncs_deferred():
    ...     for name in ("a.txt", "b.txt"):
    ...         with atomic_open(folder / name) as f:
    ...             _ = f.write(name)
    >>> sorted(p.name for p in folder.iterdir())
    ['a.txt', 'b.txt']
    """
    folders: set[Path] = set()
    token = _DEFERRED.set(folders)
    try:
        yield
    finally:
        _DEFERRED.reset(token)
        for folder in sorted(folders):
            _fsync_path(folder, directory=True)


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w", **kwargs) -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; it replaces ``path`` when the block ends.

    The data is flushed and ``fsync``-ed before the rename (by :func:`atomic_path`). On an
    exception nothing changes.

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
    # closing the file hands its data to the kernel; atomic_path then fsyncs it (once: each is a journal commit)
    with atomic_path(path) as tmp, open(tmp, mode.replace("x", "w"), **kwargs) as f:
        yield f
