"""NiftyReg, ANTs and FSL's fslpy as the outside references for their own files, on a real MRI.

The MRI is nibabel's test image ``anatomical.nii`` (33 x 41 x 25 voxels, what notebook 08 uses), given an
oblique, anisotropic grid (voxels of 2 x 2.3 x 2.7 mm along rotated axes); the moving image is the same MRI
warped by a smooth known deformation and shifted. Both are written with the sform equal to the qform, so that
every tool (NiftyReg: the sform; ITK: its own rule; fslpy: nibabel's) places them alike. The registrations run
once per test session (:func:`run_niftyreg`, :func:`run_ants`): a few seconds each on one thread.

:func:`compare_inside` compares two resampled images where both sampled inside the moving image, as the tools
differ at its border (padding value, half-voxel rules).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from reference_env import ANTS_FSL, NIFTYREG

#: Grid of the fixed image: voxel size and rotation (degrees about x, y, z) of its axes, origin (RAS, mm).
FIXED_SPACING = (2.0, 2.3, 2.7)
FIXED_ANGLES = (12.0, -8.0, 20.0)
FIXED_ORIGIN = (30.0, -45.0, -20.0)
MOVING_SHIFT = (3.0, -2.0, 1.5)


def _rotation(angles_deg) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("xyz", angles_deg, degrees=True).as_matrix()


def write_nifti(path: Path, data: np.ndarray, affine: np.ndarray) -> Path:
    """A float32 NIfTI file whose sform and qform are both ``affine`` (code 1, scanner)."""
    import nibabel as nib

    image = nib.Nifti1Image(np.asarray(data, dtype=np.float32), affine)
    image.set_sform(affine, 1)
    image.set_qform(affine, 1)
    image.header.set_xyzt_units("mm")
    nib.save(image, path)
    return path


def mri_pair(folder: Path) -> tuple[Path, Path]:
    """``fixed.nii.gz`` (the MRI on an oblique anisotropic grid) and ``moving.nii.gz`` (it warped and shifted)."""
    import nibabel as nib
    from scipy import ndimage

    folder.mkdir(parents=True, exist_ok=True)
    source = Path(os.path.dirname(nib.__file__)) / "tests" / "data" / "anatomical.nii"
    data = np.asarray(nib.load(source).dataobj, dtype=np.float32)
    affine = np.eye(4)
    affine[:3, :3] = _rotation(FIXED_ANGLES) * np.array(FIXED_SPACING)
    affine[:3, 3] = FIXED_ORIGIN
    fixed = write_nifti(folder / "fixed.nii.gz", data, affine)
    i, j, k = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in data.shape], indexing="ij")
    di = 1.5 * np.sin(2 * np.pi * j / data.shape[1]) + 0.8
    dj = 1.2 * np.sin(2 * np.pi * k / data.shape[2]) - 0.5
    dk = 0.8 * np.sin(2 * np.pi * i / data.shape[0])
    moved = ndimage.map_coordinates(data, [i + di, j + dj, k + dk], order=1, mode="nearest")
    shifted = affine.copy()
    shifted[:3, 3] += MOVING_SHIFT
    moving = write_nifti(folder / "moving.nii.gz", moved, shifted)
    return fixed, moving


def big_reference(folder: Path, fixed: Path) -> Path:
    """An image grid that reaches well beyond the fixed image on every side (coarser, same orientation)."""
    import nibabel as nib

    affine = nib.load(fixed).affine.copy()
    affine[:3, :3] *= 2.5
    affine[:3, 3] -= affine[:3, :3] @ np.array([10.0, 10.0, 10.0])
    return write_nifti(folder / "big.nii.gz", np.zeros((40, 45, 35), np.float32), affine)


def run_niftyreg(folder: Path) -> dict[str, Path]:
    """reg_aladin, then reg_f3d -aff (its affine folded into the grid) and reg_f3d -aff -vel (a velocity grid);
    reg_resample (linear, NaN outside) and reg_transform -def / -disp of each on the fixed image and on a larger
    grid. Returns the files."""
    fixed, moving = mri_pair(folder)
    big = big_reference(folder, fixed)
    out = {"fixed": fixed, "moving": moving, "big": big}
    for name in ("aff", "cpp", "resampled", "def", "disp", "def_big", "vel", "vel_resampled", "vel_def", "vel_def_big"):
        out[name] = folder / {"aff": "aff.txt", "resampled": "resampled.nii.gz"}.get(name, f"{name}.nii.gz")
    NIFTYREG.call("reg_aladin", "-ref", fixed, "-flo", moving, "-aff", out["aff"], "-res", folder / "aladin.nii.gz",
                  "-voff", cwd=folder)  # fmt: skip
    NIFTYREG.call("reg_f3d", "-ref", fixed, "-flo", moving, "-aff", out["aff"], "-cpp", out["cpp"], "-res",
                  folder / "f3d.nii.gz", "-sx", "8", "-maxit", "60", "-voff", cwd=folder)  # fmt: skip
    resample(fixed, moving, out["cpp"], out["resampled"])
    NIFTYREG.call("reg_transform", "-ref", fixed, "-def", out["cpp"], out["def"], cwd=folder)
    NIFTYREG.call("reg_transform", "-ref", fixed, "-disp", out["cpp"], out["disp"], cwd=folder)
    NIFTYREG.call("reg_transform", "-ref", big, "-def", out["cpp"], out["def_big"], cwd=folder)
    # reg_f3d -vel: a velocity grid (half affines in its extensions), exponentiated on each reference's voxels
    NIFTYREG.call("reg_f3d", "-ref", fixed, "-flo", moving, "-aff", out["aff"], "-cpp", out["vel"], "-res",
                  folder / "vel_f3d.nii.gz", "-sx", "8", "-maxit", "30", "-ln", "2", "-vel", "-voff",
                  cwd=folder)  # fmt: skip
    resample(fixed, moving, out["vel"], out["vel_resampled"])
    NIFTYREG.call("reg_transform", "-ref", fixed, "-def", out["vel"], out["vel_def"], cwd=folder)
    NIFTYREG.call("reg_transform", "-ref", big, "-def", out["vel"], out["vel_def_big"], cwd=folder)
    return out


def resample(reference: Path, floating: Path, transformation: Path, result: Path) -> Path:
    """reg_resample with linear interpolation, NaN where a neighbour falls outside the floating image."""
    NIFTYREG.call("reg_resample", "-ref", reference, "-flo", floating, "-trans", transformation, "-res", result,
                  "-inter", "1", "-pad", "nan", "-voff", cwd=result.parent)  # fmt: skip
    return result


def deformation_field(reference: Path, transformation: Path, result: Path) -> Path:
    """reg_transform -def: the positions the transformation maps the reference's voxel centres to (RAS)."""
    NIFTYREG.call("reg_transform", "-ref", reference, "-def", transformation, result, cwd=result.parent)
    return result


