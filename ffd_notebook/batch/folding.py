"""Fold-free sampling: accept a draw only if its Jacobian determinant stays above a threshold.

The determinant is checked at every vertex and on a regular grid through the mesh's bounding
box (the box holds the mesh's volume; an inside test would need VTK, and an open surface such
as a face has no inside). A draw that fails is either drawn again from the sample's own
generator (``on_fold="redraw"``: rejection sampling, so accepted samples follow the model's
distribution restricted to fold-free draws) or shrunk by ``shrink`` until it passes
(``on_fold="scale"``: always terminates, since a zero deformation has determinant 1, but shrinks
the distribution). NumPy only.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Accepted", "FoldFree", "accept", "volume_grid"]

ON_FOLD = ("redraw", "scale")


def volume_grid(points: ArrayLike, n: int) -> NDArray[np.float64]:
    """``n^3`` points on a regular grid spanning the points' bounding box (corners included).

    Parameters
    ----------
    points : array_like
        ``(N, 3)`` points.
    n : int
        Grid points per axis.

    Returns
    -------
    numpy.ndarray
        ``(n**3, 3)`` float64 grid points.

    Examples
    --------
    >>> volume_grid([[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]], 3)[[0, -1]].tolist()
    [[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]]
    """
    pts = np.asarray(points, dtype=np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    axes = [np.linspace(lo[a], hi[a], n) for a in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


@dataclass(frozen=True)
class FoldFree:
    """When a sample counts as fold-free, and what to do with one that folds.

    Parameters
    ----------
    threshold : float
        Every accepted sample has ``det J > threshold`` at every vertex and grid point
        (``0`` only forbids folds; a positive value also forbids strong local compression).
    grid : int
        Grid points per axis through the mesh's bounding box (``grid^3`` in all; 0: vertices only).
    on_fold : {"redraw", "scale"}
        Draw again, or multiply the deformation by ``shrink`` until it passes.
    max_tries : int
        Draws (or shrinks) allowed per sample before the sample fails with an error.
    shrink : float
        Factor per step of ``on_fold="scale"``, in (0, 1).

    Examples
    --------
    >>> FoldFree(threshold=0.2, on_fold="scale").shrink
    0.8
    >>> FoldFree(on_fold="drop")
    Traceback (most recent call last):
    ...
    ValueError: on_fold must be one of ('redraw', 'scale'), got 'drop'
    """

    threshold: float = 0.1
    grid: int = 12
    on_fold: str = "redraw"
    max_tries: int = 100
    shrink: float = 0.8

    def __post_init__(self) -> None:
        if not (np.isfinite(self.threshold) and 0 <= self.threshold < 1):
            raise ValueError(f"threshold must be in [0, 1) (the identity has det J = 1), got {self.threshold!r}")
        if not (isinstance(self.grid, int) and (self.grid == 0 or self.grid >= 2)):
            raise ValueError(f"grid must be 0 or an integer >= 2, got {self.grid!r}")
        if self.on_fold not in ON_FOLD:
            raise ValueError(f"on_fold must be one of {ON_FOLD}, got {self.on_fold!r}")
        if not (isinstance(self.max_tries, int) and self.max_tries >= 1):
            raise ValueError(f"max_tries must be a positive integer, got {self.max_tries!r}")
        if not 0 < self.shrink < 1:
            raise ValueError(f"shrink must be in (0, 1), got {self.shrink!r}")


@dataclass
class Accepted:
    """The outcome of :func:`accept`: the sample, its smallest determinant and how it was reached."""

    sample: Any
    min_det_j: float
    redraws: int = 0
    scale_downs: int = 0
    seconds: dict[str, float] = field(default_factory=dict)


def accept(
    bound: Any, index: int, rng: np.random.Generator, min_det_j: Callable[[Any], float], rule: FoldFree | None
) -> Accepted:
    """Draw sample ``index`` from ``bound`` and apply the fold rule.

    ``min_det_j(sample)`` is the smallest determinant over the vertices and the volume grid.
    With ``rule=None`` the first draw is kept (its minimum determinant is still measured).

    Raises
    ------
    ValueError
        If no draw passes within ``rule.max_tries``, or the model cannot redraw (a given file).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.batch import RandomLattice
    >>> pts = np.random.default_rng(0).random((200, 3))
    >>> bound = RandomLattice(5, max_displacement=1.0, locked_borders=0).bind(pts)
    >>> def smallest(sample):
    ...     return sample.jacobian_determinant(pts).min()
    >>> out = accept(bound, 0, np.random.default_rng(3), smallest, FoldFree(threshold=0.3, on_fold="scale"))
    >>> bool(out.min_det_j > 0.3), out.scale_downs > 0
    (True, True)
    """
    seconds = {"draw": 0.0, "fold_check": 0.0}
    tic = time.perf_counter()
    sample = bound.draw(rng, index)
    seconds["draw"] += time.perf_counter() - tic
    redraws = scale_downs = 0
    while True:
        tic = time.perf_counter()
        min_det = float(min_det_j(sample))
        seconds["fold_check"] += time.perf_counter() - tic
        if rule is None or min_det > rule.threshold:
            return Accepted(sample, min_det, redraws, scale_downs, seconds)
        if redraws + scale_downs + 1 >= rule.max_tries:
            raise ValueError(
                f"no fold-free draw in {rule.max_tries} tries (last min det J {min_det:.4g} <= {rule.threshold}); "
                "lower the displacement or the threshold, or use on_fold='scale'"
            )
        tic = time.perf_counter()
        if rule.on_fold == "scale":
            sample, scale_downs = sample.scaled(rule.shrink), scale_downs + 1
        elif getattr(bound, "can_redraw", True):
            sample, redraws = bound.draw(rng, index), redraws + 1
        else:
            raise ValueError(f"folds (min det J {min_det:.4g} <= {rule.threshold}) and a given file cannot be redrawn; "
                             "use on_fold='scale'")  # fmt: skip
        seconds["draw"] += time.perf_counter() - tic
