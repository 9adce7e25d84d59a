"""The editor's file operations with real files: .ffd lattices, meshes, decimation; failed loads change nothing."""

from __future__ import annotations

import numpy as np
import pytest
from editor_testing import assert_unchanged, assert_view_matches_model, colored_sphere, shown_points, snapshot
from scipy.spatial import cKDTree

from ffd_notebook import FileFormatError
from ffd_notebook.io import load_ffd, read_mesh, read_obj, write_mesh
from ffd_notebook.meshing import decimate_keeping_colors
from ffd_notebook.view.editor import Editor


def unplaced_ffd_text(shape=(4, 4, 4), spacing=0.8, moved=((1, 2, 1), (0.0, 0.0, 0.25))) -> str:
    """A .ffd file without a #quaternion# section (the FFD platform places it at the mesh minimum)."""
    nx, ny, nz = shape
    offsets = np.zeros((nx, ny, nz, 3))
    offsets[moved[0]] = moved[1]
    lines = ["#dimension#", "3", "#one to one#", "1", "#control grid size#", str(nx), str(ny), str(nz)]
    lines += ["#control grid spacing#"] + [f"      {spacing:.6f}"] * 3 + ["#offsets of the control points#"]
    for i in range(nx):
        for j in range(ny):
            lines.append("".join(f"{x:.6f} {y:.6f} {z:.6f}\t" for x, y, z in offsets[i, j]))
        lines.append("")
    return "\n".join(lines) + "\n"


def test_ffd_round_trip_and_undo(editor, tmp_path):
    editor.session.move_control_point((1, 2, 3), (0.1, -0.2, 0.3))
    editor.session.move_control_point((3, 3, 1), (0.0, 0.05, 0.0))
    path = tmp_path / "edited.ffd"
    editor.save_deformation(path)
    saved = editor.lattice.copy()
    assert load_ffd(path) == saved
    editor.session.set_shape((6, 6, 6))
    editor.load_deformation(path)
    assert editor.lattice == saved  # its quaternion placement is used as is
    assert editor.messages[-1].startswith("loaded a 5x5x5 lattice") and "quaternion" in editor.messages[-1]
    assert_view_matches_model(editor)
    editor.undo()  # the load is one step
    assert editor.lattice.shape == (6, 6, 6)
    assert_view_matches_model(editor)


def test_real_registration_ffd_keeps_its_placement(shared_data):
    face = read_mesh(shared_data / "face" / "james_colored.obj")
    editor = Editor(face, shape=(4, 4, 4), window_size=(160, 120))
    try:
        editor.load_deformation(shared_data / "seed-lineage" / "registration_11x12x11.FFD")
        lat = editor.lattice
        assert lat.shape == (11, 12, 11)
        np.testing.assert_allclose(lat.origin, (90, -126, -72))
        np.testing.assert_allclose(lat.rotation, np.diag([-1.0, 1.0, 1.0]), atol=1e-12)
        np.testing.assert_allclose(lat.offsets[1, 0, 0], (-0.191950, -0.152277, -0.006144))
        assert editor.scene.lattice_actor.glyphs.n_points == 1452 - 9 * 10 * 9  # "auto": a dense lattice's hull
        editor.show_points("all")
        assert editor.scene.lattice_actor.glyphs.n_points == 1452
        assert_view_matches_model(editor)
        assert np.abs(shown_points(editor) - face.points).max() > 0.01  # the registration moves the face
    finally:
        editor.close()


def test_ffd_without_placement_goes_to_the_mesh_minimum(editor, tmp_path):
    path = tmp_path / "platform.ffd"
    path.write_text(unplaced_ffd_text())
    editor.load_deformation(path)
    np.testing.assert_allclose(editor.lattice.origin, editor.mesh.points.min(axis=0))
    np.testing.assert_allclose(editor.lattice.spacing, 0.8)
    np.testing.assert_allclose(editor.lattice.offsets[1, 2, 1], (0, 0, 0.25))
    assert "minimum corner" in editor.messages[-1]
    assert_view_matches_model(editor)
    # a new mesh: the platform's rule again (offsets kept, placed at the new minimum)
    other = tmp_path / "moved.vtp"
    moved = colored_sphere(16)
    moved.points += (5.0, 0.0, 0.0)
    write_mesh(other, moved)
    editor.load_mesh(other)
    np.testing.assert_allclose(editor.lattice.origin, moved.points.min(axis=0), atol=1e-6)
    np.testing.assert_allclose(editor.lattice.offsets[1, 2, 1], (0, 0, 0.25))
    assert_view_matches_model(editor)


