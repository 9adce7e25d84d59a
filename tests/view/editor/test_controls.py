"""One description of the panel controls: both panels render every entry, and a new control is one entry."""

from __future__ import annotations

import uuid
from operator import attrgetter

import pytest
import pyvista as pv

from ffd_notebook.view.editor.app import EditorApp
from ffd_notebook.view.editor.editor import Editor
from ffd_notebook.view.editor.notebook.panel import ControlPanel
from ffd_notebook.view.editor.session import controls
from ffd_notebook.view.editor.session.controls import Control, session_state


@pytest.fixture
def editor():
    editor = Editor(pv.Sphere(theta_resolution=12, phi_resolution=12), shape=(4, 4, 4), window_size=(120, 90))
    yield editor
    editor.close()


def notebook_widget(panel: ControlPanel, control: Control):
    return getattr(panel, f"{control.key}_button" if control.kind in ("button", "code", "record") else control.key)


def app_html(app: EditorApp) -> str:
    return app.layout.html


def element_ids(control: Control) -> list[str]:
    return [f"ffd-{k}" for k in control.state] if control.kind in ("ints", "floats", "choices") else [control.dom_id]


def test_every_control_is_rendered_by_both_panels(editor, tmp_path):
    panel = ControlPanel(editor)
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    page = app_html(app)
    for control in controls.CONTROLS:
        if "notebook" in control.panels:
            assert notebook_widget(panel, control) is not None, control.key
        if "app" in control.panels:
            assert all(f'id="{i}"' in page for i in element_ids(control)), control.key


def test_every_state_key_comes_from_the_one_mapping(editor):
    editor.session.select((1, 1, 1))
    known = set(session_state(editor.session)) | {c.key for c in controls.CONTROLS if c.default is not None}
    for control in controls.CONTROLS:
        used = set(control.state) | set(control.args) | set(control.limits) | {control.enabled} - {None}
        assert used <= known, (control.key, used - known)
        if control.command is not None:  # a session command: the controls need no Editor
            assert callable(attrgetter(control.command)(editor.session)), control.key


def test_a_new_control_is_one_entry(editor, tmp_path, monkeypatch):
    """Appending one Control puts a working widget in the notebook panel and on the app's page."""
    new = Control("select_corner", "button", "Corner", "Display", command="select", parse=lambda v: ((3, 3, 3),), row=9)
    monkeypatch.setattr(controls, "CONTROLS", (*controls.CONTROLS, new))
    panel = ControlPanel(editor)
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    assert 'id="ffd-select-corner"' in app_html(app) and panel.select_corner_button.description == "Corner"
    panel.select_corner_button.click()
    assert editor.session.selected == (3, 3, 3) and panel.ijk[0].value == 3  # the panel follows
    editor.session.select(None)
    assert app.run("select_corner") and editor.session.selected == (3, 3, 3) and app.state.sel_k == 3


def test_both_panels_show_the_same_state(editor, tmp_path):
    panel = ControlPanel(editor)
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    editor.session.move_control_point((2, 1, 3), (0.0, 0.5, 0.0))
    editor.set_field("displacement")
    assert [w.value for w in panel.ijk] == [app.state.sel_i, app.state.sel_j, app.state.sel_k] == [2, 1, 3]
    assert [w.value for w in panel.xyz] == [app.state.dx, app.state.dy, app.state.dz] == [0.0, 0.5, 0.0]
    assert panel.field.value == app.state.field == "displacement"
    assert panel.moved_points.value == "1 control point(s) moved" and app.state.moved_points == 1
