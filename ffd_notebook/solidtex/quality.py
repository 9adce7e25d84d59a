"""How close a synthesised volume is to its exemplar, and how visible its block seams are.

* :func:`histogram_distance` compares colour statistics: the L2 distance between normalised joint
  RGB histograms (the measure behind the paper's "feature inclusiveness", see
  :func:`ffd_notebook.solidtex.blocks.feature_inclusiveness`).
* :func:`seam_energy` compares the squared colour differences between neighbouring voxels inside
  the overlap bands where blocks meet with those everywhere: 1.0 means the borders are as smooth
  as the rest of the volume, larger values mean visible seams.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.colours import as_float, as_uint8

__all__ = ["band_mask", "color_histogram", "colour_histogram", "gradient_energy", "histogram_distance", "seam_energy"]


def color_histogram(voxels: ArrayLike, *, bins: int = 8) -> NDArray[np.float64]:
    """Normalised joint RGB histogram of uint8 colours, ``bins**3`` values that sum to 1.

    Parameters
    ----------
    voxels : array_like
        Any array whose last axis has the 3 colour channels: uint8 levels, uint16 or floats in [0, 1] (the
        package's dtype policy).
    bins : int
        Bins per channel (a power of two up to 256 keeps the bins equal).

    Returns
    -------
    numpy.ndarray
        ``(bins**3,)`` float64, summing to 1.

    Examples
    --------
    >>> h = color_histogram(np.array([[0, 0, 0], [255, 255, 255]], dtype=np.uint8), bins=2)
    >>> h.tolist()
    [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]
    """
    v = np.asarray(voxels)
    if v.shape[-1] != 3 or v.size == 0:
        raise ValueError(f"expected a non-empty array of RGB colours (last axis 3), got shape {v.shape}")
    v = as_uint8(v)  # the package's dtype policy: uint16, floats in [0, 1]...
    q = (v.reshape(-1, 3).astype(np.int64) * bins) // 256
    q = np.clip(q, 0, bins - 1)
    codes = (q[:, 0] * bins + q[:, 1]) * bins + q[:, 2]
    h = np.bincount(codes, minlength=bins**3).astype(np.float64)
    return h / h.sum()


def colour_histogram(voxels: ArrayLike, bins: int = 8) -> NDArray[np.float64]:
    """Deprecated spelling of :func:`color_histogram` (the package spells ``color``, as PyVista does).

    .. deprecated:: 0.1.0
       Use :func:`color_histogram`.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     colour_histogram(np.zeros((2, 3), np.uint8), 2).tolist()
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    >>> print(caught[0].message)
    colour_histogram is deprecated: use color_histogram
    """
    warnings.warn("colour_histogram is deprecated: use color_histogram", DeprecationWarning, stacklevel=2)
    return color_histogram(voxels, bins=bins)


def histogram_distance(a: ArrayLike, b: ArrayLike, bins: int = 8) -> float:
    """L2 distance between the joint RGB histograms of two colour arrays (0 = same statistics).

    The maximum, for two single-colour volumes of different colours, is ``sqrt(2)``.

    Parameters
    ----------
    a, b : array_like
        Colour arrays ``(..., 3)`` uint8.
    bins : int
        Histogram bins per channel.

    Returns
    -------
    float
        The L2 distance between the normalised histograms.

    Examples
    --------
    >>> red = np.zeros((4, 4, 4, 3), np.uint8); red[..., 0] = 255
    >>> blue = np.zeros((2, 2, 2, 3), np.uint8); blue[..., 2] = 255
    >>> round(histogram_distance(red, blue), 4), histogram_distance(red, red[:2])
    (1.4142, 0.0)
    """
    return float(np.linalg.norm(color_histogram(a, bins=bins) - color_histogram(b, bins=bins)))


def gradient_energy(volume: ArrayLike) -> float:
    """Mean squared colour difference between face-neighbouring voxels (all three axes).

    Blurring lowers it, seams and noise raise it; compare a result with its exemplar.

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, 3)`` colours.

    Returns
    -------
    float
        The mean squared difference (0 for a constant volume).

    Examples
    --------
    >>> gradient_energy(np.zeros((3, 3, 3, 3), np.uint8))
    0.0
    """
    v = as_float(volume) * np.float32(255)  # in 0-255 levels whatever the dtype (the package's dtype policy)
    total = sum(float(np.mean(np.square(np.diff(v, axis=ax)).sum(-1), dtype=np.float64)) for ax in range(3))
    return total / 3.0


def band_mask(n: int, step: int, overlap: int) -> NDArray[np.bool_]:
    """Which of the ``n - 1`` voxel faces along an axis lie in a block-overlap band.

    Block ``k`` starts at ``k * step`` and shares ``overlap`` voxels with block ``k - 1``; the
    band is the faces from the voxel before the shared ones to the last shared voxel (where a
    feathered seam changes colour).

    Examples
    --------
    >>> band_mask(12, step=5, overlap=2).astype(int).tolist()
    [0, 0, 0, 0, 1, 1, 1, 0, 0, 1, 1]
    """
    if step < 1 or overlap < 0:
        raise ValueError("step must be >= 1 and overlap >= 0")
    mask = np.zeros(max(n - 1, 0), dtype=bool)
    for start in range(step, n, step):
        mask[max(start - 1, 0) : min(start + overlap, n - 1)] = True
    return mask


def seam_energy(volume: ArrayLike, step: int, overlap: int) -> float:
    """Squared colour differences across block-overlap bands relative to those everywhere.

    Parameters
    ----------
    volume : array_like
        ``(Z, Y, X, 3)`` colours.
    step, overlap : int
        The block layout: blocks start every ``step`` voxels and neighbours share ``overlap``
        voxels (``step = block - overlap``; see :func:`ffd_notebook.solidtex.plan_stages`).

    Returns
    -------
    float
        ``mean |dI|^2`` over faces inside bands divided by ``mean |dI|^2`` over all faces (all three
        axes pooled). About 1 when seams are invisible; NaN for a constant volume.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> smooth = rng.integers(0, 255, (24, 24, 24, 3)).astype(np.uint8)
    >>> 0.9 < seam_energy(smooth, step=8, overlap=2) < 1.1
    True
    >>> tiles = np.kron(rng.integers(0, 255, (3, 3, 3, 3)), np.ones((8, 8, 8, 1))).astype(np.uint8)
    >>> seam_energy(tiles, step=8, overlap=0) > 5
    True
    """
    v = np.asarray(volume)
    if v.ndim != 4 or v.shape[-1] != 3:
        raise ValueError(f"expected a (Z, Y, X, 3) volume, got shape {v.shape}")
    v = as_float(v) * np.float32(255)  # in 0-255 levels whatever the dtype (the package's dtype policy)
    band_sum = all_sum = 0.0
    band_n = all_n = 0
    for ax in range(3):
        d2 = np.square(np.diff(v, axis=ax)).sum(-1)
        per_face = d2.sum(axis=tuple(a for a in range(3) if a != ax), dtype=np.float64)
        faces = d2.size // max(per_face.size, 1)
        mask = band_mask(v.shape[ax], step, overlap)
        band_sum += float(per_face[mask].sum())
        band_n += int(mask.sum()) * faces
        all_sum += float(per_face.sum())
        all_n += d2.size
    if band_n == 0 or all_sum == 0:
        return float("nan")
    return (band_sum / band_n) / (all_sum / all_n)
