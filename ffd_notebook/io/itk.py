"""ITK / SimpleITK transform files: ``save_transform`` and ``load_transform``.

A B-spline FFD (the "zero" border, the seed formula) is ITK's ``BSplineTransform`` of order 3,
exactly; an affine part makes it a ``CompositeTransform`` (see :mod:`.itk_model` for the
correspondence). Text files (``.tfm``, ``.txt``), HDF5 files (``.h5``, ``.hdf5``) and MATLAB files
(``.mat``, what ANTs writes its affine transforms in) are chosen by extension, as SimpleITK does.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..ffd.deform import FFD
from .itk_h5 import read_itk_h5, write_itk_h5
from .itk_matlab import read_itk_matlab, write_itk_matlab
from .itk_model import RawTransform, ffd_to_transforms, transforms_to_ffd
from .itk_text import read_itk_text, write_itk_text

__all__ = ["ITK_SUFFIXES", "load_transform", "read_transforms", "save_transform", "write_transforms"]

ITK_SUFFIXES = {".tfm": "text", ".txt": "text", ".h5": "hdf5", ".hdf5": "hdf5", ".mat": "matlab"}


def _kind(path: str | os.PathLike[str]) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in ITK_SUFFIXES:
        raise ValueError(f"{os.fspath(path)}: unknown transform file extension {suffix!r}; expected one of "
                         f"{', '.join(ITK_SUFFIXES)}")  # fmt: skip
    return ITK_SUFFIXES[suffix]


def read_transforms(path: str | os.PathLike[str]) -> list[RawTransform]:
    """The transforms of an ITK transform file as written, by its extension (text, HDF5 or MATLAB).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "warp.tfm"
    >>> save_transform(path, FFD(Lattice((4, 4, 4), 1.0)))
    >>> [t.kind for t in read_transforms(path)]
    ['BSplineTransform_double_3_3']
    """
    kind = _kind(path)
    if kind == "text":
        return read_itk_text(path)
    return read_itk_h5(path) if kind == "hdf5" else read_itk_matlab(path)


def write_transforms(path: str | os.PathLike[str], transforms: list[RawTransform]) -> None:
    """Write ITK transforms in the format the extension names, atomically (see :func:`read_transforms`)."""
    kind = _kind(path)
    if kind == "matlab" and transforms and transforms[0].kind.startswith("CompositeTransform"):
        raise ValueError(f"{os.fspath(path)}: an ITK .mat file holds one transform, not a composite of several "
                         "(ITK's MATLAB reader would not compose them); write a .h5 or .tfm file")  # fmt: skip
    if kind == "text":
        write_itk_text(path, transforms)
    elif kind == "hdf5":
        write_itk_h5(path, transforms)
    else:
        write_itk_matlab(path, transforms)


def load_transform(path: str | os.PathLike[str]) -> FFD:
    """Read an ITK transform file as an :class:`~ffd_notebook.FFD`.

    Accepts what SimpleITK writes around a B-spline: a single ``BSplineTransform`` (order 3,
    3D), or a ``CompositeTransform`` of one ``BSplineTransform`` and ``AffineTransform`` /
    ``TranslationTransform`` parts applied after it (any) or before it (if they keep the grid
    orthogonal: rigid motions, per-axis scaling along the grid).

    Parameters
    ----------
    path : str or os.PathLike
        A ``.tfm`` or ``.txt`` (text), ``.h5`` or ``.hdf5`` (HDF5) or ``.mat`` (MATLAB) transform file.

    Returns
    -------
    FFD
        Equal to ITK's transform everywhere: ``only_inside=True`` (ITK leaves points outside the
        transform domain unmoved) unless the grid has three zero layers all round, as
        :func:`save_transform` writes, in which case the lattice is the grid without them.

    Raises
    ------
    FileFormatError
        Malformed file, other transform types, or transforms no FFD equals; names the file and
        the line (text) or HDF5 dataset.
    ValueError
        Unknown extension.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 5, 4), spacing=2.0, origin=(-1.0, 0.0, 0.0))
    >>> lat.offsets[1, 2, 1] = (0.5, 0.0, 0.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "warp.tfm"
    >>> save_transform(path, FFD(lat))
    >>> back = load_transform(path)
    >>> back.lattice.shape, bool(abs(back.lattice.offsets - lat.offsets).max() == 0)
    ((4, 5, 4), True)
    """
    return transforms_to_ffd(path, read_transforms(path))


def save_transform(path: str | os.PathLike[str], ffd: FFD) -> None:
    """Write an FFD as an ITK transform file that SimpleITK and ITK read, atomically.

    ``sitk.ReadTransform(path).TransformPoint(p)`` equals ``ffd.deform(p)`` everywhere (to
    rounding). A lattice that moves points outside ITK's transform domain (every FFD with the
    default ``only_inside=False``) is written with three more layers of zero control points all
    round; an affine part is written as ``CompositeTransform(AffineTransform, BSplineTransform)``.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.tfm`` or ``.txt`` (text) or ``.h5`` or ``.hdf5`` (HDF5) transform file.
    ffd : FFD
        A B-spline FFD with the "zero" border.

    Raises
    ------
    ValueError
        For an FFD that ITK cannot hold exactly: the Bernstein basis, a border other than "zero",
        a singular affine matrix; or an unknown extension.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> ffd = FFD(Lattice((4, 4, 4), 1.0), affine=np.diag([2.0, 1.0, 1.0, 1.0]))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "warp.h5"
    >>> save_transform(path, ffd)
    >>> load_transform(path).affine[0, 0]
    np.float64(2.0)
    """
    _kind(path)
    try:
        transforms = ffd_to_transforms(ffd)
    except ValueError as exc:
        raise ValueError(f"{os.fspath(path)}: {exc}") from None
    write_transforms(path, transforms)
