"""Orthogonal slices of an image warped through an FFD, kept up to date edit by edit (the editor's image view).

Each slice's voxel centres are bound once to a :class:`~ffd_notebook.Deformer` (the cached
evaluator of the mesh's drag path). After an edit of a few control points the deformer updates
only the points those control points reach, and only the slice pixels whose ``T(x)`` changed are
read again from the image, so the work of a drag is proportional to the moved control point's
reach, not to the image. Values are those of :func:`~ffd_notebook.warp_image` on the same voxels
(ITK's pull-back: the pixel at ``x`` shows the input at ``T(x)``).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

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
        self._deformers: dict[int, Any] = {}
        self._moved: dict[int, NDArray[np.float64]] = {}
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

    def _bind(self, axis: int) -> None:
        points = self.slice_points(axis)
        self._deformers[axis] = self.ffd.bind(points, dtype=np.float64)
        self.values[axis] = np.empty(self.slice_shape(axis) + self._reader.component_shape, dtype=self._reader.dtype)
        self._moved[axis] = self._deformers[axis].current().copy()
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
        for axis in self.axes:
            moved = self._deformers[axis].update(changed)
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