ANTS_SCRIPT = """
import ants, numpy as np
folder = IN['json']['folder']
fixed = ants.image_read(folder + '/fixed.nii.gz'); moving = ants.image_read(folder + '/moving.nii.gz')
reg = ants.registration(fixed=fixed, moving=moving, type_of_transform='SyN', outprefix=folder + '/syn_',
                        random_seed=1)
composite = ants.registration(fixed=fixed, moving=moving, type_of_transform='SyN', outprefix=folder + '/comp_',
                              write_composite_transform=True, random_seed=1)
out = {}
for name, transforms in (('list', reg['fwdtransforms']), ('composite', [composite['fwdtransforms']])):
    warped = ants.apply_transforms(fixed=fixed, moving=moving, transformlist=transforms, interpolator='linear')
    ants.image_write(warped, folder + f'/ants_{name}.nii.gz')
# the inverse: the fixed image on the moving image's grid, through invtransforms (the affine inverted)
back = ants.apply_transforms(fixed=moving, moving=fixed, transformlist=reg['invtransforms'],
                             whichtoinvert=[True, False], interpolator='linear')
ants.image_write(back, folder + '/ants_inverse.nii.gz')
open(folder + '/transforms.txt', 'w').write('\\n'.join(reg['fwdtransforms'] + [composite['fwdtransforms']]
                                                     + [reg['invtransforms'][1]]))
"""


def run_ants(folder: Path, workdir: Path) -> dict[str, Path]:
    """ANTs SyN on the MRI pair, written as separate files and as a composite ``.h5``; each applied to the moving
    image by ``ants.apply_transforms`` (linear)."""
    fixed, moving = mri_pair(folder)
    ANTS_FSL.run(ANTS_SCRIPT, {"json": {"folder": str(folder)}}, workdir=workdir)
    warp, affine, composite, inverse_warp = (folder / "transforms.txt").read_text().split("\n")
    return {"fixed": fixed, "moving": moving, "warp": Path(warp), "affine": Path(affine),
            "composite": Path(composite), "inverse_warp": Path(inverse_warp),
            "ants_list": folder / "ants_list.nii.gz", "ants_composite": folder / "ants_composite.nii.gz",
            "ants_inverse": folder / "ants_inverse.nii.gz"}  # fmt: skip


