"""Helpers for the editor tests (tests/view): meshes and checks of what the editor shows."""

from __future__ import annotations

import numpy as np

import ffd_notebook.view  # noqa: F401  (headless rendering settings before any plotter)


def colored_sphere(resolution: int = 24):
    """A sphere whose per-vertex "RGB" colours change with height (red top, blue bottom)."""
    import pyvista as pv

    mesh = pv.Sphere(radius=1.0, theta_resolution=resolution, phi_resolution=resolution)
    z = (mesh.points[:, 2] + 1.0) / 2.0
    rgb = np.column_stack([255 * z, 60 * np.ones_like(z), 255 * (1 - z)])
    mesh.point_data["RGB"] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return mesh


def widget_index(editor, ijk) -> int:
    """Flat index of control point ``ijk`` (the index the drag callbacks get)."""
    return int(np.ravel_multi_index(tuple(ijk), editor.lattice.shape))


def glyph_centers(editor) -> np.ndarray:
    """Centres of the drawn control-point spheres (all of them unless a display mode hides some)."""
    return np.asarray(editor.scene.lattice_actor.glyphs.points, dtype=np.float64)


def handle_move(editor, index, center):
    """Move the drag handle, put on control point ``index``, to ``center`` as VTK does during a drag
    (the widget moves, then fires InteractionEvent): the editor's callback runs through the handle."""
    actor = editor.scene.lattice_actor
    if actor.handle_index != index or actor.handle.GetRadius() < actor.radius:
        actor.place_handle(index)
    actor.handle.SetCenter(*center)
    actor.handle.InvokeEvent("InteractionEvent")


def handle_release(editor):
    """The mouse button released at the end of a handle drag."""
    editor.scene.lattice_actor.handle.InvokeEvent("EndInteractionEvent")


def mouse_drag(editor, start, delta, steps=1):
    """Press the left button at display ``start`` (pixels, origin bottom-left), move by ``delta`` in
    ``steps`` and release, through the VTK interactor (what trame's mouse handler does)."""
    iren = editor.plotter.iren.interactor
    x, y = (round(v) for v in start)
    iren.SetEventInformation(x, y, 0, 0, "\0", 0, None)
    iren.LeftButtonPressEvent()
    for k in range(1, steps + 1):
        iren.SetEventInformation(x + round(delta[0] * k / steps), y + round(delta[1] * k / steps), 0, 0, "\0", 0, None)
        iren.MouseMoveEvent()
    iren.LeftButtonReleaseEvent()


def display_xy(editor, index):
    """Display position (pixels, origin bottom-left) of control point ``index`` after a render."""
    editor.screenshot()
    return editor.scene.lattice_actor.display_positions()[index, :2]


def line_points(editor) -> np.ndarray:
    return np.asarray(editor.scene.lattice_actor.lines.points, dtype=np.float64)


def shown_points(editor) -> np.ndarray:
    """Points of the plotted mesh (what the renderer draws)."""
    return np.asarray(editor.scene.mesh_actor.GetMapper().GetInput().GetPoints().GetData()).astype(np.float64)


def assert_view_matches_model(editor, atol=1e-5):
    """Mesh points, lattice lines, control-point spheres and the handle all follow the lattice
    (FFD.deform as the reference)."""
    expected = editor.session.ffd.deform(editor.mesh.points)
    np.testing.assert_allclose(shown_points(editor), expected, atol=atol)
    control = editor.lattice.control_points(deformed=True).reshape(-1, 3)
    np.testing.assert_allclose(line_points(editor), control, atol=1e-6)
    actor = editor.scene.lattice_actor
    np.testing.assert_allclose(glyph_centers(editor), control[actor.shown], atol=1e-6)
    np.testing.assert_allclose(actor.handle.GetCenter(), control[actor.handle_index], atol=1e-6)


def snapshot(editor):
    """Everything a failed load must leave alone."""
    return (
        editor.mesh.points.copy(),
        editor.mesh.n_cells,
        editor.lattice.copy(),
        editor.session.basis,
        len(editor.session.history),
        editor.session.can_redo,
        shown_points(editor).copy(),
        editor.scene.lattice_actor.glyphs.n_points,
    )


def assert_unchanged(editor, snap):
    points, n_cells, lattice, basis, n_hist, can_redo, shown, n_widgets = snap
    np.testing.assert_array_equal(editor.mesh.points, points)
    assert editor.mesh.n_cells == n_cells
    assert editor.lattice == lattice and editor.session.basis == basis
    assert len(editor.session.history) == n_hist and editor.session.can_redo == can_redo
    np.testing.assert_array_equal(shown_points(editor), shown)
    assert editor.scene.lattice_actor.glyphs.n_points == n_widgets


def full_slices(image, ffd, positions):
    """The three slices at voxel ``positions`` (i, j, k) of the whole image warped by ``ffd`` (what saving writes)."""
    import SimpleITK as sitk

    from ffd_notebook.images import warp_image

    full = sitk.GetArrayFromImage(warp_image(image, ffd))
    i, j, k = positions
    return {0: full[:, :, i], 1: full[:, j, :], 2: full[k]}
