"""NiftyReg's files against NiftyReg itself: reg_f3d's grid, reg_transform's fields, reg_resample's images, and our
grids applied by reg_resample and reg_transform (see ``tests/registration_reference.py``)."""

from __future__ import annotations

import gzip
import os
import time

import nibabel as nib
import numpy as np
import pytest
import registration_reference as rr
import SimpleITK as sitk
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice, warp_image
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import DisplacementField, load_deformation, load_niftyreg, save_deformation, save_niftyreg

LPS = np.diag([-1.0, -1.0, 1.0])
EXACT_MM = 2e-4  # NiftyReg computes in float32: positions of ~100 mm carry about 1e-5 mm of rounding
VELOCITY_MM = 5e-3  # six squarings in float32 double NiftyReg's rounding six times over
GREY = 0.2  # grey levels of an MRI spanning 0..19009 (1e-5 of it): float32 positions move linear interpolation so


def niftyreg_field(path) -> tuple[np.ndarray, np.ndarray]:
    """A reg_transform -def file: the LPS voxel centres of its grid and the LPS positions they map to."""
    image = nib.load(path)
    positions = np.asarray(image.dataobj, dtype=np.float64)[:, :, :, 0, :].reshape(-1, 3)
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in image.shape[:3]], indexing="ij"), -1)
    centres = index.reshape(-1, 3) @ image.affine[:3, :3].T + image.affine[:3, 3]
    return centres @ LPS, positions @ LPS


def test_reg_f3d_grid_is_an_editable_lattice_that_moves_points_as_reg_transform(niftyreg_run):
    start = time.perf_counter()
    ffd = load_deformation(niftyreg_run["cpp"])
    print(f"\nload reg_f3d grid: {1000 * (time.perf_counter() - start):.1f} ms")
    assert isinstance(ffd, FFD) and ffd.border == "clamp" and ffd.basis == "bspline"
    header = nib.load(niftyreg_run["cpp"]).header
    assert ffd.lattice.shape == header.get_data_shape()[:3]
    assert np.allclose(ffd.lattice.spacing, 8.0)
    # the grid is oblique, placed by its sform (flipped to LPS)
    assert np.allclose(ffd.lattice.rotation * ffd.lattice.spacing, LPS @ header.get_sform()[:3, :3], atol=1e-5)
    for name in ("def", "def_big"):  # on the fixed image, and on a grid far beyond the control points
        centres, positions = niftyreg_field(niftyreg_run[name])
        error = np.abs(ffd.deform(centres) - positions)
        print(f"reg_transform -def ({name}) vs the loaded grid: max {error.max():.2e} mm, median "
              f"{np.median(error):.2e} mm over {len(error)} voxels")  # fmt: skip
        assert error.max() < EXACT_MM
    # reg_aladin's affine is in it: the displacement is mostly the affine's (several mm), not the local part
    centres, positions = niftyreg_field(niftyreg_run["def"])
    assert np.abs(positions - centres).max() > 3.0


def test_reg_f3d_grid_warps_the_image_as_reg_resample(niftyreg_run):
    ffd = load_deformation(niftyreg_run["cpp"])
    fixed, moving = str(niftyreg_run["fixed"]), str(niftyreg_run["moving"])
    ours = warp_image(moving, ffd, reference=fixed, interpolation="linear")
    theirs = sitk.ReadImage(str(niftyreg_run["resampled"]), sitk.sitkFloat64)
    mask = rr.inside_mask(ffd, fixed, moving)
    worst, median, count = rr.compare_inside(ours, theirs, mask)
    print(f"\nreg_resample vs warp_image with the grid: max {worst:.3g}, median {median:.2g} grey levels over "
          f"{count} voxels (image 0..{sitk.GetArrayFromImage(theirs)[mask].max():.0f})")  # fmt: skip
    assert count > 0.5 * mask.size and worst < GREY


