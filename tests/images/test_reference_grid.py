"""One reading of "a reference grid": warp_image, field sampling, saving and fit_lattice accept the same forms."""

from __future__ import annotations

import numpy as np
import pytest
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice
from ffd_notebook.images import ImageGrid, reference_grid, warp_image
from ffd_notebook.io import (
    fit_lattice,
    load_displacement_field,
    load_elastix,
    sample_displacement_field,
    save_displacement_field,
    save_elastix,
)

ROTATED = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
GRID = ImageGrid((7, 6, 5), spacing=(1.5, 2.0, 2.5), origin=(-4.0, -5.0, -6.0), direction=ROTATED)


def _forms(tmp_path):
    """The same grid in every form a user may hold it in."""
    image = GRID.to_sitk(sitk.Image(list(GRID.size), sitk.sitkUInt8))
    sitk.WriteImage(image, str(tmp_path / "reference.nrrd"))
    field = sample_displacement_field(lambda p: p, GRID)
    mapping = {"size": GRID.size, "spacing": GRID.spacing, "origin": GRID.origin, "direction": GRID.direction}
    # an elastix run's file names its fixed image's grid (Direction written column by column)
    lattice = Lattice((4, 4, 4), 5.0, origin=(-9.0, -9.0, -9.0))
    geometry = {"Size": list(GRID.size), "Index": [0, 0, 0], "Spacing": list(GRID.spacing)}
    lattice.metadata["elastix"] = dict(geometry, Origin=list(GRID.origin), Direction=list(GRID.direction.T.ravel()))
    save_elastix(tmp_path / "TransformParameters.0.txt", FFD(lattice))
    return {
        "ImageGrid": GRID,
        "SimpleITK image": image,
        "path": tmp_path / "reference.nrrd",
        "str path": str(tmp_path / "reference.nrrd"),
        "DisplacementField": field,
        "mapping": mapping,
        "elastix chain": load_elastix(tmp_path / "TransformParameters.0.txt"),
    }


def _same(a: ImageGrid, b: ImageGrid) -> bool:
    """Equal grids, to the rounding of a file's text header (NRRD keeps ``direction * spacing``)."""
    return a.size == b.size and all(
        np.allclose(getattr(a, key), getattr(b, key), rtol=0, atol=1e-12) for key in ("spacing", "origin", "direction")
    )


def _ffd() -> FFD:
    lat = Lattice.around(GRID.physical_points(), shape=5)
    lat.offsets[...] = np.random.default_rng(0).normal(0.0, 0.8, lat.offsets.shape)
    return FFD(lat)


def test_every_form_gives_the_same_grid(tmp_path):
    for name, form in _forms(tmp_path).items():
        assert _same(reference_grid(form), GRID), name


def test_every_function_taking_a_grid_accepts_every_form(tmp_path):
    ffd = _ffd()
    image = np.random.default_rng(1).random(GRID.shape).astype(np.float32)
    expected_warp = warp_image(image, ffd, reference=GRID, spacing=GRID.spacing, origin=GRID.origin,
                               direction=GRID.direction)  # fmt: skip
    expected_field = sample_displacement_field(ffd, GRID)
    expected_fit = fit_lattice(ffd, 5, region=GRID)
    for name, form in _forms(tmp_path).items():
        warped = warp_image(image, ffd, reference=form, spacing=GRID.spacing, origin=GRID.origin,
                            direction=GRID.direction)  # fmt: skip
        assert np.allclose(warped, expected_warp, rtol=0, atol=1e-5), name
        field = sample_displacement_field(ffd, form)
        assert _same(field.grid, GRID) and np.allclose(field.vectors, expected_field.vectors, rtol=0, atol=1e-9), name
        save_displacement_field(tmp_path / "out.nrrd", ffd, form)
        assert np.allclose(load_displacement_field(tmp_path / "out.nrrd").vectors, expected_field.vectors), name
        fitted = fit_lattice(ffd, 5, region=form)
        assert np.allclose(fitted.lattice.offsets, expected_fit.lattice.offsets, rtol=0, atol=1e-9), name


@pytest.mark.parametrize("bad", [3.0, object(), np.zeros(3)], ids=["number", "object", "array"])
def test_anything_else_is_refused_with_what_is_accepted(bad):
    with pytest.raises(TypeError, match="a reference grid is an ImageGrid, a SimpleITK image, an image file"):
        reference_grid(bad)
    with pytest.raises(TypeError, match="a reference grid is"):
        sample_displacement_field(_ffd(), bad)


def test_a_mapping_with_unknown_keys_is_refused():
    with pytest.raises(ValueError, match="needs 'size' and may have"):
        reference_grid({"size": (3, 3, 3), "spacings": 2.0})
