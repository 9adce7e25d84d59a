"""The lattice on screen: one glyph actor, one handle placed by picking, display modes (real interactor events)."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from editor_testing import assert_view_matches_model, display_xy, mouse_drag, widget_index

from ffd_notebook import Lattice
from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.scene.lattice_actor import SELECTED_COLOR, WIDGET_COLOR, shown_indices
from ffd_notebook.view.editor.session.controls import by_key, run, session_state


def actor_count(editor):
    return editor.plotter.renderer.GetActors().GetNumberOfItems()


def recorder(editor):
    changes = []
    editor.session.subscribe(lambda change: changes.append(change.kind))
    return changes


def test_a_press_on_a_sphere_drags_that_control_point(editor):
    index = widget_index(editor, (2, 3, 4))
    x, y = display_xy(editor, index)
    before = editor.session.control_points()[index].copy()
    changes = recorder(editor)
    mouse_drag(editor, (x, y), (30, 0), steps=5)
    assert editor.session.selected == (2, 3, 4)
    assert changes.count("drag") == 5 and changes[-1] == "offsets"  # one callback per move, then the release
    moved = np.flatnonzero(np.any(editor.lattice.offsets.reshape(-1, 3) != 0, axis=1))
    assert moved.tolist() == [index]
    # the sphere followed the cursor to the right on screen (VTK's widget moves it in the view plane)
    x1, y1 = display_xy(editor, index)
    assert 15 < x1 - x < 60 and abs(y1 - y) < 3
    assert np.linalg.norm(editor.session.control_points()[index] - before) > 0
    assert len(editor.session.history) == 1
    assert_view_matches_model(editor)


def test_a_press_off_every_sphere_turns_the_camera_and_drags_nothing(editor):
    editor.screenshot()
    screen = editor.scene.lattice_actor.display_positions()
    start = (3, 3)
    assert np.all(np.hypot(screen[:, 0] - start[0], screen[:, 1] - start[1]) > screen[:, 3] + 2)
    camera = editor.plotter.camera.position
    changes = recorder(editor)
    mouse_drag(editor, start, (40, 10), steps=4)
    assert editor.plotter.camera.position != camera
    assert changes == [] and not editor.lattice.offsets.any() and editor.session.selected is None


def test_the_press_picks_the_nearer_of_two_overlapping_spheres():
    """A perspective view down a lattice column: both ends are under the cursor; the one nearer the camera
    is picked and dragged, from either side."""
    lattice = Lattice((2, 2, 2), spacing=1.0, origin=(-0.5, -0.5, -0.5))
    editor = Editor(pv.Sphere(radius=0.3), lattice=lattice, basis="bernstein", window_size=(200, 200))
    try:
        for z, near_k in ((4.0, 1), (-4.0, 0)):
            camera = editor.plotter.camera
            camera.position, camera.focal_point, camera.up = (-0.5, -0.5, z), (-0.5, -0.5, 0.0), (0, 1, 0)
            editor.plotter.reset_camera_clipping_range()
            near, far = widget_index(editor, (0, 0, near_k)), widget_index(editor, (0, 0, 1 - near_k))
            x, y = display_xy(editor, near)
            screen = editor.scene.lattice_actor.display_positions()
            assert np.hypot(*(screen[far, :2] - (x, y))) < screen[far, 3]  # the far one is under the cursor too
            assert editor.scene.lattice_actor.index_at(x, y) == near
            mouse_drag(editor, (x, y), (10, 0))
            assert editor.session.selected == (0, 0, near_k)
            moved = np.flatnonzero(np.any(editor.lattice.offsets.reshape(-1, 3) != 0, axis=1))
            assert moved.tolist() == [near]
            editor.undo()
    finally:
        editor.close()


def test_display_modes_show_the_right_points_and_lines(sphere):
    editor = Editor(sphere, shape=(7, 7, 7), window_size=(200, 150))
    actor = editor.scene.lattice_actor
    try:
        assert session_state(editor.session)["points_shown"] == "auto"  # 343 points: all of them
        assert actor.glyphs.n_points == 343 and actor.lines.n_cells == len(editor.lattice.edges())
        assert run(editor.session, by_key("points_shown"), ["hull"]) and editor.session.points_shown == "hull"
        assert actor.glyphs.n_points == 343 - 125
        # hull lines: the edges with both ends on the hull, 6 faces of 2 * 7 * 6 edges, shared border edges once
        assert actor.lines.n_cells == 6 * 2 * 7 * 6 - 12 * 6
        editor.session.select((3, 3, 3))  # an inner point, selected: shown too
        assert actor.glyphs.n_points == 343 - 125 + 1
        editor.show_points("near")
        assert actor.glyphs.n_points == 5**3  # two index steps around (3, 3, 3)
        assert actor.lines.n_cells == 3 * 5 * 5 * 4
        editor.session.select((0, 0, 0))
        assert actor.glyphs.n_points == 3**3
        assert_view_matches_model(editor)
        # a hidden control point is not picked: the press goes to the camera
        hidden = widget_index(editor, (5, 5, 5))
        assert hidden not in actor.shown
        x, y = display_xy(editor, hidden)
        if actor.index_at(x, y) is None:
            mouse_drag(editor, (x, y), (20, 0))
            assert not editor.lattice.offsets.any()
        assert not run(editor.session, by_key("points_shown"), ["some"])  # refused, with a message
        assert editor.session.points_shown == "near" and "points shown must be one of" in editor.messages[-1]
        editor.show_points("all")
        assert actor.glyphs.n_points == 343
    finally:
        editor.close()


def test_the_selected_point_is_highlighted_without_new_actors(editor):
    actor = editor.scene.lattice_actor
    n = actor_count(editor)
    rgb = lambda: np.asarray(actor.glyphs.point_data["rgb"])  # noqa: E731
    assert (rgb() == pv.Color(WIDGET_COLOR).int_rgb).all()
    editor.session.select((1, 2, 3))
    index = widget_index(editor, (1, 2, 3))
    assert tuple(rgb()[index]) == pv.Color(SELECTED_COLOR).int_rgb
    assert (np.delete(rgb(), index, axis=0) == pv.Color(WIDGET_COLOR).int_rgb).all()
    editor.session.select(None)
    assert (rgb() == pv.Color(WIDGET_COLOR).int_rgb).all()
    assert actor_count(editor) == n


def test_a_rebuild_from_5_to_20_per_axis_keeps_the_actor_count(editor):
    n = actor_count(editor)
    editor.session.set_shape((20, 20, 20))
    assert editor.scene.lattice_actor.glyphs.n_points == 8000 - 18**3 and actor_count(editor) == n
    editor.screenshot()
    index = widget_index(editor, (10, 10, 19))
    mouse_drag(editor, display_xy(editor, index), (0, 12))
    assert editor.session.selected is not None and editor.lattice.offsets.any()
    assert_view_matches_model(editor)
    editor.undo()
    editor.undo()
    assert editor.lattice.shape == (5, 5, 5) and actor_count(editor) == n


@pytest.mark.parametrize("mode", ["all", "near", "hull"])
def test_shown_indices_keep_the_selected_point(mode):
    shape = (6, 4, 5)
    for selected in (None, 0, 57, 119):
        shown = shown_indices(shape, mode, selected)
        assert np.all(np.diff(shown) > 0) and shown.min() >= 0 and shown.max() < 120
        if selected is not None:
            assert selected in shown
    with pytest.raises(ValueError, match="points shown"):
        shown_indices(shape, "none")
