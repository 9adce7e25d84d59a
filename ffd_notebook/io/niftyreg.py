"""NiftyReg's transformation files: ``reg_f3d``'s control-point grids and ``reg_transform``'s fields, read and written.

What NiftyReg computes (its ``reg-lib/cpu`` sources, version 1.5.70, checked against ``reg_resample`` and
``reg_transform`` themselves in the test suite):

- A file is a NIfTI vector image (``(nx, ny, nz, 1, 3)``, float32 or float64) with the intent name ``NREG_TRANS``
  and ``intent_p1`` saying what it holds (``NREG_TRANS_TYPE``, ``_reg_maths.h``): 0 a deformation field (the
  position each voxel maps to), 1 a displacement field, 2 a cubic B-spline control-point grid (``reg_f3d -cpp``),
  3-5 velocity fields and grids (``reg_f3d -vel``), 6 a linear spline grid.
- Everything is in the NIfTI world (RAS millimetres) of the sform, or of the qform when the sform code is 0.
  ffd_notebook works in ITK's physical space (LPS), as SimpleITK reads NIfTI: x and y change sign.
- A control-point grid holds the *positions* of its control points; control point ``(i, j, k)`` rests at the
  world position of voxel ``(i, j, k)`` of the grid (``reg_createControlPointGrid`` places the grid one spacing
  outside the reference image, with the reference's orientation: the sform may be oblique, and sheared). The
  deformation is the cubic B-spline sum of the 4x4x4 positions around a point (``get_BSplineBasisValues``);
  positions beyond the grid are the border's, moved by the rest offset (``get_SlidedValues``): in displacements,
  the border control points repeated, the "clamp" border. So the grid is exactly ``FFD(lattice, border="clamp")``
  with the lattice placed by the grid's own sform and its offsets the positions minus the rest positions.
  ``reg_f3d -aff`` folds ``reg_aladin``'s affine into the positions: it is in the offsets, everywhere exact (an
  affine part kept apart would not be: NiftyReg's border slides the control points by the rest offset, not by the
  affine's).
- A deformation or displacement field is trilinear between voxel centres, its border voxels repeated beyond the
  grid (``reg_defField_compose``): a :class:`~ffd_notebook.io.DisplacementField` with ``outside="nearest"``.
- A grid or field may carry affine matrices in NIfTI extensions (the symmetric registrations' half affines,
  ``reg_spline_getDeformationField``): the first is applied before the spline, the second after. The writer
  keeps an FFD's affine part there, exact everywhere.
- A velocity grid (``reg_f3d -vel``) is exponentiated by scaling and squaring on the voxel grid of the image it
  is applied to (``reg_spline_getDefFieldFromVelocityGrid``): a deformation only with that image, read so
  with ``reference=`` as a field on its voxels. Velocity *fields* (codes 3 and 4) are exponentiated on the
  reference's grid by ``reg_resample`` but on their own by ``reg_transform``: refused, with how to turn one
  into the deformation field meant.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..ffd.deform import FFD
from ..ffd.lattice import Lattice
from .displacement_field import DisplacementField
from .nifti_files import (
    NIFTYREG_CODES,
    RAS_TO_LPS,
    RAS_TO_LPS_4,
    NiftiFile,
    check_millimetres,
    lps_field,
    lps_matrix,
    nifti_meaning,
    read_nifti,
    vector_data,
    voxel_positions,
    write_nifti,
)
from .transform_chain import AffineTransform, TransformChain

__all__ = ["load_niftyreg", "save_niftyreg"]

_AFFINE_BYTES = 64  # a mat44 of float32, as NiftyReg stores an affine in an extension


def _extension_affines(nifti: NiftiFile) -> list[NDArray[np.float64]]:
    """The affine matrices NiftyReg keeps in the extensions (RAS), first the one applied before the spline."""
    out = []
    for ext in nifti.header.extensions:
        if int(ext.get_code()) != 0:
            raise nifti.fail(f"a NIfTI extension with code {int(ext.get_code())}; NiftyReg reads its first two "
                             "extensions, whatever they hold, as affine matrices (code 0)")  # fmt: skip
        content = ext.get_content()
        if len(content) < _AFFINE_BYTES:
            raise nifti.fail(f"a NIfTI extension of {len(content)} bytes where NiftyReg keeps a 4x4 float32 affine")
        matrix = np.frombuffer(content[:_AFFINE_BYTES], "<f4").astype(np.float64).reshape(4, 4)
        if not np.all(np.isfinite(matrix)) or not np.allclose(matrix[3], [0, 0, 0, 1]):
            raise nifti.fail(f"a NIfTI extension that is not an affine matrix: {matrix.round(4).tolist()}")
        out.append(matrix)
    if len(out) > 2:
        raise nifti.fail(f"{len(out)} NIfTI extensions; NiftyReg keeps at most two affines there")
    return out


def _grid_lattice(nifti: NiftiFile, positions: NDArray[np.float64]) -> Lattice:
    world = nifti.world()
    shape = positions.shape[:3]
    axes = RAS_TO_LPS @ world[:3, :3]
    spacing = np.linalg.norm(axes, axis=0)
    if np.any(spacing <= 0) or not np.all(np.isfinite(axes)) or np.linalg.cond(axes) > 1e12:
        raise nifti.fail(f"the grid's voxel-to-world matrix is singular: {world.round(6).tolist()}")
    try:
        lattice = Lattice(shape, spacing, RAS_TO_LPS @ world[:3, 3], axes / spacing, border="clamp")
    except ValueError as exc:
        raise nifti.fail(f"the grid is not a lattice: {exc}") from None
    lattice.offsets[...] = (positions - voxel_positions(world, shape)) @ RAS_TO_LPS.T
    return lattice


def _field(nifti: NiftiFile, vectors: NDArray[np.float64], positions: bool) -> DisplacementField:
    displacements = vectors - voxel_positions(nifti.world(), vectors.shape[:3]) if positions else vectors
    return lps_field(nifti, displacements, outside="nearest")


def niftyreg_deformation(
    nifti: NiftiFile, code: Any, reference: Any = None
) -> FFD | DisplacementField | TransformChain:
    """The deformation a NiftyReg file (read by :func:`~.nifti_files.read_nifti`) holds, in LPS; a velocity grid's
    on the ``reference`` grid it is exponentiated on."""
    if code not in NIFTYREG_CODES:
        raise nifti.fail(f"a NiftyReg file (intent name NREG_TRANS) with the unknown intent_p1 code {code!r}; "
                         f"known codes: {', '.join(f'{k} {v}' for k, v in NIFTYREG_CODES.items())}")  # fmt: skip
    what = NIFTYREG_CODES[code]
    if code in (3, 4):
        raise nifti.fail(f"{what}: NiftyReg's tools exponentiate it on different grids (reg_resample on the "
                         "reference image's voxels, reg_transform on the field's own), so what it means depends on "
                         "the tool; turn it into the deformation field you mean with `reg_transform -ref REF.nii.gz "
                         "-def THIS_FILE def.nii.gz` and load that")  # fmt: skip
    if code == 5 and reference is None:
        raise nifti.fail(f"{what} (reg_f3d -vel): NiftyReg exponentiates it by scaling and squaring on the voxel "
                         "grid of the image it is applied to, so it is a deformation only with that image: "
                         "load_deformation(path, reference=IMAGE)")  # fmt: skip
    if code == 6:
        raise nifti.fail(f"{what} (intent_p1 6): its piecewise-linear interpolation is not one of ffd_notebook's "
                         "bases, so it is not read; `reg_transform -ref REF.nii.gz -def THIS_FILE def.nii.gz` "
                         "turns it into a deformation field")  # fmt: skip
    dtype = int(nifti.header["datatype"])
    if dtype not in (16, 64):
        raise nifti.fail(f"NIfTI datatype {dtype}; NiftyReg's transformations are float32 (16) or float64 (64)")
    slope, inter = (float(nifti.header[k]) for k in ("scl_slope", "scl_inter"))
    if not (np.isnan(slope) or slope in (0.0, 1.0)) or not (np.isnan(inter) or inter == 0.0):
        raise nifti.fail(f"a data scaling (slope {slope}, intercept {inter}) NiftyReg does not apply to its "
                         "transformations; ffd_notebook would have to guess")  # fmt: skip
    check_millimetres(nifti)
    shape = nifti.shape
    if len(shape) != 5 or shape[3] != 1 or shape[4] != 3 or min(shape[:3]) < 2:
        raise nifti.fail(f"{what} of shape {shape}; NiftyReg's 3D transformations are (nx, ny, nz, 1, 3) with at "
                         "least 2 voxels per axis (a 2D one has 2 components and is not read)")  # fmt: skip
    vectors = vector_data(nifti)
    affines = [lps_matrix(m) for m in _extension_affines(nifti)]
    if code == 2:
        return _grid_ffd(nifti, _grid_lattice(nifti, vectors), affines)
    if code == 5:
        return _exponentiated(nifti, _grid_lattice(nifti, vectors), affines, reference)
    field = _field(nifti, vectors, positions=code == 0)
    if not affines:
        return field
    return TransformChain([AffineTransform(affines[0]), field, *[AffineTransform(m) for m in affines[1:]]])


_MAX_STEP = 0.28  # NiftyReg's bound on a scaled velocity (mm, 3D): sqrt(0.5^2 / 3), rounded as it writes it
_MIN_SQUARINGS = 6


def _exponentiated(
    nifti: NiftiFile, lattice: Lattice, affines: list[NDArray[np.float64]], reference: Any
) -> DisplacementField:
    """A velocity grid exponentiated on the reference's voxels as NiftyReg does it
    (``reg_spline_getDefFieldFromVelocityGrid``): the flow ``v(y) = S(A0 y) - A0 y`` at every voxel (``S`` the
    grid's spline of positions, ``A0`` its first extension's affine), scaled down by ``2^n`` (``n`` =
    ``|intent_p2|``, or NiftyReg's count from the largest value when it is 0; a negative ``intent_p2`` is the
    backward deformation), composed with itself ``n`` times (trilinear, border repeated), the affine put back
    (``A0 y + ...``) and the second extension's affine applied after."""
    from ..images.reference import reference_grid

    grid = reference_grid(reference)
    if grid.dim != 3:
        raise ValueError(f"a 3D reference image is needed to exponentiate {nifti.path}, got {grid.dim}D")
    before = affines[0] if affines else np.eye(4)
    points = grid.physical_points()
    start = points @ before[:3, :3].T + before[:3, 3]
    flow = FFD(lattice, "bspline", border="clamp").deform(start) - start
    p2 = float(nifti.header["intent_p2"])
    if not np.isfinite(p2):
        raise nifti.fail(f"intent_p2 (the number of squaring steps) is {p2}")
    steps = round(abs(p2))
    if steps == 0:  # NiftyReg's own count: enough halvings to bring every value under 0.28 mm, at least 6
        largest = float(np.abs(flow).max())
        steps = 1
        while largest / 2.0**steps >= _MAX_STEP:
            steps += 1
        steps = max(steps, _MIN_SQUARINGS)
    if steps > 64:
        raise nifti.fail(f"{steps} squaring steps (intent_p2); NiftyReg writes a handful")
    displacement = flow / (2.0**steps * (-1.0 if p2 < 0 else 1.0))
    shape = (*grid.shape, 3)  # array order (nz, ny, nx): physical_points() is i-fastest
    field = DisplacementField(displacement.reshape(shape), grid.spacing, grid.origin, grid.direction,
                              outside="nearest")  # fmt: skip
    for _ in range(steps):  # phi <- phi o phi, sampled at the voxels
        displacement = displacement + field.displacement(points + displacement)
        field.vectors = displacement.reshape(shape)
    positions = start + displacement
    if len(affines) > 1:
        positions = positions @ affines[1][:3, :3].T + affines[1][:3, 3]
    return DisplacementField((positions - points).reshape(shape), grid.spacing, grid.origin, grid.direction,
                             outside="nearest")  # fmt: skip


