"""Any deformation file: ``.ffd``, ITK transforms, elastix parameter files (by content), PyGeM ``.prm``, NiftyReg,
FSL FNIRT and ANTs files, displacement fields.

One pair of functions for everything that reads or writes a whole deformation (the command-line
converter, the editor's panels): :func:`load_deformation` returns what a file means (an
:class:`~ffd_notebook.FFD` where it is one lattice), :func:`save_deformation` writes one or refuses, with the
reason, when the format cannot hold it exactly.

Every deformation read from the NIfTI world (NiftyReg, FSL, ITK and ANTs fields) lives in ITK's physical space,
LPS millimetres, as SimpleITK reads NIfTI images: the space of the images and meshes it is applied to.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Union

import numpy as np

from ..errors import FileFormatError
from ..ffd.deform import FFD
from ..images.files import read_image_information
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
from .fnirt import fnirt_deformation, save_fnirt
from .itk import ITK_SUFFIXES, read_transforms, save_transform, write_transforms
from .itk_model import deformation_to_transforms, transforms_to_deformation
from .nifti_files import nifti_meaning, read_nifti, read_nifti_header
from .niftyreg import niftyreg_deformation, save_niftyreg
from .prm import load_prm, save_prm
from .transform_chain import AffineTransform, TransformChain

__all__ = ["DEFORMATION_FORMATS", "DEFORMATION_SUFFIXES", "LoadedDeformation", "load_deformation", "save_deformation"]

DEFORMATION_SUFFIXES = (".ffd", *ITK_SUFFIXES, ".prm", *FIELD_SUFFIXES)
#: The ``format=`` names of :func:`save_deformation` (``None``: by extension).
DEFORMATION_FORMATS = ("ffd", "itk", "elastix", "prm", "field", "niftyreg", "fnirt")
#: What :func:`load_deformation` returns.
LoadedDeformation = Union[FFD, DisplacementField, AffineTransform, TransformChain]  # noqa: UP007 (a runtime alias)
_NIFTI = (".nii", ".nii.gz")


def _suffix(path: str | os.PathLike[str]) -> str:
    suffix = field_suffix(path) or Path(path).suffix.lower()
    if suffix not in DEFORMATION_SUFFIXES:
        raise ValueError(f"{os.fspath(path)}: unknown deformation file extension {suffix!r}; expected one of "
                         f"{', '.join(DEFORMATION_SUFFIXES)}")  # fmt: skip
    return suffix


def load_deformation(
    path_or_list: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    *,
    reference: Any = None,
    source: Any = None,
    within: str | os.PathLike[str] | None = None,
) -> LoadedDeformation:
    """Read any deformation file (or a list of them, applied one after another) as what it means.

    By extension, and for NIfTI files by what their header says they hold:

    - ``.ffd``: ``FFD(load_ffd(path))`` (B-spline, or the per-axis interpolations, "outside" mode and strength its
      sections record; a file without a placement section rests at (0, 0, 0), see
      :func:`~ffd_notebook.io.place_at_mesh_minimum`). ``.prm``: ``FFD(load_prm(path), "bernstein",
      only_inside=True)``, PyGeM's deformation.
    - ITK transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``, and ``.mat``, ANTs' ``GenericAffine``): an FFD where
      they are one B-spline with affine parts (:func:`~ffd_notebook.io.load_transform`), an
      :class:`~ffd_notebook.io.AffineTransform` where they are affine only, a
      :class:`~ffd_notebook.io.TransformChain` where displacement fields are among them (ANTs' composite ``.h5``,
      ``--write-composite-transform``). A ``.txt`` file whose first line is ``(Name value ...)`` is an elastix
      transform parameter file: ``load_elastix(path).to_ffd()``, the chain it starts lowered onto one FFD.
    - NiftyReg files (intent name ``NREG_TRANS``): a ``reg_f3d`` control-point grid as
      ``FFD(lattice, border="clamp")`` with an editable lattice, fields as
      :class:`~ffd_notebook.io.DisplacementField`, a velocity grid (``reg_f3d -vel``) as the field NiftyReg
      exponentiates on the ``reference`` image's voxels (:func:`~ffd_notebook.io.load_niftyreg`).
    - FSL FNIRT files (intent 2007 coefficients, 2006 fields): they map the ``reference`` image's coordinates to
      the ``source`` image's, so both are needed, as ``applywarp`` needs ``--ref`` and ``--in``
      (:func:`~ffd_notebook.io.load_fnirt`).
    - Other ``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha`` files: a displacement field in ITK's convention (ITK and
      ANTs write those), :class:`~ffd_notebook.io.DisplacementField`. A vector NIfTI whose header says it holds
      something else (an SPM field of positions, an intent name no tool here writes) is refused.
    - A list: a :class:`~ffd_notebook.io.TransformChain` of the files in ``antsApplyTransforms -t`` order, as
      ``ants.registration`` returns them (``[prefix1Warp.nii.gz, prefix0GenericAffine.mat]``): it deforms as
      ``ants.apply_transforms`` with the same list, the first file moving a point first. An item
      ``(path, True)`` is the inverse of an affine file, as ANTs' ``whichtoinvert`` (its ``invtransforms``:
      ``[(prefix0GenericAffine.mat, True), prefix1InverseWarp.nii.gz]``).

    Every deformation read from the NIfTI world lives in ITK's physical space (LPS millimetres), as SimpleITK
    reads the images it is applied to.

    Files that name other files (an elastix chain's initial transforms, a field's MetaImage or
    NRRD data files) read them as elastix and ITK do, or only inside ``within``: the app passes its
    folder (or an upload's own folder), so a file in it cannot make the app read elsewhere. The
    ``reference`` and ``source`` images given as paths are read inside ``within`` too.

    Parameters
    ----------
    path_or_list : str, os.PathLike or sequence of them
        The file, or files in ``antsApplyTransforms -t`` order (an item ``(path, True)``: its inverse).
    reference, source : path or reference grid, optional
        The images an FSL transformation maps between (the NIfTI files, or any reference grid); the image a
        NiftyReg velocity grid is exponentiated on (``reference``); other formats do not use them.
    within : str or os.PathLike, optional
        The folder the files it names (and the ``reference`` and ``source`` files) must be in; ``None``:
        anywhere.

    Returns
    -------
    FFD, DisplacementField, AffineTransform or TransformChain
        The deformation the file means: an FFD where it is one lattice.

    Raises
    ------
    FileFormatError
        A malformed file, or one whose meaning cannot be established exactly (names the file and what it found).
    ValueError
        An unknown extension, an empty list, an FSL file without its reference or source.

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
    if not isinstance(path_or_list, str | os.PathLike):
        paths = list(path_or_list)
        if not paths:
            raise ValueError("an empty list of deformation files")
        steps = [_list_item(item, reference, source, within) for item in paths]
        return steps[0] if len(steps) == 1 else TransformChain(steps)
    path = path_or_list
    suffix = _suffix(path)
    if within is not None:  # the images FSL files and velocity grids are read against: inside the folder too
        reference, source = (_grid_within(image, within) for image in (reference, source))
    if suffix in _NIFTI:
        return _load_nifti(path, reference, source, within)
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
    return transforms_to_deformation(path, read_transforms(path))


def _grid_within(image: Any, within: str | os.PathLike[str]) -> Any:
    """An image named by a path, as its grid read inside ``within``; any other reference as it is."""
    if isinstance(image, str | os.PathLike):
        return read_image_information(image, within=within)
    return image


def _list_item(item: Any, reference: Any, source: Any, within: str | os.PathLike[str] | None) -> LoadedDeformation:
    """One file of a list: a path, or ``(path, True)`` for its inverse (ANTs' ``whichtoinvert``, an affine only)."""
    if isinstance(item, tuple):
        if len(item) != 2 or not isinstance(item[1], bool):
            raise ValueError(f"a list item is a path or (path, invert), got {item!r}")
        path, invert = item
    else:
        path, invert = item, False
    loaded = load_deformation(path, reference=reference, source=source, within=within)
    if not invert:
        return loaded
    if not isinstance(loaded, AffineTransform):
        raise ValueError(f"{os.fspath(path)}: only an affine transform is inverted (as ANTs' whichtoinvert); use "
                         "the inverse field the registration wrote (prefix1InverseWarp.nii.gz)")  # fmt: skip
    return loaded.inverse()


def _load_nifti(
    path: str | os.PathLike[str], reference: Any, source: Any, within: str | os.PathLike[str] | None
) -> LoadedDeformation:
    """A NIfTI file by what its header says it holds (see :func:`~.nifti_files.nifti_meaning`)."""
    kind, what = nifti_meaning(read_nifti_header(path))
    if kind == "itk":
        return load_displacement_field(path, within=within)
    if kind == "spm":
        raise FileFormatError(path, None, f"an SPM deformation ({what}): it holds positions in millimetres in SPM's "
                              "conventions, not ITK displacements, and is not read")  # fmt: skip
    if kind == "unknown":
        raise FileFormatError(path, None, f"a NIfTI file marked as something this package does not read ({what}); "
                              "an ITK or ANTs displacement field has no intent name")  # fmt: skip
    nifti = read_nifti(path)
    if kind == "niftyreg":
        return niftyreg_deformation(nifti, what, reference)
    return fnirt_deformation(nifti, what, reference, source)


_DEFAULT_OPTIONS = {"basis": "bspline", "outside": False, "strength": 1.0}


def _refuse(path: str | os.PathLike[str], what: str, why: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: a {what} file cannot hold this FFD exactly: {why}")


def _not_a_lattice(path: str | os.PathLike[str], deformation: Any, what: str) -> ValueError:
    """The one refusal of a deformation that is not one lattice where a lattice file is asked for."""
    kind = {DisplacementField: "a displacement field", AffineTransform: "an affine transform",
            TransformChain: "a chain of transforms"}.get(type(deformation), type(deformation).__name__)  # fmt: skip
    return ValueError(f"{os.fspath(path)}: {kind} is not a lattice; fit one first (fit_lattice(deformation, "
                      f"shape)) to write it as {what}")  # fmt: skip


def _format(path: str | os.PathLike[str], format: str | None) -> str:
    """The format to write: ``format`` if given (one of :data:`DEFORMATION_FORMATS`, checked by
    :func:`save_deformation`; here against the extension), else by extension."""
    suffix = _suffix(path)
    kind = "field" if suffix in FIELD_SUFFIXES else {".ffd": "ffd", ".prm": "prm"}.get(suffix, "itk")
    if format in ("niftyreg", "fnirt"):
        if suffix not in _NIFTI:
            raise ValueError(f"{os.fspath(path)}: a {format} file is a .nii or .nii.gz file, not {suffix!r}")
        return format
    if format is not None and format != kind:
        raise ValueError(f"{os.fspath(path)}: the extension {suffix!r} does not fit format={format!r}")
    return kind


def save_deformation(
    path: str | os.PathLike[str],
    ffd: LoadedDeformation,
    *,
    format: str | None = None,
    reference: Any = None,
    source: Any = None,
) -> None:
    """Write a deformation in the format its extension (or ``format``) names, atomically, or refuse if it would
    not be exact.

    ``format`` (one of :data:`DEFORMATION_FORMATS`) overrides the extension: ``"elastix"`` writes an elastix
    transform parameter file (:func:`~ffd_notebook.io.save_elastix`), ``"niftyreg"`` a NiftyReg control-point
    grid that ``reg_resample`` and ``reg_transform`` apply as the FFD does (:func:`~ffd_notebook.io.save_niftyreg`),
    ``"fnirt"`` an FSL FNIRT coefficient file between the ``reference`` and ``source`` images
    (:func:`~ffd_notebook.io.save_fnirt`). Without it a ``.txt`` file is written in the format the FFD's lattice
    was read from: elastix for a lattice loaded from an elastix file (``lattice.metadata["elastix"]``; the editor
    saves it back so), ITK otherwise; a ``.nii``/``.nii.gz`` file is a displacement field in ITK's convention.

    ``.ffd`` holds a B-spline lattice (or Blender's per-axis interpolations, "outside" mode and
    strength, recorded in sections of their own) with either border (a "clamp" one is recorded),
    no affine part, moving every point it reaches; ``.prm`` a Bernstein lattice without affine part
    that moves only the points inside its box (``only_inside=True``) and whose rotation is not a
    reflection; ITK files a B-spline lattice with the "zero" border and any invertible affine part
    (:func:`save_transform`), an :class:`~ffd_notebook.io.AffineTransform` (``.mat``, ANTs' affine), and in
    ``.h5`` files a :class:`~ffd_notebook.io.TransformChain` (an ITK composite, as ANTs writes one). PyGeM and ITK
    files hold a strength other than 1 and "outside" mode as the offsets and affine part they give
    (:meth:`~ffd_notebook.FFD.baked`); no file holds per-point weights (they belong to one mesh). A displacement
    field is written on its own grid (an FFD becomes one with :func:`~ffd_notebook.io.save_displacement_field`
    and a reference grid).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension chooses the format.
    ffd : FFD, DisplacementField, AffineTransform or TransformChain
        The deformation to write.
    format : str, optional
        One of :data:`DEFORMATION_FORMATS`, instead of what the extension says.
    reference, source : path or reference grid, optional
        The images an FNIRT file maps between (``format="fnirt"`` only).

    Raises
    ------
    ValueError
        When the format cannot hold the deformation exactly (the message says why; a deformation that is not a
        lattice where a lattice is asked for, whatever the format), or an unknown extension.

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
    deformation = ffd
    if format is not None and format not in DEFORMATION_FORMATS:
        raise ValueError(
            f"format must be one of {', '.join(DEFORMATION_FORMATS)} (or None: by extension), got {format!r}"
        )
    if isinstance(deformation, FFD) and deformation.weights is not None:
        raise _refuse(path, "deformation", "it has per-point weights, which belong to one mesh (save them with it)")
    from_elastix = isinstance(deformation, FFD) and "elastix" in deformation.lattice.metadata
    if format == "elastix" or (format is None and from_elastix and Path(path).suffix.lower() == ".txt"):
        if not isinstance(deformation, FFD):
            raise _not_a_lattice(path, deformation, "an elastix file")
        save_elastix(path, deformation)
        return
    kind = _format(path, format)
    if kind == "field":
        if not isinstance(deformation, DisplacementField):
            raise ValueError(f"{os.fspath(path)}: a displacement field needs a voxel grid; use "
                             "save_displacement_field(path, deformation, reference)")  # fmt: skip
        if deformation.outside != "zero":
            raise ValueError(f"{os.fspath(path)}: this field moves points beyond its grid (NiftyReg's rule), an ITK "
                             "displacement field file leaves them where they are; write it with format='niftyreg', "
                             "or sample it on a grid of your choice with save_displacement_field")  # fmt: skip
        save_displacement_field(path, deformation)
        return
    if kind == "niftyreg":
        if not isinstance(deformation, FFD | DisplacementField):
            raise _not_a_lattice(path, deformation, "a NiftyReg grid")
        save_niftyreg(path, deformation)
        return
    if kind == "fnirt":
        if not isinstance(deformation, FFD):
            raise _not_a_lattice(path, deformation, "an FNIRT coefficient file")
        save_fnirt(path, deformation, reference=reference, source=source)
        return
    if kind == "itk":
        _save_itk(path, deformation)
        return
    suffix = Path(path).suffix.lower()
    what = ".ffd" if suffix == ".ffd" else "PyGeM .prm"
    if not isinstance(deformation, FFD):
        raise _not_a_lattice(path, deformation, f"a {what} file")
    ffd = deformation
    border = ffd.border
    affine = not np.array_equal(ffd.affine, np.eye(4))
    if ffd.lattice.sheared:
        raise _refuse(path, what, "its lattice is sheared (axes not orthogonal, as an elastix affine-then-B-spline "
                      "chain or an oblique NiftyReg grid makes it); elastix and NiftyReg files hold that")  # fmt: skip
    if suffix == ".ffd":
        if ffd.basis == "bernstein":
            raise _refuse(path, what, "it has the 'bernstein' basis; .ffd lattices are cubic B-splines or "
                          "Blender's per-axis interpolations")  # fmt: skip
        if affine:
            raise _refuse(path, what, "it has an affine part, which .ffd files do not store")
        if ffd.only_inside:
            raise _refuse(path, what, "it moves only the points inside its domain (only_inside=True, as an ITK "
                          "transform does), a .ffd lattice moves every point its control points reach")  # fmt: skip
        lattice = ffd.lattice.copy()  # the file records the border and options the FFD uses (sections of their own)
        lattice.border = border
        options = {"basis": ffd.basis, "outside": ffd.outside, "strength": ffd.strength}
        lattice.metadata["ffd_options"] = {k: v for k, v in options.items() if v != _DEFAULT_OPTIONS[k]}
        save_ffd(path, lattice)
        return
    if ffd.basis != "bernstein":
        raise _refuse(path, what, f"it has the {ffd.basis!r} basis; PyGeM's FFD is a Bernstein one")
    if affine:
        raise _refuse(path, what, "it has an affine part, which .prm files do not store")
    if not ffd.only_inside:
        raise _refuse(path, what, "PyGeM moves only the points inside its box; this FFD moves points "
                      "outside too (use only_inside=True)")  # fmt: skip
    # strength and "outside" change the offsets only: the file holds the offsets they give
    save_prm(path, ffd.baked().lattice)


def _save_itk(path: str | os.PathLike[str], deformation: LoadedDeformation) -> None:
    """An ITK transform file: an FFD as :func:`save_transform` writes it, an affine, a field or a chain as the
    ITK transforms equal to it (fields only in HDF5 files, as ANTs writes its composites)."""
    if isinstance(deformation, FFD):
        save_transform(path, deformation)
        return
    try:
        transforms = deformation_to_transforms(deformation)
    except ValueError as exc:
        raise ValueError(f"{os.fspath(path)}: {exc}") from None
    suffix = Path(path).suffix.lower()
    if any(t.kind.startswith("DisplacementField") for t in transforms) and ITK_SUFFIXES[suffix] != "hdf5":
        raise ValueError(f"{os.fspath(path)}: a displacement field is not a lattice; ITK files hold one in HDF5 "
                         f"(.h5, .hdf5: a DisplacementFieldTransform, as ANTs writes its composites), not in "
                         f"{suffix!r} files; or fit a lattice first (fit_lattice(deformation, shape))")  # fmt: skip
    write_transforms(path, transforms)
