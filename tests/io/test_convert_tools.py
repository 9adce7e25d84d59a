"""``python -m ffd_notebook convert`` between the registration tools' files, checked by the tools: what is exact is
written, what is not is refused with the reason (see ``tests/registration_reference.py``)."""

from __future__ import annotations

import time

import nibabel as nib
import numpy as np
import registration_reference as rr
import SimpleITK as sitk

from ffd_notebook.io import DisplacementField, load_deformation
from ffd_notebook.io.convert import convert, convert_main

LPS = np.diag([-1.0, -1.0, 1.0])


def _timed(source, target, **options):
    start = time.perf_counter()
    notes = convert(str(source), str(target), **options)
    print(f"\nconvert {source.name} -> {target.name} {options or ''}: {1000 * (time.perf_counter() - start):.0f} ms"
          + "".join(f"; {n}" for n in notes))  # fmt: skip
    return notes


def test_a_niftyreg_grid_converts_to_what_holds_it_and_is_refused_elsewhere(niftyreg_run, tmp_path, capsys):
    cpp = niftyreg_run["cpp"]
    grid = load_deformation(cpp)
    points = np.random.default_rng(0).normal(0.0, 60.0, (2000, 3))
    _timed(cpp, tmp_path / "grid.ffd")
    _timed(tmp_path / "grid.ffd", tmp_path / "again.nii.gz", to="niftyreg")
    again = load_deformation(tmp_path / "again.nii.gz")
    assert np.abs(again.deform(points) - grid.deform(points)).max() < 1e-4
    centres, positions = _def_field(rr.deformation_field(niftyreg_run["big"], tmp_path / "again.nii.gz",
                                                         tmp_path / "def.nii.gz"))  # fmt: skip
    assert np.abs(grid.deform(centres) - positions).max() < 2e-4  # NiftyReg applies the round trip as the original
    # an ITK field on the fixed image: NiftyReg's own deformation at its voxels
    _timed(cpp, tmp_path / "field.nii.gz", reference=str(niftyreg_run["fixed"]))
    field = load_deformation(tmp_path / "field.nii.gz")
    assert isinstance(field, DisplacementField) and field.outside == "zero"
    centres, positions = _def_field(niftyreg_run["def"])
    assert np.abs(field.deform(centres) - positions).max() < 2e-4
    # ITK's B-spline treats the grid's outside as zero, NiftyReg repeats its border: refused, unless fitted
    assert convert_main([str(cpp), str(tmp_path / "grid.h5")]) == 1
    assert "border='clamp' has no ITK transform" in capsys.readouterr().err
    assert not (tmp_path / "grid.h5").exists()
    notes = _timed(cpp, tmp_path / "fitted.h5", fit="14x17x14", reference=str(niftyreg_run["fixed"]))
    assert "residual RMS" in notes[0]


def test_ants_files_convert_to_itk_files_and_niftyreg_fields(ants_run, tmp_path, capsys):
    affine = load_deformation(ants_run["affine"])
    points = np.random.default_rng(1).normal(0.0, 60.0, (500, 3))
    for name in ("affine.tfm", "affine.h5", "affine_again.mat"):
        _timed(ants_run["affine"], tmp_path / name)
        back = load_deformation(tmp_path / name)
        assert np.abs(back.deform(points) - affine.deform(points)).max() < 1e-9
        itk = sitk.ReadTransform(str(tmp_path / name))
        assert (
            np.abs(np.array([itk.TransformPoint(p) for p in points[:20].tolist()]) - affine.deform(points[:20])).max()
            < 1e-9
        )
    composite = load_deformation(ants_run["composite"])
    _timed(ants_run["composite"], tmp_path / "copy.h5")
    assert np.abs(load_deformation(tmp_path / "copy.h5").deform(points) - composite.deform(points)).max() < 1e-9
    assert convert_main([str(ants_run["composite"]), str(tmp_path / "chain.ffd")]) == 1
    assert "a chain of transforms is not a lattice; give --fit SHAPE" in capsys.readouterr().err
    # the SyN warp (an ITK field: nothing moves beyond its grid) as NiftyReg field: NiftyReg would move points
    # beyond the grid, so it is refused; sampled on a grid of one's choice it can be written
    assert convert_main([str(ants_run["warp"]), str(tmp_path / "warp_nr.nii.gz"), "--to", "niftyreg"]) == 1
    assert "leaves points there unmoved" in capsys.readouterr().err


def test_an_fnirt_file_needs_its_images_on_the_command_line(tmp_path, capsys):
    image = nib.Nifti1Image(np.zeros((5, 5, 5, 3), np.float32), np.eye(4))
    image.header["intent_code"] = 2007
    nib.save(image, tmp_path / "coef.nii.gz")
    assert convert_main([str(tmp_path / "coef.nii.gz"), str(tmp_path / "out.ffd")]) == 1
    assert "needs its reference image" in capsys.readouterr().err


def _def_field(path):
    image = nib.load(path)
    positions = np.asarray(image.dataobj, dtype=np.float64)[:, :, :, 0, :].reshape(-1, 3)
    index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in image.shape[:3]], indexing="ij"), -1)
    centres = index.reshape(-1, 3) @ image.affine[:3, :3].T + image.affine[:3, 3]
    return centres @ LPS, positions @ LPS
