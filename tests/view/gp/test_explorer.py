"""GPExplorer headless: the widgets' callbacks and the methods really move the mesh and change colours."""

from __future__ import annotations

import numpy as np
import pytest
import vtk

from ffd_notebook.datasets import frog_liver
from ffd_notebook.view.gp.explorer import VARIANCE_ARRAY, VECTORS_ARRAY, GPExplorer


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
    explorer.sample(rng=3)
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


def test_a_change_from_code_is_rendered_once_with_a_browser_view(explorer):
    from ffd_notebook.view.serving.jupyter import views_of

    explorer.screenshot()  # shown once: plotter.render() renders from now on
    renders = []
    explorer.plotter.render_window.AddObserver("StartEvent", lambda *_: renders.append(1))
    explorer.sample(rng=1)
    assert len(renders) == 1  # no browser view: the explorer renders

    class View:  # a browser view renders when asked for a new image
        def update(self):
            explorer.plotter.render_window.Render()

    views_of(explorer.plotter).add(View())
    renders.clear()
    explorer.sample(rng=2)
    explorer.set_sigma(0.5 * explorer.sigma)
    assert len(renders) == 2  # the view's renders only, one per change


def test_kernel_width_sets_smoothness(explorer):
    roughness = []
    for sigma in (0.1 * explorer.size, 0.6 * explorer.size):
        explorer.set_sigma(sigma)
        explorer.sample(rng=1)
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


def _display_points(renderer, points):
    """Each point's pixel, as the pick event will carry it (integers)."""
    pixels = []
    for p in points:
        renderer.SetWorldPoint(*p, 1.0)
        renderer.WorldToDisplay()
        pixels.append(renderer.GetDisplayPoint()[:2])
    return np.rint(pixels).astype(int)


def _pickable_vertex(pl, points, pixels, among=None):
    """The vertex nearest the camera whose pixel no other vertex (front or back) comes within 3 px of.

    A point picker takes the vertex nearest the ray through the clicked pixel, so a click on a
    vertex's rounded pixel is that vertex only if no other vertex projects as close: otherwise the
    pick depends on sub-pixel rounding (it failed for about 1 shape in 100 when the shape was random).
    """
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(pixels).query(pixels, k=2)
    candidates = distance[:, 1] > 3.0
    if among is not None:
        candidates &= among
    indices = np.flatnonzero(candidates)
    camera = np.array(pl.camera.position)
    return int(indices[np.linalg.norm(points[indices] - camera, axis=1).argmin()])


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
    mesh_points = np.asarray(explorer.mesh.points)
    pixels = _display_points(pl.renderer, mesh_points)
    vertex = _pickable_vertex(pl, mesh_points, pixels)
    pl.iren._mouse_right_button_click(*pixels[vertex])
    assert len(explorer.landmarks) == 1
    picked, pinned = explorer.landmarks[0]
    np.testing.assert_allclose(picked, explorer.rest_points[vertex])
    # a new landmark pins the vertex where it is shown (a sample here)
    np.testing.assert_allclose(explorer.displacement[vertex], pinned, atol=0.02 * explorer.scale)
    # press P over another visible vertex (the nearest to the camera away from the first) of the
    # shape now shown (the posterior mean)
    mesh_points = np.asarray(explorer.mesh.points)
    pixels = _display_points(pl.renderer, mesh_points)
    away = np.linalg.norm(mesh_points - mesh_points[vertex], axis=1) > 0.25 * explorer.size
    other = _pickable_vertex(pl, mesh_points, pixels, among=away)
    pl.iren._mouse_move(*pixels[other])
    pl.iren._simulate_keypress("p")
    assert len(explorer.landmarks) == 2
    np.testing.assert_allclose(explorer.landmarks[1][0], explorer.rest_points[other])
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
    with pytest.raises(ValueError, match="either a mesh"):
        GPExplorer(off_screen=True)
    with pytest.raises(ValueError, match="either a mesh"):
        GPExplorer(liver, model=STATISMO, off_screen=True)


# ---------------------------------------------------------------------- shape models (Statismo files, examples)
STATISMO = "/work/shared/data/statismo/scalismo_asm_model.h5"


def _raw_statismo(path):
    """Reference vertices, mean shape, basis, variances and triangles straight from the HDF5 datasets."""
    import h5py

    with h5py.File(path, "r") as f:
        points = f["/representer/points"][()].T.astype(np.float64)
        mean = f["/model/mean"][()].astype(np.float64).reshape(-1, 3)
        basis = f["/model/pcaBasis"][()].astype(np.float64)
        variances = f["/model/pcaVariance"][()].astype(np.float64)
        cells = f["/representer/cells"][()].T
    return points, mean, basis, variances, cells


