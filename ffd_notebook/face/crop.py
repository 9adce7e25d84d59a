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

    def sample(self, rgb: np.ndarray, n: int, *, outside: str = "nearest", scale: float = 1.0) -> np.ndarray:
        """The crop as an ``(n, n, 3)`` float array (0-255), sampled bilinearly at the ``n x n`` pixel centres.

        ``rgb`` may be a reduced copy of the photo (``scale`` photo pixels per pixel of ``rgb``, see
        :func:`reduced`); ``outside`` is ``"nearest"`` (repeat the border) or ``"zero"`` (black).
        """
        centres = (np.arange(n) + 0.5) / n
        t, s = np.meshgrid(centres, centres, indexing="ij")
        xy = self.to_photo(np.stack([s.ravel(), t.ravel()], axis=1)) / scale
        return bilinear(rgb, xy, outside=outside).reshape(n, n, rgb.shape[2])


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
    """The photo shrunk by an integer ``factor``, each pixel the mean of a ``factor x factor`` block (no aliasing).

    Examples
    --------
    >>> reduced(np.arange(16, dtype=np.uint8).reshape(4, 4, 1), 2)[:, :, 0]
    array([[ 2.5,  4.5],
           [10.5, 12.5]], dtype=float32)
    """
    if factor <= 1:
        return rgb
    h, w = (rgb.shape[0] // factor) * factor, (rgb.shape[1] // factor) * factor
    blocks = rgb[:h, :w].reshape(h // factor, factor, w // factor, factor, rgb.shape[2])
    return blocks.mean(axis=(1, 3), dtype=np.float32)
