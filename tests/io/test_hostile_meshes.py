"""Hostile mesh files (issue 8): refused with FileFormatError before VTK can crash the process.

Each case killed the process (SIGSEGV) or loaded silently and crashed a VTK filter later before
the change; each runs in a subprocess, so a crash is a test failure, not a dead test run.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import read_mesh

LEGACY = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET {kind}\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n{cells}\n"
PLY_HEADER = (
    "ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
    "element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
)

PLY_ASCII = PLY_HEADER.format(fmt="ascii", nv=3, nf=1)


def _binary_ply_with_huge_counts() -> bytes:
    header = PLY_HEADER.format(fmt="binary_little_endian", nv=4_000_000_000, nf=4_000_000_000).encode()
    return header + bytes(200 - len(header))


CASES = {
    "huge-counts.ply": _binary_ply_with_huge_counts(),
    "index-past-points.ply": (PLY_ASCII + "0 0 0\n1 0 0\n0 1 0\n3 0 1 900000\n").encode(),
    "negative-index.ply": (PLY_ASCII + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n").encode(),
    "binary-index-past-points.ply": PLY_HEADER.format(fmt="binary_little_endian", nv=3, nf=1).encode()
    + np.zeros(9, "<f4").tobytes()
    + b"\x03"
    + np.array([0, 1, 7], "<i4").tobytes(),
    "index-past-points.vtk": LEGACY.format(kind="POLYDATA", cells="POLYGONS 1 4\n3 0 1 200000").encode(),
    "count-past-size.vtk": LEGACY.format(kind="POLYDATA", cells="POLYGONS 1 4\n100000000 0 1 2").encode(),
    "negative-index.vtk": LEGACY.format(kind="POLYDATA", cells="POLYGONS 1 4\n3 0 1 -5").encode(),
    "hexahedron-of-3.vtk": LEGACY.format(
        kind="UNSTRUCTURED_GRID", cells="CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n12"
    ).encode(),
    "huge-points.vtk": LEGACY.format(kind="POLYDATA", cells="").replace("POINTS 3 ", "POINTS 3000000000 ").encode(),
    "image.vtk": b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 100000 100000 100000\n",
    "huge-count.stl": bytes(80) + (10**9).to_bytes(4, "little") + bytes(100),
}


def _read_in_subprocess(path) -> tuple[int, str]:
    code = textwrap.dedent(f"""
        from ffd_notebook.errors import FileFormatError
        from ffd_notebook.io import read_mesh
        try:
            mesh = read_mesh({str(path)!r})
            mesh.extract_surface(algorithm=None).compute_normals()  # what the editor does with a mesh
            print("LOADED")
        except FileFormatError as exc:
            print("FileFormatError:", exc)
    """)
    env = {**os.environ, "PYTHONPATH": os.getcwd() + os.pathsep + os.environ.get("PYTHONPATH", "")}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    return done.returncode, done.stdout + done.stderr


@pytest.mark.parametrize("name", sorted(CASES))
def test_hostile_mesh_is_refused_without_crashing(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(CASES[name])
    code, output = _read_in_subprocess(path)
    assert code == 0, f"the process died (status {code}) reading {name}:\n{output[-2000:]}"
    assert output.startswith("FileFormatError:") and str(path) in output, output[-2000:]


@pytest.mark.parametrize("suffix", [".ply", ".vtk", ".stl", ".vtp", ".vtu"])
def test_special_files_are_refused_before_reading(tmp_path, suffix):
    fifo = tmp_path / f"pipe{suffix}"
    os.mkfifo(fifo)
    with pytest.raises(FileFormatError, match="FIFO"):  # before: blocked for ever in open()
        read_mesh(fifo)
    (tmp_path / f"dir{suffix}").mkdir()
    with pytest.raises(IsADirectoryError):
        read_mesh(tmp_path / f"dir{suffix}")


def test_devices_are_refused(tmp_path):
    link = tmp_path / "zero.obj"
    link.symlink_to("/dev/zero")  # before: read until the memory ran out
    with pytest.raises(FileFormatError, match="character device"):
        read_mesh(link)


def test_unknown_formats_are_refused(tmp_path):
    path = tmp_path / "mesh.case"
    path.write_text("FORMAT\ntype: ensight gold\n")
    with pytest.raises(FileFormatError, match="unsupported mesh format"):
        read_mesh(path)


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("suffix", [".vtk", ".vtp", ".vtu", ".stl", ".ply"])
def test_good_files_still_load(tmp_path, suffix, binary):
    mesh = pv.Sphere(theta_resolution=12, phi_resolution=9)
    mesh.point_data["height"] = mesh.points[:, 2].copy()
    data = mesh.cast_to_unstructured_grid() if suffix == ".vtu" else mesh
    data.save(tmp_path / f"m{suffix}", binary=binary)
    back = read_mesh(tmp_path / f"m{suffix}")
    assert back.n_cells == mesh.n_cells
    assert abs(back.extract_surface(algorithm=None).area - mesh.area) < 1e-5 * mesh.area
    if suffix not in (".stl", ".ply"):
        np.testing.assert_allclose(back.point_data["height"], mesh.point_data["height"], rtol=1e-5, atol=1e-6)


def test_ply_reader_matches_vtk_on_the_real_template(shared_data):
    path = shared_data / "face" / "template.ply"
    ours, vtk = read_mesh(path), pv.read(path)  # the real file is safe for VTK
    np.testing.assert_array_equal(ours.points, vtk.points)
    np.testing.assert_array_equal(ours.faces, vtk.faces)
    np.testing.assert_array_equal(ours.point_data["RGBA"], vtk.point_data["RGBA"])