def _raw_instance(raw, coefficients):
    _, mean, basis, variances, _ = raw
    return mean + (basis @ (np.sqrt(variances) * coefficients)).reshape(-1, 3)


@pytest.fixture(scope="module")
def raw():
    return _raw_statismo(STATISMO)


@pytest.fixture
def model_explorer():
    ex = GPExplorer(model=STATISMO, off_screen=True, window_size=(360, 240))
    yield ex
    ex.close()


def _not_blank(img):
    # pixels differing from the background (the corner) by more than a little
    return np.mean(np.abs(img.astype(int) - img[2, -3].astype(int)).sum(axis=2) > 30)


def test_model_file_shows_its_mean_and_modes(model_explorer, raw):
    ex = model_explorer
    points, mean, _, variances, cells = raw
    np.testing.assert_allclose(ex.rest_points, points, atol=1e-4)
    np.testing.assert_allclose(ex.mesh.points, mean, atol=1e-3)
    np.testing.assert_array_equal(ex.mesh.regular_faces, cells)
    assert len(ex.mode_sliders) == 5 and ex.slider is None and ex.arrow_actor is None
    points_array, actor = ex.mesh.points, ex.mesh_actor
    mean_img = ex.screenshot()
    assert _not_blank(mean_img) > 0.05
    log_mean = ex.log_density
    # modes through the API
    ex.set_mode(0, 2.0)
    ex.set_mode(3, -1.5)
    expected_c = np.zeros(len(variances))
    expected_c[[0, 3]] = 2.0, -1.5
    np.testing.assert_allclose(ex.coefficients, expected_c)
    np.testing.assert_allclose(ex.mesh.points, _raw_instance(raw, expected_c), atol=1e-3)
    assert ex.mode_sliders[0].GetRepresentation().GetValue() == pytest.approx(2.0)  # the slider follows
    # a slider dragged as the user would
    ex.mode_sliders[1].GetRepresentation().SetValue(0.75)
    ex.mode_sliders[1].InvokeEvent(vtk.vtkCommand.InteractionEvent)
    expected_c[1] = 0.75
    np.testing.assert_allclose(ex.mesh.points, _raw_instance(raw, expected_c), atol=1e-3)
    moved_img = ex.screenshot()
    assert _changed(mean_img, moved_img) > 0.2
    # the log density of the shape: lower away from the mean, the model's own value, shown as text
    from ffd_notebook.gp import load_model

    assert ex.log_density < log_mean
    assert ex.log_density == pytest.approx(load_model(STATISMO).logpdf_of(ex.displacement), abs=1e-3)
    assert f"{ex.log_density:.1f}" in ex._status.GetText(2)
    # in place: same points array and actor
    assert np.shares_memory(ex.mesh.points, points_array) and ex.mesh_actor is actor
    ex.show_mean()
    np.testing.assert_allclose(ex.mesh.points, mean, atol=1e-3)
    assert ex.mode_sliders[0].GetRepresentation().GetValue() == 0.0
    with pytest.raises(ValueError, match="coefficients"):
        ex.set_coefficients(np.zeros(3))
    with pytest.raises(ValueError, match="kernel width"):
        ex.set_sigma(1.0)


