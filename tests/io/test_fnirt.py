"""FSL FNIRT's files against FSL's own Python library, fslpy: our coefficient files read back by it to the same
displacements, and the displacement fields it writes read as the same deformation (see
``tests/registration_reference.py``). FNIRT itself is not on PyPI; fslpy is what FSLeyes evaluates FNIRT files with.
"""

from __future__ import annotations

import time

import nibabel as nib
import numpy as np
import pytest
import registration_reference as rr
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import DisplacementField, load_deformation, load_fnirt, save_deformation
from ffd_notebook.io.fnirt import fsl_image

LPS = np.diag([-1.0, -1.0, 1.0])
FLOAT32_MM = 2e-5  # FNIRT's coefficients are float32


def _image(path, shape, spacing, angles, origin, *, mirrored):
    rotation = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
    if mirrored:  # a negative determinant: "radiological", no flip in FSL's coordinates
        rotation = rotation @ np.diag([-1.0, 1.0, 1.0])
    affine = np.eye(4)
    affine[:3, :3] = rotation * np.array(spacing)
    affine[:3, 3] = origin
    return rr.write_nifti(path, np.random.default_rng(0).random(shape), affine)


@pytest.fixture(scope="module")
def fsl_case(tmp_path_factory):
    """A reference (positive determinant: FSL mirrors x), a source (negative), an FFD on FNIRT's knot grid with a
    premat, written by us, read by fslpy (and its displacement fields of it written by fslpy)."""
    folder = tmp_path_factory.mktemp("fnirt")
    reference = _image(folder / "ref.nii.gz", (20, 24, 18), (2.0, 2.2, 2.5), (10, -5, 15), (20, -30, -10),
                       mirrored=False)  # fmt: skip
    source = _image(folder / "src.nii.gz", (22, 20, 19), (1.8, 2.4, 2.1), (-8, 6, 3), (-25, 30, -15), mirrored=True)
    ref = fsl_image(reference, "reference")
    step = np.array([3.0, 3.0, 2.0])  # knot spacing in reference voxels
    place = np.diag([-1.0, -1.0, 1.0, 1.0]) @ ref.world @ np.diag([*step, 1.0])
    spacing = np.linalg.norm(place[:3, :3], axis=0)
    origin = place[:3, :3] @ [1.0, 1.0, 1.0] + place[:3, 3]  # knot (2, 2, 2): rest knots are written before it
    lattice = Lattice((8, 10, 11), spacing, origin, place[:3, :3] / spacing)
    lattice.offsets[...] = np.random.default_rng(1).normal(0.0, 1.5, lattice.offsets.shape)
    affine = np.eye(4)
    affine[:3, :3] = Rotation.from_euler("xyz", [3, -2, 4], degrees=True).as_matrix() * 1.03
    affine[:3, 3] = (1.0, -2.0, 0.5)
    ffd = FFD(lattice, affine=affine)
    start = time.perf_counter()
    save_deformation(folder / "coef.nii.gz", ffd, format="fnirt", reference=reference, source=source)
    saved_ms = 1000 * (time.perf_counter() - start)
    fslpy = rr.fslpy_read(folder / "coef.nii.gz", reference, source, folder)
    return {"folder": folder, "reference": reference, "source": source, "ffd": ffd, "fslpy": fslpy,
            "saved_ms": saved_ms}  # fmt: skip


def _ours_at_reference_voxels(deformation, reference):
    ref = fsl_image(reference, "reference")
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in ref.shape], indexing="ij"), -1)
    world = index.reshape(-1, 3) @ ref.world[:3, :3].T + ref.world[:3, 3]  # RAS
    moved = deformation.deform(world @ LPS) @ LPS
    return (moved - world).reshape(*ref.shape, 3)