def test_reg_transform_fields_are_read_as_displacement_fields(niftyreg_run, tmp_path):
    deformation = load_deformation(niftyreg_run["def"])
    displacement = load_deformation(niftyreg_run["disp"])
    for field in (deformation, displacement):
        assert isinstance(field, DisplacementField) and field.outside == "nearest"
    centres, positions = niftyreg_field(niftyreg_run["def"])
    assert np.abs(deformation.deform(centres) - positions).max() < EXACT_MM
    assert np.abs(displacement.deform(centres) - positions).max() < EXACT_MM
    # between voxel centres and far beyond the field's grid: NiftyReg's trilinear rule, its border repeated
    for field, name in ((deformation, "def"), (displacement, "disp")):
        big = rr.deformation_field(niftyreg_run["big"], niftyreg_run[name], tmp_path / f"{name}_big.nii.gz")
        centres, positions = niftyreg_field(big)
        error = np.abs(field.deform(centres) - positions)
        print(f"\nreg_transform -def of its own -{name} field on a larger grid vs the loaded field: max "
              f"{error.max():.2e} mm")  # fmt: skip
        assert error.max() < EXACT_MM


def test_our_grids_are_applied_by_niftyreg_as_we_apply_them(niftyreg_run, tmp_path):
    rng = np.random.default_rng(3)
    rotation = Rotation.from_euler("xyz", [10, 20, -15], degrees=True).as_matrix()
    sheared = rotation @ np.array([[1.0, 0.3, 0.0], [0.0, 1.0, -0.2], [0.0, 0.0, 1.0]])
    sheared /= np.linalg.norm(sheared, axis=0)
    affine = np.eye(4)
    affine[:3, :3] = [[1.05, 0.03, 0.0], [-0.02, 0.97, 0.04], [0.01, 0.0, 1.02]]
    affine[:3, 3] = (2.0, -1.0, 3.0)
    big, fixed, moving = niftyreg_run["big"], niftyreg_run["fixed"], niftyreg_run["moving"]
    cases = [("zero", rotation, None), ("clamp", rotation, None), ("zero", sheared, affine), ("clamp", sheared, affine)]
    for border, axes, matrix in cases:
        lattice = Lattice((6, 7, 5), (9.0, 8.0, 11.0), origin=(-40.0, 30.0, -35.0), rotation=axes)
        lattice.offsets[...] = rng.normal(0.0, 2.0, lattice.offsets.shape)
        ffd = FFD(lattice, border=border, affine=matrix)
        path = tmp_path / f"ours_{border}_{matrix is not None}.nii.gz"
        save_deformation(path, ffd, format="niftyreg")
        centres, positions = niftyreg_field(rr.deformation_field(big, path, tmp_path / "def.nii.gz"))
        error = np.abs(ffd.deform(centres) - positions)
        print(f"\nour grid ({border}, sheared={lattice.sheared}, affine={matrix is not None}) by reg_transform: max "
              f"{error.max():.2e} mm over {len(error)} voxels of a grid beyond the lattice")  # fmt: skip
        assert error.max() < EXACT_MM
        back = load_deformation(path)
        points = rng.normal(0.0, 60.0, (500, 3))
        assert np.abs(back.deform(points) - ffd.deform(points)).max() < 1e-4
    theirs = sitk.ReadImage(str(rr.resample(fixed, moving, path, tmp_path / "res.nii.gz")), sitk.sitkFloat64)
    ours = warp_image(str(moving), ffd, reference=str(fixed))
    worst, median, count = rr.compare_inside(ours, theirs, rr.inside_mask(ffd, fixed, moving))
    print(f"reg_resample of our sheared grid vs warp_image: max {worst:.3g}, median {median:.2g} grey levels, "
          f"{count} voxels")  # fmt: skip
    assert count > 1000 and worst < GREY


def test_the_reg_f3d_grid_round_trips_through_every_lattice_format_that_holds_it(niftyreg_run, tmp_path):
    ffd = load_deformation(niftyreg_run["cpp"])
    rng = np.random.default_rng(1)
    points = rng.normal(0.0, 50.0, (1000, 3))
    save_deformation(tmp_path / "again.nii.gz", ffd, format="niftyreg")
    assert np.abs(load_deformation(tmp_path / "again.nii.gz").deform(points) - ffd.deform(points)).max() < 1e-4
    save_deformation(tmp_path / "grid.ffd", ffd)  # .ffd keeps the clamp border; the grid is oblique, not sheared
    # (its quaternion makes the float32 sform's axes exactly orthogonal: 1e-7 mm)
    assert np.abs(load_deformation(tmp_path / "grid.ffd").deform(points) - ffd.deform(points)).max() < 1e-6
    with pytest.raises(ValueError, match=r"border='clamp' has no ITK transform"):
        save_deformation(tmp_path / "grid.tfm", ffd)


