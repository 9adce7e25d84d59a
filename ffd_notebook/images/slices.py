"""Orthogonal slices of an image warped through an FFD, kept up to date edit by edit (the editor's image view).

Each slice is a grid one voxel thick, and ``T(x)`` on it comes from the engine's one evaluator of
an FFD on a grid, :class:`~ffd_notebook.ffd.grid.GridEvaluator`, as :func:`~ffd_notebook.warp_image`'s
does: the same code on the same voxels, so a slice shows what saving the warped image writes (ITK's
pull-back: the pixel at ``x`` shows the input at ``T(x)``). Where the lattice runs along the image
the evaluation is separable and a whole 256 x 256 slice takes well under a millisecond; where it is
turned against the image the slice's voxel centres are bound to a :class:`~ffd_notebook.Deformer`
instead (the plain evaluator, cached: after an edit of a few control points it updates only the
points they reach). Either way only the slice pixels whose ``T(x)`` changed are read again from
the image, so the work of a drag is proportional to the moved control point's reach, not to the image.

An FFD's per-point weights are one per voxel of the image (array order), each slice taking its
voxels' share (:func:`~ffd_notebook.ffd.grid.grid_weights`); they are read when a slice is bound, and
again by :meth:`WarpedSlices.update` when the FFD's weights are another array.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..ffd.grid import GridEvaluator, grid_weights
from .pixels import Interpolator, as_pixels

if TYPE_CHECKING:
    from .. import FFD

__all__ = ["WarpedSlices", "intensity_window"]

_WINDOW_SAMPLES = 1_000_000  # voxels looked at for the default window (a regular subsample of larger images)


def intensity_window(pixels: NDArray, low: float = 1.0, high: float = 99.0) -> tuple[float, float]:
    """A window ``(level, width)`` for showing a grey image: its ``low``-th to ``high``-th percentile.

    Examples
    --------
    >>> intensity_window(np.arange(101.0))
    (50.0, 98.0)
    """
    flat = np.asarray(pixels).reshape(-1)
    step = max(1, flat.size // _WINDOW_SAMPLES)
    lo, hi = np.percentile(flat[::step], [low, high])
    width = float(hi - lo) if hi > lo else 1.0
    return float(lo + hi) / 2.0, width


class WarpedSlices:
    """The three orthogonal slices (one for a 2D image) of an image warped through an FFD.

    Parameters
    ----------
    image : SimpleITK.Image, path or numpy.ndarray
        As for :func:`~ffd_notebook.warp_image` (an array with ``spacing``/``origin``/``direction``).
    ffd : FFD
        The deformation; its lattice's offsets are read at every :meth:`update`.
    positions : sequence of int, optional
        Index of the slice across each index axis ``(i, j, k)``; the middle by default.
    interpolation : {"linear", "nearest", "bspline"}
        How the image is read between voxel centres.
    default_value : float
        Value where ``T(x)`` falls outside the image.
    spacing, origin, direction : array_like, optional
        The geometry of an array ``image`` (see :class:`~ffd_notebook.images.ImageGrid`); only for an array.

    Attributes
    ----------
    grid : ImageGrid
        The image's grid.
    values : dict of int to numpy.ndarray
        Per index axis, the warped slice across it, in the image array's order without that
        axis (``[k, j]`` across ``i``, ``[k, i]`` across ``j``, ``[j, i]`` across ``k``), components last.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice, warp_image
    >>> volume = np.random.default_rng(0).random((12, 14, 16)).astype(np.float32)
    >>> lat = Lattice.around(np.array([[0, 0, 0], [15, 13, 11]]), shape=10)
    >>> slices = WarpedSlices(volume, FFD(lat))
    >>> lat.offsets[3, 3, 4] = (1.5, 0.0, 0.0)
    >>> changed = slices.update([(3, 3, 4)])
    >>> bool(0 < changed[2].sum() < changed[2].size)    # only the pixels the control point reaches
    True
    >>> bool(np.allclose(slices.values[2], warp_image(volume, FFD(lat))[6], atol=1e-5))
    True
    """

    def __init__(
        self,
        image: Any,
        ffd: FFD,
        *,
        positions: ArrayLike | None = None,
        interpolation: str = "linear",
        default_value: float = 0,
        spacing: ArrayLike | None = None,
        origin: ArrayLike | None = None,
        direction: ArrayLike | None = None,
    ) -> None:
        pixels, self.grid, self._sitk = as_pixels(image, spacing=spacing, origin=origin, direction=direction)
        self.pixels = pixels
        self._reader = Interpolator(pixels, self.grid, interpolation, default_value)
        self.ffd = ffd
        self._to_index = self.grid.physical_to_index()
        middle = [n // 2 for n in self.grid.size]
        self.positions = list(middle if positions is None else (int(p) for p in cast("Iterable[Any]", positions)))
        if len(self.positions) != self.grid.dim:
            raise ValueError(f"positions must give {self.grid.dim} indices, got {positions!r}")
        self.axes = (0, 1, 2) if self.grid.dim == 3 else (2,)  # a 2D image: its one plane
        self.values: dict[int, NDArray] = {}
        self._evaluators: dict[int, Any] = {}  # per slice: a GridEvaluator (separable) or a Deformer
        self._moved: dict[int, NDArray[np.float64]] = {}
        self._weights_of: Any = None  # the FFD's weights the slices were bound with
        for axis in self.axes:
            self._bind(axis)

    # ------------------------------------------------------------------ slices
    def slice_shape(self, axis: int) -> tuple[int, int]:
        """Array shape of the slice across index axis ``axis``.

        Parameters
        ----------
        axis : int
            0, 1 or 2 (``i``, ``j``, ``k``); 2 for a 2D image's one slice.

        Returns
        -------
        tuple of int
            The slice array's two dimensions, in the image array's order without ``axis``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> volume = np.zeros((12, 14, 16), np.float32)            # [k, j, i]: 16 x 14 x 12 voxels
        >>> slices = WarpedSlices(volume, FFD(Lattice.around(np.array([[0, 0, 0], [15, 13, 11]]), shape=4)))
        >>> slices.slice_shape(0), slices.slice_shape(1), slices.slice_shape(2)
        ((12, 14), (12, 16), (14, 16))
        """
        shape = list(self.grid.shape) if self.grid.dim == 3 else [1, *self.grid.shape]
        del shape[2 - axis]  # array axes are (k, j, i)
        return tuple(shape)  # type: ignore[return-value]

    def slice_points(self, axis: int) -> NDArray[np.float64]:
        """``(N, 3)`` physical rest positions of the slice's voxel centres, in the slice array's C order.

        Parameters
        ----------
        axis : int
            0, 1 or 2 (``i``, ``j``, ``k``); 2 for a 2D image's one slice.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64, ``N`` the slice's pixel count.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> volume = np.zeros((2, 3, 4), np.float32)
        >>> slices = WarpedSlices(volume, FFD(Lattice.around(np.array([[0, 0, 0], [3, 2, 1]]), shape=4)), spacing=2.0)
        >>> points = slices.slice_points(2)                      # across k, at k = 1 (the middle)
        >>> points.shape, points[:2].tolist(), points[-1].tolist()
        ((12, 3), [[0.0, 0.0, 2.0], [2.0, 0.0, 2.0]], [6.0, 4.0, 2.0])
        """
        size = list(self.grid.size) + [1] * (3 - self.grid.dim)
        ranges = [np.arange(n, dtype=np.float64) for n in size]
        if self.grid.dim == 3:
            ranges[axis] = np.array([float(self.positions[axis])])
        k, j, i = np.meshgrid(ranges[2], ranges[1], ranges[0], indexing="ij")
        index = np.stack([i.ravel(), j.ravel(), k.ravel(), np.ones(i.size)])
        return np.ascontiguousarray((self.grid.index_to_physical() @ index)[:3].T)

    def set_ffd(self, ffd: FFD) -> None:
        """Follow another FFD (a new lattice, basis or loaded file): every slice is bound and read again.

        Parameters
        ----------
        ffd : FFD
            The new deformation.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice, warp_image
        >>> volume = np.random.default_rng(0).random((6, 7, 8)).astype(np.float32)
        >>> slices = WarpedSlices(volume, FFD(Lattice.around(np.array([[0, 0, 0], [7, 6, 5]]), shape=4)))
        >>> lat = Lattice.around(np.array([[0, 0, 0], [7, 6, 5]]), shape=5)
        >>> lat.offsets[2, 2, 2] = (1.0, 0.5, 0.0)
        >>> slices.set_ffd(FFD(lat))
        >>> bool(np.allclose(slices.values[2], warp_image(volume, FFD(lat))[3], atol=1e-5))
        True
        """
        self.ffd = ffd
        for axis in self.axes:
            self._bind(axis)

    def set_position(self, axis: int, index: int) -> None:
        """Move the slice across index axis ``axis`` to voxel ``index`` (clipped to the image).

        Parameters
        ----------
        axis : int
            0, 1 or 2 (``i``, ``j``, ``k``).
        index : int
            The voxel index along that axis.

        Raises
        ------
        ValueError
            If there is no slice across ``axis`` (a 2D image has only the one across 2).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> volume = np.arange(6 * 7 * 8, dtype=np.float32).reshape(6, 7, 8)
        >>> slices = WarpedSlices(volume, FFD(Lattice.around(np.array([[0, 0, 0], [7, 6, 5]]), shape=4)))
        >>> slices.set_position(2, 99)                    # clipped to the last slice
        >>> slices.positions, bool(np.allclose(slices.values[2], volume[5]))
        ([4, 3, 5], True)
        """
        if axis not in self.axes:
            raise ValueError(f"no slice across axis {axis} (slices across {self.axes})")
        self.positions[axis] = int(np.clip(index, 0, self.grid.size[axis] - 1))
        self._bind(axis)

    def moved(self, axis: int) -> NDArray[np.float64]:
        """``T(x)`` at the slice's voxel centres as last evaluated.

        Parameters
        ----------
        axis : int
            0, 1 or 2 (``i``, ``j``, ``k``); 2 for a 2D image's one slice.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` physical points in :meth:`slice_points`' order (the slices' own buffer: copy to keep).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> lat = Lattice.around(np.array([[0, 0, 0], [7, 6, 5]]), shape=4)
        >>> lat.offsets[...] = (0.5, 0.0, 0.0)
        >>> slices = WarpedSlices(np.zeros((6, 7, 8), np.float32), FFD(lat))
        >>> bool(np.allclose(slices.moved(2), slices.slice_points(2) + (0.5, 0.0, 0.0)))
        True
        """
        return self._moved[axis]

    def _slice_grid(self, axis: int) -> tuple[NDArray[np.float64], tuple[int, ...]]:
        """The slice as a grid: its placement (the image's, from the slice's index on) and array shape."""
        placement = self.grid.index_to_physical()
        if self.grid.dim == 2:
            return placement, self.grid.shape
        corner = np.zeros(4)
        corner[axis], corner[3] = self.positions[axis], 1.0
        placement[:3, 3] = (placement @ corner)[:3]
        shape = list(self.grid.shape)
        shape[2 - axis] = 1  # array axes are (k, j, i)
        return placement, tuple(shape)

    def _slice_weights(self, axis: int) -> NDArray[np.float64] | None:
        self._weights_of = self.ffd.weights
        weights = grid_weights(self.ffd.weights, self.grid.shape)
        if weights is None or self.grid.dim == 2:
            return weights
        return np.take(weights, [self.positions[axis]], axis=2 - axis)

    def _evaluate(self, axis: int, changed: Any) -> NDArray[np.float64]:
        """``T(x)`` on the slice: the grid evaluator's whole slice, or the deformer's update for ``changed``."""
        evaluator = self._evaluators[axis]
        if isinstance(evaluator, GridEvaluator):
            rows = evaluator.shape[0]
            return evaluator.points(0, rows).reshape(3, -1).T
        return evaluator.update(changed)

    def _bind(self, axis: int) -> None:
        placement, shape = self._slice_grid(axis)
        weights = self._slice_weights(axis)
        evaluator: Any = GridEvaluator(self.ffd, placement, shape, weights=weights)
        if not evaluator.separable:  # a lattice turned against the image: the cached plain evaluator
            flat = None if weights is None else weights.reshape(-1)
            evaluator = self.ffd.bind(self.slice_points(axis), dtype=np.float64, weights=flat)
        self._evaluators[axis] = evaluator
        self.values[axis] = np.empty(self.slice_shape(axis) + self._reader.component_shape, dtype=self._reader.dtype)
        self._moved[axis] = self._evaluate(axis, None).copy()
        self._read(axis, None)

    def _read(self, axis: int, where: NDArray[np.bool_] | None) -> None:
        """Read the image at ``T(x)`` for the slice's pixels (those of ``where``, or all)."""
        moved = self._moved[axis] if where is None else self._moved[axis][where.ravel()]
        index = self._to_index[:3, :3] @ moved.T + self._to_index[:3, 3, None]
        index = index[: self.grid.dim][::-1]  # array order (k, j, i)
        if where is None:
            self._reader.read(index.reshape(-1, *self.values[axis].shape[:2]), out=self.values[axis])
        else:
            out = np.empty((len(moved),) + self._reader.component_shape, dtype=self._reader.dtype)
            self._reader.read(index, out=out)
            self.values[axis][where] = out

    # ------------------------------------------------------------------ edits
    def update(self, changed: Any = None) -> dict[int, NDArray[np.bool_]]:
        """Bring the slices up to date with the FFD; returns, per slice, the pixels read again.

        Parameters
        ----------
        changed : sequence of (i, j, k), optional
            Control points whose offsets changed since the last update (the drag path): only
            the slice pixels whose ``T(x)`` they changed are read again. ``None``: every pixel.
            A change of the lattice's placement or of the affine part is noticed by the
            deformers and recomputes everything.

        Returns
        -------
        dict of int to numpy.ndarray
            Per index axis, a boolean mask of the slice's pixels that were read again.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> volume = np.random.default_rng(0).random((10, 10, 10)).astype(np.float32)
        >>> lat = Lattice.around(np.array([[0, 0, 0], [9, 9, 9]]), shape=8)
        >>> slices = WarpedSlices(volume, FFD(lat))
        >>> lat.offsets[1, 1, 5] = (0.0, 0.0, 0.8)       # a corner control point, near the k = 5 slice
        >>> read = slices.update([(1, 1, 5)])
        >>> {axis: int(mask.sum()) for axis, mask in read.items()}, read[2].size
        ({0: 0, 1: 0, 2: 16}, 100)
        """
        regions = {}
        rebind = self.ffd.weights is not self._weights_of  # other voxel weights: every slice takes its share again
        for axis in self.axes:
            evaluator = self._evaluators[axis]
            if rebind or (isinstance(evaluator, GridEvaluator) and not evaluator.separable):  # or turned: the plain one
                self._bind(axis)
                regions[axis] = np.ones(self.values[axis].shape[:2], dtype=bool)
                continue
            moved = self._evaluate(axis, changed)
            if changed is None:
                region = np.ones(self.values[axis].shape[:2], dtype=bool)
            else:
                region = np.any(moved != self._moved[axis], axis=1).reshape(self.values[axis].shape[:2])
            self._moved[axis][...] = moved
            if region.all():
                self._read(axis, None)
            elif region.any():
                self._read(axis, region)
            regions[axis] = region
        return regions
