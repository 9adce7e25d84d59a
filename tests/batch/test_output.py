"""The output folder's files: GP coefficient files, the fast PLY writer and its fallback, crash-safe order."""

from __future__ import annotations

import os

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.batch import RandomLattice, generate, replay
from ffd_notebook.batch.output import Layout, read_parameters_txt, write_parameters_txt
from ffd_notebook.batch.ply import TrianglePly
from ffd_notebook.batch.sample import Job, run_samples
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import _atomic, read_mesh, write_mesh

finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=50, deadline=None)
@given(st.lists(finite, min_size=1, max_size=40))
def test_coefficients_round_trip_bit_for_bit(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("c") / "c.txt"
    write_parameters_txt(path, np.array(values))
    assert np.array_equal(read_parameters_txt(path, len(values)), np.array(values))


@settings(max_examples=50, deadline=None)
@given(st.lists(finite, min_size=2, max_size=10), st.integers(0, 9), st.sampled_from(["nan", "1,5", "x", "1e", "--1"]))
def test_a_bad_coefficient_names_its_line(tmp_path_factory, values, where, token):
    path = tmp_path_factory.mktemp("c") / "c.txt"
    lines = [repr(v) for v in values]
    where = where % len(lines)
    lines[where] = token
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=rf"c\.txt, line {where + 1}:"):
        read_parameters_txt(path, len(values))


def test_wrong_coefficient_count(tmp_path):
    write_parameters_txt(tmp_path / "c.txt", np.ones(3))
    with pytest.raises(FileFormatError, match="expected 4 coefficients, got 3"):
        read_parameters_txt(tmp_path / "c.txt", 4)


def test_fast_ply_reads_back_like_vtks_writer(tmp_path, shared_data):
    face = read_mesh(shared_data / "face" / "template.ply")
    moved = np.asarray(face.points, dtype=np.float64) * 1.5 + 3.0
    TrianglePly.for_mesh(face).write(tmp_path / "fast.ply", moved)
    reference = face.copy()
    reference.points = moved
    write_mesh(tmp_path / "vtk.ply", reference)
    fast, vtk = read_mesh(tmp_path / "fast.ply"), read_mesh(tmp_path / "vtk.ply")
    assert np.array_equal(fast.points, vtk.points)
    assert np.array_equal(fast.faces, vtk.faces)
    assert np.array_equal(fast.point_data["RGB"], vtk.point_data["RGB"])


def test_non_triangle_meshes_go_through_write_mesh(tmp_path):
    plane = pv.Plane(i_resolution=6, j_resolution=5).extrude((0, 0, 0.3), capping=True)  # quads
    assert TrianglePly.for_mesh(plane) is None
    write_mesh(tmp_path / "block.ply", plane)
    generate(tmp_path / "block.ply", RandomLattice(5, 0.05), 2, tmp_path / "out", scheduler="sync", progress=False)
    saved = read_mesh(tmp_path / "out" / "meshes" / "sample_000001.ply")
    assert saved.n_cells == plane.n_cells
    assert np.array_equal(np.asarray(replay(tmp_path / "out", 1).points, dtype=np.float32), saved.points)


def test_a_task_makes_its_files_durable_before_any_record(tmp_path, monkeypatch):
    """Crash safety of run_samples: every record is renamed into place only after the meshes' and
    parameters' renames were made durable (their folders fsync-ed), and each folder is fsync-ed once."""
    mesh = tmp_path / "ball.ply"
    pv.Sphere(theta_resolution=10, phi_resolution=10).save(mesh)
    job = Job(str(mesh), RandomLattice(5, 0.05).to_spec(), 0, None, str(tmp_path / "out"), "ply")
    Layout(job.out).make()
    events: list[tuple[str, str]] = []
    real_sync, real_replace = _atomic._fsync_path, os.replace

    def sync(path, directory=False):
        events.append(("folder sync" if directory else "file sync", os.path.basename(path)))
        real_sync(path, directory)

    def replace(src, dst):
        events.append(("rename", os.path.relpath(dst, job.out)))
        real_replace(src, dst)

    monkeypatch.setattr(_atomic, "_fsync_path", sync)
    monkeypatch.setattr(_atomic.os, "replace", replace)
    outs = run_samples(job, [0, 1, 2])
    assert [o["id"] for o in outs] == [0, 1, 2] and all("row" in o for o in outs)
    folder_syncs = [name for kind, name in events if kind == "folder sync"]
    assert sorted(folder_syncs) == ["meshes", "parameters", "records"]  # once each, not once per file
    renames = [name for kind, name in events if kind == "rename"]
    first_record = next(k for k, e in enumerate(events) if e[0] == "rename" and e[1].startswith("records"))
    before = events[:first_record]
    assert ("folder sync", "meshes") in before and ("folder sync", "parameters") in before
    assert {n for n in renames if not n.startswith("records")} == {
        f"{sub}/sample_{i:06d}.{ext}" for i in range(3) for sub, ext in (("meshes", "ply"), ("parameters", "ffd"))
    }
    assert events[-1] == ("folder sync", "records")
    # every file's data was flushed before its rename
    for k, (kind, _) in enumerate(events):
        if kind == "rename":
            assert events[k - 1][0] == "file sync", events[k - 1 : k + 1]
