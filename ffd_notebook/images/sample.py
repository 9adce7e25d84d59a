"""Where each voxel of the output grid reads the input: ``T(x)`` on the reference grid, in input indices.

ITK's convention (the output voxel at physical point ``x`` takes the input's value at ``T(x)``),
so what resampling needs is, for every voxel of the reference grid, the continuous index of
``T(x)`` in the input image. It is made slab by slab along the output array's first (slowest)
axis, so the working memory stays a few megabytes whatever the image size.

Any object with a ``deform(points)`` method taking and returning ``(N, 3)`` physical points is a
deformation here (an :class:`~ffd_notebook.FFD`, an elastix chain, a displacement field...): it is
evaluated on each slab's voxel centres.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from .geometry import ImageGrid

__all__ = ["Deformation", "IndexSampler", "slab_rows"]

SLAB_VOXELS = 2**18  # output voxels per slab: ~6 MB of float64 coordinates


class Deformation(Protocol):
    """What :func:`~ffd_notebook.warp_image` needs of a deformation: ``deform`` of ``(N, 3)`` points."""

    def deform(self, points: Any) -> Any: ...


def slab_rows(grid: ImageGrid, voxels: int = SLAB_VOXELS) -> int:
    """Rows of the output array's first axis per slab: about ``voxels`` voxels, at least one row.

    Examples
    --------
    >>> slab_rows(ImageGrid((256, 256, 256)))
    4
    """
    plane = int(np.prod(grid.shape[1:]))
    return max(1, voxels // plane)


class IndexSampler:
    """Continuous input indices of ``T(x)`` for the voxels ``x`` of a reference grid, a slab at a time.

    Parameters
    ----------
    deformation : object with ``deform(points)``
        ``(N, 3) -> (N, 3)`` physical points.
    reference : ImageGrid
        The output grid (where ``x`` runs).
    source : ImageGrid
        The input image's grid (where ``T(x)`` is looked up).

    Examples
    --------
    >>> import numpy as np
    >>> class Shift:
    ...     def deform(self, points):
    ...         return np.asarray(points) + (2.0, 0.0, 0.0)
    >>> grid = ImageGrid((4, 3), spacing=2.0)
    >>> IndexSampler(Shift(), grid, grid).rows(0, 1)[:, 0].tolist()   # (j, i) of row j = 0: one voxel to the right
    [[0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 3.0, 4.0]]
    """

    def __init__(self, deformation: Deformation, reference: ImageGrid, source: ImageGrid) -> None:
        if not callable(getattr(deformation, "deform", None)):
            raise TypeError(f"a deformation needs a deform(points) method, got {type(deformation).__name__}")
        self.deformation = deformation
        self.reference = reference
        self.source = source
        self.to_physical = reference.index_to_physical()
        self.to_index = source.physical_to_index()

    def slab_index(self, start: int, stop: int) -> NDArray[np.float64]:
        """``(4, n)`` homogeneous reference indices ``(i, j, k, 1)`` of array rows ``start:stop``, C order."""
        shape = (stop - start, *self.reference.shape[1:])
        axes = [np.arange(start, stop, dtype=np.float64)] + [np.arange(n, dtype=np.float64) for n in shape[1:]]
        grids = np.meshgrid(*axes, indexing="ij")  # array order: (k, j, i) or (j, i)
        n = grids[0].size
        index = np.zeros((4, n))
        for axis, values in enumerate(reversed(grids)):  # i first
            index[axis] = values.ravel()
        index[3] = 1.0
        return index

    def rows(self, start: int, stop: int) -> NDArray[np.float64]:
        """Input indices for output array rows ``start:stop``: ``(source.dim, stop - start, ...)``, array order.

        Row ``m`` of the result is the input array's axis ``m`` (``k, j, i`` for a 3D input), ready
        for :func:`scipy.ndimage.map_coordinates`.
        """
        points = (self.to_physical @ self.slab_index(start, stop))[:3].T
        moved = np.asarray(self.deformation.deform(points), dtype=np.float64)
        if moved.shape != points.shape:
            raise ValueError(f"deformation.deform returned shape {moved.shape} for {points.shape} points")
        index = self.to_index[:3, :3] @ moved.T
        index += self.to_index[:3, 3, None]
        dim = self.source.dim
        shape = (stop - start, *self.reference.shape[1:])
        return np.ascontiguousarray(index[:dim][::-1]).reshape(dim, *shape)
