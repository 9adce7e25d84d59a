"""Quality of statistical shape models: compactness, generalization and specificity (Styner et al. 2003).

- :func:`compactness`: the variance the first ``M`` components hold, ``M = 1..rank`` — a compact
  model explains much with few.
- :func:`generalization`: leave one example out, build the model from the rest, and measure how
  far the left-out shape is from its closest instance using ``M`` components (mean vertex
  distance) — can the model describe shapes it has not seen.
- :func:`specificity`: draw random instances with ``M`` components and measure the distance to
  the closest training shape — does the model only produce valid shapes.

Shapes are ``(N, 3)`` arrays or meshes with ``.points`` in correspondence with the reference.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.gp import LowRankGP
>>> ref = np.random.default_rng(0).random((60, 3))
>>> rng = np.random.default_rng(1)
>>> shapes = [ref * (1 + 0.1 * rng.normal()) + rng.normal(0, 0.05, 3) for _ in range(8)]   # 4 modes
>>> model = LowRankGP.from_examples(ref, shapes)
>>> model.rank, bool(np.isclose(compactness(model)[-1], model.kept_variance))
(4, True)
>>> bool(generalization(ref, shapes)[3] < 1e-10)      # 4 components describe an unseen shape exactly
True
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .linalg import as_generator
from .lowrank import LowRankGP

__all__ = ["compactness", "generalization", "specificity"]


def _shapes(meshes: Sequence[ArrayLike | object]) -> NDArray[np.float64]:
    return np.stack([as_points(getattr(m, "points", m), f"meshes[{i}]") for i, m in enumerate(meshes)])


def _mean_distance(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean vertex-to-vertex distance between shapes ``(..., N, 3)``."""
    return np.linalg.norm(a - b, axis=-1).mean(axis=-1)


def compactness(model: LowRankGP) -> NDArray[np.float64]:
    """Cumulative variance of the first ``M`` components, ``M = 1..rank`` (``(rank,)``).

    Parameters
    ----------
    model : LowRankGP
        The model.

    Returns
    -------
    numpy.ndarray
        ``(rank,)`` cumulative variances, increasing.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import LowRankGP
    >>> rng = np.random.default_rng(0)
    >>> ref = rng.random((30, 3))
    >>> meshes = [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)]
    >>> c = compactness(LowRankGP.from_examples(ref, meshes))
    >>> len(c), bool(np.all(np.diff(c) >= 0))
    (4, True)
    """
    return np.cumsum(model.eigenvalues)


def generalization(reference: ArrayLike | object, meshes: Sequence[ArrayLike | object]) -> NDArray[np.float64]:
    """Leave-one-out reconstruction error with ``M = 1..n-2`` components, ``(n - 2,)``.

    For each example, a model is built from the other ``n - 1`` (at most ``n - 2`` components),
    the example is projected onto its first ``M`` components, and the mean vertex distance to
    the example is averaged over the examples. Decreases with ``M``.

    Parameters
    ----------
    reference : array_like or mesh
        ``(N, 3)`` reference points (or a mesh).
    meshes : sequence
        At least 3 shapes in correspondence with the reference.

    Returns
    -------
    numpy.ndarray
        ``(n - 2,)`` mean point distances, for ``M = 1..n-2`` components.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import LowRankGP
    >>> rng = np.random.default_rng(0)
    >>> ref = rng.random((30, 3))
    >>> meshes = [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)]
    >>> generalization(ref, meshes).shape
    (3,)
    """
    ref = as_points(getattr(reference, "points", reference), "reference")
    shapes = _shapes(meshes)
    n = len(shapes)
    if n < 3:
        raise ValueError(f"generalization needs at least 3 meshes, got {n}")
    errors = np.zeros((n, n - 2))
    for i in range(n):
        others = cast("Sequence[NDArray[np.float64]]", np.delete(shapes, i, axis=0))  # an array is a sequence of shapes
        model = LowRankGP.from_examples(ref, others)
        coef = model.coefficients(shapes[i] - ref)  # orthonormal basis: truncating c is projecting
        for m in range(n - 2):
            c = np.where(np.arange(model.rank) <= m, coef, 0.0)
            errors[i, m] = _mean_distance(ref + model.instance(c), shapes[i])
    return errors.mean(axis=0)


def specificity(
    model: LowRankGP,
    meshes: Sequence[ArrayLike | object],
    n_samples: int = 100,
    rng: int | np.random.Generator | None = None,
) -> NDArray[np.float64]:
    """Mean distance of random instances to the closest training shape, with ``M = 1..rank`` components.

    ``n_samples`` coefficient vectors are drawn once; for each ``M`` the first ``M`` are used
    (the rest zero). Returns ``(rank,)``.

    Parameters
    ----------
    model : LowRankGP
        The model.
    meshes : sequence
        The training shapes.
    n_samples : int
        Random instances per number of components.
    rng : int or numpy.random.Generator, optional
        The random source.

    Returns
    -------
    numpy.ndarray
        ``(rank,)`` mean distances.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.gp import LowRankGP
    >>> rng = np.random.default_rng(0)
    >>> ref = rng.random((30, 3))
    >>> meshes = [ref + 0.05 * rng.standard_normal((30, 3)) for _ in range(5)]
    >>> specificity(LowRankGP.from_examples(ref, meshes), meshes, n_samples=10, rng=0).shape
    (4,)
    """
    shapes = _shapes(meshes)
    coefs = as_generator(rng).standard_normal((n_samples, model.rank))
    out = np.zeros(model.rank)
    for m in range(model.rank):
        for c in coefs:
            instance = model.points + model.instance(np.where(np.arange(model.rank) <= m, c, 0.0))
            out[m] += _mean_distance(instance[None], shapes).min()
    return out / n_samples
