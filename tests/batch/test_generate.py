"""generate / replay / the command line on the local schedulers, with real meshes and files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pyvista import examples

from ffd_notebook import FFD, Lattice, load_ffd, save_ffd
from ffd_notebook.batch import (
    BatchError,
    FoldFree,
    LatticeFiles,
    RandomGP,
    RandomLattice,
    generate,
    read_manifest,
    replay,
    volume_grid,
)
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import read_mesh

ROOT = Path(__file__).resolve().parents[2]
ANT = examples.antfile


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _fd_det(ffd: FFD, points: np.ndarray, h: float) -> np.ndarray:
    """det J by central differences of FFD.deform (independent of the analytic Jacobian the run uses)."""
    jac = np.empty((len(points), 3, 3))
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        jac[:, :, axis] = (ffd.deform(points + step) - ffd.deform(points - step)) / (2 * h)
    return np.linalg.det(jac)


def test_fold_free_samples_checked_independently(tmp_path, shared_data):
    """Every accepted sample's det J (by finite differences) is above the threshold at vertices and on the grid."""
    face = shared_data / "face" / "template.ply"
    points = np.asarray(read_mesh(face).points, dtype=np.float64)
    extent = np.ptp(points, axis=0).max()
    model = RandomLattice(num_control_points=5, max_displacement=0.8 * extent, locked_borders=1)
    rule = FoldFree(threshold=0.25, grid=8)
    result = generate(face, model, 6, tmp_path, seed=4, fold_free=rule, scheduler="sync", progress=False)
    assert sum(row["redraws"] for row in result.rows) > 0  # draws that folded were rejected, and counted
    check = np.vstack([points, volume_grid(points, 8)])
    bound = model.bind(points)
    for row in result.rows:
        lattice = load_ffd(tmp_path / row["parameters_file"])
        fd = _fd_det(FFD(lattice), check, h=1e-4 * extent)
        assert fd.min() > rule.threshold - 1e-6, row
        assert fd.min() == pytest.approx(row["min_det_j"], abs=1e-5)
        assert lattice.shape == bound.lattice.shape
    # without the check the same seeds give folding samples
    loose = generate(face, model, 6, tmp_path / "loose", seed=4, fold_free=False, scheduler="sync", progress=False)
    assert min(row["min_det_j"] for row in loose.rows) <= rule.threshold


@pytest.mark.parametrize("fmt", ["ply", "vtp", "obj"])
def test_replay_reproduces_saved_meshes_and_keeps_colours(tmp_path, shared_data, fmt):
    face = shared_data / "face" / "template.ply"
    source = read_mesh(face)
    extent = np.ptp(source.points, axis=0).max()
    model = RandomLattice(num_control_points=6, max_displacement=0.05 * extent)
    generate(face, model, 2, tmp_path, format=fmt, scheduler="sync", progress=False)
    for i in range(2):
        saved = read_mesh(tmp_path / "meshes" / f"sample_{i:06d}.{fmt}")
        again = replay(tmp_path, i)
        dtype = saved.points.dtype  # the file format's precision (PLY: float32)
        assert np.array_equal(np.asarray(again.points).astype(dtype), saved.points)
        assert np.array_equal(saved.point_data["RGB"], source.point_data["RGB"])
        assert np.array_equal(saved.faces, source.faces)


def test_manifest_rows_and_parameters(tmp_path):
    model = RandomLattice(5, max_displacement=1.0, locked_borders=1)
    result = generate(ANT, model, 5, tmp_path, seed=11, scheduler="sync", progress=False)
    table = read_manifest(tmp_path)
    assert table["id"].tolist() == [0, 1, 2, 3, 4]
    assert set(table["seed"]) == {11}
    assert set(table["source_mesh"]) == {str(Path(ANT).resolve())}
    for row in result.rows:
        moved = read_mesh(tmp_path / row["mesh_file"]).points
        assert row["max_displacement"] == pytest.approx(np.linalg.norm(moved - read_mesh(ANT).points, axis=1).max())
    assert set(result.seconds) == {"draw", "fold_check", "deform", "write"}
    # CPU time of the making thread: positive, and within the wall time of the same steps
    assert result.cpu.shape == (5,) and np.all(result.cpu > 0)
    assert np.all(result.cpu <= sum(result.seconds.values()) + 0.005)
    settings = json.loads((tmp_path / "run.json").read_text())
    assert settings["model"]["max_displacement"] == [1.0, 1.0, 1.0]


def test_local_processes_and_threads_match_sync_bit_for_bit(tmp_path):
    model = RandomLattice(5, max_displacement=2.0, locked_borders=1)
    outputs = {}
    for scheduler in ("sync", "threads", "processes"):
        generate(ANT, model, 8, tmp_path / scheduler, scheduler=scheduler, workers=2, progress=False)
        outputs[scheduler] = _files(tmp_path / scheduler)
    assert len(outputs["sync"]) == 2 + 3 * 8
    assert outputs["threads"] == outputs["sync"]
    assert outputs["processes"] == outputs["sync"]