def _grid_file(tmp_path, name="cpp.nii.gz", *, p1=2.0, shape=(5, 5, 5, 1, 3), dtype=np.float32, units="mm",
               intent_name="NREG_TRANS", descrip="", extensions=()):  # fmt: skip
    image = nib.Nifti1Image(np.zeros(shape, dtype), np.diag([2.0, 2.0, 2.0, 1.0]))
    image.header.set_intent("vector", name=intent_name)
    image.header["intent_p1"] = p1
    image.header.set_xyzt_units(units)
    image.header["descrip"] = descrip
    for code, content in extensions:
        image.header.extensions.append(nib.nifti1.Nifti1Extension(code, content))
    nib.save(image, tmp_path / name)
    return tmp_path / name


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"p1": 5.0}, r"a cubic B-spline velocity grid \(reg_f3d -vel\): .*load_deformation\(path, reference=IMAGE\)"),
        ({"p1": 3.0}, "a velocity field of positions: NiftyReg's tools exponentiate it on different grids"),
        ({"p1": 4.0}, "a velocity field of displacements"),
        ({"p1": 6.0}, "a linear spline control-point grid"),
        ({"p1": 9.0}, "unknown intent_p1 code 9"),
        ({"p1": 2.5}, "unknown intent_p1 code 2.5"),
        ({"shape": (5, 5, 1, 1, 2)}, r"of shape \(5, 5, 1, 1, 2\)"),
        ({"shape": (5, 5, 5, 3)}, r"of shape \(5, 5, 5, 3\)"),
        ({"dtype": np.int16}, "datatype 4"),
        ({"units": "meter"}, "spatial units are metres"),
        ({"extensions": [(6, b"a comment")]}, "extension with code 6"),
        ({"extensions": [(0, b"short")]}, "extension of 5 bytes"),
        ({"intent_name": "SOMETHING"}, "marked as something this package does not read .*'SOMETHING'"),
        ({"intent_name": "", "descrip": "Deformation"}, "an SPM deformation"),
        ({"intent_name": "Mapping"}, "an SPM deformation"),
    ],
)
def test_what_cannot_be_read_exactly_is_refused_naming_the_file(tmp_path, options, message):
    path = _grid_file(tmp_path, **options)
    with pytest.raises(FileFormatError, match=f"cpp.nii.gz: .*{message}"):
        load_deformation(path)


def test_a_velocity_grid_is_exponentiated_on_the_reference_as_niftyreg_does(niftyreg_run, tmp_path):
    fixed, moving = niftyreg_run["fixed"], niftyreg_run["moving"]
    for reference, name in ((fixed, "vel_def"), (niftyreg_run["big"], "vel_def_big")):
        start = time.perf_counter()
        field = load_deformation(niftyreg_run["vel"], reference=str(reference))
        ms = 1000 * (time.perf_counter() - start)
        assert isinstance(field, DisplacementField) and field.outside == "nearest"
        centres, positions = niftyreg_field(niftyreg_run[name])
        error = np.abs(field.deform(centres) - positions)
        print(f"\nvelocity grid exponentiated on {reference.name} ({ms:.0f} ms) vs reg_transform -def: max "
              f"{error.max():.1e} mm, median {np.median(error):.1e} mm, displacements up to "
              f"{np.abs(positions - centres).max():.1f} mm")  # fmt: skip
        assert error.max() < VELOCITY_MM
    field = load_deformation(niftyreg_run["vel"], reference=str(fixed))
    ours = warp_image(str(moving), field, reference=str(fixed))
    theirs = sitk.ReadImage(str(niftyreg_run["vel_resampled"]), sitk.sitkFloat64)
    worst, median, count = rr.compare_inside(ours, theirs, rr.inside_mask(field, fixed, moving))
    print(f"reg_resample of the velocity grid vs warp_image: max {worst:.3g}, median {median:.2g} grey levels")
    assert count > 20000 and median < GREY and worst < 25 * GREY


