"""generate on a real ``distributed.LocalCluster`` of two worker processes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import dask
import numpy as np
import pytest
from distributed import Client
from pyvista import examples

from ffd_notebook import Lattice, save_ffd
from ffd_notebook.batch import (
    BatchError,
    LatticeFiles,
    RandomGP,
    RandomLattice,
    generate,
    local_cluster,
    read_manifest,
    replay,
)
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import read_mesh

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ANT = examples.antfile
DEADLINE_S = 120


@pytest.fixture(scope="module")
def client():
    # the package's LocalCluster: no MALLOC_TRIM_THRESHOLD_ (2-4x slower NumPy here), no profiler
    with local_cluster(2, dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


def test_local_cluster_workers_are_set_up_for_batch_work(client):
    def worker_settings():
        from threadpoolctl import threadpool_info

        blas = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
        config = (
            dask.config.get("distributed.worker.profile.enabled"),
            dask.config.get("distributed.admin.tick.interval"),
        )
        return os.environ.get("MALLOC_TRIM_THRESHOLD_"), *config, blas

    settings = list(client.run(worker_settings).values())
    assert len(settings) == 2
    assert all(s[:3] == (None, False, "1s") and s[3] and set(s[3]) == {1} for s in settings), settings


@pytest.fixture(scope="module")
def face_model(shared_data):
    face = shared_data / "face" / "template.ply"
    extent = float(np.ptp(read_mesh(face).points, axis=0).max())
    return face, RandomLattice(num_control_points=7, max_displacement=0.04 * extent)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _wait_for(predicate, what: str) -> None:
    deadline = time.monotonic() + DEADLINE_S
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


def _records(folder: Path) -> int:
    return len(list((folder / "records").glob("sample_*.json"))) if (folder / "records").is_dir() else 0


def test_cluster_output_is_bit_for_bit_the_single_process_output(client, tmp_path):
    model = RandomLattice(5, max_displacement=2.0, locked_borders=1)
    single = generate(ANT, model, 12, tmp_path / "single", scheduler="sync", progress=False)
    multi = generate(ANT, model, 12, tmp_path / "cluster", client=client, progress=False)
    assert multi.scheduler.startswith("distributed")
    assert single.rows == multi.rows
    assert _files(tmp_path / "single") == _files(tmp_path / "cluster")
    # both workers took part
    assert len(client.scheduler_info()["workers"]) == 2


def test_gp_samples_on_the_cluster_equal_the_local_ones(client, tmp_path):
    """Each worker rebuilds the low-rank GP from its spec (seeded inducing points, one BLAS thread): same bits."""
    model = RandomGP(kernel="gaussian", sigma=10.0, scale=0.3, rank=12, n_inducing=80)
    generate(ANT, model, 4, tmp_path / "local", format="vtp", progress=False)
    generate(ANT, model, 4, tmp_path / "cluster", format="vtp", client=client, progress=False)
    assert _files(tmp_path / "local") == _files(tmp_path / "cluster")


def test_a_scheduler_address_works_like_a_client(client, tmp_path):
    model = RandomLattice(5, max_displacement=2.0, locked_borders=1)
    generate(ANT, model, 4, tmp_path / "a", scheduler="sync", progress=False)
    result = generate(ANT, model, 4, tmp_path / "b", scheduler=client.scheduler.address, progress=False)
    assert result.scheduler == f"distributed {client.scheduler.address}"
    assert _files(tmp_path / "a") == _files(tmp_path / "b")


def test_a_worker_killed_mid_run_still_yields_every_sample_once(client, tmp_path, face_model):
    face, model = face_model
    n = 40
    outcome: dict = {}

    def run():
        try:
            outcome["result"] = generate(face, model, n, tmp_path, client=client, progress=False)
        except BaseException as exc:  # reported to the test thread
            outcome["error"] = exc

    thread = threading.Thread(target=run)
    thread.start()
    _wait_for(lambda: _records(tmp_path) >= 3, "the first samples")
    victim_pid = next(iter(client.run(os.getpid).values()))
    os.kill(victim_pid, signal.SIGKILL)
    done_at_kill = _records(tmp_path)
    thread.join(DEADLINE_S)
    assert not thread.is_alive()
    assert "error" not in outcome, outcome.get("error")
    assert done_at_kill < n, "the run finished before the kill: nothing was tested"
    table = read_manifest(tmp_path)
    assert table["id"].tolist() == list(range(n))  # every sample, once
    assert all((tmp_path / f).is_file() for f in table["mesh_file"])
    _wait_for(lambda: len(client.scheduler_info()["workers"]) == 2, "the nanny to restart the worker")
    saved = read_mesh(tmp_path / table["mesh_file"][n - 1])
    assert np.array_equal(np.asarray(replay(tmp_path, n - 1).points, dtype=np.float32), saved.points)


def test_an_interrupted_run_resumes(client, tmp_path, face_model):
    face, model = face_model
    n = 16
    args = [sys.executable, "-m", "ffd_notebook", "batch", str(face), "--n", str(n), "--out", str(tmp_path),
            "--num-control-points", "7", "--max-displacement", repr(model.max_displacement[0]),
            "--scheduler", "sync", "--no-progress"]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(args, env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        _wait_for(lambda: _records(tmp_path) >= 3, "the first samples")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the run is interrupted hard: no cleanup
        proc.wait(30)
    done = sorted(int(p.stem.split("_")[1]) for p in (tmp_path / "records").glob("sample_*.json"))
    assert 3 <= len(done) < n
    stamps = {i: (tmp_path / "meshes" / f"sample_{i:06d}.ply").stat().st_mtime_ns for i in done}
    resumed = generate(face, model, n, tmp_path, client=client, progress=False)
    assert resumed.skipped == done and sorted(resumed.made + done) == list(range(n))
    assert read_manifest(tmp_path)["id"].tolist() == list(range(n))
    assert all((tmp_path / "meshes" / f"sample_{i:06d}.ply").stat().st_mtime_ns == stamps[i] for i in done)
    reference = generate(face, model, n, tmp_path / "reference", scheduler="sync", progress=False)
    assert reference.rows == resumed.rows
    for i in (done[-1], n - 1):
        name = f"meshes/sample_{i:06d}.ply"
        assert (tmp_path / name).read_bytes() == (tmp_path / "reference" / name).read_bytes()


def test_bad_input_errors_before_work_reaches_the_cluster(client, tmp_path):
    bad = tmp_path / "empty.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 0\nend_header\n")
    with pytest.raises(FileFormatError, match=r"empty\.ply"):
        generate(bad, RandomLattice(5, 1.0), 5, tmp_path / "out", client=client, progress=False)
    assert not (tmp_path / "out").exists()
    assert not client.run_on_scheduler(lambda dask_scheduler: [k for k in dask_scheduler.tasks if "ffd-sample" in k])


def test_a_worker_error_names_the_sample_and_keeps_the_others(client, tmp_path):
    points = np.asarray(read_mesh(ANT).points, dtype=np.float64)
    paths = []
    for i in range(5):
        lattice = Lattice.around(points, shape=5)
        lattice.offsets[2, 2, 2] = (0.2 * i, 0.0, 0.0)
        if i == 3:
            lattice.offsets[2, :, :, 0] = -3.0 * lattice.spacing[0]  # folds
        paths.append(tmp_path / f"given_{i}.ffd")
        save_ffd(paths[-1], lattice)
    with pytest.raises(BatchError, match=r"1 of 5 samples failed: sample 3: ValueError: folds") as info:
        generate(ANT, LatticeFiles(paths), None, tmp_path / "out", client=client, progress=False)
    assert [row["id"] for row in info.value.result.rows] == [0, 1, 2, 4]
    assert read_manifest(tmp_path / "out")["id"].tolist() == [0, 1, 2, 4]