def _grid_ffd(nifti: NiftiFile, lattice: Lattice, affines: list[NDArray[np.float64]]) -> FFD:
    """The grid's FFD with the extensions' affines folded in: ``A1 (S(A0 x))`` is one FFD whose lattice is the
    grid pulled back through ``A0`` (sheared if ``A0`` shears it) with offsets ``A1 @ offsets`` and the affine
    part ``A1 A0``."""
    before = affines[0] if affines else np.eye(4)
    after = affines[1] if len(affines) > 1 else np.eye(4)
    if not np.array_equal(before, np.eye(4)):
        inverse = np.linalg.inv(before)
        axes = inverse[:3, :3] @ (lattice.rotation * lattice.spacing)
        spacing = np.linalg.norm(axes, axis=0)
        try:
            pulled = Lattice(lattice.shape, spacing, inverse[:3, :3] @ lattice.origin + inverse[:3, 3],
                             axes / spacing, offsets=lattice.offsets, border="clamp")  # fmt: skip
        except ValueError as exc:
            raise nifti.fail(f"the affine of its first extension makes the grid no lattice: {exc}") from None
        lattice = pulled
    lattice.offsets[...] = lattice.offsets @ after[:3, :3].T
    return FFD(lattice, "bspline", border="clamp", affine=after @ before)


