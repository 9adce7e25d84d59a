"""``python -m ffd_notebook convert IN OUT`` and the by-extension load/save it is built on."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice, load_deformation, load_ffd, save_deformation
from ffd_notebook.__main__ import main

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def real_ffd(shared_data):
    return shared_data / "seed-lineage" / "registration_11x12x11.FFD"


def test_command_line_converts_the_real_lattice(tmp_path, real_ffd):
    target = tmp_path / "registration.tfm"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    run = subprocess.run([sys.executable, "-m", "ffd_notebook", "convert", str(real_ffd), str(target)],
                         capture_output=True, text=True, env=env, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == f"{real_ffd} -> {target}"
    lattice = load_ffd(real_ffd)
    points = lattice.to_world(np.random.default_rng(0).uniform(-3, 13, (500, 3)))
    tx = sitk.ReadTransform(str(target))
    applied = np.array([tx.TransformPoint(p) for p in points.tolist()])
    np.testing.assert_allclose(applied, FFD(lattice).deform(points), rtol=0, atol=1e-9)


def test_chain_of_formats_is_exact(tmp_path, real_ffd, capsys):
    steps = [real_ffd, tmp_path / "a.h5", tmp_path / "b.txt", tmp_path / "c.ffd"]
    for source, target in itertools.pairwise(steps):
        assert main(["convert", str(source), str(target)]) == 0
    assert load_ffd(steps[-1]) == load_ffd(real_ffd)
    assert "no placement" not in capsys.readouterr().err  # the real file is placed


def test_prm_round_trip_and_refusals(tmp_path, shared_data, capsys):
    prm = shared_data / "pygem" / "parameters_test_ffd_sphere.prm"
    assert main(["convert", str(prm), str(tmp_path / "copy.prm")]) == 0
    assert load_deformation(tmp_path / "copy.prm").lattice == load_deformation(prm).lattice
    assert main(["convert", str(prm), str(tmp_path / "x.tfm")]) == 1
    assert "'bernstein' basis has no ITK transform" in capsys.readouterr().err
    assert main(["convert", str(prm), str(tmp_path / "x.ffd")]) == 1
    assert "x.ffd: a .ffd file cannot hold this FFD exactly: it has the 'bernstein' basis" in capsys.readouterr().err
    assert main(["convert", str(prm), str(tmp_path / "x.vtk")]) == 1
    assert "unknown deformation file extension '.vtk'" in capsys.readouterr().err
    assert not (tmp_path / "x.tfm").exists() and not (tmp_path / "x.ffd").exists()


def test_itk_with_domain_does_not_become_ffd(tmp_path, capsys):
    lattice = Lattice((5, 5, 5), 1.0)
    lattice.offsets[2, 2, 2] = 1.0
    save_deformation(tmp_path / "in.tfm", FFD(lattice, only_inside=True))
    assert main(["convert", str(tmp_path / "in.tfm"), str(tmp_path / "out.ffd")]) == 1
    assert "only_inside=True" in capsys.readouterr().err


def test_unplaced_ffd_gets_a_note(tmp_path, capsys):
    save_deformation(tmp_path / "plain.ffd", FFD(Lattice((4, 4, 4), 1.0)))
    assert main(["convert", str(tmp_path / "plain.ffd"), str(tmp_path / "plain.tfm")]) == 0
    assert "has no placement (#quaternion#) section" in capsys.readouterr().err


def test_bad_input_is_an_error_message(tmp_path, capsys):
    bad = tmp_path / "bad.tfm"
    bad.write_text("#Insight Transform File V1.0\nTransform: Nonsense\n")
    assert main(["convert", str(bad), str(tmp_path / "out.ffd")]) == 1
    assert "bad.tfm, line 2: unsupported transform type 'Nonsense'" in capsys.readouterr().err
    assert main(["convert", str(tmp_path / "missing.tfm"), str(tmp_path / "out.ffd")]) == 1
    assert not (tmp_path / "out.ffd").exists()


@pytest.mark.parametrize("suffix", [".ffd", ".tfm", ".h5"])
def test_save_deformation_refuses_affine_where_not_held(tmp_path, suffix):
    ffd = FFD(Lattice((4, 4, 4), 1.0), affine=np.diag([2.0, 2.0, 2.0, 1.0]))
    if suffix == ".ffd":
        with pytest.raises(ValueError, match=r"affine part, which \.ffd files do not store"):
            save_deformation(tmp_path / f"x{suffix}", ffd)
    else:
        save_deformation(tmp_path / f"x{suffix}", ffd)
        np.testing.assert_array_equal(load_deformation(tmp_path / f"x{suffix}").affine, ffd.affine)
