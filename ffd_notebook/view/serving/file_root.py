"""The standalone app's file access: one root folder, regular files of bounded size, safe messages.

A path typed into the app's page comes from whoever holds the page, possibly over the network, so:

* it is resolved (``..`` and symlinks too) against the app's root folder and refused outside it,
  with one message that does not depend on whether the target exists;
* a file to read must be a regular file (not a FIFO, which would block the server, nor a device
  such as ``/dev/zero``, nor a folder) no bigger than a limit, checked before anything opens it;
* a file to write must have the extension of what is written (a lattice file: ``.ffd``, ITK
  ``.tfm``/``.txt``/``.h5``/``.hdf5``, PyGeM ``.prm``; or a mesh format), so no
  panel action can create a ``.pth``, ``.py`` or ``.bashrc``;
* an error shown on the page names the file by its path inside the root and never quotes the
  file's content (a reader's ``got '...'`` detail stays in the server's log).
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

from ...errors import FileFormatError, NoFaceError, PathRefused
from ...io import check_regular_file
from ...io.deformation_files import DEFORMATION_SUFFIXES

__all__ = [
    "DEFAULT_MAX_FILE_BYTES",
    "FileRoot",
    "PathRefused",
    "ScratchFolder",
    "client_message",
    "refuse_special_or_oversize",
]

DEFAULT_MAX_FILE_BYTES = 512 * 1024 * 1024
#: lattice files the app reads and writes: every deformation format of :mod:`ffd_notebook.io`
FFD_SUFFIXES = tuple(DEFORMATION_SUFFIXES)


def refuse_special_or_oversize(path: str | os.PathLike[str], max_bytes: int) -> None:
    """Raise :class:`PathRefused` unless ``path`` is a regular file of at most ``max_bytes`` bytes.

    The readers' own check (:func:`ffd_notebook.io.check_regular_file`: ``os.stat``, follows
    symlinks, never opens the file, so a FIFO cannot block and a device cannot be read for ever),
    with a message fit for the page. A missing file raises :class:`FileNotFoundError`.

    Examples
    --------
    >>> refuse_special_or_oversize("/dev/zero", 1024)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.PathRefused: /dev/zero is not a regular file
    """
    try:
        check_regular_file(path, max_bytes)
    except IsADirectoryError:
        raise PathRefused(f"{os.fspath(path)} is not a regular file") from None
    except FileFormatError as exc:
        too_big = "too large" in exc.problem
        what = f"bigger than the limit of {max_bytes / 2**20:.0f} MiB" if too_big else "not a regular file"
        raise PathRefused(f"{os.fspath(path)} is {what}") from None


class FileRoot:
    """The folder the app may read and write in.

    Parameters
    ----------
    root : path-like
        The folder (resolved once, symlinks included).
    max_bytes : int
        Largest file the app reads.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = FileRoot(tempfile.mkdtemp())
    >>> root.for_writing("out/../lattice.ffd", FFD_SUFFIXES) == root.path / "lattice.ffd"
    True
    >>> root.for_writing("../lattice.ffd", FFD_SUFFIXES)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.PathRefused: '../lattice.ffd' is outside the app's folder
    >>> root.for_writing("evil.pth", (".ffd", ".tfm"))
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.PathRefused: 'evil.pth': the file name must end with .ffd or .tfm
    """

    def __init__(self, root: str | os.PathLike[str], max_bytes: int = DEFAULT_MAX_FILE_BYTES) -> None:
        self.path = Path(root).expanduser().resolve(strict=True)
        if not self.path.is_dir():
            raise NotADirectoryError(f"the app's root is not a folder: {self.path}")
        self.max_bytes = int(max_bytes)

    def _inside(self, typed: str | os.PathLike[str]) -> Path:
        """``typed`` (relative to the root, or absolute) resolved, or PathRefused if outside the root."""
        text = os.fspath(typed).strip()
        outside = PathRefused(f"{text!r} is outside the app's folder")
        if not text or "\x00" in text:
            raise PathRefused("no file name given")
        try:
            resolved = (self.path / text).resolve(strict=False)
        except (OSError, RuntimeError):  # symlink loops: same answer as outside, whatever is there
            raise outside from None
        if resolved != self.path and not resolved.is_relative_to(self.path):
            raise outside
        return resolved

    def for_reading(self, typed: str | os.PathLike[str]) -> Path:
        """The file to read for ``typed``: inside the root, a regular file, not over the size limit."""
        path = self._inside(typed)
        try:
            refuse_special_or_oversize(path, self.max_bytes)
        except PathRefused as exc:  # name it as the page does
            raise PathRefused(str(exc).replace(os.fspath(path), self.shown(path), 1)) from None
        return path

    def for_writing(self, typed: str | os.PathLike[str], suffixes: tuple[str, ...]) -> Path:
        """The file to write for ``typed``: inside the root, in an existing folder, with one of ``suffixes``."""
        path = self._inside(typed)
        if not path.name.lower().endswith(suffixes):  # endswith: ".nii.gz" is one suffix here
            raise PathRefused(f"{os.fspath(typed).strip()!r}: the file name must end with {' or '.join(suffixes)}")
        if path.exists() and not path.is_file():
            raise PathRefused(f"{self.shown(path)} exists and is not a regular file")
        if not path.parent.is_dir():
            raise FileNotFoundError(f"no folder {self.shown(path.parent)} in the app's folder")
        return path

    def shown(self, path: Path) -> str:
        """``path`` as the page shows it: relative to the root."""
        try:
            return path.relative_to(self.path).as_posix() or "."
        except ValueError:
            return path.name


class ScratchFolder:
    """A private temporary folder (uploads, downloads) that :meth:`cleanup` removes; cleanup is idempotent.

    Examples
    --------
    >>> scratch = ScratchFolder()
    >>> target = scratch.file("../../up load.ffd")
    >>> target.parent == scratch.path, target.name
    (True, 'up_load.ffd')
    >>> scratch.cleanup(); scratch.path.exists()
    False
    """

    def __init__(self, prefix: str = "ffd_notebook_upload_") -> None:
        self.path = Path(tempfile.mkdtemp(prefix=prefix))

    def file(self, name: str) -> Path:
        """A path in the folder for a file called ``name`` (any folder part dropped, odd characters replaced)."""
        base = re.sub(r"[^A-Za-z0-9._-]", "_", Path(str(name)).name).lstrip(".") or "upload"
        return self.path / base[-100:]

    def private_file(self, name: str) -> Path:
        """A path for a file called ``name`` (as :meth:`file`) alone in a new folder of its own inside this one.

        An upload stored there and read with ``within=`` its folder cannot name another file (the
        uploads before it, the downloads).

        Examples
        --------
        >>> scratch = ScratchFolder()
        >>> a, b = scratch.private_file("a.mha"), scratch.private_file("a.mha")
        >>> a.parent != b.parent and a.parent.parent == scratch.path, a.name
        (True, 'a.mha')
        >>> scratch.cleanup()
        """
        folder = Path(tempfile.mkdtemp(prefix="upload_", dir=self.path))
        return folder / self.file(name).name

    def cleanup(self) -> None:
        """Remove the folder and everything in it."""
        shutil.rmtree(self.path, ignore_errors=True)


def _first_clause(problem: str) -> str:
    """The reader's own description of a problem, without the file's text it may quote (``got '...'``)."""
    clause = re.split(r",? got\b|\(|:\s|['\"]", problem, maxsplit=1)[0].strip(" ,;:")
    return clause[:160] or "not a valid file"


def client_message(exc: BaseException, shown: str) -> str:
    """What the page may see of ``exc`` raised while reading or writing ``shown`` (a root-relative path).

    Examples
    --------
    >>> from ffd_notebook.errors import FileFormatError
    >>> client_message(FileFormatError("/srv/x.ffd", 1, "expected a section header, got 'root:x:0:0'"), "x.ffd")
    'x.ffd, line 1: expected a section header'
    >>> client_message(FileNotFoundError(2, "No such file or directory"), "y.obj")
    'y.obj: No such file or directory'
    >>> client_message(NoFaceError("/srv/me.jpg", "no face found in the photo"), "me.jpg")
    'me.jpg: no face found in the photo'
    """
    if isinstance(exc, PathRefused):
        return str(exc)
    if isinstance(exc, NoFaceError):  # what the face models found: made by the package, not read from the file
        return f"{shown}: {exc.problem}"
    if isinstance(exc, FileFormatError):
        where = f"{shown}, line {exc.line}" if exc.line is not None else shown
        return f"{where}: {_first_clause(exc.problem)}"
    if isinstance(exc, OSError):
        return f"{shown}: {exc.strerror or type(exc).__name__}"
    return f"{shown}: {_first_clause(str(exc))}"