def test_model_posterior_with_per_landmark_noise(model_explorer):
    from ffd_notebook.gp import load_model

    ex = model_explorer
    model = load_model(STATISMO)
    ref = model.points
    vertices = [10, 700, 1200]
    goals = [np.array([0.0, 0.0, 8.0]), np.array([3.0, -2.0, 0.0]), np.array([0.0, 4.0, 1.0])]
    rot = np.linalg.qr(np.random.default_rng(0).standard_normal((3, 3)))[0]
    cov = rot @ np.diag([0.01, 1.0, 25.0]) @ rot.T  # a general 3x3 covariance
    noises = [cov, 0.5, [0.1, 2.0, 0.3]]
    variance_before = ex.mesh.point_data[VARIANCE_ARRAY].copy()
    ex.add_landmark(ref[vertices[0]], goals[0], noise=cov)
    direct = model.posterior(ref[vertices[:1]], goals[:1], noise=cov[None])
    np.testing.assert_allclose(ex.displacement, direct.mean(), atol=1e-3)
    assert ex.mesh.point_data[VARIANCE_ARRAY][vertices[0]] < 0.5 * variance_before[vertices[0]]
    for v, goal, noise in zip(vertices[1:], goals[1:], noises[1:], strict=True):
        ex.add_landmark(ref[v], goal, noise=noise)
    covs = np.stack([cov, 0.5 * np.eye(3), np.diag([0.1, 2.0, 0.3])])
    direct = model.posterior(ref[vertices], np.stack(goals), noise=covs)
    np.testing.assert_allclose(ex.displacement, direct.mean(), atol=1e-3)
    np.testing.assert_allclose(ex.mesh.point_data[VARIANCE_ARRAY], direct.variance().sum(axis=1), rtol=1e-5)
    # a landmark's noise changed later
    ex.set_landmark_noise(1, np.diag([1e-4, 1e-4, 1e-4]))
    covs[1] = np.diag([1e-4, 1e-4, 1e-4])
    direct = model.posterior(ref[vertices], np.stack(goals), noise=covs)
    np.testing.assert_allclose(ex.displacement, direct.mean(), atol=1e-3)
    # dragging a landmark's sphere: the displacement is measured from the reference vertex
    sphere = ex.plotter.widgets.sphere_widgets[2]
    target = ref[vertices[2]] + [1.0, 1.0, -3.0]
    sphere.SetCenter(*target)
    sphere.InvokeEvent(vtk.vtkCommand.InteractionEvent)
    goals[2] = target - ref[vertices[2]]
    np.testing.assert_allclose(ex.landmarks[2][1], goals[2], atol=1e-9)
    direct = model.posterior(ref[vertices], np.stack(goals), noise=covs)
    np.testing.assert_allclose(ex.displacement, direct.mean(), atol=1e-3)
    # bad noise: refused, nothing changed
    shown = ex.mesh.points.copy()
    for bad in (-1.0, np.ones((3, 3)) - 2 * np.eye(3), [1.0, 2.0]):
        with pytest.raises(ValueError, match="noise"):
            ex.add_landmark(ref[5], (0.0, 0.0, 1.0), noise=bad)
    assert len(ex.landmarks) == len(ex.landmark_noise) == 3
    np.testing.assert_array_equal(ex.mesh.points, shown)


def _corrupt_files(tmp_path):
    import shutil

    import h5py

    garbage = tmp_path / "garbage.h5"
    garbage.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 4)
    nan_mean = tmp_path / "nan_mean.h5"
    shutil.copy(STATISMO, nan_mean)
    with h5py.File(nan_mean, "r+") as f:
        data = f["/model/mean"][()]
        data[7] = np.nan
        f["/model/mean"][...] = data
    no_variance = tmp_path / "no_variance.h5"
    shutil.copy(STATISMO, no_variance)
    with h5py.File(no_variance, "r+") as f:
        del f["/model/pcaVariance"]
    return [garbage, nan_mean, no_variance]


def _state(ex):
    return (
        ex.mesh.points.copy(),
        ex.mesh.faces.copy(),
        ex.mesh.point_data[VARIANCE_ARRAY].copy(),
        ex.model,
        ex.model_name,
        [(w.copy(), m.copy()) for w, m in ex.landmarks],
        None if ex._coefficients is None else ex._coefficients.copy(),
        len(ex.plotter.widgets.slider_widgets),
        len(ex.plotter.widgets.sphere_widgets),
        ex._status.GetText(2),
    )


def _assert_same_state(a, b):
    for x, y in zip(a, b, strict=True):
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        elif isinstance(x, list):
            assert len(x) == len(y)
            for (w1, m1), (w2, m2) in zip(x, y, strict=True):
                np.testing.assert_array_equal(w1, w2)
                np.testing.assert_array_equal(m1, m2)
        else:
            assert x is y or x == y


@pytest.mark.parametrize("kind", ["kernel", "model"])
def test_failed_load_changes_nothing(kind, liver, tmp_path):
    from ffd_notebook.errors import FileFormatError

    if kind == "kernel":
        ex = GPExplorer(liver, off_screen=True, window_size=(240, 180), n_inducing=100, rank=40)
    else:
        ex = GPExplorer(model=STATISMO, off_screen=True, window_size=(240, 180))
    try:
        ex.add_landmark(ex.rest_points[3], (0.0, 0.0, 0.1 * ex.scale))
        ex.sample(rng=2)
        before, img = _state(ex), ex.screenshot()
        for path in _corrupt_files(tmp_path):
            with pytest.raises(FileFormatError, match=path.name):
                ex.open_model(path)
            _assert_same_state(before, _state(ex))
        with pytest.raises(TypeError):
            ex.open_model(42)
        _assert_same_state(before, _state(ex))
        np.testing.assert_array_equal(img, ex.screenshot())
    finally:
        ex.close()


