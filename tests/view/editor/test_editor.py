"""The editor's drag path, programmatic edits, undo/redo, lattice rebuilds and hooks (headless)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from editor_instrument import Instrument
from editor_testing import (
    assert_view_matches_model,
    glyph_centers,
    handle_move,
    handle_release,
    line_points,
    mouse_drag,
    shown_points,
    widget_index,
)

from ffd_notebook import FFD, Lattice
from ffd_notebook.view.editor import Editor


def drag(editor, ijk, delta):
    """Simulate a handle move of control point ``ijk`` by ``delta`` (as VTK would move it and call back)."""
    index = widget_index(editor, ijk)
    center = editor.session.control_points()[index] + delta
    handle_move(editor, index, center)
    return center


def test_widget_callback_updates_mesh_lines_and_history(editor):
    inst = Instrument(editor)
    rest = editor.mesh.points.copy()
    drag(editor, (2, 2, 4), (0.0, 0.0, 0.4))  # the sphere on top of the mesh
    np.testing.assert_allclose(editor.lattice.offsets[2, 2, 4], (0, 0, 0.4), atol=1e-12)
    assert np.count_nonzero(editor.lattice.offsets) == 1
    assert_view_matches_model(editor)
    assert np.abs(shown_points(editor) - rest).max() > 0.05  # the mesh really moved
    np.testing.assert_array_equal(editor.mesh.points, rest)  # the rest mesh did not
    assert editor.session.selected == (2, 2, 4)
    assert inst.n_drags == 1 and editor.last_callback_ms > 0
    assert len(editor.session.history) == 1 and editor.session.can_undo
    # the same drag continues: still one undo step
    drag(editor, (2, 2, 4), (0.1, 0.0, 0.0))
    assert len(editor.session.history) == 1
    assert_view_matches_model(editor)
    assert editor.undo()
    assert not editor.lattice.offsets.any()
    np.testing.assert_allclose(shown_points(editor), rest, atol=1e-5)
    assert_view_matches_model(editor)
    assert editor.redo()
    np.testing.assert_allclose(editor.lattice.offsets[2, 2, 4], (0.1, 0, 0.4), atol=1e-12)
    assert_view_matches_model(editor)


def test_one_undo_step_per_drag(editor):
    drag(editor, (1, 2, 2), (0.2, 0, 0))
    drag(editor, (1, 2, 2), (0.2, 0, 0))
    drag(editor, (3, 2, 2), (0, 0.2, 0))  # another sphere: a new step
    assert len(editor.session.history) == 2
    handle_release(editor)  # mouse released
    drag(editor, (3, 2, 2), (0, 0.2, 0))  # grabbed again: a new step
    assert len(editor.session.history) == 3
    editor.undo()
    np.testing.assert_allclose(editor.lattice.offsets[3, 2, 2], (0, 0.2, 0), atol=1e-12)
    editor.undo()
    editor.undo()
    assert not editor.lattice.offsets.any() and not editor.session.can_undo
    assert not editor.undo()
    assert_view_matches_model(editor)


def test_programmatic_edit_and_update(editor):
    editor.lattice.offsets[2, :, 3] += (0, 0, 0.5)
    editor.update()
    assert_view_matches_model(editor)
    assert len(editor.session.history) == 1  # picked up as one undoable step
    editor.undo()
    assert not editor.lattice.offsets.any()
    assert_view_matches_model(editor)
    # moving the lattice itself (a placement change) is followed too
    editor.lattice.origin = editor.lattice.origin + (0.1, 0.0, 0.0)
    editor.update()
    assert_view_matches_model(editor)


def test_an_edit_from_code_is_rendered_once(editor):
    """With a browser view attached, the view renders the change (when it reads the image back) and the
    scene does not render it first; with none, the scene renders it itself."""
    renders = []
    editor.plotter.render_window.AddObserver("StartEvent", lambda *_: renders.append(1))

    class View:  # what a browser view does on update(): render the window and read its image
        updates = 0

        def update(self):
            View.updates += 1
            editor.plotter.render_window.Render()

    changes = []
    editor.session.subscribe(changes.append)
    editor.session.move_control_point((2, 2, 3), (0.0, 0.0, 0.5))  # two changes: the offsets, then the selection
    assert len(changes) == 2 and len(renders) == 2  # no view: the scene renders each
    editor.scene.views.add(View())
    renders.clear()
    editor.session.move_control_point((2, 2, 3), (0.0, 0.0, 0.8))
    editor.session.select((1, 1, 1))
    assert View.updates == 3 and len(renders) == 3  # the view's renders only
    assert_view_matches_model(editor)


def test_deformed_mesh_is_a_new_mesh_with_point_data(editor, sphere):
    drag(editor, (2, 3, 2), (0.3, 0.0, 0.0))
    out = editor.deformed_mesh
    np.testing.assert_allclose(out.points, editor.session.ffd.deform(sphere.points), atol=1e-5)
    np.testing.assert_array_equal(out.faces, sphere.faces)
    np.testing.assert_array_equal(out.point_data["RGB"], sphere.point_data["RGB"])
    out.points[:] = 0.0
    assert np.abs(shown_points(editor)).max() > 0.5  # independent of the editor


def test_screenshot_changes_after_an_edit(editor, tmp_path):
    from PIL import Image

    before = editor.screenshot()
    assert before.dtype == np.uint8 and before.shape == (180, 240, 3)
    editor.lattice.offsets[2, 2, 3] = (0.0, 0.0, 1.0)
    editor.update()
    after = editor.screenshot(tmp_path / "after.png")
    assert np.abs(after.astype(int) - before).sum() > 1000
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "after.png").convert("RGB")), after)


def test_move_select_reset_undo(editor):
    editor.session.move_control_point((1, 2, 3), (0.1, 0.2, 0.3))
    assert editor.session.selected == (1, 2, 3)
    editor.session.move_control_point((3, 2, 1), (-0.1, 0.0, 0.0))
    assert_view_matches_model(editor)
    editor.reset((1, 2, 3))
    assert not editor.lattice.offsets[1, 2, 3].any() and editor.lattice.offsets[3, 2, 1].any()
    editor.reset()
    assert not editor.lattice.offsets.any()
    assert_view_matches_model(editor)
    assert len(editor.session.history) == 4
    editor.undo()  # reset all
    editor.undo()  # reset one
    np.testing.assert_allclose(editor.lattice.offsets[1, 2, 3], (0.1, 0.2, 0.3))
    np.testing.assert_allclose(editor.lattice.offsets[3, 2, 1], (-0.1, 0.0, 0.0))
    assert_view_matches_model(editor)
    before = editor.lattice.offsets.copy()
    for bad in [(5, 0, 0), (0, -1, 0), (1, 2), (0.5, 0, 0)]:
        with pytest.raises(ValueError, match="within the lattice"):
            editor.session.move_control_point(bad, (1, 1, 1))
    with pytest.raises(ValueError, match="finite"):
        editor.session.move_control_point((0, 0, 0), (np.nan, 0, 0))
    np.testing.assert_array_equal(editor.lattice.offsets, before)
    editor.session.select((4, 4, 4))
    assert editor.session.selected == (4, 4, 4)


def test_set_shape_and_basis_are_undoable(editor):
    editor.session.move_control_point((2, 2, 2), (0.0, 0.3, 0.0))
    n_actors = editor.plotter.renderer.GetActors().GetNumberOfItems()
    editor.session.set_shape((4, 5, 6))
    assert editor.lattice.shape == (4, 5, 6) and not editor.lattice.offsets.any()
    assert editor.scene.lattice_actor.glyphs.n_points == 120
    assert line_points(editor).shape == (120, 3)
    assert editor.scene.lattice_actor.lines.n_cells == len(editor.lattice.edges())
    assert_view_matches_model(editor)
    editor.session.set_basis("bernstein")
    assert editor.session.basis == "bernstein" and editor.session.ffd.basis == "bernstein"
    drag(editor, (1, 1, 1), (0.2, 0.0, 0.0))
    assert_view_matches_model(editor)
    editor.undo()  # the drag
    editor.undo()  # the basis
    assert editor.session.basis == "bspline" and editor.lattice.shape == (4, 5, 6)
    editor.undo()  # the shape
    assert editor.lattice.shape == (5, 5, 5)
    np.testing.assert_allclose(editor.lattice.offsets[2, 2, 2], (0, 0.3, 0))
    assert editor.scene.lattice_actor.glyphs.n_points == 125
    assert editor.plotter.renderer.GetActors().GetNumberOfItems() == n_actors  # no stale actors
    assert_view_matches_model(editor)


def test_invalid_lattice_requests_change_nothing(editor):
    editor.session.move_control_point((2, 2, 2), (0.0, 0.3, 0.0))
    before = (editor.lattice.copy(), len(editor.session.history), len(editor.messages))
    with pytest.raises(ValueError):
        editor.session.set_shape((1, 3, 3))  # too small for any lattice
    with pytest.raises(ValueError):
        editor.session.set_basis("nurbs")
    with pytest.raises(TypeError):
        editor.session.set_lattice("not a lattice")
    assert editor.lattice == before[0] and len(editor.session.history) == before[1]
    assert len(editor.messages) == before[2] + 2
    assert editor.messages[-2].startswith("Error: cannot build a (1, 3, 3) lattice")
    assert_view_matches_model(editor)


def test_given_lattice_and_assignment(sphere):
    lattice = Lattice((4, 4, 4), spacing=1.0, origin=(-1.5, -1.5, -1.5))
    lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.5)
    editor = Editor(sphere, lattice=lattice, window_size=(160, 120))
    try:
        assert editor.lattice is lattice
        np.testing.assert_allclose(shown_points(editor), FFD(lattice).deform(sphere.points), atol=1e-5)
        other = Lattice((4, 4, 4), spacing=0.9, origin=(-1.4, -1.4, -1.4))
        editor.lattice = other
        assert editor.lattice is other and len(editor.session.history) == 1
        assert_view_matches_model(editor)
    finally:
        editor.close()


def test_callback_errors_become_messages(editor):
    inst = Instrument(editor)
    editor.on_widget_moved((0.0, 0.0, 0.0), 10_000)  # no such control point: must not raise into VTK
    assert editor.messages[-1].startswith("Error: widget callback failed for control point 10000")
    assert not editor.lattice.offsets.any() and inst.n_drags == 0


def fingerprint(points):
    """The documented checksum, computed independently: points projected on a seeded pattern."""
    flat = np.asarray(points, dtype=np.float64).ravel()
    return float(flat @ np.random.default_rng(0).standard_normal(len(flat)))


def test_checksum_sees_moves_across_the_position_vector(editor):
    inst = Instrument(editor)
    before = inst.fingerprint()
    assert before == pytest.approx(fingerprint(shown_points(editor)))
    points = shown_points(editor)
    k = int(np.argmax(np.linalg.norm(points, axis=1)))
    p = points[k].astype(float)
    across = np.cross(p, [0.0, 0.0, 1.0]) if abs(p[2]) < np.linalg.norm(p) * 0.9 else np.cross(p, [1.0, 0, 0])
    across *= 1e-3 / np.linalg.norm(across)  # |p| unchanged to first order: sum |p| would not see it
    editor.scene.display_points[k] = p + across
    assert inst.fingerprint() != pytest.approx(before, rel=1e-12, abs=1e-9)


def test_trace_file_records_each_callback(sphere, tmp_path):
    trace = tmp_path / "trace.jsonl"
    editor = Editor(sphere, window_size=(160, 120))
    Instrument(editor, trace=trace)
    try:
        drag(editor, (2, 2, 2), (0.1, 0, 0))
        drag(editor, (2, 2, 1), (0, 0.1, 0))
        records = [json.loads(line) for line in trace.read_text().splitlines()]
        assert [r["index"] for r in records] == [62, 61]
        assert records[1]["ijk"] == [2, 2, 1] and records[1]["ev"] == "cb"
        assert records[1]["checksum"] == pytest.approx(fingerprint(shown_points(editor)), rel=1e-9)
        np.testing.assert_allclose(records[1]["center"], glyph_centers(editor)[61])
        assert records[0]["ms"] > 0 and records[0]["t"] > 1e9
    finally:
        editor.close()


def test_widget_display_positions_and_triggers(editor):
    from trame.app import get_server

    inst = Instrument(editor)
    editor.screenshot()
    positions = inst.widget_display_positions()
    assert [p["index"] for p in positions] == list(range(125))
    # independent projection: the renderer's world -> normalised view transform
    camera = editor.plotter.camera
    w, h = editor.plotter.window_size
    matrix = camera.GetCompositeProjectionTransformMatrix(w / h, -1, 1)
    m = np.array([[matrix.GetElement(r, c) for c in range(4)] for r in range(4)])
    for p, center in zip(positions, glyph_centers(editor), strict=True):
        ndc = m @ np.append(center, 1.0)
        ndc = ndc[:3] / ndc[3]
        assert p["u"] == pytest.approx((ndc[0] + 1) / 2, abs=1e-3)
        assert p["v"] == pytest.approx((ndc[1] + 1) / 2, abs=1e-3)
    server = get_server("ffd-editor-test-triggers")
    inst.register_triggers(server)
    drag(editor, (2, 2, 2), (0.1, 0, 0))
    state = server.controller.trigger_fn("ffd_state")()
    assert state == {
        "checksum": pytest.approx(fingerprint(shown_points(editor)), rel=1e-9),
        "offsets_abs_sum": pytest.approx(0.1),
        "n_callbacks": 1,
        "selected": [2, 2, 2],  # a drag selects the point it moves
        "n_points": editor.mesh.n_points,
        "messages": [],
    }
    px = server.controller.trigger_fn("ffd_widget_px")()
    assert px["size"] == [240, 180] and len(px["widgets"]) == 125


def test_observers_follow_changes(editor):
    events = []
    editor.session.subscribe(lambda change: events.append(change.kind))
    drag(editor, (2, 2, 2), (0.1, 0, 0))
    editor.undo()
    editor.session.set_shape((4, 4, 4))
    assert events[:3] == ["select", "drag", "offsets"]
    assert "lattice" in events


@pytest.mark.parametrize("from_below", [False, True])
def test_a_click_grabs_the_nearest_sphere(editor, from_below):
    """Looking straight down a lattice column every sphere of the column is under the cursor; the nearest
    must move. (VTK alone hands the click to the first-created widget under the cursor: the far end.)"""
    editor.plotter.enable_parallel_projection()
    editor.plotter.view_xy(negative=from_below)
    editor.screenshot()
    w, h = editor.plotter.window_size
    nz = editor.lattice.shape[2]
    nearest_k = 0 if from_below else nz - 1
    positions = Instrument(editor).widget_display_positions()
    for i, j in [(1, 1), (2, 3), (3, 2)]:
        column = [widget_index(editor, (i, j, k)) for k in range(nz)]
        u = [positions[c]["u"] for c in column]
        v = [positions[c]["v"] for c in column]
        assert np.ptp(u) * w < 0.01 and np.ptp(v) * h < 0.01  # the column's spheres overlap exactly on screen
        assert editor.scene.lattice_actor.index_at(u[0] * w, v[0] * h) == column[nearest_k]
        mouse_drag(editor, (u[0] * w, v[0] * h), (4, 0))
        assert editor.session.selected == (i, j, nearest_k)
        moved = np.flatnonzero(np.any(editor.lattice.offsets.reshape(-1, 3) != 0, axis=1))
        assert moved.tolist() == [column[nearest_k]] and editor.lattice.offsets[i, j, nearest_k, 0] != 0
        editor.undo()
    # between drags the handle is parked: nothing to see or grab
    assert editor.scene.lattice_actor.handle.GetRadius() < 1e-3 * editor.scene.lattice_actor.radius
