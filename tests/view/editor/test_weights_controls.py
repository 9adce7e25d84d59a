"""Blender's controls in the editor: the interpolation per axis and the strength (one control each in the
list both panels draw), the weight brush ("paint weights" mode), clear weights and ``editor.weights``;
every one undoable, the mesh always what ``FFD.deform`` gives for the session's FFD."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook import FFD
from ffd_notebook.view.editor import EditingSession
from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
from ffd_notebook.view.editor.session.controls import CONTROLS, by_key, run, session_state
from ffd_notebook.view.editor.session.weights import brush_falloff


def new_session(**kw) -> EditingSession:
    mesh = pv.Sphere(theta_resolution=24, phi_resolution=24)
    return EditingSession(mesh, mesh_io=PYVISTA_MESH_IO, **{"shape": (5, 5, 5), **kw})


def expected_points(session):
    """The outside reference: a fresh FFD with the session's lattice and options, applied by the one-shot evaluator."""
    ffd = session.ffd
    reference = FFD(session.lattice, ffd.basis, ffd.border, outside=ffd.outside, strength=ffd.strength)
    return reference.deform(session.rest_points, weights=session.deformer.weights)


def assert_follows(session):
    np.testing.assert_allclose(session.deformed_points, expected_points(session), atol=1e-5)


def test_interpolation_per_axis_is_one_control_and_one_undo_step():
    session = new_session()
    session.move_control_point((2, 2, 4), (0.0, 0.0, 0.3))
    assert session_state(session)["interp_y"] == "bspline" and session_state(session)["has_interpolation"]
    assert run(session, by_key("interpolation"), ["catmull-rom", "linear", "cardinal"])
    assert session.basis == ("catmull-rom", "linear", "cardinal")
    assert session.lattice.offsets[2, 2, 4, 2] == 0.3  # the offsets stay, as in Blender
    assert [session_state(session)[k] for k in ("interp_x", "interp_y", "interp_z")] == list(session.basis)
    assert_follows(session)
    session.undo()
    assert session.basis == "bspline"
    assert_follows(session)
    session.redo()
    assert session.basis == ("catmull-rom", "linear", "cardinal")
    assert not run(session, by_key("interpolation"), ["cubic", "linear", "linear"])
    assert "cannot set the interpolation" in session.messages[-1]
    session.set_shape((4, 6, 4))  # a new lattice keeps the interpolation
    assert session.basis == ("catmull-rom", "linear", "cardinal") and session.lattice.shape == (4, 6, 4)


def test_a_bernstein_lattice_has_no_interpolation_per_axis():
    session = new_session(basis="bernstein")
    assert not session_state(session)["has_interpolation"]
    with pytest.raises(ValueError, match="Bernstein"):
        session.set_interpolation(("linear",) * 3)


def test_strength_is_one_control_and_undoable():
    session = new_session()
    session.move_control_point((1, 2, 3), (0.2, 0.0, 0.1))
    full = session.deformed_points.copy()
    assert run(session, by_key("strength"), [0.25])
    assert session.ffd.strength == 0.25 and session_state(session)["strength"] == 0.25
    np.testing.assert_allclose(session.deformed_points, session.rest_points + 0.25 * (full - session.rest_points),
                               atol=1e-5)  # fmt: skip
    session.move_control_point((1, 2, 3), (0.4, 0.0, 0.1))  # the strength stays while editing
    assert_follows(session)
    session.undo()
    session.undo()
    assert session.ffd.strength == 1.0
    np.testing.assert_allclose(session.deformed_points, full, atol=1e-6)


def test_painted_weights_decide_which_part_of_the_mesh_follows():
    session = new_session()
    assert run(session, by_key("mode"), ["paint weights"]) and session.surface.mode == "paint weights"
    nose = session.rest_points[np.argmax(session.rest_points[:, 0])]  # the +x pole
    session.paint.begin()
    for step in range(3):  # a stroke of three mouse events, moving a little
        session.paint.stroke(nose + (0.0, 0.02 * step, 0.0), amount=0.5, radius=0.4)
    assert len(session.history) == 0  # the stroke is one step, recorded when it ends
    session.paint.end()
    assert len(session.history) == 1 and session_state(session)["has_weights"]
    weights = session.weights
    assert weights.max() == 1.0 and (weights == 0).sum() > len(weights) // 2
    distance = np.linalg.norm(session.rest_points - nose, axis=1)
    assert np.all(weights[distance > 0.45] == 0) and np.all(weights[distance < 0.1] > 0.9)
    # move the whole lattice up: only the painted part follows, each vertex by its weight
    session.lattice.offsets[...] = (0.0, 0.0, 0.5)
    session.update()
    moved = session.deformed_points[:, 2] - session.rest_points[:, 2]
    np.testing.assert_allclose(moved, 0.5 * weights, atol=1e-5)
    assert_follows(session)
    session.set_field("weights")
    np.testing.assert_allclose(session.field_values(), weights, atol=1e-7)
    session.undo()  # the lattice move
    session.undo()  # the stroke
    assert session.weights is None
    session.lattice.offsets[...] = (0.0, 0.0, 0.5)
    session.update()
    np.testing.assert_allclose(session.deformed_points[:, 2] - session.rest_points[:, 2], 0.5, atol=1e-5)