def test_our_coefficient_file_is_read_by_fslpy_to_the_same_displacements(fsl_case):
    theirs = fsl_case["fslpy"]["world"]  # fslpy: reference world -> source world, relative, at reference voxels
    ours = _ours_at_reference_voxels(fsl_case["ffd"], fsl_case["reference"])
    error = np.abs(ours - theirs)
    print(f"\nsave FNIRT coefficients: {fsl_case['saved_ms']:.1f} ms; fslpy reads them back to within "
          f"{error.max():.1e} mm (median {np.median(error):.1e}) of the FFD, displacements up to "
          f"{np.abs(theirs).max():.1f} mm")  # fmt: skip
    assert error.max() < FLOAT32_MM
    header = nib.load(fsl_case["folder"] / "coef.nii.gz").header
    assert int(header["intent_code"]) == 2007 and np.allclose(header.get_zooms()[:3], (3.0, 3.0, 2.0))


def test_a_coefficient_file_is_an_editable_lattice_that_reads_back_exactly(fsl_case):
    start = time.perf_counter()
    back = load_deformation(fsl_case["folder"] / "coef.nii.gz", reference=fsl_case["reference"],
                            source=fsl_case["source"])  # fmt: skip
    print(f"\nload FNIRT coefficients: {1000 * (time.perf_counter() - start):.1f} ms")
    ffd = fsl_case["ffd"]
    assert isinstance(back, FFD) and back.border == "zero" and back.lattice.shape == (10, 12, 13)  # 2 rest knots
    assert np.allclose(back.lattice.offsets[2:, 2:, 2:], ffd.lattice.offsets, atol=1e-5)
    points = np.random.default_rng(2).normal(0.0, 40.0, (2000, 3))
    assert np.abs(back.deform(points) - ffd.deform(points)).max() < FLOAT32_MM
    ours = _ours_at_reference_voxels(back, fsl_case["reference"])
    assert np.abs(ours - fsl_case["fslpy"]["world"]).max() < FLOAT32_MM


def test_fnirt_displacement_fields_are_read_as_fslpy_means_them(fsl_case):
    images = {"reference": fsl_case["reference"], "source": fsl_case["source"]}
    relative = fsl_case["folder"] / "fields_relative.nii.gz"  # written by fslpy, intent 2006
    absolute = fsl_case["folder"] / "fields_absolute.nii.gz"
    fields = {"relative": load_deformation(relative, **images)}  # displacements: clearly so
    # positions between a reference and a mirrored source: read as displacements they vary 3x less than
    # as positions, not clearly enough to tell (fslpy would guess): refused unless told
    with pytest.raises(FileFormatError, match=r"fields_absolute\.nii.gz: .*not guessed: say which"):
        load_deformation(absolute, **images)
    fields["absolute"] = load_fnirt(absolute, **images, field="absolute")
    for kind, field in fields.items():
        assert isinstance(field, DisplacementField)
        error = np.abs(_ours_at_reference_voxels(field, fsl_case["reference"]) - fsl_case["fslpy"]["world"])
        print(f"\nFNIRT {kind} displacement field vs fslpy: max {error.max():.1e} mm")
        assert error.max() < FLOAT32_MM


def test_an_fnirt_field_is_told_relative_or_absolute_from_its_values_when_they_are_clear(fsl_case, tmp_path):
    reference = fsl_case["reference"]
    ref = fsl_image(reference, "reference")
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in ref.shape], indexing="ij"), -1)
    fsl = index @ ref.voxel_to_fsl()[:3, :3].T + ref.voxel_to_fsl()[:3, 3]
    small = 1.5 * np.sin(index / 4.0)  # a few millimetres: a registration within one subject's images
    loaded = {}
    for kind, values in (("relative", small), ("absolute", small + fsl)):
        image = nib.Nifti1Image(values.astype(np.float32), ref.world)
        image.header["intent_code"] = 2006
        nib.save(image, tmp_path / f"{kind}.nii.gz")
        loaded[kind] = load_deformation(tmp_path / f"{kind}.nii.gz", reference=reference, source=reference)
    points = ref_points(reference)
    assert np.abs(loaded["absolute"].deform(points) - loaded["relative"].deform(points)).max() < 1e-4
    assert np.abs(loaded["relative"].deform(points) - points).max() > 1.0


def ref_points(reference):
    from ffd_notebook.images import reference_grid

    return reference_grid(str(reference)).physical_points()


