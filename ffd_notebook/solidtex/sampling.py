"""Sampling a solid texture at points of a mesh (trilinear, in the organ's rest frame).

A solid texture is a colour volume placed in space: voxel ``(k, j, i)`` of the ``(Z, Y, X, 3)``
array has its centre at ``origin + (i, j, k) * spacing`` (world ``x, y, z``). Sample it at the
*rest* positions of a mesh's points, never at deformed ones: the texture belongs to the tissue and
must follow it when the organ deforms.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from .slices import exemplar_volume

__all__ = ["SolidTexture", "TextureSampler"]


@runtime_checkable
class TextureSampler(Protocol):
    """What the organ viewer needs from a solid texture: colours at rest-frame points, and a voxel size.

    :class:`SolidTexture` (a whole volume) and :class:`~ffd_notebook.solidtex.LazySolidTexture`
    (blocks synthesised on demand) both are one.

    Parameters
    ----------
    *args, **kwargs
        None: a protocol is never instantiated; a class is a ``TextureSampler`` by having a
        ``sample`` method and a ``spacing``.

    Examples
    --------
    >>> isinstance(SolidTexture(np.zeros((2, 2, 2, 3), np.uint8)), TextureSampler)
    True
    """

    spacing: float

    def sample(self, points: ArrayLike) -> NDArray[np.uint8]:
        """``(N, 3)`` uint8 colours at ``(N, 3)`` rest-frame points.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` rest-frame points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.solidtex import SolidTexture
        >>> vol = np.zeros((2, 2, 2, 3), np.uint8); vol[:, :, 1] = 200
        >>> tex = SolidTexture(vol, spacing=1.0, origin=(0, 0, 0))
        >>> isinstance(tex, TextureSampler), tex.sample([[1.0, 0.0, 0.0]]).tolist()
        (True, [[200, 200, 200]])
        """
        ...


@dataclass
class SolidTexture:
    """A colour volume placed in the rest frame.

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, 3)`` colours: uint8, uint16 or floats in [0, 1] (the package's dtype policy), kept as uint8.
    spacing : float
        Edge of a voxel in world units (voxels are cubes).
    origin : array_like
        World ``(x, y, z)`` of the centre of voxel ``[0, 0, 0]``.
    mode : str
        What lies outside the volume, as in :func:`scipy.ndimage.map_coordinates`
        (``"mirror"``: reflected, no visible border; ``"grid-wrap"``: tiled).

    Examples
    --------
    >>> vol = np.zeros((2, 2, 2, 3), np.uint8); vol[:, :, 1] = 200      # x = 1 is bright
    >>> tex = SolidTexture(vol, spacing=1.0, origin=(0, 0, 0))
    >>> tex.sample([[0.0, 0, 0], [0.5, 0, 0], [1, 1, 1]])[:, 0].tolist()
    [0, 100, 200]
    """

    volume: NDArray[np.uint8]
    spacing: float = 1.0
    origin: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    mode: str = "mirror"

    def __post_init__(self) -> None:
        # a (Z, Y, X, 3) volume, uint8 by the package's dtype policy
        self.volume = exemplar_volume(self.volume, "a solid texture")
        self.origin = np.asarray(self.origin, dtype=np.float64).reshape(3)
        self.spacing = float(self.spacing)
        if not self.spacing > 0:
            raise ValueError("spacing must be positive")
        # one contiguous float32 channel each: map_coordinates works per channel
        self._channels = [np.ascontiguousarray(self.volume[..., c], dtype=np.float32) for c in range(3)]

    @classmethod
    def fit(cls, volume: ArrayLike, bounds: ArrayLike, margin: float = 0.02, mode: str = "mirror") -> SolidTexture:
        """Place ``volume`` so that it covers a box, centred, with cubic voxels.

        Parameters
        ----------
        volume : array_like
            ``(Z, Y, X, 3)`` uint8 colours.
        bounds : array_like
            ``(xmin, xmax, ymin, ymax, zmin, zmax)``, e.g. ``mesh.bounds`` of the rest mesh.
        margin : float
            Extra room around the box, as a fraction of its size.
        mode : str
            What lies outside the volume (see :class:`SolidTexture`).

        Returns
        -------
        SolidTexture
            The placed texture.

        Examples
        --------
        >>> tex = SolidTexture.fit(np.zeros((10, 20, 40, 3), np.uint8), (0, 8, 0, 2, 0, 1), margin=0)
        >>> tex.spacing, tex.origin.round(6).tolist()
        (0.2, [0.1, -0.9, -0.4])
        """
        vol = np.asarray(volume)
        b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
        extent = (b[:, 1] - b[:, 0]) * (1.0 + margin)
        shape_xyz = np.array(vol.shape[2::-1], dtype=np.float64)
        spacing = float(np.max(extent / shape_xyz))
        centre = b.mean(axis=1)
        origin = centre - spacing * (shape_xyz - 1) / 2.0
        return cls(vol, spacing, origin, mode)

    def voxel_coordinates(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(3, N)`` fractional voxel indices ``(k, j, i)`` of world points, as map_coordinates wants.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` world points ``(x, y, z)``.

        Returns
        -------
        numpy.ndarray
            ``(3, N)`` float64 indices ``(k, j, i)``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.solidtex import SolidTexture
        >>> vol = np.zeros((2, 2, 2, 3), np.uint8); vol[:, :, 1] = 200
        >>> tex = SolidTexture(vol, spacing=1.0, origin=(0, 0, 0))
        >>> tex.voxel_coordinates([[1.0, 0.0, 0.5]]).tolist()
        [[0.5], [0.0], [1.0]]
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return ((p - self.origin) / self.spacing)[:, ::-1].T

    def sample(self, points: ArrayLike) -> NDArray[np.uint8]:
        """Trilinearly interpolated ``(N, 3)`` uint8 colours at rest-frame points ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in the organ's rest frame.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.solidtex import SolidTexture
        >>> vol = np.zeros((2, 2, 2, 3), np.uint8); vol[:, :, 1] = 200
        >>> tex = SolidTexture(vol, spacing=1.0, origin=(0, 0, 0))
        >>> tex.sample([[0.5, 0.0, 0.0]]).tolist()
        [[100, 100, 100]]
        """
        coords = self.voxel_coordinates(points)
        out = np.empty((coords.shape[1], 3), dtype=np.uint8)
        for c, channel in enumerate(self._channels):
            values = ndimage.map_coordinates(channel, coords, order=1, mode=self.mode, prefilter=False)
            out[:, c] = np.clip(np.rint(values), 0, 255)
        return out

    @property
    def bounds(self) -> NDArray[np.float64]:
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the voxel centres."""
        hi = self.origin + self.spacing * (np.array(self.volume.shape[2::-1]) - 1)
        return np.column_stack([self.origin, hi]).ravel()
