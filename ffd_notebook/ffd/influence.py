"""How much of a deformation each point gets: a strength for all, a weight per point (Blender's modifier).

Blender's lattice modifier moves a vertex by ``strength * weight`` times the lattice's
displacement (``lattice_deform.cc``), ``weight`` being the vertex's weight in the modifier's vertex
group (0 outside it; ``1 - weight`` when the group is inverted) and ``strength`` any number (1:
the full deformation, 0: none, negative: the opposite way). For an FFD with an affine part the
whole displacement ``T(x) - x`` is scaled the same way.

Examples
--------
>>> import numpy as np
>>> rest, moved = np.zeros((2, 3)), np.ones((2, 3))
>>> blend(rest, moved, influence(0.5, np.array([1.0, 0.2]), 2)).tolist()
[[0.5, 0.5, 0.5], [0.1, 0.1, 0.1]]
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["blend", "check_strength", "influence", "point_weights"]


def check_strength(strength: Any) -> float:
    """``strength`` as a finite float, else a ``ValueError``.

    Examples
    --------
    >>> check_strength(-0.5)
    -0.5
    >>> check_strength(float("nan"))
    Traceback (most recent call last):
    ...
    ValueError: strength must be a finite number, got nan
    """
    try:
        value = float(strength)
    except (TypeError, ValueError):
        raise ValueError(f"strength must be a finite number, got {strength!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"strength must be a finite number, got {strength!r}")
    return value


def point_weights(weights: Any, n: int, mesh: Any = None) -> NDArray[np.float64] | None:
    """Per-point weights in [0, 1] as an ``(n,)`` float array (None stays None).

    Parameters
    ----------
    weights : None, array_like or str
        One weight per point, or the name of a point-data array of ``mesh``.
    n : int
        Number of points.
    mesh : object with ``point_data``, optional
        The mesh being deformed, where a name is looked up.

    Examples
    --------
    >>> point_weights([0.0, 0.5, 1.0], 3).tolist()
    [0.0, 0.5, 1.0]
    >>> point_weights([0.0, 2.0], 2)
    Traceback (most recent call last):
    ...
    ValueError: weights must be between 0 and 1 (Blender's vertex weights), got values up to 2.0
    """
    if weights is None:
        return None
    if isinstance(weights, str):
        data = getattr(mesh, "point_data", None)
        if data is None:
            raise ValueError(f"weights={weights!r} names a point-data array, but the points are not a mesh")
        if weights not in data:
            raise ValueError(f"the mesh has no point-data array {weights!r} (it has {sorted(data.keys())})")
        weights = data[weights]
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim == 2 and w.shape[1] == 1:
        w = w[:, 0]
    if w.shape != (n,):
        raise ValueError(f"weights must be one number per point ({n}), got shape {w.shape}")
    if not np.isfinite(w).all():
        raise ValueError("weights contain NaN or infinite values")
    if len(w) and (w.min() < 0.0 or w.max() > 1.0):
        bad = w.min() if w.min() < 0.0 else w.max()
        raise ValueError(
            f"weights must be between 0 and 1 (Blender's vertex weights), got values "
            f"{'down' if bad < 0 else 'up'} to {bad}"
        )
    return w


def influence(strength: float, weights: NDArray[np.float64] | None, n: int) -> NDArray[np.float64] | None:
    """Per-point factors ``strength * weight`` (None when every point gets the full deformation)."""
    if weights is None:
        return None if strength == 1.0 else np.full(n, strength)
    return weights * strength


def blend(
    rest: NDArray[np.float64], deformed: NDArray[np.float64], factor: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """``rest + factor * (deformed - rest)`` per point, in ``deformed`` (returned); None: ``deformed``."""
    if factor is None:
        return deformed
    for d in range(3):  # column by column: NumPy runs along the long axis
        col = deformed[:, d]
        col -= rest[:, d]
        col *= factor
        col += rest[:, d]
    return deformed
