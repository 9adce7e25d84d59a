"""``python -m ffd_notebook convert IN OUT``: a deformation from one file format to another.

Formats by extension: ``.ffd``, ITK and ANTs transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``, ``.mat``),
elastix transform parameter files (``.txt``, told from ITK's by content; ``--to elastix`` to write one),
PyGeM ``.prm``, NiftyReg and FSL FNIRT files (``.nii``, ``.nii.gz``, told by their header; ``--to niftyreg``
or ``--to fnirt`` to write one) and displacement fields (``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha``). An FNIRT
file maps ``--reference IMAGE`` to ``--source IMAGE``, reading or writing. A conversion that could not be
exact (a Bernstein lattice to ITK, an ITK transform that leaves points outside its domain unmoved to ``.ffd``,
a field to a lattice, a NiftyReg grid with its clamp border to ITK, ...) is refused with the reason; ``--fit
SHAPE`` fits a lattice (:func:`~ffd_notebook.io.fit_lattice`) where one must be made, and tells the residual. A
field is written on the voxel grid of ``--reference IMAGE``, of the source field, or of an elastix chain's
fixed image.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from typing import Any

from ..errors import FileFormatError
from ..ffd.deform import FFD
from .deformation_files import DEFORMATION_FORMATS, DEFORMATION_SUFFIXES, load_deformation, save_deformation
from .displacement_field import DisplacementField, field_suffix, save_displacement_field
from .elastix import ElastixTransform, load_elastix
from .elastix_text import is_parameter_file
from .lattice_fitting import fit_lattice
from .transform_chain import AffineTransform, TransformChain

__all__ = ["convert", "convert_main", "parse_shape"]


def parse_shape(text: str) -> tuple[int, int, int]:
    """``"16"``, ``"16x16x12"`` or ``"16,16,12"`` as three control-point counts.

    Examples
    --------
    >>> parse_shape("8"), parse_shape("16x16x12")
    ((8, 8, 8), (16, 16, 12))
    """
    parts = [p for p in re.split(r"[x,\s]+", text.strip().lower()) if p]
    if len(parts) not in (1, 3) or not all(p.isdigit() for p in parts):
        raise ValueError(f"expected a lattice shape N or NXxNYxNZ, got {text!r}")
    counts = tuple(int(p) for p in parts) * (3 if len(parts) == 1 else 1)
    if min(counts) < 4:
        raise ValueError(f"a cubic B-spline lattice needs at least 4 control points per axis, got {text!r}")
    return counts  # type: ignore[return-value]


def _source(path: str, reference: Any, moving: Any) -> tuple[Any, FFD | None, str | None]:
    """The deformation a file holds, the FFD equal to it (if any) and why there is none."""
    if path.lower().endswith(".txt") and is_parameter_file(path):
        chain = load_elastix(path)
        try:
            return chain, chain.to_ffd(), None
        except ValueError as exc:
            return chain, None, f"this elastix chain has no FFD equal to it: {exc}"
    loaded = load_deformation(path, reference=reference, source=moving)
    if isinstance(loaded, FFD):
        return loaded, loaded, None
    what = {DisplacementField: "a displacement field", AffineTransform: "an affine transform"}
    return loaded, None, f"{what.get(type(loaded), 'a chain of transforms')} is not a lattice"


def convert(source: str, target: str, *, to: str | None = None, fit: str | None = None, affine: bool = False,
            reference: str | None = None, moving: str | None = None) -> list[str]:  # fmt: skip
    """Convert ``source`` to ``target``; return notes worth telling the user.

    Parameters
    ----------
    source, target : str
        Files to read and to write (the format of each by extension; elastix ``.txt`` by content).
    to : {"ffd", "itk", "elastix", "prm", "field", "niftyreg", "fnirt"}, optional
        The target format when its extension does not say (``.txt``: elastix for an elastix source,
        else ITK; ``.nii``/``.nii.gz``: a displacement field unless ``niftyreg`` or ``fnirt``).
    fit : str, optional
        A lattice shape (``"16"``, ``"16x16x12"``): fit a lattice to the source instead of
        requiring an exact one (:func:`~ffd_notebook.io.fit_lattice`, over a field's voxels or an
        elastix chain's fixed image grid).
    affine : bool
        With ``fit``: separate the affine part first.
    reference : str, optional
        An image whose voxel grid a displacement field is written on; for an FNIRT file (read or written), the
        image it maps from (FSL's ``--ref``).
    moving : str, optional
        For an FNIRT file, the image it maps to (FSL's ``--in``; ``--source`` on the command line).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import Lattice
    >>> from ffd_notebook.io import save_ffd
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> save_ffd(folder / "a.ffd", Lattice((4, 4, 4), 2.0, origin=(1.0, 2.0, 3.0)))
    >>> convert(str(folder / "a.ffd"), str(folder / "a.h5"))
    []
    >>> convert(str(folder / "a.ffd"), str(folder / "TransformParameters.0.txt"), to="elastix")
    []
    """
    if to is not None and to not in DEFORMATION_FORMATS:
        raise ValueError(f"--to must be one of {', '.join(DEFORMATION_FORMATS)}, got {to!r}")
    deformation, ffd, why_not = _source(source, reference, moving)
    notes = []
    if source.lower().endswith(".ffd") and ffd is not None and ffd.lattice.metadata.get("placement") is None:
        notes.append(f"{source} has no placement (#quaternion#) section: its lattice is written at origin "
                     "(0, 0, 0), axis-aligned (the FFD platform put it at the mesh's minimum corner)")  # fmt: skip
    to_field = to == "field" or (to is None and field_suffix(target) is not None)
    if to_field:
        grid: Any = reference
        if grid is None and isinstance(deformation, DisplacementField):
            grid = deformation
        if grid is None and isinstance(deformation, ElastixTransform):
            grid = deformation.grid
        if grid is None:
            raise ValueError(f"{target}: a displacement field needs a voxel grid: give --reference IMAGE")
        save_displacement_field(target, deformation, grid)
        return notes
    if fit is not None:
        region = None
        if not isinstance(deformation, DisplacementField) and reference is not None:
            region = reference
        if isinstance(deformation, FFD) and region is None:
            raise ValueError("--fit on a lattice file needs --reference IMAGE: the grid to fit over")
        if isinstance(deformation, ElastixTransform) and region is None and deformation.grid is None:
            raise ValueError(f"{source}: no fixed image grid (Size, Spacing, Origin, Direction) to fit over: give "
                             "--reference IMAGE")  # fmt: skip
        if isinstance(deformation, FFD | AffineTransform | TransformChain) and region is None:
            raise ValueError(f"--fit on {source} needs --reference IMAGE: the grid to fit over")
        ffd = fit_lattice(deformation, parse_shape(fit), region=region, affine=affine)
        report = ffd.lattice.metadata["fit"]
        notes.append(f"fitted a {'x'.join(map(str, ffd.lattice.shape))} lattice to {report['samples']} samples: "
                     f"residual RMS {report['rms']:.6g}, max {report['max']:.6g}")  # fmt: skip
        save_deformation(target, ffd, format=to, reference=reference, source=moving)
        return notes
    try:  # an affine or a chain goes to the formats that hold one (ITK .mat/.h5, NiftyReg fields) as it is
        save_deformation(target, ffd if ffd is not None else deformation, format=to, reference=reference,
                         source=moving)  # fmt: skip
    except ValueError as exc:
        if ffd is None:
            raise ValueError(f"{source}: {why_not}; give --fit SHAPE to fit a lattice to it (as is: {exc})") from None
        raise
    return notes


def convert_main(argv: Sequence[str]) -> int:
    """Command line of ``python -m ffd_notebook convert``; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m ffd_notebook convert",
        description="Convert a deformation between .ffd, ITK and ANTs transform, elastix parameter, PyGeM .prm, "
        "NiftyReg, FSL FNIRT and displacement field files (by extension; elastix .txt by content, NIfTI by header); "
        "refuses conversions that would not be exact, unless --fit makes a lattice.",
        epilog=f"extensions: {' '.join(DEFORMATION_SUFFIXES)}",
    )
    parser.add_argument("source", metavar="IN", help="file to read")
    parser.add_argument("target", metavar="OUT", help="file to write (replaced atomically)")
    parser.add_argument("--to", choices=DEFORMATION_FORMATS,
                        help="format of OUT when its extension does not say (.txt: elastix for an elastix IN, "
                        "else ITK)")  # fmt: skip
    parser.add_argument("--fit", metavar="SHAPE", help="fit a lattice of this shape (N or NXxNYxNZ) to IN")
    parser.add_argument("--affine", action="store_true", help="with --fit: separate the affine part first")
    parser.add_argument("--reference", metavar="IMAGE", help="image whose voxel grid a field is written on "
                        "(or --fit fits over); an FNIRT file's reference image (FSL's --ref)")  # fmt: skip
    parser.add_argument("--source", dest="moving", metavar="IMAGE", help="an FNIRT file's source image (FSL's --in)")
    args = parser.parse_args(list(argv))
    try:
        notes = convert(args.source, args.target, to=args.to, fit=args.fit, affine=args.affine,
                        reference=args.reference, moving=args.moving)  # fmt: skip
    except (FileFormatError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    print(f"{args.source} -> {args.target}")
    return 0
