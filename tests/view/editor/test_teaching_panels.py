"""The teaching controls of both panels: the blend slider, the code (shown, downloaded), its running log, Record."""

from __future__ import annotations

import asyncio
import uuid

import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.view.editor.app import EditorApp
from ffd_notebook.view.editor.editor import Editor
from ffd_notebook.view.editor.notebook.panel import ControlPanel
from ffd_notebook.view.editor.session.controls import RECORD_FRAMES


@pytest.fixture
def editor():
    editor = Editor(pv.Sphere(theta_resolution=12, phi_resolution=12), shape=(4, 4, 4), window_size=(96, 72))
    yield editor
    editor.close()


def test_the_notebook_panel_teaches(editor, tmp_path):
    panel = ControlPanel(editor)
    assert "(no edits yet)" in panel.code_log.value
    editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
    editor.session.set_strength(0.5)
    assert "lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.25)" in panel.code_log.value  # the running log follows
    assert "ffd.strength = 0.5" in panel.code_log.value and 'class="ffd-scroll"' in panel.code_log.value
    assert panel.code_text.layout.display == "none"
    panel.code_button.click()
    assert panel.code_text.value == editor.to_code() and panel.code_text.layout.display == "block"
    editor.session.undo()  # shown, the code follows the edits
    assert panel.code_text.value == editor.to_code() and "strength" not in panel.code_text.value

    panel.blend.value = 0.25  # the slider: a quarter of the deformation, no undo step
    assert editor.session.blend == 0.25 and len(editor.session.history) == 1 and "0.25" in panel.blend_help.value
    editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.3))  # an edit: the whole deformation again
    assert panel.blend.value == 1.0

    seen = []
    panel.record_progress.observe(lambda change: seen.append(change["new"]), names="value")
    panel.movie_path.value = str(tmp_path / "lesson.gif")
    panel.record_button.click()
    assert iio.imread(tmp_path / "lesson.gif").shape[0] == RECORD_FRAMES
    assert seen[-1] == RECORD_FRAMES and len(seen) >= RECORD_FRAMES // 2  # the bar moved frame by frame
    assert editor.messages[-1] == f"recorded {tmp_path / 'lesson.gif'}: {RECORD_FRAMES} frames"
    panel.movie_path.value = str(tmp_path / "lesson.png")
    panel.record_button.click()
    assert editor.messages[-1].startswith("Error: could not record") and not panel.record_button.disabled


def test_the_app_teaches(editor, tmp_path):
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
    app.sync()
    assert "lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.25)" in app.state.code_log
    app.files.show_code()
    assert app.state.code_open and app.state.code_text == editor.to_code()
    assert asyncio.run(app.files.download_code()).decode() == editor.to_code()
    assert app.run("blend", [0.5]) and editor.session.blend == 0.5 and app.state.blend == 0.5
    assert len(editor.session.history) == 1

    progress = []
    app.state.change("record_progress")(lambda record_progress, **_: progress.append(record_progress))
    gif = asyncio.run(app.files.record("gif", True))
    frames = iio.imread(gif, extension=".gif")
    assert frames.shape[0] == RECORD_FRAMES and not app.state.recording
    assert not np.array_equal(frames[0], frames[-1])
    assert asyncio.run(app.files.record("mp4"))[4:8] == b"ftyp"  # an MP4 file's first box
    assert "recorded the deformation" in app.state.messages[0]["text"]
    assert not list(tmp_path.glob("**/animation.*"))  # the scratch copies are gone
    with pytest.raises(ValueError, match="an animation is one of gif, mp4"):
        asyncio.run(app.files.record("avi"))
    app.close()