def test_brush_lowers_and_clear_weights_is_undoable():
    session = new_session()
    session.paint.set(np.full(len(session.rest_points), 0.8))
    assert run(session, by_key("brush"), ["lower"]) and session.paint.amount < 0
    point = session.rest_points[0]
    session.paint.begin()
    session.paint.stroke(point, radius=0.3)
    session.paint.end()
    assert session.weights[0] == pytest.approx(0.8 - 0.25) and session.weights.max() == pytest.approx(0.8)
    assert run(session, by_key("clear_weights"), [])
    assert session.weights is None and not session_state(session)["has_weights"]
    session.undo()
    assert session.weights[0] == pytest.approx(0.55)
    assert_follows(session)


def test_bad_weights_change_nothing_and_a_decimation_clears_them():
    session = new_session()
    with pytest.raises(ValueError, match="between 0 and 1"):
        session.paint.set(np.full(len(session.rest_points), 2.0))
    assert session.weights is None and len(session.history) == 0
    assert "cannot set the weights" in session.messages[-1]
    session.paint.set(np.linspace(0.0, 1.0, len(session.rest_points)))
    session.decimate(0.5)
    assert session.weights is None and "weights were cleared" in session.messages[-2]
    assert_follows(session)
    session.undo()  # the weights step, on the decimated mesh: the old weights do not fit, none are used
    assert_follows(session)


def test_a_basis_change_keeps_strength_and_weights_as_a_size_change_does(tmp_path):
    """Strength and painted weights belong to the deformation, not to the lattice: a new size, a new basis and
    undo keep them alike (issue 36). A new mesh keeps the strength; its vertices are other ones, so the weights
    go, and a message says so."""
    session = new_session()
    weights = np.linspace(0.0, 1.0, len(session.rest_points))
    session.set_strength(0.5)
    session.paint.set(weights)
    for change in (lambda: session.set_shape((6, 5, 5)), lambda: session.set_basis("bernstein"),
                   lambda: session.set_basis("bspline"), session.undo, session.undo, session.redo):  # fmt: skip
        change()
        assert session.ffd.strength == 0.5
        np.testing.assert_array_equal(session.weights, weights)
        assert_follows(session)
    cube = pv.Cube().triangulate().subdivide(2)
    cube.save(tmp_path / "cube.vtp")
    session.files.load_mesh(tmp_path / "cube.vtp")
    assert session.ffd.strength == 0.5 and session.weights is None
    assert any("weights were cleared" in m for m in list(session.messages)[-2:]), list(session.messages)
    assert_follows(session)
    session.files.load_mesh(tmp_path / "cube.vtp")  # nothing painted: nothing to say
    assert not any("weights" in m for m in list(session.messages)[-2:])


def test_falloff_is_smooth_and_zero_outside():
    d = np.linspace(0.0, 2.0, 9)
    f = brush_falloff(d, 1.0)
    assert f[0] == 1.0 and np.all(f[d >= 1.0] == 0.0) and np.all(np.diff(f) <= 0)


def test_every_new_control_is_in_the_one_list():
    keys = {c.key for c in CONTROLS}
    assert {"interpolation", "strength", "brush", "clear_weights"} <= keys
    assert "paint weights" in [v for v, _ in by_key("mode").choices]
    assert "weights" in [v for v, _ in by_key("field").choices]


def test_editor_weights_and_the_brush_in_the_view(editor):
    """``editor.weights`` from code, and a mouse drag over the mesh in "paint weights" mode paints them."""
    editor.screenshot()
    session = editor.session
    n = len(session.rest_points)
    editor.weights = np.zeros(n)
    assert np.array_equal(editor.weights, np.zeros(n)) and len(session.history) == 1
    editor.undo()
    assert editor.weights is None
    run(session, by_key("mode"), ["paint weights"])
    picking = editor.scene.surface_picking
    iren = editor.plotter.iren.interactor
    start = (120.0, 90.0)
    assert picking.pick(*start) is not None
    for name, (x, y) in [("LeftButtonPressEvent", start), ("MouseMoveEvent", (124.0, 92.0)),
                         ("MouseMoveEvent", (128.0, 94.0)), ("LeftButtonReleaseEvent", (128.0, 94.0))]:  # fmt: skip
        iren.SetEventInformation(round(x), round(y), 0, 0, "\0", 0, None)
        getattr(iren, name)()
    weights = editor.weights
    assert weights is not None and 0 < (weights > 0).sum() < n and len(session.history) == 1
    assert not editor.lattice.offsets.any()  # painting moved no control point
    editor.lattice.offsets[...] = (0.0, 0.0, 0.2)
    editor.update()
    np.testing.assert_allclose(editor.scene.shown_points()[:, 2] - session.rest_points[:, 2], 0.2 * weights,
                               atol=1e-4)  # fmt: skip
    # the weights as a colour map on the mesh
    assert run(session, by_key("field"), ["weights"])
    mapper = editor.scene.mesh_actor.GetMapper()
    assert mapper.GetArrayName() == "ffd_weights" and mapper.GetScalarVisibility()
    np.testing.assert_allclose(editor.scene.display.point_data["ffd_weights"], weights, atol=1e-6)
