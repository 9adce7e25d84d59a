"""Picking respects what is seen (issue 24): a press grabs a control point only if its sphere is in front of the
mesh under the cursor; one hidden by the mesh is drawn faintly through it and grabbed with Alt; pins likewise.

The reference for "in front" is VTK's own cell picker (``vtkCellPicker`` on the plotted mesh), independent of
the editor's NumPy ray test.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.view import Editor

NOSE = (2, 2, 2)  # the sample face's 5x5x5 lattice: the middle control point, inside the head behind the nose


@pytest.fixture(scope="module")
def face_editor():
    editor = Editor(window_size=(800, 600))  # the sample face, its 5x5x5 lattice: the quickstart's first view
    yield editor
    editor.close()


def flat(editor, ijk) -> int:
    return int(np.ravel_multi_index(ijk, editor.lattice.shape))


def screen_xy(editor, ijk) -> tuple[float, float]:
    editor.screenshot()
    x, y = editor.scene.lattice_actor.display_positions()[flat(editor, ijk), :2]
    return float(x), float(y)


def press_drag_release(editor, xy, delta=(40, 25), *, alt=False, steps=4):
    iren = editor.plotter.iren.interactor
    x, y = (round(v) for v in xy)
    iren.SetAltKey(int(alt))
    try:
        iren.SetEventInformation(x, y, 0, 0, "\0", 0, None)
        iren.SetAltKey(int(alt))
        iren.LeftButtonPressEvent()
        for k in range(1, steps + 1):
            iren.SetEventInformation(x + round(delta[0] * k / steps), y + round(delta[1] * k / steps), 0, 0, "\0", 0)
            iren.SetAltKey(int(alt))
            iren.MouseMoveEvent()
        iren.LeftButtonReleaseEvent()
    finally:
        iren.SetAltKey(0)


def vtk_mesh_distance(editor, xy) -> float:
    """Distance from the camera to the mesh under display ``xy``, by VTK's cell picker (inf off the mesh)."""
    from vtkmodules.vtkRenderingCore import vtkCellPicker

    picker = vtkCellPicker()
    picker.SetTolerance(1e-6)
    picker.PickFromListOn()
    picker.AddPickList(editor.scene.mesh_actor)
    if not picker.Pick(xy[0], xy[1], 0.0, editor.plotter.renderer):
        return float("inf")
    return float(np.linalg.norm(np.array(picker.GetPickPosition()) - editor.plotter.camera.position))


def camera_state(editor):
    cam = editor.plotter.camera
    return np.array([*cam.position, *cam.focal_point, *cam.up])


def reset(editor):
    editor.session.reset(None)
    editor.session.history.clear()
    editor.session.select(None)  # (the selected sphere is gold)
    editor.scene.frame()


def test_a_press_on_the_face_over_a_hidden_control_point_turns_the_camera(face_editor):
    editor = face_editor
    reset(editor)
    xy = screen_xy(editor, NOSE)
    # the reference: the mesh is in front of that control point's sphere there
    centre = editor.session.control_points()[flat(editor, NOSE)]
    sphere_front = np.linalg.norm(centre - editor.plotter.camera.position) - editor.scene.lattice_actor.radius
    assert vtk_mesh_distance(editor, xy) < sphere_front, "the nose is not in front of (2, 2, 2) in this view"
    before = camera_state(editor)
    press_drag_release(editor, xy)
    assert not np.any(editor.lattice.offsets), "a hidden control point was dragged"
    assert len(editor.session.history) == 0
    assert np.abs(camera_state(editor) - before).max() > 1e-3, "the camera did not turn"


def test_a_press_on_a_visible_sphere_in_front_of_the_mesh_drags_it(face_editor):
    editor = face_editor
    reset(editor)
    actor = editor.scene.lattice_actor
    editor.screenshot()
    screen = actor.display_positions()
    camera = np.array(editor.plotter.camera.position)
    centres = editor.session.control_points()
    # a sphere whose front is in front of the mesh under its centre, by VTK's picker, in the middle of the view
    chosen = None
    for index in np.argsort(screen[:, 2]):
        x, y = screen[index, :2]
        if not (200 < x < 600 and 150 < y < 450):
            continue
        front = np.linalg.norm(centres[index] - camera) - actor.radius
        mesh = vtk_mesh_distance(editor, (x, y))
        if np.isfinite(mesh) and front < mesh - 2 * actor.radius:  # over the mesh, clearly in front of it
            chosen = int(index)
            break
    assert chosen is not None, "no sphere in front of the mesh in the middle of the view"
    ijk = tuple(int(v) for v in np.unravel_index(chosen, editor.lattice.shape))
    press_drag_release(editor, screen[chosen, :2])
    moved = [tuple(int(v) for v in m) for m in np.argwhere(np.any(editor.lattice.offsets != 0, axis=-1))]
    assert moved == [ijk], f"dragging the visible sphere {ijk} moved {moved}"
    assert len(editor.session.history) == 1


def test_alt_grabs_the_hidden_control_point(face_editor):
    editor = face_editor
    reset(editor)
    press_drag_release(editor, screen_xy(editor, NOSE), alt=True)
    moved = [tuple(int(v) for v in m) for m in np.argwhere(np.any(editor.lattice.offsets != 0, axis=-1))]
    assert moved == [NOSE]


def test_hidden_control_points_show_faintly_through_the_mesh(face_editor):
    editor = face_editor
    reset(editor)
    x, y = screen_xy(editor, NOSE)
    _layer, xray = editor.scene.lattice_actor.xray
    row, col = editor.plotter.window_size[1] - 1 - round(y), round(x)
    with_xray = editor.screenshot()[row - 1 : row + 2, col - 1 : col + 2].astype(int)
    xray.VisibilityOff()
    try:
        without = editor.screenshot()[row - 1 : row + 2, col - 1 : col + 2].astype(int)
    finally:
        xray.VisibilityOn()
    blue = np.array(pv.Color("royalblue").int_rgb)
    # the face there is tinted towards the sphere's blue, not hidden by it
    assert np.abs(with_xray - without).max() > 10
    assert np.linalg.norm(with_xray.mean(axis=(0, 1)) - blue) < np.linalg.norm(without.mean(axis=(0, 1)) - blue)
    assert np.linalg.norm(with_xray.mean(axis=(0, 1)) - blue) > 30  # faint: still mostly the face


def test_a_click_does_not_remove_a_pin_hidden_behind_the_mesh_but_alt_does():
    editor = Editor(pv.Sphere(radius=10, theta_resolution=40, phi_resolution=40), shape=(4, 4, 4),
                    window_size=(400, 300))  # fmt: skip
    try:
        editor.session.surface.set_mode("surface")
        editor.screenshot()
        camera = np.array(editor.plotter.camera.position)
        points = np.asarray(editor.mesh.points)
        back = int(np.argmax(np.linalg.norm(points - camera, axis=1)))  # the far side of the sphere
        editor.session.surface.pin(back)
        x, y, _ = editor.scene.surface_picking.world_to_display(points[back])[0]
        assert editor.scene.surface_picking.pin_at(x, y) is None  # hidden: a click there is on the front
        press_drag_release(editor, (x, y), delta=(0, 0), steps=1)  # a click: pins the front point instead
        assert len(editor.session.surface.pins) == 2
        press_drag_release(editor, (x, y), delta=(0, 0), steps=1)  # a click on that new front pin removes it
        assert len(editor.session.surface.pins) == 1
        press_drag_release(editor, (x, y), delta=(0, 0), steps=1, alt=True)  # Alt reaches the hidden one
        assert len(editor.session.surface.pins) == 0
    finally:
        editor.close()
