"""The face from a photo in the editor: the session command, ``fn.edit(photo)``, both panels, the app's upload
and worker thread, ``python -m ffd_notebook photo.jpg``; a photo without a face changes nothing."""

from __future__ import annotations

import asyncio
import io
import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest
from editor_testing import assert_unchanged, assert_view_matches_model, snapshot
from loop_watch import longest_stall
from PIL import Image
from skimage import data

import ffd_notebook as fn
from ffd_notebook.errors import FileFormatError, NoFaceError
from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.app import EditorApp
from ffd_notebook.view.editor.notebook.panel import ControlPanel

REPO = Path(__file__).resolve().parents[3]
NOSE_TIP = 4


@pytest.fixture(scope="module")
def photos(tmp_path_factory) -> Path:
    """A folder with the astronaut (a face), coins (no face) and a text file named like a photo."""
    folder = tmp_path_factory.mktemp("photos")
    Image.fromarray(data.astronaut()).save(folder / "astronaut.png")
    Image.fromarray(data.astronaut()).save(folder / "astronaut.jpg", quality=95)
    Image.fromarray(data.coins()).save(folder / "coins.png")
    (folder / "notes.jpg").write_text("not a picture")
    return folder


@pytest.fixture(scope="module")
def face_mesh():
    return fn.face_from_photo(data.astronaut())


def png_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format="PNG")
    return buffer.getvalue()


def assert_is_the_face(editor, face_mesh):
    """The editor holds the astronaut's face in a lattice fitted around it, from a new history."""
    assert editor.mesh.n_points == face_mesh.n_points and np.allclose(editor.mesh.points, face_mesh.points, atol=1e-4)
    assert editor.session.has_colors and np.array_equal(editor.mesh.point_data["RGB"], face_mesh.point_data["RGB"])
    corners = editor.lattice.control_points().reshape(-1, 3)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    assert np.all(lo <= face_mesh.points.min(axis=0) + 1e-6) and np.all(hi >= face_mesh.points.max(axis=0) - 1e-6)
    assert not editor.session.can_undo
    assert_view_matches_model(editor)


def test_the_session_loads_a_face_and_a_drag_moves_it(editor, photos, face_mesh):
    editor.session.move_control_point((1, 1, 1), (0.1, 0.0, 0.0))  # something to undo, gone with the new mesh
    editor.load_face(photos / "astronaut.png")
    assert_is_the_face(editor, face_mesh)
    assert editor.messages[-1].startswith(f"made the face in {str(photos / 'astronaut.png')!r}: 28881 vertices")
    # a control point near the nose pulls it
    points = editor.lattice.control_points()
    ijk = np.unravel_index(np.argmin(np.linalg.norm(points - face_mesh.points[NOSE_TIP], axis=-1)), points.shape[:3])
    editor.session.move_control_point(ijk, (0.0, 0.0, 15.0))
    assert editor.deformed_mesh.points[NOSE_TIP, 2] > face_mesh.points[NOSE_TIP, 2] + 5
    assert editor.session.can_undo


def test_a_photo_without_a_face_changes_nothing(editor, photos):
    editor.session.move_control_point((1, 1, 1), (0.1, 0.0, 0.0))
    before = snapshot(editor)
    with pytest.raises(NoFaceError, match="no face found"):
        editor.load_face(photos / "coins.png")
    assert_unchanged(editor, before)
    assert (
        editor.messages[-1]
        == f"Error: could not make a face from {str(photos / 'coins.png')!r}: no face found in the photo"
    )
    with pytest.raises(FileFormatError, match="not an image"):
        editor.load_face(photos / "notes.jpg")
    assert_unchanged(editor, before)
    with pytest.raises(FileNotFoundError):
        editor.load_face(photos / "missing.jpg")
    assert_unchanged(editor, before)
    with pytest.raises(NoFaceError):
        editor.session.files.load_face_upload("coins.png", png_bytes(data.coins()))
    assert_unchanged(editor, before)
    assert editor.messages[-1] == "Error: could not make a face from coins.png: no face found in the photo"
    editor.undo()  # the history is the one from before
    assert not editor.lattice.offsets.any()


def test_edit_opens_on_the_face_of_a_photo(photos, face_mesh):
    for photo in (photos / "astronaut.png", str(photos / "astronaut.png"), data.astronaut()):
        editor = Editor(photo, window_size=(160, 120))
        try:
            assert_is_the_face(editor, face_mesh)
        finally:
            editor.close()
    with pytest.raises(NoFaceError, match=r"coins\.png: no face found"):
        Editor(photos / "coins.png", window_size=(160, 120))


def test_the_notebook_panel_makes_a_face_from_a_path_and_an_upload(editor, photos, face_mesh):
    panel = ControlPanel(editor)
    panel.photo_path.value = str(photos / "coins.png")
    before = snapshot(editor)
    panel.load_face_button.click()
    assert_unchanged(editor, before)
    assert "no face found in the photo" in panel.message.value and "#c62828" in panel.message.value  # in red

    panel.photo_path.value = str(photos / "astronaut.png")
    panel.load_face_button.click()
    assert_is_the_face(editor, face_mesh)
    assert panel.mesh_info.value.startswith("28881 vertices")

    editor.session.move_control_point((2, 2, 2), (0.0, 1.0, 0.0))  # the upload gives a new history
    upload = panel.face_upload
    assert upload.accept == "image/*" and not upload.multiple
    send(upload, "me.png", png_bytes(data.astronaut()))
    assert_is_the_face(editor, face_mesh)
    assert editor.messages[-1].startswith("made the face in me.png: 28881 vertices")
    assert upload.value == ()  # emptied, so the same file can be sent again

    before = snapshot(editor)
    send(upload, "notes.png", b"not a picture")
    assert_unchanged(editor, before)
    assert "notes.png: not an image" in panel.message.value.replace("could not make a face from ", "")


