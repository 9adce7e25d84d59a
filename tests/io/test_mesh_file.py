"""read_mesh / write_mesh: dispatch by extension, colours through PLY, errors, atomic writes."""

from __future__ import annotations

import os

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import read_mesh, read_obj, write_mesh


def test_obj_goes_through_read_obj(shared_data, tmp_path):
    mesh = read_mesh(shared_data / "face" / "james_colored.obj")
    assert mesh.n_points == 6393 and mesh.point_data["RGB"].dtype == np.uint8
    write_mesh(tmp_path / "copy.OBJ", mesh)  # extension matched case-insensitively
    assert (tmp_path / "copy.OBJ").read_text().startswith("# written by ffd_notebook")
    np.testing.assert_array_equal(read_mesh(tmp_path / "copy.OBJ").point_data["RGB"], mesh.point_data["RGB"])


def test_ply_keeps_colours(shared_data, tmp_path):
    template = read_mesh(shared_data / "face" / "template.ply")
    assert template.n_points == 53349
    rgba = template.point_data["RGBA"]
    np.testing.assert_array_equal(template.point_data["RGB"], rgba[:, :3])
    assert template.point_data.active_scalars_name == "RGB"
    # the OBJ version of the same template carries the same colours
    obj = read_obj(shared_data / "face" / "template_colored.obj")
    np.testing.assert_array_equal(obj.point_data["RGB"], template.point_data["RGB"])
    write_mesh(tmp_path / "t.ply", template)
    back = read_mesh(tmp_path / "t.ply")
    np.testing.assert_array_equal(back.point_data["RGBA"], rgba)
    np.testing.assert_allclose(back.points, template.points)


def test_ply_from_obj_colours(shared_data, tmp_path):
    james = read_obj(shared_data / "face" / "james_colored.obj")
    write_mesh(tmp_path / "james.ply", james)
    back = read_mesh(tmp_path / "james.ply")
    np.testing.assert_array_equal(back.point_data["RGB"], james.point_data["RGB"])


@pytest.mark.parametrize("suffix", [".vtp", ".stl", ".vtk", ".ply"])
def test_other_formats_round_trip(tmp_path, suffix):
    mesh = pv.Sphere(theta_resolution=10, phi_resolution=8)
    mesh.point_data["height"] = mesh.points[:, 2].copy()
    write_mesh(tmp_path / f"s{suffix}", mesh)
    back = read_mesh(tmp_path / f"s{suffix}")
    assert back.n_cells == mesh.n_cells
    np.testing.assert_allclose(back.area, mesh.area, rtol=1e-6)
    if suffix in (".vtp", ".vtk"):
        np.testing.assert_array_equal(back.point_data["height"], mesh.point_data["height"])


@pytest.mark.parametrize("name", ["junk.ply", "junk.stl", "junk.vtp", "junk.vtk", "mesh.xyz", "empty.stl"])
def test_unreadable_files_are_file_format_errors(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"" if name.startswith("empty") else bytes(np.random.default_rng(0).integers(0, 256, 400)))
    with pytest.raises(FileFormatError) as info:
        read_mesh(path)
    assert info.value.path == str(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_mesh(tmp_path / "none.ply")


def test_write_mesh_is_atomic(tmp_path, monkeypatch):
    target = tmp_path / "keep.vtp"
    write_mesh(target, pv.Cube())
    before = target.read_bytes()

    def failing_save(self, filename, *args, **kwargs):
        with open(filename, "wb") as f:
            f.write(b"<VTKFile half")
        raise OSError("No space left on device")

    monkeypatch.setattr(pv.PolyData, "save", failing_save)
    with pytest.raises(OSError, match="No space"):
        write_mesh(target, pv.Sphere())
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == ["keep.vtp"]


def test_write_unknown_extension_leaves_nothing(tmp_path):
    with pytest.raises(ValueError):
        write_mesh(tmp_path / "mesh.xyz", pv.Cube())
    assert not list(tmp_path.iterdir())