def load_niftyreg(path: str | os.PathLike[str], *, reference: Any = None) -> FFD | DisplacementField | TransformChain:
    """Read a NiftyReg transformation file: a control-point grid as an FFD, a field as a DisplacementField.

    The result lives in ITK's physical space (LPS millimetres), as SimpleITK reads the images it is applied to,
    and moves points as ``reg_transform -def`` and ``reg_resample`` do (see :mod:`.niftyreg`): a ``reg_f3d``
    control-point grid is ``FFD(lattice, border="clamp")`` with an editable lattice placed by the grid's own
    sform (sheared if the sform is), ``reg_aladin``'s affine included where ``reg_f3d -aff`` folded it into the
    grid, affines in the file's extensions folded in (``reg_resample`` applies the first before the spline, the
    second after); a deformation or displacement field is a :class:`~ffd_notebook.io.DisplacementField` whose border
    voxels go on beyond its grid (``outside="nearest"``), a :class:`~ffd_notebook.io.TransformChain` with the
    affines of the file's extensions. A velocity grid (``reg_f3d -vel``) is a deformation only on the image
    NiftyReg exponentiates it on: with ``reference``, the field of that image's voxels, as ``reg_transform -ref
    REFERENCE -def`` computes it.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii`` or ``.nii.gz`` file with the intent name ``NREG_TRANS``.
    reference : path or reference grid, optional
        The image a velocity grid is exponentiated on (anything :func:`~ffd_notebook.images.reference_grid`
        reads); other files do not use it.

    Returns
    -------
    FFD, DisplacementField or TransformChain

    Raises
    ------
    FileFormatError
        Not a NiftyReg file, an unknown ``intent_p1`` code, a velocity grid without its reference, velocity
        fields (NiftyReg's tools exponentiate them differently: the message says how to turn one into a field),
        linear spline grids, 2D files, units other than millimetres; names the file and what it found.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lattice = Lattice((5, 5, 5), 4.0, origin=(-8.0, -8.0, -8.0), border="clamp")
    >>> lattice.offsets[2, 2, 2] = (1.0, 0.0, 0.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "cpp.nii.gz"
    >>> save_niftyreg(path, FFD(lattice))
    >>> back = load_niftyreg(path)
    >>> back.border, bool(np.allclose(back.deform([[0.0, 0.0, 0.0]]), [[1.0 * (2 / 3) ** 3, 0.0, 0.0]]))
    ('clamp', True)
    """
    nifti = read_nifti(path)
    kind, code = nifti_meaning(nifti.header)
    if kind != "niftyreg":
        raise nifti.fail("not a NiftyReg transformation (no intent name NREG_TRANS)")
    return niftyreg_deformation(nifti, code, reference)


