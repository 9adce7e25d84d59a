"""FSL FNIRT's transformation files: cubic B-spline coefficients and displacement fields, read and written.

What they mean is what FSL's own Python library computes (fslpy 3.29: ``fsl/transform/fnirt.py``,
``nonlinear.py``, ``fsl/data/image.py``; checked against it in the test suite):

- FSL works in *FSL coordinates* of an image: voxel indices times the voxel size, with x mirrored,
  ``(nx - 1 - i) * dx``, when the voxel-to-world matrix (the sform, else the qform) has a positive determinant.
  A transformation maps a reference image's FSL coordinates to a source image's, so reading one needs both
  images (as ``applywarp`` needs ``--ref`` and ``--in``).
- A coefficient file (intent 2007, ``FSL_CUBIC_SPLINE_COEFFICIENTS``; fslpy also reads TOPUP's 2016 so) holds
  one 3-vector per knot, in the reference's FSL coordinates. Its ``pixdim`` is the knot spacing in reference
  voxels, ``intent_p1..p3`` the voxel size of the reference it was made on (a reference of another voxel size
  scales the knot spacing), its sform the FLIRT *premat* (source FSL coordinates to reference FSL coordinates),
  and its qform offsets the reference's size. Knot ``q`` sits at reference voxel ``(q - 1) * spacing``; the
  displacement is the cubic B-spline sum of the 4x4x4 knots around a point, knots beyond the grid counting zero.
  A reference point ``r`` (FSL coordinates) goes to ``premat^-1 r + d(r)`` (fslpy's
  ``coefficientFieldToDeformationField``, as FSL's ``fnirtfileutils`` does). In world coordinates that is an FFD:
  the lattice is the knot grid placed on the reference (axis-aligned with its voxels), the offsets the knots'
  vectors carried into the source's world, the affine part the premat between the two worlds, the "zero" border.
- A displacement field (intent 2006) holds, at each voxel of its grid (placed in the world by its own header),
  the displacement from the reference's FSL coordinates to the source's (*relative*) or the source's FSL
  coordinates themselves (*absolute*). The files do not say which; fslpy guesses from which reading varies less.
  Here that reading must vary at least three times less than the other, or the file is refused (unless
  :func:`load_fnirt` is told which with ``field=``).
- Everything is then carried from the NIfTI world (RAS) to ITK's physical space (LPS), as SimpleITK reads images.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..ffd.deform import FFD
from ..ffd.lattice import Lattice
from .displacement_field import DisplacementField
from .nifti_files import (
    FSL_INTENTS,
    RAS_TO_LPS_4,
    NiftiFile,
    check_millimetres,
    lps_field,
    lps_matrix,
    nifti_meaning,
    read_nifti,
    read_nifti_header,
    voxel_positions,
    write_nifti,
)

__all__ = ["load_fnirt", "save_fnirt"]

_CUBIC = (2007, 2016)
_FIELD = 2006
_CLEAR = 3.0  # how much less one reading of a displacement field must vary than the other to be taken


@dataclass
class FslImage:
    """What FSL needs of an image: its voxel-to-world matrix (RAS), voxel size and size."""

    world: NDArray[np.float64]
    pixdim: NDArray[np.float64]
    shape: tuple[int, int, int]

    def voxel_to_fsl(self) -> NDArray[np.float64]:
        """Voxel indices to FSL coordinates: scaled by the voxel size, x mirrored for a positive determinant."""
        matrix = np.diag([*self.pixdim, 1.0])
        if np.linalg.det(self.world[:3, :3]) > 0:
            flip = np.diag([-1.0, 1.0, 1.0, 1.0])
            flip[0, 3] = (self.shape[0] - 1) * self.pixdim[0]
            matrix = flip @ matrix
        return matrix

    def fsl_to_world(self) -> NDArray[np.float64]:
        return self.world @ np.linalg.inv(self.voxel_to_fsl())


def fsl_image(image: Any, what: str) -> FslImage:
    """The FSL geometry of a reference or source: a NIfTI file (its header, read as fslpy reads it) or any
    reference grid :func:`~ffd_notebook.images.reference_grid` reads (its ITK geometry, carried to RAS)."""
    if image is None:
        raise ValueError(f"an FSL transformation needs its {what} image (as applywarp needs --ref and --in): "
                         f"load_deformation(path, reference=..., source=...)")  # fmt: skip
    if isinstance(image, str | os.PathLike) and os.fspath(image).lower().endswith((".nii", ".nii.gz")):
        header = read_nifti_header(image)
        shape = tuple(int(n) for n in header.get_data_shape()[:3])
        if len(shape) < 3:
            shape = shape + (1,) * (3 - len(shape))
        pixdim = np.asarray(header.get_zooms()[:3], dtype=np.float64)
        if int(header["qform_code"]) == 0 and int(header["sform_code"]) == 0:
            world = np.diag([*pixdim, 1.0])
        else:
            world = np.asarray(header.get_best_affine(), dtype=np.float64)
        return FslImage(world, pixdim, shape)  # type: ignore[arg-type]
    from ..images.reference import reference_grid

    grid = reference_grid(image)
    world = RAS_TO_LPS_4 @ grid.index_to_physical()
    return FslImage(world, np.asarray(grid.spacing, dtype=np.float64), tuple(grid.size))  # type: ignore[arg-type]


def _coefficients(nifti: NiftiFile, reference: FslImage, source: FslImage) -> FFD:
    header = nifti.header
    shape = nifti.shape
    if len(shape) != 4 or shape[3] != 3:
        raise nifti.fail(f"FNIRT coefficients are (nx, ny, nz, 3), got data of shape {shape}")
    if min(shape[:3]) < 4:
        raise nifti.fail(f"a grid of {shape[:3]} knots; a cubic B-spline needs at least 4 per axis")
    knots = np.asarray(header.get_zooms()[:3], dtype=np.float64)
    made_on = np.array([float(header[f"intent_p{i}"]) for i in (1, 2, 3)])
    if np.any(knots <= 0) or not np.all(np.isfinite(knots)):
        raise nifti.fail(f"a knot spacing (pixdim) of {knots.tolist()}; expected positive voxel counts")
    if np.any(made_on <= 0) or not np.all(np.isfinite(made_on)):
        raise nifti.fail(f"the reference voxel size (intent_p1..p3) is {made_on.tolist()}; expected positive sizes")
    premat = np.asarray(header.get_sform(), dtype=np.float64)  # source FSL -> reference FSL (FLIRT)
    if not np.all(np.isfinite(premat)) or abs(np.linalg.det(premat[:3, :3])) < 1e-12:
        raise nifti.fail(f"the premat (sform) is not an invertible affine matrix: {premat.round(6).tolist()}")
    step = knots * made_on / reference.pixdim  # knot spacing in this reference's voxels (fslpy's fieldToRefMat)
    assert nifti.data is not None
    coefficients = nifti.data
    ref_fsl_to_world = reference.fsl_to_world()
    src_fsl_to_world = source.fsl_to_world()
    # knot q rests at reference voxel (q - 1) * step: the lattice's placement in the reference's world (LPS)
    place = RAS_TO_LPS_4 @ reference.world @ np.diag([*step, 1.0])
    axes = place[:3, :3]
    spacing = np.linalg.norm(axes, axis=0)
    lattice = Lattice(shape[:3], spacing, place[:3, :3] @ [-1.0, -1.0, -1.0] + place[:3, 3], axes / spacing)
    carry = (RAS_TO_LPS_4 @ src_fsl_to_world)[:3, :3]  # a vector in the source's FSL coordinates, into LPS
    lattice.offsets[...] = coefficients @ carry.T
    affine = lps_matrix(src_fsl_to_world @ np.linalg.inv(premat) @ np.linalg.inv(ref_fsl_to_world))
    return FFD(lattice, "bspline", border="zero", affine=affine)


def _field(nifti: NiftiFile, reference: FslImage, source: FslImage, field: str | None) -> DisplacementField:
    shape = nifti.shape
    if len(shape) != 4 or shape[3] != 3:
        raise nifti.fail(f"an FNIRT displacement field is (nx, ny, nz, 3), got data of shape {shape}")
    world = nifti.world()
    voxels = voxel_positions(world, shape[:3])  # RAS world of each field voxel
    world_to_fsl = np.linalg.inv(reference.fsl_to_world())
    ref_fsl = voxels @ world_to_fsl[:3, :3].T + world_to_fsl[:3, 3]
    assert nifti.data is not None
    data = nifti.data
    if field is None:
        varies_as_is = float(data.reshape(-1, 3).std(axis=0).sum())
        varies_minus = float((data - ref_fsl).reshape(-1, 3).std(axis=0).sum())
        if max(varies_as_is, varies_minus) < _CLEAR * max(min(varies_as_is, varies_minus), 1e-12):
            raise nifti.fail(f"an FNIRT displacement field that does not say whether it holds displacements or "
                             f"positions, and whose values do not tell clearly either (they vary by "
                             f"{varies_as_is:.3g} mm read as displacements, {varies_minus:.3g} mm read as positions); "
                             "not guessed: say which with load_fnirt(path, reference=..., source=..., "
                             "field='relative' or 'absolute')")  # fmt: skip
        field = "relative" if varies_as_is < varies_minus else "absolute"
    src_fsl = data + ref_fsl if field == "relative" else data
    target = src_fsl @ source.fsl_to_world()[:3, :3].T + source.fsl_to_world()[:3, 3]
    return lps_field(nifti, target - voxels)


def fnirt_deformation(
    nifti: NiftiFile, intent: int, reference: Any, source: Any, field: str | None = None
) -> FFD | DisplacementField:
    """The deformation an FSL file (read by :func:`~.nifti_files.read_nifti`) holds, in LPS."""
    what = FSL_INTENTS.get(intent, f"intent {intent}")
    if intent not in (*_CUBIC, _FIELD):
        raise nifti.fail(f"{what} (intent {intent}): only cubic B-spline coefficients (2007, and TOPUP's 2016 as "
                         "fslpy reads them) and displacement fields (2006) are read, as fslpy evaluates")  # fmt: skip
    check_millimetres(nifti)
    ref, src = fsl_image(reference, "reference"), fsl_image(source, "source")
    return _coefficients(nifti, ref, src) if intent in _CUBIC else _field(nifti, ref, src, field)


def load_fnirt(
    path: str | os.PathLike[str], *, reference: Any, source: Any, field: str | None = None
) -> FFD | DisplacementField:
    """Read an FSL FNIRT coefficient file as an FFD, or an FNIRT displacement field, in ITK's physical space (LPS).

    The result moves a point of the reference image where FSL (fslpy) takes it in the source image: a
    coefficient file is ``FFD(lattice, border="zero", affine=premat)`` with an editable lattice on the knot
    grid, a displacement field a :class:`~ffd_notebook.io.DisplacementField` (see :mod:`.fnirt`).

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii`` or ``.nii.gz`` file with intent 2007 (or 2016) or 2006.
    reference, source : path or reference grid
        The images FNIRT registered (``--ref`` and ``--in``): NIfTI files (read as fslpy reads them), or
        anything :func:`~ffd_notebook.images.reference_grid` takes.
    field : {"relative", "absolute"}, optional
        What a displacement field holds: displacements or positions. FNIRT's files do not say; by default it is
        told from the values (the reading that varies at least three times less), and the file is refused when
        they do not tell clearly.

    Returns
    -------
    FFD or DisplacementField

    Raises
    ------
    FileFormatError
        Not an FSL file, quadratic or DCT coefficients, a field that does not tell displacements from positions;
        names the file.
    ValueError
        A missing reference or source.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> grid = {"size": (10, 10, 10), "spacing": 2.0}
    >>> lattice = Lattice((7, 7, 7), 4.0, origin=(-4.0, -4.0, -4.0))
    >>> lattice.offsets[3, 3, 3] = (0.0, 1.0, 0.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "coef.nii.gz"
    >>> save_fnirt(path, FFD(lattice), reference=grid, source=grid)
    >>> back = load_fnirt(path, reference=grid, source=grid)
    >>> bool(abs(back.deform([[8.0, 8.0, 8.0]]) - FFD(lattice).deform([[8.0, 8.0, 8.0]])).max() < 1e-6)
    True
    """
    nifti = read_nifti(path)
    kind, intent = nifti_meaning(nifti.header)
    if kind != "fsl":
        raise nifti.fail("not an FSL transformation (no FSL intent code)")
    if field not in (None, "relative", "absolute"):
        raise ValueError(f"field must be 'relative', 'absolute' or None, got {field!r}")
    return fnirt_deformation(nifti, intent, reference, source, field)


# ---------------------------------------------------------------------------------------- writing
def _refuse(path: str | os.PathLike[str], why: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: an FNIRT coefficient file cannot hold this deformation exactly: {why}")


def save_fnirt(path: str | os.PathLike[str], ffd: FFD, *, reference: Any, source: Any) -> None:
    """Write an FFD as an FNIRT cubic B-spline coefficient file that fslpy reads back to the same displacements.

    FNIRT's knots sit on the reference's voxel grid: knot ``q`` at voxel ``(q - 1) * spacing``. So the lattice
    must be the reference's voxel axes (same directions and order), its spacing a positive multiple of the voxel
    size per axis, and its control points on that knot grid (the lattice a loaded FNIRT file gives, or one made
    so); knots at rest are added in front of it. The FFD's basis must be the cubic B-spline with the "zero"
    border (fslpy counts knots beyond the grid as zero); its affine part becomes the premat. The coefficients are
    float32, as FNIRT writes them.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii`` or ``.nii.gz`` file.
    ffd : FFD
        The deformation.
    reference, source : path or reference grid
        The images the transformation maps between (see :func:`load_fnirt`).

    Raises
    ------
    ValueError
        What a coefficient file cannot hold exactly (the message says why), a missing reference or source.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> grid = {"size": (10, 10, 10), "spacing": 2.0}       # FSL mirrors x of this grid (LPS -> RAS: det > 0)
    >>> on_knots = Lattice((7, 7, 7), 4.0, origin=(-4.0, -4.0, -4.0))
    >>> save_fnirt(pathlib.Path(tempfile.mkdtemp()) / "coef.nii.gz", FFD(on_knots), reference=grid, source=grid)
    >>> off_knots = Lattice((7, 7, 7), 4.0, origin=(-3.0, -4.0, -4.0))
    >>> save_fnirt(pathlib.Path(tempfile.mkdtemp()) / "coef.nii.gz", FFD(off_knots), reference=grid, source=grid)
    Traceback (most recent call last):
    ...
    ValueError: ...: its control points are not on a knot grid of the reference ...
    """
    import nibabel as nib

    if not os.fspath(path).lower().endswith((".nii", ".nii.gz")):
        raise ValueError(f"{os.fspath(path)}: an FNIRT coefficient file is a .nii or .nii.gz file")
    if not isinstance(ffd, FFD):
        raise _refuse(path, f"it is a {type(ffd).__name__}, not an FFD (fit one first: fit_lattice)")
    if ffd.basis != "bspline" or ffd.border != "zero" or ffd.only_inside or ffd.weights is not None:
        raise _refuse(path, f"FNIRT's splines are cubic B-splines whose knots beyond the grid count zero (basis "
                      f"'bspline', border 'zero', only_inside False, no weights); this FFD has basis {ffd.basis!r}, "
                      f"border {ffd.border!r}, only_inside {ffd.only_inside}")  # fmt: skip
    ref, src = fsl_image(reference, "reference"), fsl_image(source, "source")
    ffd = ffd.baked()
    lattice = ffd.lattice
    # the lattice's steps in reference voxels: must be (step, 0, 0), (0, step, 0), (0, 0, step)
    to_voxel = np.linalg.inv(RAS_TO_LPS_4 @ ref.world)
    steps = to_voxel[:3, :3] @ (lattice.rotation * lattice.spacing)
    step = np.diag(steps).copy()
    if np.abs(steps - np.diag(step)).max() > 1e-6 * np.abs(step).max() or np.any(step <= 0):
        raise _refuse(path, "its lattice is not along the reference's voxel axes (in the same order and direction); "
                      "FNIRT's knots are on the reference's voxel grid")  # fmt: skip
    first = (to_voxel[:3, :3] @ lattice.origin + to_voxel[:3, 3]) / step + 1.0  # knot index of the first point
    lead = np.round(first)
    if np.abs(first - lead).max() > 1e-6 or np.any(lead < 0):
        raise _refuse(path, f"its control points are not on a knot grid of the reference (knot q at voxel (q - 1) "
                      f"x spacing; its first control point is at knot {first.round(6).tolist()})")  # fmt: skip
    carry = (RAS_TO_LPS_4 @ src.fsl_to_world())[:3, :3]
    coefficients = lattice.offsets @ np.linalg.inv(carry).T
    coefficients = np.pad(coefficients, [(int(n), 0) for n in lead] + [(0, 0)])
    world_affine = lps_matrix(ffd.affine)  # RAS
    ref_to_src = np.linalg.inv(src.fsl_to_world()) @ world_affine @ ref.fsl_to_world()
    if abs(np.linalg.det(ref_to_src[:3, :3])) < 1e-12:
        raise _refuse(path, "its affine part is singular (the premat is its inverse)")
    image = nib.Nifti1Image(coefficients.astype(np.float32), None)
    header = image.header
    header.set_intent(2007)
    header["intent_p1"], header["intent_p2"], header["intent_p3"] = ref.pixdim
    qform = np.diag([*step, 1.0])  # FNIRT's layout: the knot spacing, and the reference's size as offsets
    qform[:3, 3] = ref.shape
    image.set_sform(np.linalg.inv(ref_to_src), 1)
    image.set_qform(qform, 1)
    header.set_zooms((*step, 1.0))
    header.set_xyzt_units("mm")
    write_nifti(path, image)