def test_rerun_skips_and_extends(tmp_path):
    model = RandomLattice(5, max_displacement=1.0)
    generate(ANT, model, 3, tmp_path, scheduler="sync", progress=False)
    stamp = (tmp_path / "meshes" / "sample_000001.ply").stat().st_mtime_ns
    (tmp_path / "manifest.csv").unlink()  # the records, not the manifest, say what is done
    more = generate(ANT, model, 5, tmp_path, scheduler="sync", progress=False)
    assert (more.skipped, more.made) == ([0, 1, 2], [3, 4])
    assert (tmp_path / "meshes" / "sample_000001.ply").stat().st_mtime_ns == stamp
    assert read_manifest(tmp_path)["id"].tolist() == [0, 1, 2, 3, 4]
    with pytest.raises(ValueError, match=r"holds a run with other settings .*seed"):
        generate(ANT, model, 5, tmp_path, seed=1, scheduler="sync", progress=False)


def test_bad_input_fails_before_any_work(tmp_path):
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99999\nend_header\n\x00\x01")
    with pytest.raises(FileFormatError, match=r"broken\.ply"):
        generate(bad, RandomLattice(5, 1.0), 3, tmp_path / "out", scheduler="sync", progress=False)
    with pytest.raises(FileNotFoundError):
        generate(tmp_path / "missing.ply", RandomLattice(5, 1.0), 3, tmp_path / "out", progress=False)
    with pytest.raises(ValueError, match="n must be a non-negative integer"):
        generate(ANT, RandomLattice(5, 1.0), -2, tmp_path / "out", progress=False)
    with pytest.raises(ValueError, match="format must be one of"):
        generate(ANT, RandomLattice(5, 1.0), 2, tmp_path / "out", format="stl", progress=False)
    assert not (tmp_path / "out").exists()


def _folding_lattice(points: np.ndarray) -> Lattice:
    lattice = Lattice.around(points, shape=5)
    lattice.offsets[2, :, :, 0] = -3.0 * lattice.spacing[0]  # a whole layer pulled far back: folds
    return lattice


def test_a_failing_sample_is_named_and_the_others_are_kept(tmp_path):
    points = np.asarray(read_mesh(ANT).points, dtype=np.float64)
    paths = []
    for i in range(4):
        lattice = _folding_lattice(points) if i == 2 else Lattice.around(points, shape=5)
        lattice.offsets[1, 1, 1] += 0.1 * i
        paths.append(tmp_path / f"given_{i}.ffd")
        save_ffd(paths[-1], lattice)
    with pytest.raises(BatchError, match=r"1 of 4 samples failed: sample 2: ValueError: folds") as info:
        generate(ANT, LatticeFiles(paths), None, tmp_path / "out", scheduler="processes", progress=False)
    assert [row["id"] for row in info.value.result.rows] == [0, 1, 3]
    assert read_manifest(tmp_path / "out")["parameters_file"].tolist() == [str(paths[i]) for i in (0, 1, 3)]
    # with on_fold="scale" the given file is shrunk until it passes, and replay repeats the shrinking
    rule = FoldFree(on_fold="scale")
    files = LatticeFiles(paths)
    out = generate(ANT, files, None, tmp_path / "scaled", fold_free=rule, scheduler="sync", progress=False)
    assert out.rows[2]["scale_downs"] > 0
    saved = read_mesh(tmp_path / "scaled" / "meshes" / "sample_000002.ply")
    assert np.array_equal(np.asarray(replay(tmp_path / "scaled", 2).points, dtype=np.float32), saved.points)


def test_gp_model_runs_and_replays(tmp_path):
    model = RandomGP(kernel="bspline", scale=0.5, num_control_points=6, rank=20, n_inducing=100)
    result = generate(ANT, model, 3, tmp_path, format="vtp", progress=False)
    assert result.scheduler == "threads"
    for i in range(3):
        saved = read_mesh(tmp_path / "meshes" / f"sample_{i:06d}.vtp")
        assert np.array_equal(replay(tmp_path, i).points, saved.points)
        assert len((tmp_path / "parameters" / f"sample_{i:06d}.txt").read_text().split()) == 20


def _cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env_path = str(ROOT)
    return subprocess.run(
        [sys.executable, "-m", "ffd_notebook", "batch", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env={**__import__("os").environ, "PYTHONPATH": env_path},
    )


def test_command_line(tmp_path):
    out = _cli(ANT, "--n", "3", "--out", str(tmp_path / "o"), "--max-displacement", "1", "--num-control-points", "5",
               "--locked-borders", "1", "--scheduler", "sync", "--no-progress")  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "3 samples made" in out.stdout
    assert read_manifest(tmp_path / "o")["id"].tolist() == [0, 1, 2]
    bad = _cli(ANT, "--n", "3", "--out", str(tmp_path / "b"), "--max-displacement", "-1")
    assert bad.returncode == 2 and "max_displacement must be >= 0" in bad.stderr
    bad = _cli(ANT, "--n", "3", "--out", str(tmp_path / "b"), "--num-control-points", "3")
    assert bad.returncode == 2 and "at least 4 control points" in bad.stderr
    assert not (tmp_path / "b").exists()
    helptext = _cli("--help").stdout
    for option in ("--num-control-points", "--max-displacement", "--locked-borders", "--scheduler", "--on-fold"):
        assert option in helptext
