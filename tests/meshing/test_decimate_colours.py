"""Decimation keeps every colour array in its own type and scale: uint8 0-255, float 0-1, uint16 0-65535."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook.meshing import decimate_keeping_colors


def _two_coloured_sphere(dtype, top, bottom) -> pv.PolyData:
    sphere = pv.Sphere(theta_resolution=30, phi_resolution=30)
    sphere.point_data["RGB"] = np.where(sphere.points[:, 2:] > 0, top, bottom).astype(dtype)
    return sphere


@pytest.mark.parametrize("attribute_error", [False, True])
@pytest.mark.parametrize(
    ("dtype", "top", "bottom"),
    [
        (np.uint8, (204, 102, 51), (0, 128, 255)),
        (np.float32, (0.8, 0.4, 0.2), (0.0, 0.5, 1.0)),
        (np.float64, (0.8, 0.4, 0.2), (0.0, 0.5, 1.0)),
        (np.uint16, (52428, 26214, 13107), (0, 32768, 65535)),
    ],
)
def test_colours_keep_their_type_and_values(dtype, top, bottom, attribute_error):
    sphere = _two_coloured_sphere(dtype, top, bottom)
    out = decimate_keeping_colors(sphere, 0.7, attribute_error=attribute_error)
    assert out.n_cells < 0.4 * sphere.n_cells
    colours = out.point_data["RGB"]
    assert colours.dtype == dtype
    # away from the seam, a vertex keeps its half's colour (to the type's rounding)
    far = np.abs(out.points[:, 2]) > 0.2
    expected = np.where(out.points[far, 2:] > 0, top, bottom)
    tolerance = 1.0 if np.issubdtype(dtype, np.integer) else 1e-6
    scale = 1.0 if np.issubdtype(dtype, np.floating) else float(np.iinfo(dtype).max)
    np.testing.assert_allclose(colours[far], expected, rtol=0, atol=tolerance + 0.02 * scale * attribute_error)
    assert sphere.point_data["RGB"].dtype == dtype  # the input is not changed