# ---------------------------------------------------------------------------------------- writing
def _refuse(path: str | os.PathLike[str], why: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: a NiftyReg control-point grid cannot hold this deformation exactly: {why}")


def niftyreg_grid(
    path: str | os.PathLike[str], ffd: FFD
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """The control-point positions (RAS, ``(nx, ny, nz, 3)``), the grid's voxel-to-world matrix and the affine
    matrix applied after the spline (RAS, or ``None``) of an FFD NiftyReg's grids hold exactly, or ``ValueError``.

    The "clamp" border is NiftyReg's own rule: the lattice is the grid. With the "zero" border the grid gets three
    more layers of control points at rest all round, which NiftyReg's rule then repeats: zero displacement where
    the lattice no longer reaches (its supports end two layers out). An affine part ``A x + b`` goes into the
    grid's second NIfTI extension, which NiftyReg applies after the spline (the first, applied before, is the
    identity), the offsets becoming ``A^-1 offsets``: ``A (x + A^-1 T_local(x)) + b``, exact everywhere (folded
    into the positions, as ``reg_f3d -aff`` does, it would not be beyond the grid).
    """
    if not isinstance(ffd, FFD):
        raise TypeError(f"expected an FFD, got {type(ffd).__name__}")
    if ffd.basis != "bspline":
        raise _refuse(path, f"it has the {ffd.basis!r} basis; NiftyReg's grids are cubic B-splines on every axis")
    if ffd.weights is not None:
        raise _refuse(path, "it has per-point weights, which belong to one mesh")
    if ffd.only_inside:
        raise _refuse(path, "it moves only the points inside its domain (only_inside=True); NiftyReg's grids move "
                      "every point")  # fmt: skip
    ffd = ffd.baked()  # strength and "outside" mode: the offsets and affine part they give
    lattice = ffd.lattice
    offsets, origin = lattice.offsets, lattice.origin
    if ffd.border == "zero":
        pad = 3
        offsets = np.pad(offsets, ((pad, pad), (pad, pad), (pad, pad), (0, 0)))
        origin = origin - lattice.rotation @ (pad * lattice.spacing)
    after = None
    if not np.array_equal(ffd.affine, np.eye(4)):
        linear = ffd.affine[:3, :3]
        if np.linalg.cond(linear) > 1e12:
            raise _refuse(path, "its affine matrix is singular (the offsets A^-1 offsets do not exist)")
        offsets = offsets @ np.linalg.inv(linear).T
        after = lps_matrix(ffd.affine)
    placement = np.eye(4)  # index -> LPS: columns one step along each lattice axis, then the origin
    placement[:3, :3] = lattice.rotation * lattice.spacing
    placement[:3, 3] = origin
    positions = voxel_positions(placement, offsets.shape[:3]) + offsets
    return positions @ RAS_TO_LPS.T, RAS_TO_LPS_4 @ placement, after


def save_niftyreg(path: str | os.PathLike[str], deformation: FFD | DisplacementField) -> None:
    """Write an FFD as a NiftyReg cubic B-spline control-point grid, or a field as a NiftyReg displacement field,
    that ``reg_resample`` and ``reg_transform`` apply as ffd_notebook does, atomically.

    An FFD: see :func:`niftyreg_grid` for what is exact and what is refused. A
    :class:`~ffd_notebook.io.DisplacementField` must follow NiftyReg's rule beyond its grid
    (``outside="nearest"``, as NiftyReg's own fields are read); an ITK field leaves points there unmoved, which no
    NiftyReg field does. The file is float32, as NiftyReg computes (``reg_transform`` refuses a float64 grid: its
    deformation fields are float32), so positions are rounded to about 1e-7 of their size (1e-5 mm at 100 mm);
    its placement is in both the sform and the qform (an oblique grid is one too; a sheared one only in the
    sform, which NiftyReg prefers), in RAS millimetres.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii`` or ``.nii.gz`` file.
    deformation : FFD or DisplacementField
        A cubic B-spline FFD, or a field with ``outside="nearest"``.

    Raises
    ------
    ValueError
        What NiftyReg's files cannot hold exactly (the message says why).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "cpp.nii"
    >>> save_niftyreg(path, FFD(Lattice((4, 4, 4), 2.0), "bernstein"))
    Traceback (most recent call last):
    ...
    ValueError: ...cpp.nii: a NiftyReg control-point grid cannot hold this deformation exactly: it has the ...
    """
    import nibabel as nib

    name = os.fspath(path).lower()
    if not name.endswith((".nii", ".nii.gz")):
        raise ValueError(f"{os.fspath(path)}: a NiftyReg file is a .nii or .nii.gz file")
    extensions: list[NDArray[np.float64]] = []
    if isinstance(deformation, DisplacementField):
        if deformation.outside != "nearest":
            raise ValueError(f"{os.fspath(path)}: a NiftyReg displacement field repeats its border voxels beyond its "
                             "grid; this field leaves points there unmoved (ITK's rule), so NiftyReg would move "
                             "them: not written (resample it on a grid that covers every point you need)")  # fmt: skip
        grid = deformation.grid
        world = RAS_TO_LPS_4 @ grid.index_to_physical()
        values = (deformation.vectors @ RAS_TO_LPS.T).transpose(2, 1, 0, 3)  # array order to nibabel's (i, j, k)
        code = 1  # DISP_FIELD
    else:
        values, world, after = niftyreg_grid(path, deformation)
        code = 2  # CUB_SPLINE_GRID
        if after is not None:  # NiftyReg applies its first extension before the spline, its second after
            extensions = [np.eye(4), after]
    image = nib.Nifti1Image(values[:, :, :, None, :].astype(np.float32), world)
    header = image.header
    for matrix in extensions:  # NiftyReg's layout: a mat44 of float32 in 72 bytes (an extension of 80)
        header.extensions.append(nib.nifti1.Nifti1Extension(0, matrix.astype("<f4").tobytes() + bytes(8)))
    header.set_sform(world, 1)
    gram = world[:3, :3].T @ world[:3, :3]
    if np.allclose(gram, np.diag(np.diag(gram)), rtol=0, atol=1e-9 * gram.max()):
        header.set_qform(world, 1)
    else:
        header.set_qform(None, 0)  # a sheared grid: a qform cannot hold it, the sform (preferred) does
    header.set_intent("vector", name="NREG_TRANS")
    header["intent_p1"] = code
    header.set_xyzt_units("mm")
    write_nifti(path, image)
