"""The ipywidgets control panel: each control drives the editor through its real handlers and follows it."""

from __future__ import annotations

import time

import numpy as np
import pytest
from editor_testing import assert_view_matches_model, shown_points, widget_index

from ffd_notebook.io import load_ffd, read_obj
from ffd_notebook.view.editor.notebook.panel import ControlPanel
from ffd_notebook.view.editor.session.changes import DRAG_SYNC_S


@pytest.fixture
def panel(editor):
    return ControlPanel(editor)


def set_ijk(panel, ijk):
    for w, v in zip(panel.ijk, ijk, strict=True):
        w.value = v


def test_apply_reset_undo_redo(panel, editor):
    assert panel.undo_button.disabled and panel.redo_button.disabled
    set_ijk(panel, (1, 2, 3))
    assert editor.session.selected == (1, 2, 3)
    for w, v in zip(panel.xyz, (0.1, -0.2, 0.3), strict=True):
        w.value = v
    panel.apply_button.click()
    np.testing.assert_allclose(editor.lattice.offsets[1, 2, 3], (0.1, -0.2, 0.3))
    assert_view_matches_model(editor)
    assert not panel.undo_button.disabled and panel.redo_button.disabled
    panel.reset_point_button.click()
    assert not editor.lattice.offsets.any() and [w.value for w in panel.xyz] == [0.0, 0.0, 0.0]
    panel.undo_button.click()
    assert [w.value for w in panel.xyz] == [0.1, -0.2, 0.3]
    panel.undo_button.click()
    assert not editor.lattice.offsets.any() and panel.undo_button.disabled and not panel.redo_button.disabled
    panel.redo_button.click()
    np.testing.assert_allclose(editor.lattice.offsets[1, 2, 3], (0.1, -0.2, 0.3))
    panel.reset_all_button.click()
    assert not editor.lattice.offsets.any()
    assert_view_matches_model(editor)


def test_dragging_selects_the_point_in_the_panel(panel, editor):
    index = widget_index(editor, (3, 1, 2))
    center = editor.session.control_points()[index] + (0.0, 0.25, 0.0)
    editor.on_widget_moved(center, index)
    assert [w.value for w in panel.ijk] == [3, 1, 2]
    np.testing.assert_allclose([w.value for w in panel.xyz], (0.0, 0.25, 0.0), atol=1e-9)
    assert not panel.undo_button.disabled


def test_a_long_drag_updates_the_panel_at_a_bounded_rate_and_ends_exact(panel, editor, monkeypatch):
    """Each panel sync is widget messages that JupyterLab's page handles on the thread that shows the
    view's frames: a drag syncs at most every DRAG_SYNC_S, and its release shows the final offsets."""
    syncs, sync = [], panel.sync
    monkeypatch.setattr(panel, "sync", lambda: (syncs.append(time.monotonic()), sync())[1])
    index = widget_index(editor, (3, 1, 2))
    start = editor.session.control_points()[index].copy()
    editor.session.begin_drag(index)
    began = time.monotonic()
    for k in range(1, 61):
        editor.on_widget_moved(start + (0.0, 0.005 * k, 0.0), index)
    elapsed = time.monotonic() - began
    # the first move selects the point (a "select" change) and syncs as a drag; then one per period at most
    assert 2 <= len(syncs) <= 2 + elapsed / DRAG_SYNC_S + 1e-9
    editor.session.end_drag()
    np.testing.assert_allclose([w.value for w in panel.xyz], (0.0, 0.3, 0.0), atol=1e-9)
    assert [w.value for w in panel.ijk] == [3, 1, 2]


