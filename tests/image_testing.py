"""Images with awkward geometry and lattices over them, shared by the image tests."""

from __future__ import annotations

import numpy as np
import SimpleITK as sitk
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice
from ffd_notebook.images import ImageGrid


def smooth_volume(shape: tuple[int, ...], rng: np.random.Generator) -> np.ndarray:
    """A float32 volume with structure at several scales (blurred noise plus a blob), values in about [0, 100]."""
    from scipy import ndimage

    noise = ndimage.gaussian_filter(rng.normal(size=shape), 1.5)
    centre = np.array(shape) / 2.0
    grids = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    r2 = sum(((g - c) / (n / 4.0)) ** 2 for g, c, n in zip(grids, centre, shape, strict=True))
    volume = 60.0 * np.exp(-r2) + 400.0 * noise
    return (volume - volume.min()).astype(np.float32)


def awkward_grid(size: tuple[int, ...]) -> ImageGrid:
    """Anisotropic spacing, a rotated direction (not a permutation of the axes), an origin far from zero."""
    if len(size) == 3:
        direction = Rotation.from_euler("zyx", [25.0, -15.0, 10.0], degrees=True).as_matrix()
        return ImageGrid(size, spacing=(0.9, 1.3, 2.1), origin=(-41.5, 23.0, 112.0), direction=direction)
    angle = np.radians(20.0)
    direction = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    return ImageGrid(size, spacing=(0.8, 1.7), origin=(-31.0, 57.5), direction=direction)


def lattice_over(
    grid: ImageGrid, shape: tuple[int, int, int], scale: float, rng: np.random.Generator, aligned: bool = False
) -> FFD:
    """A B-spline FFD ("zero" border) over the grid's box with random offsets (in-plane for a 2D grid).

    ``aligned``: the lattice's axes along the grid's (its rotation is the grid's direction), else
    along x, y, z (turned against a rotated grid).
    """
    lo, hi = grid.bounds()
    if grid.dim == 2:
        lo[2], hi[2] = -1.0, 1.0
    if aligned:
        rotation = np.eye(3)
        rotation[: grid.dim, : grid.dim] = grid.direction
        extent = np.append((np.array(grid.size) - 1) * grid.spacing, [2.0] * (3 - grid.dim))
        spacing = extent / (np.array(shape) - 3)
        corner = np.append(grid.origin, [-1.0] * (3 - grid.dim))
        lat = Lattice(shape, spacing, origin=corner - rotation @ spacing, rotation=rotation)
    else:
        lat = Lattice.around(np.array([lo, hi]), shape=shape)
    lat.offsets[...] = rng.normal(scale=scale, size=lat.offsets.shape)
    if grid.dim == 2:
        lat.offsets[..., 2] = 0.0
        lat.offsets[...] = lat.offsets[:, :, :1]  # the same in every layer: a deformation of the plane
    return FFD(lat)


def sitk_image(array: np.ndarray, grid: ImageGrid, vector: bool = False) -> sitk.Image:
    return grid.to_sitk(sitk.GetImageFromArray(array, isVector=vector))
