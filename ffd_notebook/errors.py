"""The package's exceptions, in one place: bad files, refused paths, failed batches."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .batch.engine import BatchResult

__all__ = ["BatchError", "FileFormatError", "NoFaceError", "PathRefused"]


class FileFormatError(ValueError):
    """A file could not be read: names the file, the line (1-based, if known) and the problem.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    line : int or None
        The 1-based line of the problem, or None when it has no line (binary files, HDF5).
    problem : str
        What was expected and what was found.

    Examples
    --------
    >>> err = FileFormatError("lattice.ffd", 12, "expected 3 numbers, got 'a b'")
    >>> str(err)
    "lattice.ffd, line 12: expected 3 numbers, got 'a b'"
    >>> err.line
    12
    """

    def __init__(self, path: str | os.PathLike[str], line: int | None, problem: str) -> None:
        self.path = os.fspath(path)
        self.line = line
        self.problem = problem
        where = f"{self.path}, line {line}" if line is not None else self.path
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):  # keep it picklable (multiprocessing, pytest-xdist)
        return (type(self), (self.path, self.line, self.problem))


class NoFaceError(ValueError):
    """A photo has no face the face models can use: names the photo and says what was (not) found.

    Parameters
    ----------
    photo : str
        The photo's name (its path, or a description of the array).
    problem : str
        What was (not) found.

    Examples
    --------
    >>> str(NoFaceError("coins.png", "no face found in the photo"))
    'coins.png: no face found in the photo'
    """

    def __init__(self, photo: str, problem: str) -> None:
        self.photo = photo
        self.problem = problem
        super().__init__(f"{photo}: {problem}")

    def __reduce__(self):
        return (type(self), (self.photo, self.problem))


class PathRefused(ValueError):
    """A path the app will not read or write (outside its root, a special file, too big, wrong kind).

    Examples
    --------
    >>> str(PathRefused("'../a.ffd' is outside the app's folder"))
    "'../a.ffd' is outside the app's folder"
    """


class BatchError(RuntimeError):
    """Some samples of a batch failed; the others were written. ``result`` holds everything.

    Parameters
    ----------
    result : BatchResult
        What the run did; ``result.failed`` names each failed sample and why.

    Examples
    --------
    >>> import pathlib
    >>> from ffd_notebook.batch import BatchResult
    >>> error = BatchError(BatchResult(pathlib.Path("out"), made=[0], failed={1: "sample 1: folds"}))
    >>> str(error)
    '1 of 2 samples failed: sample 1: folds'
    """

    def __init__(self, result: BatchResult) -> None:
        self.result = result
        shown = "; ".join(result.failed[i] for i in sorted(result.failed)[:5])
        more = "" if len(result.failed) <= 5 else f"; and {len(result.failed) - 5} more"
        total = len(result.failed) + len(result.made)
        super().__init__(f"{len(result.failed)} of {total} samples failed: {shown}{more}")
