"""``T(x)`` of an FFD on a regular grid whose axes run along the lattice's: a tensor product, three small contractions.

When every image axis runs along one lattice axis (a lattice fitted to the image, a
registration's control grid), lattice coordinate ``u_a`` of voxel ``(i, j, k)`` depends on one
index only, so the B-spline (or Bernstein) weights of the whole grid are three small per-axis
matrices ``W_i (I, n), W_j (J, n), W_k (K, n)`` and

    T_local(i, j, k) = sum_abc W_i[i, a] W_j[j, b] W_k[k, c] P[a, b, c]

is contracted one axis at a time: ``K n n`` values, then ``K J n``, then one BLAS product per
component for the whole slab, with the affine part and the move into the input's index frame
folded in (two more columns, ``i`` and ``1``, on ``W_i``). The weights come from the engine's
border rule (:func:`axis_support`), so "zero" and "clamp" are what ``FFD.deform`` computes; any
grid or FFD this does not cover (a lattice turned against the image, ``only_inside``, a basis
given per axis) is left to :class:`~.sample.IndexSampler`, which calls ``deform``.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..ffd import FFD
from ..ffd.basis import bernstein
from ..ffd.support import axis_support
from .geometry import ImageGrid
from .sample import Deformation, IndexSampler

__all__ = ["GridFFDSampler", "index_sampler"]

_ALIGNED = 1e-9  # largest lattice-coordinate error, across the whole grid, of treating the axes as aligned


def _axis_pairs(along: NDArray[np.float64], size: tuple[int, int, int]) -> list[int] | None:
    """For each lattice axis, the one grid axis it runs along (``along[a, g]``: ``du_a / d index_g``), or None."""
    pairs = []
    for row in along:
        spans = np.abs(row) * (np.array(size) - 1)  # how far u_a moves across the grid along each grid axis
        g = int(np.argmax(np.abs(row)))
        if np.delete(spans, g).max(initial=0.0) > _ALIGNED:
            return None
        pairs.append(g)
    return pairs if sorted(pairs) == [0, 1, 2] else None


class GridFFDSampler(IndexSampler):
    """Input indices of ``T(x)`` for an FFD on a grid aligned with its lattice, by separable contraction.

    Same results as :class:`~.sample.IndexSampler` (to rounding); build with :func:`index_sampler`.
    """

    def __init__(self, ffd: FFD, reference: ImageGrid, source: ImageGrid, pairs: list[int]) -> None:
        super().__init__(ffd, reference, source)
        lat = ffd.lattice
        size = reference.size + (1,) * (3 - reference.dim)
        to_lattice = (lat.rotation / lat.spacing).T  # x -> u: to_lattice @ (x - origin)
        along = to_lattice @ self.to_physical[:3, :3]
        start = to_lattice @ (self.to_physical[:3, 3] - lat.origin)
        # weights per grid axis g: (size_g, n_a) for the lattice axis a running along it
        self._weights: list[NDArray[np.float64]] = [np.empty(0)] * 3
        for a, g in enumerate(pairs):
            u = start[a] + along[a, g] * np.arange(size[g], dtype=np.float64)
            self._weights[g] = self._axis_weights(ffd, u, lat.shape[a])
        # offsets moved into the input's index frame, their axes put in grid order (i, j, k)
        to_index = self.to_index[:3, :3]
        axes_by_grid = [pairs.index(g) for g in range(3)]
        self._offsets = np.ascontiguousarray((lat.offsets @ to_index.T).transpose(*axes_by_grid, 3))
        # the rest: index of A x + b, affine in (i, j, k): c = linear @ (i, j, k) + constant
        affine = ffd.affine
        self._linear = to_index @ affine[:3, :3] @ self.to_physical[:3, :3]
        self._constant = to_index @ (affine[:3, :3] @ self.to_physical[:3, 3] + affine[:3, 3]) + self.to_index[:3, 3]
        n_i = self._weights[0].shape[1]
        i = np.arange(size[0], dtype=np.float64)
        self._w_i = np.ascontiguousarray(np.column_stack([self._weights[0], i, np.ones_like(i)]).T)  # (n_i + 2, I)
        self._n_i = n_i
        if reference.dim == 2:  # k = 0 only: contract it once
            self._plane = np.einsum("c,abcm->abm", self._weights[2][0], self._offsets)

    @staticmethod
    def _axis_weights(ffd: FFD, u: NDArray[np.float64], n: int) -> NDArray[np.float64]:
        if ffd.basis == "bernstein":
            return bernstein(u / (n - 1), n - 1)
        index, weight = axis_support(u, n, ffd.border)
        dense = np.zeros((len(u), n))
        np.add.at(dense, (np.arange(len(u))[:, None], index), weight)  # "clamp" repeats a border index
        return dense

    def rows(self, start: int, stop: int) -> NDArray[np.float64]:
        dim = self.source.dim
        _, w_j, w_k = self._weights
        if self.reference.dim == 3:
            ks = np.arange(start, stop, dtype=np.float64)
            js = np.arange(w_j.shape[0], dtype=np.float64)
            q = np.einsum("kc,abcm->mkab", w_k[start:stop], self._offsets, optimize=True)
            r = np.einsum("jb,mkab->mkja", w_j, q, optimize=True)  # (3, K, J, n_i)
            rest = (
                self._linear[:, 1, None, None] * js[None, None, :] + self._linear[:, 2, None, None] * ks[None, :, None]
            )
        else:
            js = np.arange(start, stop, dtype=np.float64)
            r = np.einsum("jb,abm->mja", w_j[start:stop], self._plane, optimize=True)  # (3, J, n_i)
            rest = self._linear[:, 1, None] * js[None, :]
        lead = r.shape[1:-1]
        augmented = np.empty((*r.shape[:-1], self._n_i + 2))
        augmented[..., : self._n_i] = r
        augmented[..., self._n_i] = self._linear[:, 0].reshape(3, *([1] * len(lead)))
        augmented[..., self._n_i + 1] = rest + self._constant.reshape(3, *([1] * len(lead)))
        out = np.empty((dim, *lead, self._w_i.shape[1]))
        for m in range(dim):  # input axis m (i, j, k) is row dim - 1 - m of the result (array order)
            np.matmul(
                augmented[m].reshape(-1, self._n_i + 2), self._w_i, out=out[dim - 1 - m].reshape(-1, out.shape[-1])
            )
        return out


def index_sampler(deformation: object, reference: ImageGrid, source: ImageGrid) -> IndexSampler:
    """The fastest exact way to get input indices of ``T(x)`` on ``reference``: separable for an aligned FFD.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> grid = ImageGrid((30, 20, 10), spacing=(1.0, 1.5, 2.0))
    >>> lat = Lattice.around(grid.physical_points(), shape=6)
    >>> lat.offsets[...] = np.random.default_rng(0).normal(size=lat.offsets.shape)
    >>> fast, slow = index_sampler(FFD(lat), grid, grid), IndexSampler(FFD(lat), grid, grid)
    >>> type(fast).__name__, bool(np.allclose(fast.rows(3, 5), slow.rows(3, 5), atol=1e-9))
    ('GridFFDSampler', True)
    """
    if isinstance(deformation, FFD) and deformation.basis in ("bspline", "bernstein") and not deformation.only_inside:
        lat = deformation.lattice
        to_physical = reference.index_to_physical()[:3, :3]
        along = (lat.rotation / lat.spacing).T @ to_physical
        size = reference.size + (1,) * (3 - reference.dim)
        pairs = _axis_pairs(along, cast("tuple[int, int, int]", size))
        if pairs is not None:
            return GridFFDSampler(deformation, reference, source, pairs)
    return IndexSampler(cast(Deformation, deformation), reference, source)  # it checks for deform(points)
