"""The blend: the editor shows ``rest + t * (deformed - rest)`` live, without an undo step; t = 1 is the deformation.

A teacher slides t from 0 to 1 and the class sees the deformation grow and where it folds first: the folding
colours are those of ``x + t (T(x) - x)``. Below 1 the mouse grabs nothing in the view; any edit applies to the
whole deformation and brings t back to 1.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from editor_testing import display_xy, mouse_drag, shown_points

from ffd_notebook import FFD
from ffd_notebook.view.editor import Editor


@pytest.fixture
def editor():
    editor = Editor(pv.Sphere(theta_resolution=16, phi_resolution=16), shape=(4, 4, 4), window_size=(240, 180))
    yield editor
    editor.close()


def fold(editor: Editor) -> None:
    """Swap two middle layers of control points: the deformation folds between them, but only beyond some t."""
    editor.lattice.offsets[2, :, :, 0] -= 1.4 * editor.lattice.spacing[0]
    editor.lattice.offsets[1, :, :, 0] += 1.4 * editor.lattice.spacing[0]
    editor.update()


def test_the_blend_moves_the_mesh_without_an_undo_step(editor):
    fold(editor)
    session = editor.session
    steps, rest, deformed = len(session.history), session.rest_points, session.deformed_points.copy()
    for t in (0.0, 0.35, 1.0):
        session.set_blend(t)
        expected = rest + t * (deformed - rest)
        np.testing.assert_allclose(shown_points(editor), expected, atol=1e-6)
        np.testing.assert_allclose(session.shown_control_points(),
                                   session.lattice.control_points().reshape(-1, 3) + t * (
                                       session.lattice.offsets.reshape(-1, 3)), atol=1e-12)  # fmt: skip
    assert len(session.history) == steps and not session.can_redo
    assert session.shown_points() is session.deformed_points  # t = 1: the deformation itself, exactly
    assert np.array_equal(shown_points(editor), session.deformed_points.astype(np.float32))
    with pytest.raises(ValueError, match=r"the blend must be in \[0, 1\]"):
        session.set_blend(1.5)


def test_the_folding_colours_follow_t(editor):
    fold(editor)
    session = editor.session
    editor.set_field("jacobian")
    folded = session.field_values().sum()
    assert folded > 0
    reference = FFD(session.lattice, session.basis, strength=0.2).jacobian_determinant(session.rest_points) <= 0
    session.set_blend(0.2)
    assert np.array_equal(session.field_values() > 0, reference) and not reference.any()  # not folded yet
    session.set_blend(0.7)
    assert 0 < session.field_values().sum() < folded  # folding, not everywhere yet
    session.set_blend(1.0)
    assert session.field_values().sum() == folded


def test_below_one_the_mouse_grabs_nothing_and_an_edit_shows_it_all(editor):
    session = editor.session
    session.set_blend(0.5)
    xy = display_xy(editor, 21)
    mouse_drag(editor, xy, (25, 10), steps=3)  # on a sphere: turns the camera, moves nothing
    assert not np.any(session.lattice.offsets) and session.blend == 0.5
    session.move_control_point((1, 1, 1), (0.0, 0.1, 0.0))  # typed: applies to the whole deformation
    assert session.blend == 1.0
    np.testing.assert_allclose(shown_points(editor), session.deformed_points, atol=1e-6)
    editor.plotter.view_xy()
    xy = display_xy(editor, 21)
    mouse_drag(editor, xy, (25, 10), steps=3)  # at 1: the sphere follows the mouse again
    assert session.lattice.offsets.reshape(-1, 3)[21].any()
