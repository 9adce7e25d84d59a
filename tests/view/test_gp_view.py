"""GPExplorer headless: the widgets' callbacks and the methods really move the mesh and change colours."""

from __future__ import annotations

import numpy as np
import pytest
import vtk

from ffd_notebook.datasets import frog_liver
from ffd_notebook.view.gp_view import VARIANCE_ARRAY, VECTORS_ARRAY, GPExplorer


@pytest.fixture(scope="module")
def liver():
    return frog_liver(1500)


@pytest.fixture
def explorer(liver):
    ex = GPExplorer(liver, off_screen=True, window_size=(320, 240), n_inducing=200, rank=90)
    yield ex
    ex.close()


def _changed(a, b):
    return np.abs(a.astype(int) - b.astype(int)).mean()


def test_sample_moves_mesh_and_arrows_in_place(explorer, liver):
    points_array, actor, arrow_actor = explorer.mesh.points, explorer.mesh_actor, explorer.arrow_actor
    np.testing.assert_allclose(explorer.displacement, 0.0)  # the prior mean: nothing moved
    before = explorer.screenshot()
    explorer.sample(seed=3)
    after = explorer.screenshot()
    assert np.abs(explorer.displacement).max() > 0.5 * explorer.scale
    np.testing.assert_allclose(liver.points, explorer.rest_points)  # the caller's mesh is untouched
    arrows = explorer.arrow_points.point_data[VECTORS_ARRAY]
    assert np.abs(arrows).max() > 0.5 * explorer.scale
    # the same random field on mesh and grid: at a vertex, the arrows' interpolant agrees
    np.testing.assert_allclose(
        explorer.process.instance(explorer._coefficients, explorer.rest_points[:5]),
        explorer.displacement[:5],
        atol=1e-4 * explorer.scale,
    )  # float32 mesh points
    assert _changed(before, after) > 0.5
    # in place: the same VTK points array and actors
    assert np.shares_memory(explorer.mesh.points, points_array)
    assert explorer.mesh_actor is actor and explorer.arrow_actor is arrow_actor
    assert sum(a is actor for a in explorer.plotter.renderer.actors.values()) == 1


def test_kernel_width_sets_smoothness(explorer):
    roughness = []
    for sigma in (0.1 * explorer.size, 0.6 * explorer.size):
        explorer.set_sigma(sigma)
        explorer.sample(seed=1)
        d = explorer.displacement
        # differences across mesh edges, relative to the displacement's size
        edges = explorer.mesh.extract_all_edges().lines.reshape(-1, 3)[:, 1:]
        roughness.append(np.abs(d[edges[:, 0]] - d[edges[:, 1]]).mean() / np.abs(d).mean())
    assert roughness[0] > 2 * roughness[1]


def test_landmarks_pin_the_posterior_and_lower_the_variance(explorer):
    colours_before = explorer.mesh.point_data[VARIANCE_ARRAY].copy()
    img_before = explorer.screenshot()
    vertex = 100
    target = np.array([0.0, 0.0, 2.0 * explorer.scale])
    explorer.add_landmark(explorer.rest_points[vertex], target)
    np.testing.assert_allclose(explorer.displacement[vertex], target, atol=0.02 * explorer.scale)
    variance = explorer.mesh.point_data[VARIANCE_ARRAY]
    far = np.linalg.norm(explorer.rest_points - explorer.rest_points[vertex], axis=1).argmax()
    assert variance[vertex] < 0.05 * colours_before[vertex]
    assert variance[far] > 0.5 * colours_before[far]
    assert _changed(img_before, explorer.screenshot()) > 0.5
    # moving the observation changes the mean, not the variance
    explorer.move_landmark(0, -target)
    np.testing.assert_allclose(explorer.displacement[vertex], -target, atol=0.02 * explorer.scale)
    np.testing.assert_array_equal(explorer.mesh.point_data[VARIANCE_ARRAY], variance)
    explorer.clear_landmarks()
    np.testing.assert_allclose(explorer.displacement, 0.0, atol=1e-4 * explorer.scale)


def test_widgets_drive_the_explorer(explorer):
    pl = explorer.plotter
    # the slider: set a value as a drag would, end the interaction
    explorer.slider.GetRepresentation().SetValue(0.5 * explorer.size)
    explorer.slider.InvokeEvent(vtk.vtkCommand.EndInteractionEvent)
    assert explorer.sigma == pytest.approx(0.5 * explorer.size)
    # the "sample" button: each click is a new random deformation
    explorer.button.GetRepresentation().SetState(1)
    explorer.button.InvokeEvent(vtk.vtkCommand.StateChangedEvent)
    first = explorer.displacement.copy()
    assert np.abs(first).max() > 0
    explorer.button.GetRepresentation().SetState(0)
    explorer.button.InvokeEvent(vtk.vtkCommand.StateChangedEvent)
    assert not np.allclose(explorer.displacement, first)
    # picking: right-click the vertex nearest the camera, then press P over it
    pl.show(auto_close=False)  # off screen: renders once and starts the interactor without blocking
    camera = np.array(pl.camera.position)
    mesh_points = np.asarray(explorer.mesh.points)
    vertex = int(np.linalg.norm(mesh_points - camera, axis=1).argmin())
    pl.renderer.SetWorldPoint(*mesh_points[vertex], 1.0)
    pl.renderer.WorldToDisplay()
    x, y = (round(c) for c in pl.renderer.GetDisplayPoint()[:2])
    pl.iren._mouse_right_button_click(x, y)
    assert len(explorer.landmarks) == 1
    picked, pinned = explorer.landmarks[0]
    np.testing.assert_allclose(picked, explorer.rest_points[vertex])
    # a new landmark pins the vertex where it is shown (a sample here)
    np.testing.assert_allclose(explorer.displacement[vertex], pinned, atol=0.02 * explorer.scale)
    # press P over another visible vertex (the nearest to the camera away from the first)
    away = np.linalg.norm(mesh_points - mesh_points[vertex], axis=1) > 0.25 * explorer.size
    other = int(np.flatnonzero(away)[np.linalg.norm(mesh_points[away] - camera, axis=1).argmin()])
    pl.renderer.SetWorldPoint(*mesh_points[other], 1.0)
    pl.renderer.WorldToDisplay()
    pl.iren._mouse_move(*(round(c) for c in pl.renderer.GetDisplayPoint()[:2]))
    pl.iren._simulate_keypress("p")
    assert len(explorer.landmarks) == 2
    assert np.linalg.norm(explorer.landmarks[1][0] - explorer.rest_points[other]) < 0.05 * explorer.size
    # dragging the landmark's sphere sets its observed displacement
    sphere = pl.widgets.sphere_widgets[0]
    goal = picked + np.array([explorer.scale, 0.0, 0.0])
    sphere.SetCenter(*goal)
    sphere.InvokeEvent(vtk.vtkCommand.InteractionEvent)
    np.testing.assert_allclose(explorer.landmarks[0][1], goal - picked, atol=1e-9)
    shown = explorer.process.mean(picked[None])[0]
    np.testing.assert_allclose(shown, goal - picked, atol=0.05 * explorer.scale)


def test_bad_arguments(liver):
    with pytest.raises(ValueError, match="kernel"):
        GPExplorer(liver, kernel="matern", off_screen=True)
    ex = GPExplorer(liver, kernel="exponential", off_screen=True, window_size=(200, 150), widgets=False, rank=30)
    with pytest.raises(ValueError, match="sigma"):
        ex.set_sigma(-1.0)
    ex.close()
