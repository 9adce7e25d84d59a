"""An image in the editor: warped slices in the session and the scene, following drags where the point reaches."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
import SimpleITK as sitk
from editor_testing import full_slices

from ffd_notebook.images import ImageGrid, read_image, warp_image
from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
from ffd_notebook.view.editor.session import EditingSession
from ffd_notebook.view.editor.session.controls import by_key, run, session_state


def drag(session, ijk, by):
    """Drag control point ``ijk`` by ``by`` in two steps; returns, per slice, every pixel the drag re-read."""
    session.image.take_unshown()  # forget what was read before
    index = session.flat_index(ijk)
    start = session.control_points()[index]
    session.begin_drag(index)
    session.drag(index, start + 0.5 * np.asarray(by))
    session.drag(index, start + np.asarray(by))
    session.end_drag()
    return session.image.take_unshown()


def test_session_slices_follow_drags_only_where_the_control_point_reaches(ct):
    session = EditingSession(pv.Sphere(radius=0.5), mesh_io=PYVISTA_MESH_IO, shape=(7, 7, 7))
    image = session.image
    changes = []
    session.subscribe(changes.append)
    image.load(ct)
    assert changes[0].kind == "image" and changes[0].label == "load image"
    level, width = image.window
    assert -200 < level < 300 and width > 100
    before = {axis: v.copy() for axis, v in image.slices.values.items()}
    reached = drag(session, (3, 3, 4), (0.15, 0.0, -0.1))
    expected = full_slices(read_image(ct), session.ffd, image.slices.positions)
    for axis in range(3):
        region = reached[axis]
        assert 0 < region.sum() < region.size
        np.testing.assert_array_equal(image.slices.values[axis][~region], before[axis][~region])
        np.testing.assert_allclose(image.slices.values[axis], expected[axis], atol=1e-3)
    session.set_shape((5, 6, 5))  # a new lattice: the slices follow it
    assert all(region.all() for region in image.regions.values())
    session.lattice.offsets[2, 2, 2] = (0.2, 0.1, 0.0)
    session.update()
    expected = full_slices(read_image(ct), session.ffd, image.slices.positions)
    for axis in range(3):
        np.testing.assert_allclose(image.slices.values[axis], expected[axis], atol=1e-3)


def test_controls_window_slices_and_a_failed_load(ct, tmp_path):
    session = EditingSession(pv.Sphere(radius=0.5), mesh_io=PYVISTA_MESH_IO, shape=(5, 5, 5))
    assert session_state(session)["has_image"] is False
    bad = tmp_path / "bad.nii"
    bad.write_bytes(b"\0" * 600)
    assert not run(session, by_key("load_image"), [str(bad)])
    assert not session.image.loaded and "bad.nii" in session.messages[-1] and not session.can_undo
    assert run(session, by_key("load_image"), [str(ct)])
    state = session_state(session)
    assert state["has_image"] and (state["img_max_i"], state["img_max_j"], state["img_max_k"]) == (33, 29, 25)
    assert run(session, by_key("image_slices"), [5, 6, 7])
    assert session.image.slices.positions == [5, 6, 7]
    assert run(session, by_key("image_window"), [50, 400])
    assert session.image.window == (50.0, 400.0)
    assert not run(session, by_key("image_window"), [50, -1])
    assert "positive width" in session.messages[-1]
    assert run(session, by_key("save_image"), [str(tmp_path / "w.nrrd")])
    saved = sitk.GetArrayFromImage(read_image(tmp_path / "w.nrrd"))
    np.testing.assert_allclose(saved, sitk.GetArrayFromImage(warp_image(ct, session.ffd)))
    # saving the lattice writes the image warped by it beside it
    session.move_control_point((2, 2, 2), (0.2, 0.0, 0.0))
    session.files.save_deformation(tmp_path / "lattice.ffd")
    beside = tmp_path / "lattice.warped.nii.gz"
    np.testing.assert_allclose(sitk.GetArrayFromImage(read_image(beside)),
                               sitk.GetArrayFromImage(warp_image(ct, session.ffd)), atol=1e-4)  # fmt: skip


def texels(session, axis):
    from ffd_notebook.view.editor.scene.image_slices import to_texels

    return to_texels(session.image.slices.values[axis], session.image.window)


def test_scene_shows_the_slices_and_changes_only_reached_pixels(ct):
    editor = Editor(pv.Sphere(radius=0.5), image=ct, shape=(7, 7, 7), window_size=(240, 180))
    try:
        shown = editor.scene.image_slices
        assert shown is not None and set(shown.planes) == {0, 1, 2}
        session = editor.session
        for axis in range(3):
            np.testing.assert_array_equal(shown.shown_values(axis), texels(session, axis))
        before = {axis: shown.shown_values(axis).copy() for axis in range(3)}
        cp = (3, 3, 4)
        drag(session, cp, (0.15, 0.0, -0.1))
        for axis in range(3):
            now = shown.shown_values(axis)
            changed = (now != before[axis]).ravel()
            # the cubic B-spline support of an inner control point: two cells each way
            u = session.lattice.to_lattice(session.image.slices.slice_points(axis))
            reach = np.all(np.abs(u - np.array(cp)) < 2.0, axis=1)
            assert changed.any() and not changed[~reach].any() and reach.mean() < 0.9
            np.testing.assert_array_equal(now, texels(session, axis))
        # during a drag the slices are brought up to date just before each frame is rendered
        index = session.flat_index(cp)
        session.begin_drag(index)
        session.drag(index, session.control_points()[index] + (0.0, 0.1, 0.0))
        pending = {axis: shown.shown_values(axis).copy() for axis in range(3)}
        editor.scene.plotter.render_window.Render()
        assert any((shown.shown_values(axis) != pending[axis]).any() for axis in range(3))
        session.end_drag()
        for axis in range(3):
            np.testing.assert_array_equal(shown.shown_values(axis), texels(session, axis))
        session.image.set_window((0.0, 100.0))
        editor.scene.plotter.render_window.Render()
        for axis in range(3):
            np.testing.assert_array_equal(shown.shown_values(axis), texels(session, axis))
        picture = editor.screenshot()
        assert np.ptp(picture) > 50
    finally:
        editor.close()


def test_lattice_over_the_image_alone(ct):
    editor = Editor(None, image=ct, shape=(5, 5, 5), window_size=(240, 180))
    try:
        lo, hi = ImageGrid.of(read_image(ct)).bounds()
        mesh = editor.session.mesh
        np.testing.assert_allclose(mesh.bounds, [lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]], atol=1e-9)
        corners = editor.lattice.control_points().reshape(-1, 3)
        assert (corners.min(axis=0) <= lo + 1e-9).all() and (corners.max(axis=0) >= hi - 1e-9).all()
        assert editor.scene.image_slices is not None
    finally:
        editor.close()


def test_the_app_loads_shows_and_saves_an_image_inside_its_folder(tmp_path, ct):
    import uuid

    from ffd_notebook.view.editor.app import EditorApp

    editor = Editor(pv.Sphere(radius=0.5), shape=(5, 5, 5), window_size=(160, 120))
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=ct.parent)
    try:
        assert app.state.has_image is False
        app.run("load_image", ["../outside.nii"])  # through the app's folder only
        assert app.state.messages[0]["error"] and "outside" in app.state.messages[0]["text"]
        (ct.parent / "sneaky.mhd").write_text("ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                                              "ElementType = MET_UCHAR\nElementDataFile = /etc/hostname\n")  # fmt: skip
        app.run("load_image", ["sneaky.mhd"])  # its header points outside the folder: refused, nothing read
        assert app.state.messages[0]["error"] and "outside" in app.state.messages[0]["text"]
        assert not app.state.has_image
        app.run("load_image", [ct.name])
        assert app.state.has_image and app.state.image_info.startswith("ct.nii.gz: 34 x 30 x 26")
        assert editor.scene.image_slices is not None
        app.run("image_slices", [3, 4, 5])
        assert editor.session.image.slices.positions == [3, 4, 5] and app.state.img_k == 5
        app.run("apply", [2, 2, 2, 0.2, 0.0, 0.0])
        app.run("save_image", ["warped.mha"])
        saved = sitk.GetArrayFromImage(read_image(ct.parent / "warped.mha"))
        np.testing.assert_allclose(saved, sitk.GetArrayFromImage(warp_image(ct, editor.session.ffd)))
        app.run("save_image", ["warped.txt"])
        assert app.state.messages[0]["error"] and "must end with" in app.state.messages[0]["text"]
    finally:
        app.close()
        editor.close()


def test_the_command_line_takes_an_image():
    from ffd_notebook.__main__ import build_parser

    args = build_parser().parse_args(["--image", "ct.nii.gz", "--shape", "6", "6", "6"])
    assert args.image == "ct.nii.gz" and args.mesh is None


def test_the_notebook_panel_loads_an_image_and_sets_its_window(ct):
    from ffd_notebook.view import ControlPanel

    editor = Editor(pv.Sphere(radius=0.5), shape=(5, 5, 5), window_size=(160, 120))
    try:
        panel = ControlPanel(editor)
        assert panel.save_image_button.disabled
        panel.image_path.value = str(ct)
        panel.load_image_button.click()
        assert editor.session.image.loaded and not panel.save_image_button.disabled
        assert [field.max for field in panel.image_slices] == [33, 29, 25]
        panel.image_window[1].value = 250.0
        assert editor.session.image.window[1] == 250.0
        panel.image_slices[0].value = 7
        assert editor.session.image.slices.positions[0] == 7
    finally:
        editor.close()


def test_the_meshs_vertex_weights_are_not_the_images(ct):
    """Vertex weights are one per vertex: the image follows the lattice fully (its slices and its saved file)."""
    session = EditingSession(pv.Sphere(radius=0.5), mesh_io=PYVISTA_MESH_IO, shape=(7, 7, 7))
    session.ffd.weights = np.linspace(0.0, 1.0, session.mesh.n_points)
    session.image.load(ct)  # the slices took the mesh's weights for the voxels' (ValueError) before
    drag(session, (3, 3, 4), (0.15, 0.0, -0.1))
    session.ffd.weights = np.zeros(session.mesh.n_points)  # weights painted after the image is shown
    drag(session, (3, 4, 3), (0.0, 0.1, 0.05))
    image = session.image
    whole = image.deformation()
    assert whole.weights is None and whole.lattice is session.lattice
    expected = full_slices(read_image(ct), whole, image.slices.positions)
    for axis in range(3):
        np.testing.assert_allclose(image.slices.values[axis], expected[axis], atol=1e-3, rtol=0)
    np.testing.assert_array_equal(sitk.GetArrayFromImage(image.warped()), sitk.GetArrayFromImage(warp_image(ct, whole)))
    with pytest.raises(ValueError, match="one per voxel"):
        warp_image(ct, session.ffd)  # warp_image itself does not take a mesh's weights for an image's