def test_kernel_explorer_opens_a_model_file(explorer, raw):
    mesh, actor = explorer.mesh, explorer.mesh_actor
    explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, explorer.scale))
    explorer.open_model(STATISMO)
    assert explorer.mesh is mesh and explorer.mesh_actor is actor  # same objects, new content
    np.testing.assert_allclose(explorer.mesh.points, raw[1], atol=1e-3)
    np.testing.assert_array_equal(explorer.mesh.regular_faces, raw[4])
    assert explorer.landmarks == [] and explorer.plotter.widgets.sphere_widgets == []
    assert not explorer.arrow_actor.visibility and not explorer.slider.GetEnabled()
    assert [s.GetEnabled() for s in explorer.mode_sliders] == [1] * 5
    explorer.set_mode(4, 1.0)
    c = np.zeros(len(raw[3]))
    c[4] = 1.0
    np.testing.assert_allclose(explorer.mesh.points, _raw_instance(raw, c), atol=1e-3)
    assert _not_blank(explorer.screenshot()) > 0.05
    assert explorer.kernel is None


def test_model_from_examples(liver):
    from ffd_notebook.gp import LowRankGP

    ref = liver
    pts = np.asarray(ref.points, dtype=np.float64)
    centre, size = pts.mean(axis=0), np.ptp(pts, axis=0).max()
    rng = np.random.default_rng(5)
    # deformed copies: a stretch along x and a bend in z, in random amounts
    stretch = (pts - centre) * [0.1, 0.0, 0.0]
    bend = np.zeros_like(pts)
    bend[:, 2] = ((pts[:, 0] - centre[0]) / size) ** 2 * 0.2 * size
    examples = [pts + a * stretch + b * bend for a, b in rng.standard_normal((6, 2))]
    model = LowRankGP.from_examples(ref, examples)
    assert model.rank == 2
    ex = GPExplorer(model=model, off_screen=True, window_size=(300, 200))
    try:
        data = np.stack(examples)
        np.testing.assert_array_equal(ex.mesh.regular_faces, ref.regular_faces)
        np.testing.assert_allclose(ex.mesh.points, data.mean(axis=0), atol=1e-6 * size)
        assert len(ex.mode_sliders) == 2
        # first mode: the leading principal component of the examples (sign is arbitrary)
        centred = (data - data.mean(axis=0)).reshape(len(data), -1)
        _, sv, vt = np.linalg.svd(centred, full_matrices=False)
        ex.set_mode(0, 1.0)
        step = (ex.mesh.points - data.mean(axis=0)).ravel()
        np.testing.assert_allclose(np.linalg.norm(step), sv[0] / np.sqrt(len(data) - 1), rtol=1e-6)
        assert abs(step @ vt[0]) == pytest.approx(np.linalg.norm(step), rel=1e-6)
        assert _not_blank(ex.screenshot()) > 0.05
        # a model with more modes adds sliders to the same explorer
        ex.open_model(STATISMO)
        assert len(ex.mode_sliders) == 5 and all(s.GetEnabled() for s in ex.mode_sliders)
        ex.open_model(model)
        assert [s.GetEnabled() for s in ex.mode_sliders] == [1, 1, 0, 0, 0]
    finally:
        ex.close()


def test_rng_repeats_samples_and_seed_is_a_deprecated_alias(liver):
    def explorer(**kw):
        return GPExplorer(liver, off_screen=True, window_size=(120, 90), widgets=False, n_inducing=60, rank=20, **kw)

    a, b = explorer(rng=4), explorer(rng=4)
    try:
        a.sample(), b.sample()  # the button's draws: the same sequence for the same rng
        np.testing.assert_array_equal(a.displacement, b.displacement)
        a.sample()
        assert not np.allclose(a.displacement, b.displacement)
        with pytest.warns(DeprecationWarning, match=r"sample\(seed=\.\.\.\) is deprecated: use rng="):
            a.sample(seed=9)
        b.sample(rng=9)
        np.testing.assert_array_equal(a.displacement, b.displacement)
    finally:
        a.close(), b.close()
    with pytest.warns(DeprecationWarning, match=r"GPExplorer\(seed=\.\.\.\)"):
        old = explorer(seed=4)
    new = explorer(rng=4)
    try:
        np.testing.assert_array_equal(old.model.basis_matrix(), new.model.basis_matrix())
    finally:
        old.close(), new.close()
    with pytest.raises(TypeError):
        GPExplorer(liver, 0.3)  # keyword-only after the mesh