@pytest.mark.parametrize(
    ("content", "where"),
    [
        ("#dimension#\n3\n#control grid size#\n4\n4\nfour\n", "line 6"),
        ("this is not a lattice\n", "line 1"),
        (unplaced_ffd_text().replace("0.250000", "0.25 0.1"), "line"),
        (unplaced_ffd_text(shape=(3, 3, 3), moved=((1, 1, 1), (0, 0, 0.1))), "at least 4"),  # too small for B-splines
    ],
)
def test_failed_ffd_load_changes_nothing(editor, tmp_path, content, where):
    editor.session.move_control_point((2, 2, 2), (0.1, 0.0, 0.0))
    editor.undo()  # something to redo: a failed load must not drop it either
    editor.session.move_control_point((1, 1, 1), (0.0, 0.1, 0.0))
    snap = snapshot(editor)
    path = tmp_path / "bad.ffd"
    path.write_text(content)
    with pytest.raises(ValueError) as info:
        editor.load_deformation(path)
    assert where in str(info.value)
    assert_unchanged(editor, snap)
    assert editor.messages[-1].startswith("Error: could not load the lattice") and "bad.ffd" in editor.messages[-1]
    with pytest.raises(FileNotFoundError):
        editor.load_deformation(tmp_path / "missing.ffd")
    assert_unchanged(editor, snap)


def test_load_colored_obj_and_save_deformed_meshes(editor, shared_data, tmp_path):
    editor.session.move_control_point((2, 2, 2), (0.3, 0.0, 0.0))
    editor.load_mesh(shared_data / "face" / "james_colored.obj")
    assert editor.mesh.n_points == 6393 and editor.session.has_colors
    assert len(editor.session.history) == 0 and not editor.lattice.offsets.any()  # a new document, refitted lattice
    assert editor.lattice.shape == (5, 5, 5)
    bounds = editor.lattice.bounds()
    assert np.all(editor.mesh.points.min(axis=0) > bounds[::2]) and np.all(
        editor.mesh.points.max(axis=0) < bounds[1::2]
    )
    span = float(np.ptp(editor.mesh.points, axis=0).max())
    editor.session.move_control_point((2, 2, 2), (0.0, 0.0, 0.2 * span))
    expected = editor.session.ffd.deform(editor.mesh.points)
    for name in ("out.obj", "out.ply", "out.vtp"):
        editor.save_mesh(tmp_path / name)
        back = read_obj(tmp_path / name) if name.endswith(".obj") else read_mesh(tmp_path / name)
        assert back.n_points == 6393 and back.n_cells == editor.mesh.n_cells
        np.testing.assert_allclose(back.points, expected, rtol=1e-5, atol=1e-4 * span)
        np.testing.assert_array_equal(back.point_data["RGB"], editor.mesh.point_data["RGB"])
    assert editor.messages[-1] == f"saved the deformed mesh to {tmp_path / 'out.vtp'}"


def test_load_mesh_keeps_a_placed_lattice(sphere, tmp_path):
    from ffd_notebook import Lattice

    lattice = Lattice((4, 4, 4), spacing=1.5, origin=(-2.25, -2.25, -2.25))
    editor = Editor(sphere, lattice=lattice, window_size=(160, 120))
    try:
        path = tmp_path / "small.ply"
        write_mesh(path, colored_sphere(12).scale(0.5))
        editor.load_mesh(path)
        assert editor.lattice == lattice and editor.mesh.n_points == colored_sphere(12).n_points
        assert_view_matches_model(editor)
    finally:
        editor.close()


@pytest.mark.parametrize(
    ("name", "content"),
    [("bad.obj", "v 1 2 3\nv 1 2\nf 1 2 3\n"), ("bad.ply", "ply\nformat nonsense\n"), ("empty.vtp", "")],
)
def test_failed_mesh_load_changes_nothing(editor, tmp_path, name, content):
    editor.session.move_control_point((1, 2, 3), (0.1, 0.0, 0.0))
    snap = snapshot(editor)
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(FileFormatError):
        editor.load_mesh(path)
    assert_unchanged(editor, snap)
    assert editor.messages[-1].startswith("Error: could not load the mesh") and name in editor.messages[-1]


