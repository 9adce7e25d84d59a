"""Any deformation file: ``.ffd``, ITK transforms, elastix parameter files (by content), PyGeM ``.prm``.

One pair of functions for everything that reads or writes a whole deformation (the command-line
converter, the editor's panels): :func:`load_deformation` returns the :class:`~ffd_notebook.FFD`
a file means, :func:`save_deformation` writes one or refuses, with the reason, when the format
cannot hold it exactly.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import cast

import numpy as np

from ..errors import FileFormatError
from ..ffd.deform import FFD
from .displacement_field import (
    FIELD_SUFFIXES,
    DisplacementField,
    field_suffix,
    load_displacement_field,
    save_displacement_field,
)
from .elastix import load_elastix, save_elastix
from .elastix_text import is_parameter_file
from .ffd_file import load_ffd, save_ffd
from .itk import ITK_SUFFIXES, load_transform, save_transform
from .prm import load_prm, save_prm

__all__ = ["DEFORMATION_FORMATS", "DEFORMATION_SUFFIXES", "load_deformation", "save_deformation"]

DEFORMATION_SUFFIXES = (".ffd", *ITK_SUFFIXES, ".prm", *FIELD_SUFFIXES)
#: The ``format=`` names of :func:`save_deformation` (``None``: by extension).
DEFORMATION_FORMATS = ("ffd", "itk", "elastix", "prm", "field")


def _suffix(path: str | os.PathLike[str]) -> str:
    suffix = field_suffix(path) or Path(path).suffix.lower()
    if suffix not in DEFORMATION_SUFFIXES:
        raise ValueError(f"{os.fspath(path)}: unknown deformation file extension {suffix!r}; expected one of "
                         f"{', '.join(DEFORMATION_SUFFIXES)}")  # fmt: skip
    return suffix


def load_deformation(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None
                     ) -> FFD | DisplacementField:  # fmt: skip
    """Read a ``.ffd``, ITK (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``), elastix or PyGeM ``.prm`` file as an FFD.

    ``.ffd``: ``FFD(load_ffd(path))`` (B-spline, or the per-axis interpolations, "outside" mode and
    strength its sections record; a file without a placement section rests at (0, 0, 0), see
    :func:`~ffd_notebook.io.place_at_mesh_minimum`). ITK: :func:`load_transform`.
    A ``.txt`` file whose first line is not ITK's header but ``(Name value ...)`` is an elastix
    transform parameter file: ``load_elastix(path).to_ffd()``, the chain it starts lowered onto
    one FFD (see :mod:`~ffd_notebook.io.elastix`).
    ``.prm``: ``FFD(load_prm(path), "bernstein", only_inside=True)``, PyGeM's deformation.
    A displacement field (``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha``) is returned as a
    :class:`~ffd_notebook.io.DisplacementField` (:func:`~ffd_notebook.io.fit_lattice` makes a
    lattice of it).

    Files that name other files (an elastix chain's initial transforms, a field's MetaImage or
    NRRD data files) read them as elastix and ITK do, or only inside ``within``: the app passes its
    folder (or an upload's own folder), so a file in it cannot make the app read elsewhere.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension chooses the format.
    within : str or os.PathLike, optional
        The folder the files it names must be in; ``None``: anywhere.

    Returns
    -------
    FFD or DisplacementField
        The deformation the file means.

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
    if suffix in FIELD_SUFFIXES:
        return load_displacement_field(path, within=within)
    if suffix == ".ffd":
        lattice = load_ffd(path)
        options = lattice.metadata.get("ffd_options") or {}
        return FFD(
            lattice,
            options.get("basis", "bspline"),
            outside=options.get("outside", False),
            strength=options.get("strength", 1.0),
        )
    if suffix == ".prm":
        return FFD(load_prm(path), "bernstein", only_inside=True)
    if suffix == ".txt" and is_parameter_file(path):
        chain = load_elastix(path, within=within)
        try:
            return chain.to_ffd()
        except ValueError as exc:
            raise FileFormatError(path, None, f"this elastix chain has no FFD equal to it: {exc}") from None
    return load_transform(path)


_DEFAULT_OPTIONS = {"basis": "bspline", "outside": False, "strength": 1.0}


def _refuse(path: str | os.PathLike[str], what: str, why: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: a {what} file cannot hold this FFD exactly: {why}")


def save_deformation(path: str | os.PathLike[str], ffd: FFD | DisplacementField, *, format: str | None = None) -> None:
    """Write an FFD in the format its extension names, atomically, or refuse if it would not be exact.

    ``format`` (one of :data:`DEFORMATION_FORMATS`) overrides the extension: ``"elastix"`` writes an elastix
    transform parameter file (:func:`~ffd_notebook.io.save_elastix`). Without it a ``.txt`` file is
    written in the format the FFD's lattice was read from: elastix for a lattice loaded from an
    elastix file (``lattice.metadata["elastix"]``; the editor saves it back so), ITK otherwise.
    A displacement field (``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha``) is written on its own grid;
    an FFD becomes one with :func:`~ffd_notebook.io.save_displacement_field` and a reference grid.

    ``.ffd`` holds a B-spline lattice (or Blender's per-axis interpolations, "outside" mode and
    strength, recorded in sections of their own) with either border (a "clamp" one is recorded),
    no affine part, moving every point it reaches; ``.prm`` a Bernstein lattice without affine part
    that moves only the points inside its box (``only_inside=True``) and whose rotation is not a
    reflection; ITK files a B-spline lattice with the "zero" border and any invertible affine part
    (:func:`save_transform`). PyGeM and ITK files hold a strength other than 1 and "outside" mode
    as the offsets and affine part they give (:meth:`~ffd_notebook.FFD.baked`); no file holds
    per-point weights (they belong to one mesh).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension chooses the format.
    ffd : FFD or DisplacementField
        The deformation to write.
    format : str, optional
        One of :data:`DEFORMATION_FORMATS`, instead of what the extension says.

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
    if format is not None and format not in DEFORMATION_FORMATS:
        raise ValueError(
            f"format must be one of {', '.join(DEFORMATION_FORMATS)} (or None: by extension), got {format!r}"
        )
    if isinstance(ffd, FFD) and ffd.weights is not None:
        raise _refuse(path, "deformation", "it has per-point weights, which belong to one mesh (save them with it)")
    from_elastix = isinstance(ffd, FFD) and "elastix" in ffd.lattice.metadata
    if format == "elastix" or (format is None and from_elastix and Path(path).suffix.lower() == ".txt"):
        save_elastix(path, cast(FFD, ffd))  # a displacement field: save_elastix refuses it (TypeError)
        return
    suffix = _suffix(path)
    kind = "field" if suffix in FIELD_SUFFIXES else {".ffd": "ffd", ".prm": "prm"}.get(suffix, "itk")
    if format is not None and format != kind:
        raise ValueError(f"{os.fspath(path)}: the extension {suffix!r} does not fit format={format!r}")
    if kind == "field":
        if not isinstance(ffd, DisplacementField):
            raise ValueError(f"{os.fspath(path)}: a displacement field needs a voxel grid; use "
                             "save_displacement_field(path, deformation, reference)")  # fmt: skip
        save_displacement_field(path, ffd)
        return
    if isinstance(ffd, DisplacementField):
        raise ValueError(f"{os.fspath(path)}: a displacement field is not a lattice; fit one first "
                         f"(fit_lattice(field, shape)) to write it as a {suffix} file")  # fmt: skip
    if suffix in ITK_SUFFIXES:
        save_transform(path, ffd)
        return
    border = ffd.border
    affine = not np.array_equal(ffd.affine, np.eye(4))
    if ffd.lattice.sheared and suffix in (".ffd", ".prm"):
        what = ".ffd" if suffix == ".ffd" else "PyGeM .prm"
        raise _refuse(path, what, "its lattice is sheared (axes not orthogonal, as an elastix affine-then-B-spline "
                      "chain makes it); only elastix files hold that")  # fmt: skip
    if suffix == ".ffd":
        if ffd.basis == "bernstein":
            raise _refuse(path, ".ffd", "it has the 'bernstein' basis; .ffd lattices are cubic B-splines or "
                          "Blender's per-axis interpolations")  # fmt: skip
        if affine:
            raise _refuse(path, ".ffd", "it has an affine part, which .ffd files do not store")
        if ffd.only_inside:
            raise _refuse(path, ".ffd", "it moves only the points inside its domain (only_inside=True, as an ITK "
                          "transform does), a .ffd lattice moves every point its control points reach")  # fmt: skip
        lattice = ffd.lattice.copy()  # the file records the border and options the FFD uses (sections of their own)
        lattice.border = border
        options = {"basis": ffd.basis, "outside": ffd.outside, "strength": ffd.strength}
        lattice.metadata["ffd_options"] = {k: v for k, v in options.items() if v != _DEFAULT_OPTIONS[k]}
        save_ffd(path, lattice)
        return
    if ffd.basis != "bernstein":
        raise _refuse(path, "PyGeM .prm", f"it has the {ffd.basis!r} basis; PyGeM's FFD is a Bernstein one")
    if affine:
        raise _refuse(path, "PyGeM .prm", "it has an affine part, which .prm files do not store")
    if not ffd.only_inside:
        raise _refuse(path, "PyGeM .prm", "PyGeM moves only the points inside its box; this FFD moves points "
                      "outside too (use only_inside=True)")  # fmt: skip
    # strength and "outside" change the offsets only: the file holds the offsets they give
    save_prm(path, ffd.baked().lattice)
