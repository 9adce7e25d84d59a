"""``python -m ffd_notebook convert`` with elastix files, displacement fields and ``--fit``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice
from ffd_notebook.__main__ import main
from ffd_notebook.io import load_deformation, load_displacement_field, load_ffd, save_deformation

REPO = Path(__file__).resolve().parents[2]


def _reference(path: Path) -> Path:
    image = sitk.Image([12, 10, 9], sitk.sitkUInt8)
    image.SetSpacing((1.5, 1.5, 2.0))
    image.SetOrigin((-5.0, -3.0, 0.0))
    sitk.WriteImage(image, str(path))
    return path


def test_command_line_writes_elastix_and_reads_it_back(shared_data, tmp_path):
    real = shared_data / "seed-lineage" / "registration_11x12x11.FFD"
    target = tmp_path / "TransformParameters.0.txt"
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    run = subprocess.run([sys.executable, "-m", "ffd_notebook", "convert", str(real), str(target), "--to", "elastix"],
                         capture_output=True, text=True, env=env, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert target.read_text().startswith('(Transform "BSplineTransform")')
    assert main(["convert", str(target), str(tmp_path / "back.ffd")]) == 0  # elastix told from ITK by content
    assert load_ffd(tmp_path / "back.ffd").offsets.tolist() == load_ffd(real).offsets.tolist()


def test_lattice_to_field_on_a_reference_grid_and_field_needs_fit(tmp_path, capsys):
    lat = Lattice((5, 5, 5), 5.0, origin=(-10.0, -8.0, -5.0))
    lat.offsets[2, 2, 2] = (1.0, -2.0, 0.5)
    save_deformation(tmp_path / "warp.tfm", FFD(lat))
    reference = _reference(tmp_path / "ref.nrrd")
    assert main(["convert", str(tmp_path / "warp.tfm"), str(tmp_path / "field.nii.gz")]) == 1
    assert "needs a voxel grid: give --reference IMAGE" in capsys.readouterr().err
    args = ["convert", str(tmp_path / "warp.tfm"), str(tmp_path / "field.nii.gz"), "--reference", str(reference)]
    assert main(args) == 0
    field = load_displacement_field(tmp_path / "field.nii.gz")
    points = field.grid_points()
    assert field.size == (12, 10, 9) and np.abs(field.deform(points) - FFD(lat).deform(points)).max() < 1e-6
    assert main(["convert", str(tmp_path / "field.nii.gz"), str(tmp_path / "x.tfm")]) == 1
    assert "a displacement field is not a lattice; give --fit SHAPE" in capsys.readouterr().err
    assert not (tmp_path / "x.tfm").exists()
    assert main(["convert", str(tmp_path / "field.nii.gz"), str(tmp_path / "fitted.ffd"), "--fit", "8x7x7"]) == 0
    note = capsys.readouterr().err
    assert "fitted a 8x7x7 lattice to 1080 samples: residual RMS" in note
    fitted = load_deformation(tmp_path / "fitted.ffd")
    assert fitted.lattice.shape == (8, 7, 7)
    assert np.abs(fitted.deform(points) - field.deform(points)).max() < 0.2
    assert main(["convert", str(tmp_path / "field.nii.gz"), str(tmp_path / "copy.mha")]) == 0
    assert np.array_equal(load_displacement_field(tmp_path / "copy.mha").vectors, field.vectors)


def test_fit_needs_a_grid_for_a_lattice_and_shapes_are_checked(tmp_path, capsys):
    save_deformation(tmp_path / "a.tfm", FFD(Lattice((4, 4, 4), 1.0)))
    assert main(["convert", str(tmp_path / "a.tfm"), str(tmp_path / "b.tfm"), "--fit", "5"]) == 1
    assert "--fit on a lattice file needs --reference IMAGE" in capsys.readouterr().err
    reference = _reference(tmp_path / "ref.nrrd")
    assert main(["convert", str(tmp_path / "a.tfm"), str(tmp_path / "b.tfm"), "--fit", "3", "--reference",
                 str(reference)]) == 1  # fmt: skip
    assert "at least 4 control points" in capsys.readouterr().err
    assert main(["convert", str(tmp_path / "a.tfm"), str(tmp_path / "b.tfm"), "--fit", "5x5", "--reference",
                 str(reference)]) == 1  # fmt: skip
    assert "expected a lattice shape" in capsys.readouterr().err