def test_save_failures_are_reported(editor, tmp_path):
    with pytest.raises(OSError):
        editor.save_deformation(tmp_path / "no-such-dir" / "x.ffd")
    assert editor.messages[-1].startswith("Error: could not save the lattice")
    with pytest.raises(ValueError):
        editor.save_mesh(tmp_path / "mesh.unknown-format")
    assert editor.messages[-1].startswith("Error: could not save the mesh")
    assert not list(tmp_path.iterdir())


def nearest_color_error(original, decimated) -> float:
    """Mean |colour difference| (0-255) between each new vertex and the nearest original vertex."""
    _, nearest = cKDTree(original.points).query(decimated.points)
    diff = decimated.point_data["RGB"].astype(float) - original.point_data["RGB"][nearest]
    return float(np.abs(diff).mean())


def test_decimation_keeps_colours(editor):
    original = editor.mesh
    editor.session.move_control_point((2, 3, 2), (0.0, 0.0, 0.3))
    history = len(editor.session.history)
    mesh = editor.session.decimate(0.6)
    assert 0.3 * original.n_cells < mesh.n_cells < 0.5 * original.n_cells
    assert editor.mesh is mesh and mesh.point_data["RGB"].dtype == np.uint8
    assert nearest_color_error(original, mesh) < 6.0  # colours follow their place on the surface
    red_top = mesh.points[:, 2] > 0.8
    assert (mesh.point_data["RGB"][red_top, 0] > 200).all() and (mesh.point_data["RGB"][red_top, 2] < 60).all()
    assert len(editor.session.history) == history and editor.lattice.offsets[2, 3, 2, 2] == 0.3  # lattice kept
    assert_view_matches_model(editor)  # the deformer re-bound to the new vertices
    assert editor.session.decimate(0.6).n_cells == mesh.n_cells  # from the loaded mesh: does not compound
    assert editor.session.decimate(0.0).n_points == original.n_points
    snap = snapshot(editor)
    with pytest.raises(ValueError):
        editor.session.decimate(1.0)
    assert editor.messages[-1].startswith("Error: could not decimate")
    n_messages = len(editor.messages)
    with pytest.raises(TypeError):
        editor.session.decimate(None)
    assert len(editor.messages) == n_messages + 1 and editor.messages[-1].startswith("Error: could not decimate")
    assert_unchanged(editor, snap)  # a failed decimation changes nothing


def test_decimation_of_a_real_coloured_scan(shared_data):
    face = read_obj(shared_data / "face" / "james_colored.obj")
    out = decimate_keeping_colors(face, 0.8)
    assert out.n_cells < 0.25 * face.n_cells
    # colours of a real scan: the decimated vertices keep the colour of the skin where they sit
    assert nearest_color_error(face, out) < 12.0
    spread = np.abs(face.point_data["RGB"].astype(float) - face.point_data["RGB"].mean(axis=0)).mean()
    assert nearest_color_error(face, out) < 0.5 * spread
    assert decimate_keeping_colors(face, 0.8, attribute_error=True).point_data["RGB"].dtype == np.uint8


def test_undo_and_assignment_keep_how_the_lattice_follows_a_new_mesh(editor, tmp_path):
    """A fitted lattice is refitted around a newly loaded mesh, a placed or assigned one stays: also after undo."""
    from ffd_notebook import Lattice

    other = tmp_path / "moved.vtp"
    moved = colored_sphere(16)
    moved.points += (5.0, 0.0, 0.0)
    write_mesh(other, moved)
    path = tmp_path / "placed.ffd"
    editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.2))
    editor.save_deformation(path)  # with its quaternion placement
    editor.load_deformation(path)
    editor.session.set_shape((6, 6, 6))
    editor.undo()  # back to the placed .ffd lattice: it must stay where it is
    placed = editor.lattice.copy()
    editor.load_mesh(other)
    assert editor.lattice == placed
    editor.session.set_shape((5, 5, 5))  # fitted around the moved sphere
    editor.load_deformation(path)
    editor.undo()  # back to the fitted lattice: refitted around the next mesh
    home = tmp_path / "home.vtp"
    write_mesh(home, colored_sphere(16))
    editor.load_mesh(home)
    assert editor.lattice.bounds()[0] < -1.0  # around the sphere at the origin, not the moved one
    assigned = Lattice((4, 4, 4), spacing=1.0, origin=(-1.5, -1.5, -1.5))
    editor.lattice = assigned  # a lattice given by the user stays where it is
    editor.load_mesh(other)
    assert editor.lattice == assigned