def test_fsl_files_need_their_images_and_refuse_what_fslpy_does_not_evaluate(fsl_case, tmp_path):
    coef = fsl_case["folder"] / "coef.nii.gz"
    with pytest.raises(ValueError, match=r"needs its reference image .*applywarp"):
        load_deformation(coef)
    with pytest.raises(ValueError, match="needs its source image"):
        load_fnirt(coef, reference=fsl_case["reference"], source=None)
    image = nib.load(coef)
    for intent, message in ((2008, "discrete cosine"), (2009, "quadratic"), (2018, "a TOPUP field")):
        copy = nib.Nifti1Image(np.asarray(image.dataobj), image.affine, image.header.copy())
        copy.header["intent_code"] = intent
        nib.save(copy, tmp_path / "other.nii.gz")
        with pytest.raises(FileFormatError, match=f"other.nii.gz: .*{message}.*only cubic"):
            load_deformation(tmp_path / "other.nii.gz", reference=fsl_case["reference"], source=fsl_case["source"])
    # a field whose values do not tell displacements from positions: refused, not guessed
    ref = fsl_image(fsl_case["reference"], "reference")
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in ref.shape], indexing="ij"), -1)
    fsl = index @ ref.voxel_to_fsl()[:3, :3].T + ref.voxel_to_fsl()[:3, 3]
    ambiguous = nib.Nifti1Image((fsl * 0.5).astype(np.float32), ref.world)
    ambiguous.header["intent_code"] = 2006
    nib.save(ambiguous, tmp_path / "ambiguous.nii.gz")
    with pytest.raises(FileFormatError, match=r"ambiguous\.nii.gz: .*not guessed"):
        load_deformation(tmp_path / "ambiguous.nii.gz", reference=fsl_case["reference"], source=fsl_case["source"])


def test_an_ffd_off_the_knot_grid_is_refused_with_the_reason(fsl_case, tmp_path):
    ffd = fsl_case["ffd"]
    moved = ffd.lattice.copy()
    moved.origin = moved.origin + 0.3
    with pytest.raises(ValueError, match="not on a knot grid of the reference"):
        save_deformation(tmp_path / "c.nii.gz", FFD(moved), format="fnirt", reference=fsl_case["reference"],
                         source=fsl_case["source"])  # fmt: skip
    turned = Lattice(ffd.lattice.shape, ffd.lattice.spacing, ffd.lattice.origin)
    with pytest.raises(ValueError, match="not along the reference's voxel axes"):
        save_deformation(tmp_path / "c.nii.gz", FFD(turned), format="fnirt", reference=fsl_case["reference"],
                         source=fsl_case["source"])  # fmt: skip
    with pytest.raises(ValueError, match=r"knots beyond the grid count zero .*border 'clamp'"):
        save_deformation(tmp_path / "c.nii.gz", FFD(ffd.lattice, border="clamp"), format="fnirt",
                         reference=fsl_case["reference"], source=fsl_case["source"])  # fmt: skip
    assert not (tmp_path / "c.nii.gz").exists()


def test_an_fnirt_file_converts_to_a_niftyreg_grid_that_niftyreg_applies_as_fslpy(fsl_case, tmp_path):
    from ffd_notebook.io.convert import convert

    start = time.perf_counter()
    convert(str(fsl_case["folder"] / "coef.nii.gz"), str(tmp_path / "cpp.nii.gz"), to="niftyreg",
            reference=str(fsl_case["reference"]), moving=str(fsl_case["source"]))  # fmt: skip
    ms = 1000 * (time.perf_counter() - start)
    field = rr.deformation_field(fsl_case["reference"], tmp_path / "cpp.nii.gz", tmp_path / "def.nii.gz")
    positions = np.asarray(nib.load(field).dataobj, dtype=np.float64)[:, :, :, 0, :]
    ref = fsl_image(fsl_case["reference"], "reference")
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in ref.shape], indexing="ij"), -1)
    world = index @ ref.world[:3, :3].T + ref.world[:3, 3]
    error = np.abs((positions - world) - fsl_case["fslpy"]["world"])
    print(f"\nconvert FNIRT -> NiftyReg: {ms:.0f} ms; reg_transform of it vs fslpy of the FNIRT file: max "
          f"{error.max():.1e} mm")  # fmt: skip
    assert error.max() < 2e-4
