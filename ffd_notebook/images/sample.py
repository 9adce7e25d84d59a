"""Where each voxel of the output grid reads the input: ``T(x)`` on the reference grid, in input indices.

ITK's convention (the output voxel at physical point ``x`` takes the input's value at ``T(x)``),
so what resampling needs is, for every voxel of the reference grid, the continuous index of
``T(x)`` in the input image. It is made slab by slab along the output array's first (slowest)
axis, so the working memory stays a few megabytes whatever the image size, by the engine's one
evaluator of a deformation on a grid (:class:`~ffd_notebook.ffd.grid.GridEvaluator`): separably for
an FFD whose lattice runs along the grid, through ``deform`` on each slab's voxel centres for
anything else.

Any object with a ``deform(points)`` method taking and returning ``(N, 3)`` physical points is a
deformation here (an :class:`~ffd_notebook.FFD`, an elastix chain, a displacement field...).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ..ffd.grid import GridEvaluator
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
        ``(N, 3) -> (N, 3)`` physical points. An FFD's per-point weights, if any, are one per
        voxel of ``reference`` (:func:`~ffd_notebook.ffd.grid.grid_weights`).
    reference : ImageGrid
        The output grid (where ``x`` runs).
    source : ImageGrid
        The input image's grid (where ``T(x)`` is looked up).

    Attributes
    ----------
    evaluator : GridEvaluator
        ``T`` on the reference grid, in the source's index frame.

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
        self.reference = reference
        self.source = source
        self.evaluator = GridEvaluator(
            deformation, reference.index_to_physical(), reference.shape, output=source.physical_to_index()
        )
        self._components = tuple(range(source.dim))[::-1]  # the input's array order: (k, j, i) or (j, i)

    @property
    def separable(self) -> bool:
        """Whether ``T`` is evaluated separably (an FFD whose lattice runs along the reference grid)."""
        return self.evaluator.separable

    def rows(self, start: int, stop: int) -> NDArray[np.float64]:
        """Input indices for output array rows ``start:stop``: ``(source.dim, stop - start, ...)``, array order.

        Row ``m`` of the result is the input array's axis ``m`` (``k, j, i`` for a 3D input), ready
        for :func:`scipy.ndimage.map_coordinates`.
        """
        return self.evaluator.points(start, stop, components=self._components)