APPLY_SCRIPT = """
import ants
fixed = ants.image_read(IN['json']['fixed']); moving = ants.image_read(IN['json']['moving'])
for result, transforms in IN['json']['jobs'].items():
    warped = ants.apply_transforms(fixed=fixed, moving=moving, transformlist=transforms, interpolator='linear')
    ants.image_write(warped, result)
"""


def ants_apply(fixed: Path, moving: Path, jobs: dict[Path, list[Path]], workdir: Path) -> None:
    """``ants.apply_transforms`` (linear) of lists of transform files, each written to its ``result`` path (the
    keys of ``jobs``), in one run of ANTs' Python."""
    meta = {"fixed": str(fixed), "moving": str(moving),
            "jobs": {str(result): [str(t) for t in files] for result, files in jobs.items()}}  # fmt: skip
    ANTS_FSL.run(APPLY_SCRIPT, {"json": meta}, workdir=workdir)


def inside_mask(deformation, reference, moving) -> np.ndarray:
    """Voxels of ``reference`` (array order) whose mapped point has all eight linear-interpolation neighbours in
    ``moving``: where every tool samples the image itself, not its padding."""
    from ffd_notebook.images import reference_grid

    ref, mov = reference_grid(reference), reference_grid(moving)
    points = ref.physical_points()
    index = (np.asarray(deformation.deform(points)) - mov.origin) @ np.linalg.inv(mov.direction * mov.spacing).T
    margin = 1e-6
    inside = np.all((index >= margin) & (index <= np.array(mov.size) - 1 - margin), axis=1)
    return inside.reshape(ref.shape)


def compare_inside(ours, theirs, mask) -> tuple[float, float, int]:
    """Max and median absolute difference of two images (arrays or SimpleITK images) over ``mask`` (and where
    ``theirs`` is finite), and the number of voxels compared."""
    import SimpleITK as sitk

    a = sitk.GetArrayFromImage(ours) if isinstance(ours, sitk.Image) else np.asarray(ours)
    b = sitk.GetArrayFromImage(theirs) if isinstance(theirs, sitk.Image) else np.asarray(theirs)
    keep = mask & np.isfinite(b)
    diff = np.abs(a[keep].astype(np.float64) - b[keep].astype(np.float64))
    return float(diff.max()), float(np.median(diff)), int(keep.sum())


FSLPY_SCRIPT = """
import numpy as np, nibabel as nib
import fsl.transform.fnirt as fnirt, fsl.transform.nonlinear as nonlinear
from fsl.data.image import Image
ref = Image(IN['json']['reference']); src = Image(IN['json']['source'])
field = fnirt.readFnirt(IN['json']['coefficients'], src, ref)
world = fnirt.fromFnirt(field, 'world', 'world')
out = {'world': np.asarray(world.data, dtype=np.float64), 'type': np.array(field.__class__.__name__)}
for kind in ('relative', 'absolute'):   # FNIRT displacement fields of the same deformation, as fslpy writes them
    df = nonlinear.coefficientFieldToDeformationField(field, defType=kind, premat=True)
    image = nib.Nifti1Image(np.asarray(df.data, dtype=np.float32), ref.voxToWorldMat)
    image.header['intent_code'] = 2006
    image.set_sform(ref.voxToWorldMat, 1); image.set_qform(ref.voxToWorldMat, 1)
    nib.save(image, IN['json']['fields'] + f'_{kind}.nii.gz')
save(**out)
"""


def fslpy_read(coefficients: Path, reference: Path, source: Path, workdir: Path) -> dict:
    """fslpy's reading of an FNIRT coefficient file: ``world`` (the displacements, reference world to source
    world, at the reference's voxels, RAS, array ``[i, j, k, 3]``), and FNIRT displacement fields of it, relative
    and absolute, written beside (``fields_relative.nii.gz``, ``fields_absolute.nii.gz``)."""
    meta = {"reference": str(reference), "source": str(source), "coefficients": str(coefficients),
            "fields": str(workdir / "fields")}  # fmt: skip
    return ANTS_FSL.run(FSLPY_SCRIPT, {"json": meta}, workdir=workdir)