def test_lattice_size_and_basis(panel, editor):
    for w, v in zip(panel.shape, (4, 6, 5), strict=True):
        w.value = v
    panel.rebuild_button.click()
    assert editor.lattice.shape == (4, 6, 5) and editor.scene.lattice_actor.glyphs.n_points == 120
    assert [w.max for w in panel.ijk] == [3, 5, 4]
    panel.basis.value = "bernstein"
    assert editor.session.basis == "bernstein"
    panel.undo_button.click()
    assert editor.session.basis == "bspline" and panel.basis.value == "bspline"
    # every size the fields allow (2 or more) is a valid fitted lattice ("clamp" border), so the bad
    # request is a lattice the session refuses: an error in the message area, nothing changed
    assert not editor.session.attempt(editor.session.set_shape, (1, 3, 3))
    assert editor.lattice.shape == (4, 6, 5)
    assert "Error: cannot build a (1, 3, 3) lattice" in panel.message.value and "#c62828" in panel.message.value
    assert [w.value for w in panel.shape] == [4, 6, 5]  # the panel shows the editor's lattice


def test_ffd_files_through_the_panel(panel, editor, tmp_path):
    editor.session.move_control_point((2, 2, 2), (0.0, 0.0, 0.2))
    panel.ffd_path.value = str(tmp_path / "panel.ffd")
    panel.save_ffd_button.click()
    assert load_ffd(tmp_path / "panel.ffd") == editor.lattice
    assert "saved the lattice" in panel.message.value and "#2e7d32" in panel.message.value
    panel.reset_all_button.click()
    panel.load_ffd_button.click()
    np.testing.assert_allclose(editor.lattice.offsets[2, 2, 2], (0, 0, 0.2))
    # a bad file: the panel shows the error, the editor keeps everything
    before = (editor.lattice.copy(), len(editor.session.history), shown_points(editor).copy())
    good = (tmp_path / "panel.ffd").read_text().splitlines()
    size_line = good.index("#control grid size#") + 2  # the ny line, 0-based
    good[size_line] = "twelve"
    (tmp_path / "bad.ffd").write_text("\n".join(good) + "\n")
    panel.ffd_path.value = str(tmp_path / "bad.ffd")
    panel.load_ffd_button.click()  # no exception escapes a button
    assert "Error: could not load the lattice" in panel.message.value and f"line {size_line + 1}" in panel.message.value
    assert editor.lattice == before[0] and len(editor.session.history) == before[1]
    np.testing.assert_array_equal(shown_points(editor), before[2])


def test_mesh_files_decimation_and_display(panel, editor, shared_data, tmp_path):
    panel.mesh_path.value = str(shared_data / "face" / "james_colored.obj")
    panel.load_mesh_button.click()
    assert editor.mesh.n_points == 6393 and "loaded" in panel.message.value
    panel.mesh_path.value = str(tmp_path / "missing.obj")
    panel.load_mesh_button.click()
    assert editor.mesh.n_points == 6393 and "Error" in panel.message.value
    panel.reduction.value = 0.5
    panel.decimate_button.click()
    assert editor.mesh.n_cells < 0.55 * 12228 and editor.mesh.point_data["RGB"].dtype == np.uint8
    set_ijk(panel, (2, 2, 2))
    panel.xyz[0].value = 10.0
    panel.apply_button.click()
    panel.mesh_save_path.value = str(tmp_path / "deformed.obj")
    panel.save_mesh_button.click()
    back = read_obj(tmp_path / "deformed.obj")
    np.testing.assert_allclose(back.points, editor.deformed_mesh.points, rtol=1e-5, atol=1e-3)
    np.testing.assert_array_equal(back.point_data["RGB"], editor.mesh.point_data["RGB"])
    panel.colors.value = False
    assert not editor.session.colors_shown and not editor.scene.mesh_actor.GetMapper().GetScalarVisibility()
    panel.field.value = "displacement"
    assert editor.session.field == "displacement"
    panel.field.value = "jacobian"
    assert editor.session.field == "jacobian" and panel.message.value.count("folding (det J") == 1
    panel.field.value = "none"  # shown as "mesh colours", never as an empty dropdown
    assert editor.session.field is None and panel.field.label == "mesh colours"
