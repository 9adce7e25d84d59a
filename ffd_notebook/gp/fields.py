"""Displacement fields on regular grids, for arrow (glyph) display.

The blog post that motivated :mod:`ffd_notebook.gp` drew a GP sample on a 5x5x5 grid as
arrows; :func:`arrow_field` does that for a process (one random draw) or for any deterministic
field (a posterior mean, an FFD's ``displacement``). :func:`sample_jointly` draws one sample
at several point sets at once (a mesh and its arrow grid) so the two pictures agree.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import GaussianKernel, GaussianProcess, arrow_field
>>> field = arrow_field(GaussianProcess(GaussianKernel(sigma=1.0)), [0, 1, 0, 1, 0, 1], rng=0)
>>> field.points.shape, field.vectors.shape
((125, 3), (125, 3))
>>> bool(np.allclose(arrow_field(lambda p: p * 0 + 1, [0, 1, 0, 1, 0, 1]).vectors, 1))
True
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .process import GaussianProcess

__all__ = ["ArrowField", "arrow_field", "grid_points", "sample_jointly"]


class ArrowField(NamedTuple):
    """Arrow positions and the displacement at each, both ``(M, 3)``.

    Parameters
    ----------
    points : numpy.ndarray
        ``(M, 3)`` arrow tails.
    vectors : numpy.ndarray
        ``(M, 3)`` displacements.

    Examples
    --------
    >>> import numpy as np
    >>> field = ArrowField(np.zeros((2, 3)), np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0]]))
    >>> field.magnitudes.tolist()
    [5.0, 1.0]
    """

    points: NDArray[np.float64]
    vectors: NDArray[np.float64]

    @property
    def magnitudes(self) -> NDArray[np.float64]:
        """Arrow lengths, ``(M,)``."""
        return np.linalg.norm(self.vectors, axis=1)


def grid_points(bounds: ArrayLike, shape: int | Sequence[int] = (5, 5, 5), margin: float = 0.0) -> NDArray[np.float64]:
    """Points of a regular grid filling a box, ``(nx * ny * nz, 3)`` in C order (x slowest).

    Parameters
    ----------
    bounds : array_like
        ``[xmin, xmax, ymin, ymax, zmin, zmax]`` (PyVista's ``mesh.bounds`` works).
    shape : int or three ints
        Points per axis.
    margin : float
        Grow the box on every side by this fraction of its largest extent.

    Returns
    -------
    numpy.ndarray
        ``(nx * ny * nz, 3)`` float64 points.

    Examples
    --------
    >>> grid_points([0, 1, 0, 2, 0, 0], shape=(2, 3, 1)).tolist()
    [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 0.0]]
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(-1)
    if b.shape != (6,) or not np.all(np.isfinite(b)) or np.any(b[1::2] < b[::2]):
        raise ValueError(f"bounds must be [xmin, xmax, ymin, ymax, zmin, zmax], got {bounds!r}")
    counts = np.broadcast_to(np.asarray(shape, dtype=np.int64), (3,))
    if np.any(counts < 1):
        raise ValueError(f"shape must be positive, got {shape!r}")
    pad = margin * float(np.max(b[1::2] - b[::2]))
    axes = [np.linspace(b[2 * a] - pad, b[2 * a + 1] + pad, int(n)) for a, n in enumerate(counts)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def arrow_field(
    source: GaussianProcess | Callable[[NDArray[np.float64]], ArrayLike],
    bounds: ArrayLike,
    shape: int | Sequence[int] = (5, 5, 5),
    margin: float = 0.0,
    rng: int | np.random.Generator | None = None,
) -> ArrowField:
    """Evaluate a displacement field on a regular grid.

    Parameters
    ----------
    source : GaussianProcess or callable
        A process (one random sample is drawn, with ``rng``) or a function
        ``points -> (M, 3)`` such as ``process.mean`` or ``FFD(lattice).displacement``.
    bounds, shape, margin
        The grid, see :func:`grid_points`.
    rng : int or Generator, optional
        Random state for a process sample.

    Returns
    -------
    ArrowField
        The grid points and the displacement at each.

    Examples
    --------
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
    >>> lat.offsets[..., 2] = 0.5
    >>> field = arrow_field(FFD(lat).displacement, [0, 1, 0, 1, 0, 1], shape=2)
    >>> field.points.shape, field.magnitudes.round(6).tolist()
    ((8, 3), [0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5])
    """
    pts = grid_points(bounds, shape, margin)
    if isinstance(source, GaussianProcess):
        vectors = source.sample(pts, n=1, rng=rng)[0]
    else:
        vectors = np.asarray(source(pts), dtype=np.float64)
        if vectors.shape != pts.shape:
            raise ValueError(f"the field returned shape {vectors.shape}, expected {pts.shape}")
    return ArrowField(pts, vectors)


def sample_jointly(
    process: GaussianProcess, point_sets: Sequence[ArrayLike], rng: int | np.random.Generator | None = None
) -> list[NDArray[np.float64]]:
    """One sample of ``process`` drawn at all point sets together, split back, ``[(N_i, 3), ...]``.

    Parameters
    ----------
    process : GaussianProcess
        The process.
    point_sets : sequence of array_like
        Point sets ``(N_i, 3)``.
    rng : int or numpy.random.Generator, optional
        The random source.

    Returns
    -------
    list of numpy.ndarray
        One ``(N_i, 3)`` field per point set, from one joint draw.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import GaussianKernel, GaussianProcess
    >>> a = np.zeros((2, 3)); b = np.zeros((1, 3))
    >>> ua, ub = sample_jointly(GaussianProcess(GaussianKernel(1.0)), [a, b], rng=0)
    >>> bool(np.allclose(ua[0], ub[0], atol=1e-5))    # same point, same displacement
    True
    """
    sets = [as_points(p) for p in point_sets]
    drawn = process.sample(np.vstack(sets), n=1, rng=rng)[0]
    return np.split(drawn, np.cumsum([len(s) for s in sets])[:-1])