def test_what_main_read_silently_as_itk_displacements_is_read_as_niftyreg_means_it(niftyreg_run):
    from ffd_notebook.io.displacement_field import load_displacement_field

    centres, positions = niftyreg_field(niftyreg_run["def"])
    as_itk = load_displacement_field(niftyreg_run["def"])  # SimpleITK's reading: what load_deformation did on main
    wrong = np.abs(as_itk.deform(centres) - positions).max()
    right = np.abs(load_deformation(niftyreg_run["def"]).deform(centres) - positions).max()
    print(f"\nreg_transform -def read as ITK displacements: {wrong:.0f} mm off; as NiftyReg's: {right:.1e} mm")
    assert wrong > 20.0 and right < EXACT_MM


def test_truncated_and_special_files_are_refused(niftyreg_run, tmp_path):
    data = niftyreg_run["cpp"].read_bytes()
    raw = gzip.decompress(data)
    (tmp_path / "cut.nii").write_bytes(raw[: len(raw) - 100])
    with pytest.raises(FileFormatError, match=r"cut\.nii: not a NIfTI file nibabel can read whole"):
        load_deformation(tmp_path / "cut.nii")
    (tmp_path / "cut.nii.gz").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match=r"cut\.nii\.gz"):
        load_deformation(tmp_path / "cut.nii.gz")
    header = bytearray(raw[:352])
    header[42:44] = (30000).to_bytes(2, "little")  # dim[1]: a huge declared size
    header[44:46] = (30000).to_bytes(2, "little")
    (tmp_path / "huge.nii").write_bytes(bytes(header) + raw[352:])
    with pytest.raises(FileFormatError, match=r"huge\.nii: .*larger than"):
        load_deformation(tmp_path / "huge.nii")
    os.mkfifo(tmp_path / "fifo.nii")
    with pytest.raises(FileFormatError, match=r"fifo\.nii: refused to read a FIFO"):
        load_deformation(tmp_path / "fifo.nii")
    with pytest.raises(FileFormatError, match=r"fifo\.nii: refused to read a FIFO"):
        load_niftyreg(tmp_path / "fifo.nii")


def test_fields_and_affines_of_niftyreg_are_written_back_exactly(niftyreg_run, tmp_path):
    field = load_deformation(niftyreg_run["disp"])
    with pytest.raises(ValueError, match="moves points beyond its grid"):
        save_deformation(tmp_path / "f.nii.gz", field)
    save_niftyreg(tmp_path / "disp.nii.gz", field)
    back = load_deformation(tmp_path / "disp.nii.gz")
    centres, positions = niftyreg_field(deformation_of(tmp_path / "disp.nii.gz", niftyreg_run, tmp_path))
    assert np.abs(back.deform(centres) - positions).max() < EXACT_MM
    assert np.abs(field.deform(centres) - positions).max() < EXACT_MM


def deformation_of(path, run, tmp_path):
    return rr.deformation_field(run["big"], path, tmp_path / "def_of.nii.gz")


@pytest.mark.parametrize(
    ("offset", "fmt", "value", "message"),
    [
        (80, "<f", -8.0, r"pixdim\[1,2,3\] should be positive"),
        (254, "<h", -255, "sform_code -255 not valid"),
        (252, "<h", 77, "qform_code 77 not valid"),
        (0, "<i", 300, "sizeof_hdr"),
    ],
)
def test_a_header_nibabel_would_repair_is_refused_not_read_as_repaired(tmp_path, offset, fmt, value, message):
    import struct

    lattice = Lattice((5, 5, 5), 4.0, border="clamp")
    save_niftyreg(tmp_path / "cpp.nii", FFD(lattice))
    data = bytearray((tmp_path / "cpp.nii").read_bytes())
    struct.pack_into(fmt, data, offset, value)
    (tmp_path / "cpp.nii").write_bytes(bytes(data))
    with pytest.raises(FileFormatError, match=rf"cpp\.nii: .*({message}|not a NIfTI)"):
        load_deformation(tmp_path / "cpp.nii")