def send(upload, name: str, content: bytes) -> None:
    """What the browser does to a FileUpload: its value from the JSON the front-end sends (ipywidgets 8)."""
    upload.set_state(
        {"value": [{"name": name, "type": "image/png", "size": len(content), "content": memoryview(content),
                    "last_modified": 1_700_000_000_000}]}
    )  # fmt: skip


@pytest.fixture
def app(tmp_path, photos):
    for name in ("astronaut.jpg", "coins.png"):
        (tmp_path / name).write_bytes((photos / name).read_bytes())
    app = EditorApp(Editor(window_size=(160, 120)), name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    yield app
    app.close()


def test_the_app_makes_a_face_from_a_path_in_its_folder_and_from_its_mesh_upload(app, tmp_path, face_mesh):
    editor = app.editor
    app.run("load_face", ["coins.png"])  # no loop running: done at once
    assert app.state.messages[0]["error"] and "coins.png" in app.state.messages[0]["text"]
    assert "no face found" in app.state.messages[0]["text"] and str(tmp_path) not in app.state.messages[0]["text"]
    app.run("load_face", ["../outside.jpg"])
    assert app.state.messages[0]["error"] and "outside" in app.state.messages[0]["text"]
    assert editor.mesh.n_points == 6393  # still the sample face

    app.run("load_face", ["astronaut.jpg"])
    assert editor.mesh.n_points == face_mesh.n_points and not app.state.messages[0]["error"]
    assert np.median(np.linalg.norm(editor.mesh.points[:468] - face_mesh.points[:468], axis=1)) < 2.0  # (a JPEG)
    assert app.state.mesh_info.startswith("28881 vertices")

    editor.session.move_control_point((1, 1, 1), (1.0, 0.0, 0.0))
    content = png_bytes(data.astronaut())
    app.files.receive_mesh_upload([{"name": "me.png", "size": len(content), "type": "image/png",
                                    "content": [content[:1000], content[1000:]]}])  # fmt: skip
    assert np.allclose(editor.mesh.points, face_mesh.points, atol=1e-4) and not editor.session.can_undo
    assert app.state.mesh_upload is None and "me.png (uploaded)" in app.state.messages[0]["text"]

    before = snapshot(editor)
    coins = png_bytes(data.coins())
    app.files.receive_mesh_upload({"name": "coins.png", "content": coins})
    assert_unchanged(editor, before)
    assert app.state.messages[0]["error"] and "coins.png (uploaded)" in app.state.messages[0]["text"]


def test_the_app_makes_the_face_off_its_event_loop(app):
    """Like a big mesh's load: the models, the subdivision and the lattice's binding run in a worker thread."""
    editor = app.editor
    editor.screenshot()

    async def scenario():
        return await longest_stall(lambda: app.run("load_face", ["astronaut.jpg"]), lambda: not app.state.busy)

    seconds, stall = asyncio.run(scenario())
    assert editor.mesh.n_points == 28881, list(editor.messages)
    # the face takes ~0.5 s of work (more on a loaded machine); the loop only swaps the result in
    assert stall < max(0.5, 0.6 * seconds), f"the loop stalled {stall:.2f} s of {seconds:.2f} s"


def test_the_command_line_opens_a_photo(photos, tmp_path):
    from ffd_notebook.__main__ import build_parser

    assert "photo of a face" in build_parser().format_help()
    env = {"PYTHONPATH": str(REPO)}
    result = subprocess.run(
        [sys.executable, "-m", "ffd_notebook", str(photos / "coins.png"), "--port", "0"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path, env={**__import__("os").environ, **env},
    )  # fmt: skip
    assert result.returncode == 1
    assert f"error: {photos / 'coins.png'}: no face found in the photo" in result.stderr


def test_the_view_turns_to_the_new_face(editor, photos):
    """Whatever the camera looked at before, the face is seen from the front and fills the view."""
    editor.plotter.camera.azimuth = 120  # the user turned the sphere round
    editor.plotter.camera.zoom(0.3)
    editor.load_face(photos / "astronaut.png")
    fresh = Editor(photos / "astronaut.png", window_size=(240, 180))  # a new editor frames the face
    try:

        def looking(camera) -> np.ndarray:
            towards = np.subtract(camera.position, camera.focal_point)
            return towards / np.linalg.norm(towards)

        assert np.allclose(looking(editor.plotter.camera), looking(fresh.plotter.camera), atol=1e-6)
        assert looking(editor.plotter.camera)[2] > 0.9  # from the front (+z), a little right and above
        assert np.allclose(editor.plotter.camera.focal_point, fresh.plotter.camera.focal_point, atol=0.5)  # mm
    finally:
        fresh.close()
