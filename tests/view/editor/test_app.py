"""The standalone app without a browser: its panel actions, editor -> page sync, and the command line."""

from __future__ import annotations

import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from editor_instrument import Instrument

from ffd_notebook import Lattice, load_ffd, save_ffd
from ffd_notebook.__main__ import build_parser
from ffd_notebook.view import Editor
from ffd_notebook.view.editor.app import EditorApp

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture
def app(tmp_path):
    mesh = pv.Sphere(theta_resolution=20, phi_resolution=20)
    mesh.point_data["RGB"] = np.tile(np.array([200, 40, 40], dtype=np.uint8), (mesh.n_points, 1))
    editor = Editor(mesh, shape=(4, 5, 4), window_size=(160, 120))
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    Instrument(editor).register_triggers(app.server)  # the tests' own triggers (tests/editor_instrument.py)
    yield app
    app.close()


def test_initial_state_mirrors_the_editor(app):
    s = app.state
    assert (s.nx, s.ny, s.nz, s.max_j) == (4, 5, 4, 4)
    assert s.basis == "bspline" and s.field == "none" and s.colors and s.has_colors
    assert not s.can_undo and not s.can_redo and not s.has_selection
    assert s.mesh_info == f"{app.editor.mesh.n_points} vertices, {app.editor.mesh.n_cells} faces"


def test_apply_reset_undo_redo(app):
    app.run("apply", ["1", "2", "1", "0.1", "-0.2", "0.3"])  # text fields send strings
    assert app.editor.lattice.offsets[1, 2, 1].tolist() == [0.1, -0.2, 0.3]
    assert (app.state.sel_i, app.state.sel_j, app.state.sel_k) == (1, 2, 1)
    assert (app.state.dx, app.state.dy, app.state.dz) == (0.1, -0.2, 0.3)
    assert app.state.can_undo and app.state.moved_points == 1
    app.run("reset_point", [1, 2, 1])
    assert not app.editor.lattice.offsets.any() and app.state.dx == 0.0
    app.run("undo")
    assert app.editor.lattice.offsets[1, 2, 1, 2] == 0.3 and app.state.can_redo
    app.run("redo")
    assert not app.editor.lattice.offsets.any()
    app.run("apply", [0, 0, 0, 1, 1, 1])
    app.run("apply", [3, 4, 3, 1, 1, 1])
    app.run("reset_all")
    assert not app.editor.lattice.offsets.any() and app.state.moved_points == 0


def test_bad_input_becomes_a_message_and_changes_nothing(app):
    before = app.editor.lattice.copy()
    app.run("apply", [1, 2, 1, "abc", 0, 0])
    app.run("apply", [9, 0, 0, 1, 0, 0])  # outside the lattice: the editor's own error
    app.run("rebuild", [4, "", 4])
    app.run("rebuild", [1, 3, 3])  # too small for any lattice
    assert app.editor.lattice == before
    texts = [m["text"] for m in app.state.messages]
    assert len(texts) == 4 and all(t.startswith("Error") for t in texts)
    assert "displacement x must be a number, got 'abc'" in texts[-1]  # newest first
    assert "lattice size y must be a whole number" in texts[1]
    assert all(m["error"] for m in app.state.messages)


def test_rebuild_basis_colors_field_and_decimate(app):
    app.run("rebuild", ["5", "6", "4"])
    assert app.editor.lattice.shape == (5, 6, 4) and (app.state.nx, app.state.ny) == (5, 6)
    app.run("basis", ["bernstein"])
    assert app.editor.session.basis == "bernstein" and app.state.basis == "bernstein"
    app.run("colors", [False])
    assert not app.editor.session.colors_shown and not app.state.colors
    app.run("field", ["displacement"])
    assert app.editor.session.field == "displacement"
    app.run("field", ["none"])
    assert app.editor.session.field is None
    n = app.editor.mesh.n_cells
    app.run("decimate", ["0.5"])
    assert app.editor.mesh.n_cells < 0.7 * n and app.state.mesh_info.endswith(f"{app.editor.mesh.n_cells} faces")


