"""Rotated square crops of a photo, resampled to a model's input size, and the way back.

Coordinates are continuous pixel coordinates of the photo: x to the right, y downwards, pixel
``(row i, column j)`` covers ``[j, j + 1] x [i, i + 1]`` (its centre is at ``(j + 0.5, i + 0.5)``).
A crop is a square of side ``size`` centred at ``center``, turned by ``rotation`` radians (as
MediaPipe's ``NormalizedRect.rotation``: its x axis points along ``(cos r, sin r)`` in the photo,
clockwise on the screen for r > 0). A position ``(s, t)`` in [0, 1]^2 of the crop is the photo point
``center + R(r) @ ((s - 0.5) * size, (t - 0.5) * size)``: MediaPipe's ImageToTensor and
LandmarkProjection calculators, done in pixels so non-square photos are exact too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

__all__ = ["Square", "bilinear", "reduced"]


@dataclass(frozen=True)
class Square:
    """A rotated square of the photo: centre ``(x, y)``, side and rotation (radians)."""

    center: tuple[float, float]
    size: float
    rotation: float = 0.0

    def to_photo(self, st: np.ndarray) -> np.ndarray:
        """Photo points ``(N, 2)`` of crop positions ``st`` ``(N, 2)`` in [0, 1].

        Examples
        --------
        >>> sq = Square((10.0, 20.0), 4.0, np.pi / 2)
        >>> sq.to_photo(np.array([[0.5, 0.5], [1.0, 0.5]])).round(6)
        array([[10., 20.],
               [10., 22.]])
        """
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        local = (np.asarray(st, dtype=np.float64) - 0.5) * self.size
        return np.asarray(self.center) + local @ np.array([[c, s], [-s, c]])

    def sample(self, rgb: np.ndarray, n: int, *, outside: str = "nearest") -> np.ndarray:
        """The crop as an ``(n, n, C)`` float array (0-255), sampled bilinearly at the ``n x n`` pixel centres.

        A square more than twice as large as ``n`` is first shrunk by a whole factor (block means of
        the part of the photo it covers, :func:`reduced`), so a large photo gives the models the
        same picture as a small one, without aliasing. ``outside`` is ``"nearest"`` (repeat the
        photo's border) or ``"zero"`` (black), for the part of the square beyond the photo.

        Examples
        --------
        >>> rgb = np.zeros((40, 60, 3), np.uint8)
        >>> rgb[:, 30:] = 200                                   # the right half is bright
        >>> Square((30.0, 20.0), 8.0).sample(rgb, 4)[:, :, 0]
        array([[  0.,   0., 200., 200.],
               [  0.,   0., 200., 200.],
               [  0.,   0., 200., 200.],
               [  0.,   0., 200., 200.]])
        """
        factor = max(1, int(self.size // (2 * n)))
        corners = self.to_photo(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
        x0, y0 = np.clip(np.floor(corners.min(axis=0)).astype(int) - factor, 0, None)
        x1, y1 = np.ceil(corners.max(axis=0)).astype(int) + factor
        region = rgb[y0:y1, x0:x1]  # the part of the photo under the square (beyond it: beyond the photo)
        if region.size == 0:
            return np.zeros((n, n, rgb.shape[2]))
        centres = (np.arange(n) + 0.5) / n
        t, s = np.meshgrid(centres, centres, indexing="ij")
        xy = (self.to_photo(np.stack([s.ravel(), t.ravel()], axis=1)) - (x0, y0)) / factor
        return bilinear(reduced(region, factor), xy, outside=outside).reshape(n, n, rgb.shape[2])


def bilinear(rgb: np.ndarray, xy: np.ndarray, *, outside: str = "nearest") -> np.ndarray:
    """Bilinear samples ``(N, C)`` float of an ``(H, W, C)`` image at continuous pixel points ``xy`` ``(N, 2)``.

    Examples
    --------
    >>> img = np.array([[[0], [100]], [[50], [150]]], dtype=np.uint8)     # 2x2, one channel
    >>> bilinear(img, np.array([[1.0, 1.0], [0.5, 0.5], [1.5, 0.5]]))     # centre, pixel (0, 0), pixel (0, 1)
    array([[ 75.],
           [  0.],
           [100.]])
    """
    coords = [np.asarray(xy[:, 1]) - 0.5, np.asarray(xy[:, 0]) - 0.5]
    mode, cval = ("nearest", 0.0) if outside == "nearest" else ("constant", 0.0)
    out = np.empty((len(xy), rgb.shape[2]), dtype=np.float64)
    for channel in range(rgb.shape[2]):
        out[:, channel] = ndimage.map_coordinates(
            rgb[:, :, channel], coords, order=1, mode=mode, cval=cval, output=np.float64
        )
    return out


def reduced(rgb: np.ndarray, factor: int) -> np.ndarray:
    """An ``(H, W, C)`` uint8 image shrunk by a whole ``factor``, each pixel the mean of a ``factor x factor`` block.

    Pixel ``(i, j)`` of the result covers pixels ``[i f, (i + 1) f) x [j f, (j + 1) f)`` of the
    image (a partial block at the far edges: the mean of what there is). Pillow's ``reduce``.

    Examples
    --------
    >>> reduced(np.arange(16, dtype=np.uint8).reshape(4, 4, 1).repeat(3, axis=2), 2)[:, :, 0]
    array([[ 3,  5],
           [11, 13]], dtype=uint8)
    """
    if factor <= 1:
        return rgb
    from PIL import Image

    return np.asarray(Image.fromarray(np.ascontiguousarray(rgb)).reduce(factor))
