"""Camera framing for static figures: every point in view, and the frame actually filled."""

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as st

import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
from ffd_notebook.view.rendering.camera import frame_camera, view_direction


def _ndc(plotter, points):
    """Normalised device coordinates (-1..1 across the renderer) of world points."""
    x0, y0, x1, y1 = plotter.renderer.GetViewport()
    w, h = plotter.window_size
    aspect = (x1 - x0) * w / ((y1 - y0) * h)
    m = plotter.camera.GetCompositeProjectionTransformMatrix(aspect, -1, 1)
    m = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
    hom = np.c_[points, np.ones(len(points))] @ m.T
    return hom[:, :2] / hom[:, 3:]


@settings(max_examples=15, deadline=None)
@given(
    scale=st.tuples(*[st.floats(0.2, 5.0)] * 3),
    direction=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2),
    top=st.sampled_from([0.0, 0.15]),
)
def test_every_point_is_in_view_and_the_frame_is_filled(scale, direction, top):
    points = pv.ParametricEllipsoid(*scale, u_res=12, v_res=12, w_res=12).points + (3.0, -2.0, 1.0)
    pl = pv.Plotter(off_screen=True, window_size=(400, 200))
    try:
        frame_camera(pl, points, direction, margin=1.0, top=top)
        ndc = _ndc(pl, points)
    finally:
        pl.close()
    assert ndc[:, 0].min() >= -1 - 1e-6 and ndc[:, 0].max() <= 1 + 1e-6
    assert ndc[:, 1].min() >= -1 - 1e-6 and ndc[:, 1].max() <= 1 - 2 * top + 1e-6
    # tight: some point touches the edge of the frame (below the free band), none is left a margin
    band_y = (ndc[:, 1] + top) / (1 - top)
    assert max(np.abs(ndc[:, 0]).max(), np.abs(band_y).max()) == pytest.approx(1.0, abs=1e-6)


def test_subplots_use_their_own_aspect_and_up_follows_the_long_side():
    points = pv.Box().points * (3.0, 1.0, 0.5)  # long along x
    pl = pv.Plotter(off_screen=True, shape=(1, 2), window_size=(600, 300))
    pl.subplot(0, 1)
    up = frame_camera(pl, points, direction=(0, 0, 1))
    ndc = _ndc(pl, points)
    pl.close()
    np.testing.assert_allclose(np.abs(up), [0, 1, 0], atol=1e-9)  # x runs across the picture
    assert np.abs(ndc).max() == pytest.approx(1 / 1.04, rel=1e-3)  # default margin, this half's aspect


def test_view_direction_and_bad_input():
    np.testing.assert_allclose(view_direction((0, 0, 2), elevation=0.0), [0, 0, 1])
    assert view_direction((0, 0, 1))[1] > 0  # a horizontal face is raised along y, not z
    pl = pv.Plotter(off_screen=True)
    with pytest.raises(ValueError, match="top"):
        frame_camera(pl, pv.Box().points, (0, 0, 1), top=1.0)
    with pytest.raises(ValueError, match="zero"):
        frame_camera(pl, pv.Box().points, (0, 0, 0))
    pl.close()
