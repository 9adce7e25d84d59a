"""What the mesh shows: per-vertex colours on/off, |displacement|, folding (det J <= 0)."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.scene import coloring as fields


def mapper(editor):
    return editor.scene.mesh_actor.GetMapper()


def red_pixels(img) -> int:
    """Pixels of a red hue (any shading); the sphere's own colours are red-blue mixes with green 60."""
    r, g, b = (img[..., c].astype(int) for c in range(3))
    return int(((r > 60) & (r > 3 * g) & (r > 3 * b)).sum())


def test_colours_on_and_off(editor):
    assert editor.session.has_colors and editor.session.colors_shown
    assert mapper(editor).GetScalarVisibility() and mapper(editor).GetArrayName() == "RGB"
    with_colors = editor.screenshot()
    editor.session.show_colors(False)
    assert not mapper(editor).GetScalarVisibility()
    plain = editor.screenshot()
    assert np.abs(with_colors.astype(int) - plain).sum() > 1000
    editor.session.show_colors(True)
    np.testing.assert_array_equal(editor.screenshot(), with_colors)


def test_colours_requested_on_a_mesh_without_them():
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(160, 120))
    try:
        editor.session.show_colors(True)
        assert editor.messages[-1] == "this mesh has no per-vertex colours"
        assert not mapper(editor).GetScalarVisibility()
    finally:
        editor.close()


def test_displacement_field_follows_drags(editor):
    editor.set_field("displacement")
    shown = editor.scene.display.point_data[fields.DISPLACEMENT_ARRAY]
    assert not shown.any() and mapper(editor).GetArrayName() == fields.DISPLACEMENT_ARRAY
    index = int(np.ravel_multi_index((2, 2, 3), editor.lattice.shape))
    center = editor.session.control_points()[index] + (0, 0, 0.5)
    editor.on_widget_moved(center, index)
    shown = editor.scene.display.point_data[fields.DISPLACEMENT_ARRAY]
    expected = np.linalg.norm(editor.session.ffd.deform(editor.mesh.points) - editor.mesh.points, axis=1)
    np.testing.assert_allclose(shown, expected, atol=1e-5)
    assert mapper(editor).GetScalarRange() == pytest.approx((0.0, expected.max()), rel=1e-5)
    editor.set_field(None)
    assert mapper(editor).GetArrayName() == "RGB"


def test_folding_is_highlighted(editor):
    editor.set_field("jacobian")
    assert editor.messages[-1] == f"folding (det J <= 0) at 0 of {editor.mesh.n_points} vertices"
    assert red_pixels(editor.screenshot()) == 0
    # pull one layer of control points far back through the next: the mapping folds there
    editor.lattice.offsets[3, :, :, 0] = -2.5 * editor.lattice.spacing[0]
    editor.update()
    folded = editor.session.ffd.jacobian_determinant(editor.mesh.points) <= 0
    assert 0 < folded.sum() < editor.mesh.n_points
    np.testing.assert_array_equal(editor.scene.display.point_data[fields.FOLDING_ARRAY] > 0.5, folded)
    editor.plotter.view_zy()  # the folded half faces -x
    assert red_pixels(editor.screenshot()) > 200
    editor.set_field("jacobian")
    assert editor.messages[-1] == f"folding (det J <= 0) at {folded.sum()} of {editor.mesh.n_points} vertices"
    with pytest.raises(ValueError, match="field must be one of"):
        editor.set_field("curl")


def test_folding_view_follows_drags(editor):
    """During a drag the folding view is recomputed through the deformer; it equals the FFD's own evaluation."""
    editor.session.set_shape((8, 8, 8))  # a control point then reaches only part of the sphere
    editor.set_field("jacobian")
    spacing = float(editor.lattice.spacing[0])
    folds = []
    # a single control point must move ~5 spacings to fold a cubic B-spline; then it comes back
    for ijk, delta in [((1, 3, 3), (-6 * spacing, 0, 0)), ((5, 4, 4), (0, 0, 0.3)), ((1, 3, 3), (5.5 * spacing, 0, 0))]:
        index = int(np.ravel_multi_index(ijk, editor.lattice.shape))
        center = editor.session.control_points()[index] + delta
        editor.on_widget_moved(center, index)
        shown = editor.scene.display.point_data[fields.FOLDING_ARRAY] > 0.5
        np.testing.assert_array_equal(shown, editor.session.ffd.jacobian_determinant(editor.mesh.points) <= 0)
        folds.append(int(shown.sum()))
    assert folds[0] > 0 and folds[2] < folds[0]  # folded, then partly unfolded again
