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
    """Flat index of control point ``ijk`` (the sphere widget's index)."""
    return int(np.ravel_multi_index(tuple(ijk), editor.lattice.shape))


def widget_centers(editor) -> np.ndarray:
    return np.array([w.GetCenter() for w in editor.plotter.widgets.sphere_widgets])


def line_points(editor) -> np.ndarray:
    return np.asarray(editor.scene.lattice_actor.lines.points, dtype=np.float64)


def shown_points(editor) -> np.ndarray:
    """Points of the plotted mesh (what the renderer draws)."""
    return np.asarray(editor.mesh_actor.GetMapper().GetInput().GetPoints().GetData()).astype(np.float64)


def assert_view_matches_model(editor, atol=1e-5):
    """Mesh points, lattice lines and widget centres all follow the lattice (FFD.deform as the reference)."""
    expected = editor.ffd.deform(editor.mesh.points)
    np.testing.assert_allclose(shown_points(editor), expected, atol=atol)
    control = editor.lattice.control_points(deformed=True).reshape(-1, 3)
    np.testing.assert_allclose(line_points(editor), control, atol=1e-6)
    np.testing.assert_allclose(widget_centers(editor), control, atol=1e-6)