def test_selection_typed_in_the_panel(app):
    app.run("ijk", ["2", "3", "1"])
    assert app.editor.session.selected == (2, 3, 1) and app.state.has_selection
    app.run("ijk", ["2", "", "1"])  # half-typed: ignored
    assert app.editor.session.selected == (2, 3, 1)


def test_ffd_and_mesh_files_by_path(app, tmp_path):
    app.run("apply", [1, 1, 2, 0.0, 0.5, 0.0])
    app.files.save_deformation_in_background(str(tmp_path / "a.ffd"))
    saved = load_ffd(tmp_path / "a.ffd")
    assert saved.offsets[1, 1, 2].tolist() == [0.0, 0.5, 0.0]
    app.run("reset_all")
    app.files.load_deformation_in_background(str(tmp_path / "a.ffd"))
    assert app.editor.lattice.offsets[1, 1, 2, 1] == 0.5
    app.files.load_deformation_in_background(str(tmp_path / "missing.ffd"))
    assert app.state.messages[0]["error"] and "missing.ffd" in app.state.messages[0]["text"]
    assert app.editor.lattice.offsets[1, 1, 2, 1] == 0.5  # a failed load changes nothing

    app.files.save_mesh_in_background(str(tmp_path / "deformed.ply"))
    deformed = pv.read(tmp_path / "deformed.ply")
    assert np.allclose(deformed.points, app.editor.deformed_mesh.points)
    pv.Cube().triangulate().save(tmp_path / "cube.vtp")
    app.files.load_mesh_in_background(str(tmp_path / "cube.vtp"))
    assert app.editor.mesh.n_points == 8 and app.state.mesh_info.startswith("8 vertices")


def test_upload_of_a_ffd_file(app, tmp_path):
    lattice = app.editor.lattice
    upload = Lattice(lattice.shape, lattice.spacing, origin=lattice.origin)
    upload.offsets[2, 2, 2] = (0.25, 0.0, 0.0)
    save_ffd(tmp_path / "up.ffd", upload)
    content = (tmp_path / "up.ffd").read_bytes()
    # what the trame client sends for a Vuetify file input: a list of file dicts, content possibly chunked
    app.files.receive_ffd_upload(
        [{"name": "up.ffd", "size": len(content), "type": "", "content": [content[:100], content[100:]]}]
    )
    assert app.editor.lattice.offsets[2, 2, 2, 0] == 0.25
    assert app.state.ffd_upload is None and "up.ffd (uploaded)" in app.state.messages[0]["text"]
    app.files.receive_ffd_upload({"name": "bad.ffd", "content": b"#dimension#\nthree\n"})
    assert app.state.messages[0]["error"] and app.editor.lattice.offsets[2, 2, 2, 0] == 0.25


def test_a_drag_updates_the_panel_and_the_triggers(app):
    app.editor.on_widget_moved(app.editor.lattice.control_points()[1, 1, 1] + [0.0, 0.0, 0.2], index=5 * 4 + 4 + 1)
    app.editor.session.end_drag()  # the mouse lets go
    assert (app.state.sel_i, app.state.sel_j, app.state.sel_k) == (1, 1, 1)
    assert app.state.dz == pytest.approx(0.2)
    px = app.server.controller.trigger_fn("ffd_widget_px")()
    state = app.server.controller.trigger_fn("ffd_state")()
    assert px["size"] == [160, 120] and len(px["widgets"]) == 4 * 5 * 4
    assert state["n_callbacks"] == 1 and state["offsets_abs_sum"] == pytest.approx(0.2)


