"""``warp_image`` through an elastix registration (affine then B-spline, ``load_elastix``) against transformix."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk
from elastix_reference import blobs, register
from scipy.spatial.transform import Rotation

from ffd_notebook import load_elastix
from ffd_notebook.images import ImageGrid, warp_image

pytestmark = pytest.mark.slow  # itk-elastix's import and a small registration

ROTATED = Rotation.from_euler("zyx", [20.0, -10.0, 5.0], degrees=True).as_matrix()


def test_equals_transformix_resampled_image(tmp_path: Path):
    import itk

    geometry = {"spacing": (1.5, 1.0, 2.0), "origin": (10.0, -5.0, 3.0)}
    last = register(tmp_path, affine=True, direction=ROTATED, grid_spacing=8.0, **geometry)
    for f in tmp_path.glob("TransformParameters.*.txt"):  # transformix: linear, float, 0 outside (as warp_image)
        text = re.sub(r'\(ResampleInterpolator "[^"]*"\)', '(ResampleInterpolator "FinalLinearInterpolator")',
                      f.read_text())  # fmt: skip
        text = re.sub(r'\(ResultImagePixelType "[^"]*"\)', '(ResultImagePixelType "float")', text)
        f.write_text(re.sub(r"\(DefaultPixelValue [^)]*\)", "(DefaultPixelValue 0)", text))
    moving = (100.0 * blobs((18, 22, 20), [(10, 12, 9), (6, 6, 5)])).astype(np.float32)
    itk_moving = itk.image_from_array(moving)
    itk_moving.SetSpacing(list(geometry["spacing"]))
    itk_moving.SetOrigin(list(geometry["origin"]))
    itk_moving.SetDirection(itk.matrix_from_array(ROTATED))
    transformix = itk.TransformixFilter[itk.Image[itk.F, 3]].New()
    transformix.SetMovingImage(itk_moving)
    transformix.SetTransformParameterFileName(str(last))  # the chain: the affine file through its initial transform
    transformix.SetLogToConsole(False)
    transformix.Update()
    result = transformix.GetOutput()
    expected = itk.array_from_image(result)
    reference = ImageGrid(tuple(result.GetLargestPossibleRegion().GetSize()), tuple(result.GetSpacing()),
                          tuple(result.GetOrigin()), np.array(result.GetDirection()))  # fmt: skip
    image = sitk.GetImageFromArray(moving)
    image.SetSpacing(geometry["spacing"])
    image.SetOrigin(geometry["origin"])
    image.SetDirection(ROTATED.ravel().tolist())
    got = sitk.GetArrayFromImage(warp_image(image, load_elastix(last), reference=reference))
    assert np.abs(got - moving).max() > 0.05 * np.ptp(moving), "the registration should move the image"
    np.testing.assert_allclose(got, expected, atol=1e-5 * np.ptp(expected), rtol=0)
