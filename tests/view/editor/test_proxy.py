"""The lighter copy of a large mesh drawn while a mouse button is held (ffd_notebook/view/editor/proxy.py)."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from editor_testing import display_xy, widget_index

from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.scene.proxy import INTERACTIVE_CELLS, simplified
from ffd_notebook.view.editor.scene.scene import prepare_display


@pytest.fixture(scope="module")
def face(shared_data):
    return pv.read(shared_data / "face" / "template.ply")  # 53,349 vertices, 106k triangles, RGBA colours


@pytest.fixture
def face_editor(face):
    editor = Editor(face, shape=(5, 5, 5), window_size=(400, 300))
    yield editor
    editor.close()


def visible(actor) -> bool:
    return bool(actor.GetVisibility())


@pytest.mark.parametrize("cells", [2_000, 8_000, INTERACTIVE_CELLS])
def test_simplified_face_keeps_its_own_vertices(face, cells):
    ids, faces = simplified(face, cells)
    copy = pv.PolyData(face.points[ids], faces=faces)
    assert 0.5 * cells <= copy.n_cells <= 1.5 * cells
    assert len(np.unique(ids)) == len(ids) and ids.min() >= 0 and ids.max() < face.n_points
    assert copy.is_all_triangles
    # the copy covers the mesh: its bounding box is within 2% of the face's on every side
    np.testing.assert_allclose(copy.bounds, face.bounds, atol=0.02 * max(np.ptp(face.points, axis=0)))


def test_small_meshes_and_none_have_no_copy(face):
    assert simplified(pv.Sphere(), 2_000) is None  # 1680 triangles: under twice 2000
    assert simplified(face, None) is None
    assert simplified(face, face.n_cells) is None


def test_a_drag_through_the_interactor_draws_the_copy_then_the_full_mesh(face_editor):
    editor = face_editor
    scene = editor.scene
    assert scene.proxy is not None and scene.proxy.mesh.n_cells <= 1.5 * INTERACTIVE_CELLS
    editor.set_field("displacement")
    index = widget_index(editor, (2, 2, 4))  # the middle of the front face: it moves the nose
    x, y = (round(v) for v in display_xy(editor, index))
    before = editor.screenshot()
    assert visible(scene.mesh_actor) and not visible(scene.proxy.actor)

    iren = editor.plotter.iren.interactor
    iren.SetEventInformation(x, y, 0, 0, "\0", 0, None)
    iren.LeftButtonPressEvent()
    for step in range(1, 4):
        iren.SetEventInformation(x + 12 * step, y + 6 * step, 0, 0, "\0", 0, None)
        iren.MouseMoveEvent()
        scene.plotter.render_window.Render()  # what the view does after each event
        assert visible(scene.proxy.actor) and not visible(scene.mesh_actor)
        proxy = scene.proxy.mesh
        # the copy shows the deformed mesh at its vertices, with the displacement field and its colouring
        np.testing.assert_allclose(proxy.points, editor.deformed_mesh.points[scene.proxy.ids], atol=1e-4)
        shown = np.asarray(scene.display.point_data["ffd_displacement"])
        np.testing.assert_array_equal(proxy.point_data["ffd_displacement"], shown[scene.proxy.ids])
        mapper, full = scene.proxy.actor.GetMapper(), scene.mesh_actor.GetMapper()
        assert mapper.GetArrayName() == full.GetArrayName() == "ffd_displacement"
        assert mapper.GetScalarRange() == full.GetScalarRange()
        assert scene.proxy.actor.GetProperty() is scene.mesh_actor.GetProperty()
    assert editor.session.history.can_undo  # the mouse really dragged the control point
    iren.LeftButtonReleaseEvent()

    after = editor.screenshot()
    assert visible(scene.mesh_actor) and not visible(scene.proxy.actor)
    assert np.abs(after.astype(int) - before).sum() > 0  # the mesh moved
    # the released frame is the full mesh's: the same image as a fresh render of the same state
    editor.set_field(None)
    editor.set_field("displacement")
    np.testing.assert_array_equal(editor.screenshot(), after)


def test_colors_and_a_mesh_hidden_from_code_follow(face_editor):
    scene = face_editor.scene
    scene.set_interacting(True)
    face_editor.screenshot()
    mapper = scene.proxy.actor.GetMapper()
    assert mapper.GetScalarVisibility() and mapper.GetArrayName() == "RGBA"
    np.testing.assert_array_equal(
        scene.proxy.mesh.point_data["RGBA"], scene.display.point_data["RGBA"][scene.proxy.ids]
    )
    face_editor.session.show_colors(False)
    face_editor.screenshot()
    assert not mapper.GetScalarVisibility()
    scene.set_interacting(False)
    scene.mesh_actor.VisibilityOff()  # hidden by the user: the copy never shows in its place
    scene.set_interacting(True)
    face_editor.screenshot()
    assert not visible(scene.proxy.actor) and not visible(scene.mesh_actor)
    scene.set_interacting(False)
    face_editor.screenshot()
    assert not visible(scene.mesh_actor)


def test_without_a_copy_the_full_mesh_is_always_drawn(face):
    editor = Editor(face, shape=(4, 4, 4), window_size=(200, 150), interactive_cells=None)
    try:
        assert editor.scene.proxy is None
        editor.scene.set_interacting(True)
        editor.screenshot()
        assert visible(editor.scene.mesh_actor)
        assert len(editor.plotter.renderer.actors) == len(Editor(pv.Sphere(), shape=(4, 4, 4)).plotter.renderer.actors)
    finally:
        editor.close()


def test_a_loaded_mesh_gets_its_copy_from_the_worker_and_loses_it_when_small(face_editor, face, tmp_path):
    scene = face_editor.scene
    old = scene.proxy.actor
    path = tmp_path / "bigger.ply"
    bigger = face.copy()
    bigger.points *= 2.0
    bigger.save(path)
    mesh, deformer = face_editor.session.files.read_mesh(path)
    prepared = prepare_display(mesh, deformer.current(), scene.interactive_cells)  # as the app's worker does
    scene.offer_display(prepared)
    face_editor.session.files.use_mesh(mesh, deformer, "bigger.ply")
    assert scene.proxy is not None and scene.proxy.ids is prepared.proxy[0]
    assert old not in scene.plotter.renderer.actors.values()
    path = tmp_path / "small.ply"
    pv.Sphere().save(path)
    face_editor.load_mesh(path)
    assert scene.proxy is None
    scene.set_interacting(True)
    face_editor.screenshot()
    assert visible(scene.mesh_actor)