def test_command_line():
    args = build_parser().parse_args(["m.obj", "--ffd", "l.ffd", "--shape", "6", "5", "4", "--basis", "bernstein"])
    assert (args.mesh, args.ffd, args.shape, args.basis, args.port, args.host) == (
        "m.obj", "l.ffd", [6, 5, 4], "bernstein", 8080, "127.0.0.1"
    )  # fmt: skip
    env = {"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"}
    run = subprocess.run([sys.executable, "-m", "ffd_notebook", "no_such_mesh.obj"], capture_output=True, text=True,
                         env=env, timeout=60)  # fmt: skip
    assert run.returncode == 2 and "no such mesh: no_such_mesh.obj" in run.stderr
    run = subprocess.run([sys.executable, "-m", "ffd_notebook", "--help"], capture_output=True, text=True, env=env,
                         timeout=60)  # fmt: skip
    assert run.returncode == 0 and "--ffd FILE" in run.stdout and "--shape NX NY NZ" in run.stdout
    # --ffd reads what load_deformation reads: the help says so, by the tools' names
    assert all(tool in run.stdout for tool in ("elastix", "NiftyReg", "ANTs", "FNIRT", "displacement"))


def test_itk_and_pygem_files_by_path_inside_the_root_only(app, tmp_path):
    from ffd_notebook import FFD, load_transform, save_transform

    lattice = Lattice.around(app.editor.mesh, (4, 5, 4), border="zero")
    lattice.offsets[1, 2, 1] = (0.0, 0.2, 0.0)
    affine = np.diag([1.2, 1.0, 0.9, 1.0])
    save_transform(tmp_path / "in.tfm", FFD(lattice, affine=affine))
    app.files.load_deformation_in_background("in.tfm")
    assert np.allclose(app.editor.session.ffd.affine, affine)
    expected = load_transform(tmp_path / "in.tfm").deform(app.editor.mesh.points)
    assert np.allclose(app.editor.deformed_mesh.points, expected, atol=1e-5)
    app.files.save_deformation_in_background("sub/../out.h5")  # inside the root: written, affine part included
    assert np.allclose(load_transform(tmp_path / "out.h5").affine, affine)
    assert "saved the lattice to out.h5" in app.state.messages[0]["text"]

    outside = tmp_path.parent / f"outside_{uuid.uuid4().hex}.tfm"
    app.files.save_deformation_in_background(str(outside))
    assert app.state.messages[0]["error"] and "outside the app's folder" in app.state.messages[0]["text"]
    assert not outside.exists()
    save_transform(outside, FFD(lattice))
    try:
        app.files.load_deformation_in_background(str(outside))
        assert app.state.messages[0]["error"] and "outside the app's folder" in app.state.messages[0]["text"]
        assert np.allclose(app.editor.session.ffd.affine, affine)  # a refused load changes nothing
    finally:
        outside.unlink()

    app.files.save_deformation_in_background("out.prm")  # a B-spline FFD with an affine part: PyGeM cannot hold it
    text = app.state.messages[0]["text"]
    assert app.state.messages[0]["error"] and "out.prm" in text and "cannot hold this FFD" in text
    assert str(tmp_path) not in text and not (tmp_path / "out.prm").exists()


def test_upload_of_an_itk_file(app, tmp_path):
    from ffd_notebook import FFD, save_transform

    lattice = Lattice.around(app.editor.mesh, (4, 4, 4), border="zero")
    lattice.offsets[2, 1, 2] = (0.3, 0.0, 0.0)
    save_transform(tmp_path / "up.h5", FFD(lattice))
    content = (tmp_path / "up.h5").read_bytes()
    app.files.receive_ffd_upload({"name": "up.h5", "content": content})
    assert "up.h5 (uploaded)" in app.state.messages[0]["text"] and not app.state.messages[0]["error"]
    assert np.abs(app.editor.deformed_mesh.points - app.editor.mesh.points).max() > 0.01
    app.files.receive_ffd_upload({"name": "evil.pth", "content": b"import os"})
    assert app.state.messages[0]["error"] and "expected a file ending with" in app.state.messages[0]["text"]
