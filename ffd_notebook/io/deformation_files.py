"""Any deformation file by extension: ``.ffd``, ITK transforms, PyGeM ``.prm``.

One pair of functions for everything that reads or writes a whole deformation (the command-line
converter, the editor's panels): :func:`load_deformation` returns the :class:`~ffd_notebook.FFD`
a file means, :func:`save_deformation` writes one or refuses, with the reason, when the format
cannot hold it exactly.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..ffd.deform import FFD
from .ffd_file import load_ffd, save_ffd
from .itk import ITK_SUFFIXES, load_transform, save_transform
from .prm import load_prm, save_prm

__all__ = ["DEFORMATION_SUFFIXES", "load_deformation", "save_deformation"]

DEFORMATION_SUFFIXES = (".ffd", *ITK_SUFFIXES, ".prm")


def _suffix(path: str | os.PathLike[str]) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in DEFORMATION_SUFFIXES:
        raise ValueError(f"{os.fspath(path)}: unknown deformation file extension {suffix!r}; expected one of "
                         f"{', '.join(DEFORMATION_SUFFIXES)}")  # fmt: skip
    return suffix


def load_deformation(path: str | os.PathLike[str]) -> FFD:
    """Read a ``.ffd``, ITK (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``) or PyGeM ``.prm`` file as an FFD.

    ``.ffd``: ``FFD(load_ffd(path))`` (B-spline; a file without a placement section rests at
    (0, 0, 0), see :func:`~ffd_notebook.io.place_at_mesh_minimum`). ITK: :func:`load_transform`.
    ``.prm``: ``FFD(load_prm(path), "bernstein", only_inside=True)``, PyGeM's deformation.

    Raises
    ------
    FileFormatError
        A malformed file (names the file and line or HDF5 dataset).
    ValueError
        An unknown extension.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import Lattice
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "box.prm"
    >>> save_prm(path, Lattice((3, 2, 2), 1.0))
    >>> ffd = load_deformation(path)
    >>> ffd.basis, ffd.only_inside
    ('bernstein', True)
    """
    suffix = _suffix(path)
    if suffix == ".ffd":
        return FFD(load_ffd(path), "bspline")
    if suffix == ".prm":
        return FFD(load_prm(path), "bernstein", only_inside=True)
    return load_transform(path)


def _refuse(path: str | os.PathLike[str], what: str, why: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: a {what} file cannot hold this FFD exactly: {why}")


def save_deformation(path: str | os.PathLike[str], ffd: FFD) -> None:
    """Write an FFD in the format its extension names, atomically, or refuse if it would not be exact.

    ``.ffd`` holds a B-spline lattice with either border (a "clamp" one is recorded), no affine
    part, moving every point it reaches; ``.prm`` a Bernstein lattice without affine part that
    moves only the points inside its box (``only_inside=True``) and whose rotation is not a
    reflection; ITK files a B-spline lattice with the "zero" border and any invertible affine
    part (:func:`save_transform`).

    Raises
    ------
    ValueError
        When the format cannot hold ``ffd`` exactly (the message says why), or an unknown extension.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> ffd = FFD(Lattice((4, 4, 4), 1.0))
    >>> save_deformation(folder / "a.ffd", ffd); save_deformation(folder / "a.tfm", ffd)
    >>> load_deformation(folder / "a.tfm").lattice == load_deformation(folder / "a.ffd").lattice
    True
    >>> save_deformation(folder / "a.prm", ffd)
    Traceback (most recent call last):
    ...
    ValueError: ...a.prm: a PyGeM .prm file cannot hold this FFD exactly: it has the 'bspline' basis; ...
    """
    suffix = _suffix(path)
    if suffix in ITK_SUFFIXES:
        save_transform(path, ffd)
        return
    border = ffd.border
    affine = not np.array_equal(ffd.affine, np.eye(4))
    if suffix == ".ffd":
        if ffd.basis != "bspline":
            raise _refuse(path, ".ffd", f"it has the {ffd.basis!r} basis; .ffd lattices are cubic B-splines")
        if affine:
            raise _refuse(path, ".ffd", "it has an affine part, which .ffd files do not store")
        if ffd.only_inside:
            raise _refuse(path, ".ffd", "it moves only the points inside its domain (only_inside=True, as an ITK "
                          "transform does), a .ffd lattice moves every point its control points reach")  # fmt: skip
        lattice = ffd.lattice
        if lattice.border != border:  # the file records the border the FFD uses (a #border# section)
            lattice = lattice.copy()
            lattice.border = border
        save_ffd(path, lattice)
        return
    if ffd.basis != "bernstein":
        raise _refuse(path, "PyGeM .prm", f"it has the {ffd.basis!r} basis; PyGeM's FFD is a Bernstein one")
    if affine:
        raise _refuse(path, "PyGeM .prm", "it has an affine part, which .prm files do not store")
    if not ffd.only_inside:
        raise _refuse(path, "PyGeM .prm", "PyGeM moves only the points inside its box; this FFD moves points "
                      "outside too (use only_inside=True)")  # fmt: skip
    save_prm(path, ffd.lattice)
