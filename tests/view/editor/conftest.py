"""Fixtures of the editor's tests."""

from __future__ import annotations

import numpy as np
import pytest
import SimpleITK as sitk

from ffd_notebook.images import ImageGrid, write_image


@pytest.fixture
def ct(tmp_path):
    """A CT-like volume around the unit sphere (anisotropic voxels), as a NIfTI file."""
    grid = ImageGrid((34, 30, 26), spacing=(0.075, 0.085, 0.095), origin=(-1.25, -1.25, -1.2))
    points = grid.physical_points()
    r = np.linalg.norm(points, axis=1)
    values = np.where(r < 0.5, 300.0, -200.0) + 100.0 * np.sin(6.0 * points[:, 0])
    path = tmp_path / "ct.nii.gz"
    write_image(path, grid.to_sitk(sitk.GetImageFromArray(values.reshape(grid.shape).astype(np.float32))))
    return path
