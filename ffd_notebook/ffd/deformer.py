"""An FFD bound to one point set: cached weights, full and incremental updates (the drag path).

The points are grouped by :class:`~ffd_notebook.ffd.support.CellGroups` and a control point's share of
each group's supports comes from :func:`~ffd_notebook.ffd.support.support_slots`: the border rule is
:mod:`~ffd_notebook.ffd.support`'s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .basis import bernstein_values
from .influence import blend, check_strength, influence, point_weights
from .interpolation import axis_bases
from .jacobian import bspline_lattice_jacobian, det3, jacobian_to_world
from .outside import outside_offsets
from .support import CellGroups, in_domain, outer_uv, support_slots

if TYPE_CHECKING:
    from .deform import FFD

__all__ = ["Deformer"]


class Deformer:
    """An FFD bound to one point set, for fast repeated evaluation (the editor's drag path).

    What does not change while offsets are edited is computed once: each point's lattice cell
    and its basis values. Points are grouped by cell, so a full update is one small matrix
    product per cell; an update for a few changed control points touches only the cells they
    influence and adds ``weight * (new offset - old offset)``.

    Parameters
    ----------
    ffd : FFD
        The deformation; its lattice's offsets and affine are read at each update.
    points : array_like
        ``(N, 3)`` rest positions.
    dtype : numpy dtype
        Precision of the cached weights: ``float32`` (default, 88 bytes a point for the
        B-spline basis, about 1e-7 relative error) or ``float64`` (exact to rounding).
    strength : float, optional
        Scales every point's displacement (Blender's modifier strength); by default the FFD's
        :attr:`~ffd_notebook.FFD.strength`, read at each update.
    weights : array_like or str, optional
        One weight in [0, 1] per point scaling its displacement (Blender's vertex group), or the
        name of a point-data array of the mesh given as ``points``: the deformer's own, kept
        whatever the FFD's become. By default the FFD's :attr:`~ffd_notebook.FFD.weights`,
        followed as its strength is: read again at each update when they were set or edited.
        Settable later (:attr:`weights`, which makes them the deformer's own).

    Notes
    -----
    :meth:`update` returns an internal buffer that the next update overwrites: copy it if you
    need to keep it. Changing the affine part, the lattice's shape or placement needs a new
    deformer (:meth:`update` checks and rebinds automatically when they change).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice, FFD
    >>> pts = np.random.default_rng(0).random((1000, 3))
    >>> lat = Lattice.around(pts, shape=(6, 6, 6))
    >>> ffd = FFD(lat)
    >>> deformer = ffd.bind(pts)
    >>> lat.offsets[2, 3, 2] = (0.1, 0.0, 0.0)
    >>> fast = deformer.update(changed=[(2, 3, 2)])
    >>> bool(np.allclose(fast, ffd.deform(pts), atol=1e-6))
    True
    """

    def __init__(
        self, ffd: FFD, points: ArrayLike, dtype: Any = np.float32, *, strength: Any = None, weights: Any = None
    ) -> None:
        self.ffd = ffd
        self.points = as_points(points)
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64, got {self.dtype}")
        self._strength = None if strength is None else check_strength(strength)
        self._mesh = None if isinstance(points, np.ndarray) else points  # where a weights name is looked up
        self._own_weights = weights is not None
        if self._own_weights:
            self._weights = point_weights(weights, len(self.points), mesh=points)
        else:
            self._weights = self._followed_weights()
        self._bind()

    @property
    def strength(self) -> float:
        """The strength in use: the one given at binding, else the FFD's."""
        return self.ffd.strength if self._strength is None else self._strength

    def _followed_weights(self) -> NDArray[np.float64] | None:
        """The FFD's weights for these points, remembering what they were read from (see :meth:`_weights_moved`)."""
        given = self.ffd.weights
        weights = point_weights(given, len(self.points), mesh=self._mesh)  # (refused: read again next time)
        self._source = (given, given.copy() if isinstance(given, np.ndarray) else given)
        return weights

    def _weights_moved(self) -> bool:
        """Whether the FFD's weights, followed by this deformer, were set or edited since they were read."""
        if self._own_weights:
            return False
        given, (read, values) = self.ffd.weights, self._source
        if isinstance(given, np.ndarray):
            return not (isinstance(values, np.ndarray) and np.array_equal(given, values))
        return given is not read

    def _follow_weights(self) -> bool:
        """Take the FFD's weights if they moved (re-weighting the cache and evaluating): whether they did."""
        if not self._weights_moved():
            return False
        self._weights = self._followed_weights()
        self._apply_weights()
        return True

    @property
    def weights(self) -> NDArray[np.float64] | None:
        """Per-point weights in [0, 1] (None: all 1). Setting them re-weights the cache and evaluates once.

        Until set here (or given at binding) they are the FFD's, read again when they change.
        Setting them makes them the deformer's own: later changes of the FFD's are not followed
        (the editor's brush paints a stroke's weights here before they become the FFD's). The cell
        grouping stays: only the last axis' weights and the affine image are redone (a few ms on
        the 53k face, where binding takes tens; the weight brush sets them per event).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(0).random((100, 3))
        >>> lat = Lattice.around(pts, shape=4, border="clamp")
        >>> lat.offsets[...] = (0.0, 0.0, 1.0)
        >>> deformer = FFD(lat).bind(pts)
        >>> deformer.weights = np.linspace(0, 1, 100)
        >>> moved = deformer.update() - pts
        >>> bool(np.allclose(moved[:, 2], np.linspace(0, 1, 100)))
        True
        """
        self._follow_weights()
        return self._weights

    @weights.setter
    def weights(self, value: Any) -> None:
        self._weights = point_weights(value, len(self.points), mesh=self._mesh)
        self._own_weights = True
        self._apply_weights()

    def _apply_weights(self) -> None:
        """Re-weight the cache for new :attr:`weights` (rebind if the geometry changed too) and evaluate."""
        if (
            self._cells is None
            or self._geometry_key() != self._key
            or not np.array_equal(self.ffd.affine, self._affine)
        ):
            self._bind()
            return
        self._reweight()

    def _last_axis_weights(self, uvw: NDArray[np.float64], order: Any = slice(None)) -> NDArray[np.float64]:
        """The w-axis weights of the points (in ``order``) with "only inside" and strength * weight applied."""
        lat, n = self.ffd.lattice, len(self.points)
        sorted_uvw = uvw[order]
        t = sorted_uvw[:, 2] - np.floor(sorted_uvw[:, 2])
        bw = axis_bases(self.ffd.basis)[2].weights(t)
        if self.ffd.only_inside:
            bw[~in_domain(self.ffd.basis, lat.shape, sorted_uvw, self.ffd.only_inside)] = 0.0
        factor = influence(self.strength, self._weights, n)
        if factor is not None:
            bw *= factor[order, None]
        return bw

    def _reweight(self) -> None:
        """New per-point factors on the same grouping: the w-axis weights and the affine image, then evaluate."""
        cells = self._cells
        assert cells is not None  # reweighting keeps the B-spline grouping
        uvw = self.ffd.lattice.to_lattice(self.points)
        self._bw = self._last_axis_weights(uvw, cells.order).astype(self.dtype)
        factor = influence(self.strength, self._weights, len(self.points))
        base = blend(self.points, np.array(self.ffd.apply_affine(self.points), dtype=np.float64), factor)
        self._base = base[cells.order]
        self._last_offsets = self._offsets().copy()
        self._full()

    def _offsets(self) -> NDArray[np.float64]:
        """The offsets the deformation uses: the lattice's, or with "outside" the inner ones derived."""
        offsets = self.ffd.lattice.offsets
        return outside_offsets(offsets) if self.ffd.outside else offsets

    # ------------------------------------------------------------------ set-up
    def _geometry_key(self) -> tuple:
        lat = self.ffd.lattice
        geometry = (lat.shape, lat.spacing.tobytes(), lat.origin.tobytes(), lat.rotation.tobytes())
        return (self.ffd.basis, self.ffd.border, self.ffd.only_inside, self.ffd.outside, self.strength, *geometry)

    def _bind(self) -> None:
        lat, n = self.ffd.lattice, len(self.points)
        self._key = self._geometry_key()
        self._affine = self.ffd.affine.copy()
        uvw = lat.to_lattice(self.points)
        self._cells: CellGroups | None = None
        # points the lattice may displace (all unless only_inside): the others get zero weights
        movable = in_domain(self.ffd.basis, lat.shape, uvw, self.ffd.only_inside) if self.ffd.only_inside else None
        # strength * weight per point: the displacement is linear in one weight factor, scale that
        factor = influence(self.strength, self._weights, n)
        if self.ffd.basis != "bernstein":
            cells = CellGroups(uvw, lat.shape, self.ffd.border)
            bases = axis_bases(self.ffd.basis)
            t = cells.t
            assert t is not None  # a fresh grouping keeps its t
            bu, bv, bw = (bases[a].weights(t[:, a]) for a in range(3))
            self._buv = outer_uv(bu, bv).astype(self.dtype)
            if movable is not None:
                bw[~movable[cells.order]] = 0.0
            if factor is not None:
                bw *= factor[cells.order, None]
            self._bw = bw.astype(self.dtype)
            cells.t = None  # not needed after the weights: keep the cache small
            self._cells = cells
            # inverse permutation: original point p sits at sorted position inverse[p]
            self._inverse = np.empty_like(cells.order)
            self._inverse[cells.order] = np.arange(n, dtype=cells.order.dtype)
            # deformed positions in sorted order: affine image + displacement, brought back to the
            # points' order by one gather (np.take) per update
            self._sorted = np.zeros((n, 3))
        else:
            bx, by, bz = bernstein_values(lat.shape, uvw)
            nx, ny, _ = lat.shape
            self._bxy = (bx[:, :, None] * by[:, None, :]).reshape(n, nx * ny).astype(self.dtype)
            if movable is not None:
                bz[~movable] = 0.0
            if factor is not None:
                bz *= factor[:, None]
            self._bz = bz.astype(self.dtype)
        self._base = blend(self.points, np.array(self.ffd.apply_affine(self.points), dtype=np.float64), factor)
        if self._cells is not None:
            self._base = self._base[self._cells.order]  # only ever used in sorted order
        self._out = np.empty((n, 3), dtype=np.float64)
        self._last_offsets = self._offsets().copy()
        self._full()

    @property
    def cache_bytes(self) -> int:
        """Bytes of weights and indices held for fast updates.

        Not counted: the rest points, the affine image of the points and the working and
        output buffers (three ``(N, 3)`` float64 arrays any evaluation needs).
        """
        arrays = [getattr(self, k) for k in ("_buv", "_bw", "_inverse", "_bxy", "_bz") if hasattr(self, k)]
        if self._cells is not None:
            arrays += [self._cells.order, self._cells.runs, self._cells.run_first]
        return int(sum(a.nbytes for a in arrays))

    # ------------------------------------------------------------------ updates
    def update(self, changed: Any = None) -> NDArray[np.float64]:
        """Deformed points for the lattice's current offsets, ``(N, 3)`` float64.

        Parameters
        ----------
        changed : sequence of (i, j, k), optional
            Control points whose offsets changed since the last update; only the points they
            influence are recomputed. ``None`` recomputes everything.

        Returns
        -------
        numpy.ndarray
            The deformer's output buffer (overwritten by the next call).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> pts = np.random.default_rng(0).random((100, 3))
        >>> deformer = FFD(Lattice.around(pts, shape=5)).bind(pts, dtype=np.float64)
        >>> deformer.ffd.lattice.offsets[2, 2, 2] = (0.0, 0.2, 0.0)
        >>> moved = deformer.update(changed=[(2, 2, 2)])
        >>> bool(np.allclose(moved, deformer.ffd.deform(pts)))
        True
        """
        if self._follow_weights():  # new weights of the FFD: re-weighted (or rebound) and evaluated
            return self._out
        if self._geometry_key() != self._key or not np.array_equal(self.ffd.affine, self._affine):
            self._bind()
            return self._out
        if changed is None:
            self._full()
            return self._out
        ijk = np.asarray(changed, dtype=np.int64).reshape(-1, 3)
        if np.any(ijk < 0) or np.any(ijk >= np.array(self.ffd.lattice.shape)):
            raise IndexError(f"control point index out of range for lattice {self.ffd.lattice.shape}: {changed!r}")
        offsets = self._offsets()
        if self.ffd.outside:  # a surface point moves inner ones too: the changed ones are those that moved
            ijk = np.argwhere(np.any(offsets != self._last_offsets, axis=-1))
        ijk = np.unique(ijk, axis=0)
        index = tuple(ijk.T)
        moved = [tuple(c) for c in ijk[np.any(offsets[index] != self._last_offsets[index], axis=1)].tolist()]
        if self._cells is None:  # Bernstein
            for i, j, k in moved:
                self._add_bernstein(i, j, k, offsets[i, j, k] - self._last_offsets[i, j, k])
                self._last_offsets[i, j, k] = offsets[i, j, k]
            return self._out
        plans, n_hit = [], 0
        for c in moved:
            plans.append(self._runs_moved_by(c))
            n_hit += int(np.diff(self._cells.runs[plans[-1][0]], axis=1).sum())
            if n_hit > len(self.points):  # e.g. a fit_points step moving 64 control points: one full pass is cheaper
                self._full()
                return self._out
        # many points: add in sorted order (contiguous) and gather once; few: touch only those rows
        gather_all = n_hit > len(self.points) // 4
        for (i, j, k), plan in zip(moved, plans, strict=True):
            self._add_control_point(plan, offsets[i, j, k] - self._last_offsets[i, j, k], gather_all)
            self._last_offsets[i, j, k] = offsets[i, j, k]
        if gather_all:
            self._refresh_all()
        return self._out

    def current(self) -> NDArray[np.float64]:
        """Deformed points for the current FFD, evaluated only if it changed since the last evaluation.

        Binding evaluates once; installing a freshly bound deformer need not evaluate again (on a
        500k-point mesh a full evaluation takes about a second, and the editor installs on its event loop).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)``: the deformer's output buffer (overwritten by the next evaluation).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(0).random((200, 3))
        >>> deformer = FFD(Lattice.around(pts, shape=4)).bind(pts)
        >>> deformer.current() is deformer.update()
        True
        >>> deformer.ffd.lattice.offsets[1, 1, 1] = (0.0, 0.0, 0.1)
        >>> bool(np.allclose(deformer.current(), deformer.ffd.deform(pts)))
        True
        """
        same_geometry = self._geometry_key() == self._key and np.array_equal(self.ffd.affine, self._affine)
        if same_geometry and not self._weights_moved() and np.array_equal(self._offsets(), self._last_offsets):
            return self._out
        return self.update()

    def jacobian_determinant(self, *, strength: float | None = None) -> NDArray[np.float64]:
        """``det dT/dx`` at the bound points for the current offsets (``<= 0`` where it folds).

        The same values as :meth:`FFD.jacobian_determinant` on the bound points, reusing the
        cached grouping of points by cell (the editor's folding view calls it on every drag).

        Parameters
        ----------
        strength : float, optional
            Another strength than :attr:`strength` (the editor's blend shows ``t`` times the deformation).

        Returns
        -------
        numpy.ndarray
            ``(N,)`` float64 determinants, in the order of the bound points.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(0).random((500, 3))
        >>> lat = Lattice.around(pts, shape=5)
        >>> lat.offsets[2, :, :, 0] -= 2.5 * lat.spacing[0]
        >>> ffd = FFD(lat)
        >>> bool(np.allclose(ffd.bind(pts).jacobian_determinant(), ffd.jacobian_determinant(pts)))
        True
        """
        if not self._follow_weights() and (
            self._geometry_key() != self._key or not np.array_equal(self.ffd.affine, self._affine)
        ):
            self._bind()
        strength = self.strength if strength is None else check_strength(strength)
        if self._cells is None:  # Bernstein: every control point reaches every point
            return det3(self.ffd.jacobian(self.points, strength=strength, weights=self._weights))
        uvw = self.ffd.lattice.to_lattice(self.points)[self._cells.order]
        bases = axis_bases(self.ffd.basis)
        d_uvw = bspline_lattice_jacobian(self._cells, self._offsets(), uvw - np.floor(uvw), bases=bases)
        if self.ffd.only_inside:
            d_uvw[~in_domain(self.ffd.basis, self.ffd.lattice.shape, uvw, self.ffd.only_inside)] = 0.0
        jacobian = jacobian_to_world(self.ffd.lattice, self.ffd.affine, d_uvw)
        factor = influence(strength, self._weights, len(self.points))
        if factor is not None:  # I + f (J - I): the weights are constants of the points
            jacobian -= np.eye(3)
            jacobian *= factor[self._cells.order, None, None]
            jacobian += np.eye(3)
        return det3(jacobian)[self._inverse]

    def _full(self) -> None:
        offsets = self._offsets()
        self._last_offsets[...] = offsets
        if self.ffd.basis == "bernstein":
            nx, ny, nz = self.ffd.lattice.shape
            x = self._bxy @ offsets.reshape(nx * ny, nz * 3).astype(self.dtype)
            local = np.einsum("pkd,pk->pd", x.reshape(-1, nz, 3), self._bz)
            np.add(self._base, local, out=self._out)
            return
        cells = self._cells
        assert cells is not None  # the B-spline basis groups its points
        local = cells.sum(cells.pad(offsets, self.dtype), self._buv, self._bw)
        np.add(self._base, local, out=self._sorted)
        self._refresh_all()

    def _refresh_all(self) -> None:
        """Bring the sorted deformed positions back to the points' order (one gather)."""
        np.take(self._sorted, self._inverse, axis=0, out=self._out)

    def _add_bernstein(self, i: int, j: int, k: int, delta: NDArray[np.float64]) -> None:
        w = self._bxy[:, i * self.ffd.lattice.shape[1] + j] * self._bz[:, k]
        self._out += w[:, None].astype(np.float64) * delta

    def _runs_moved_by(
        self, ijk: tuple[int, int, int]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
        """The runs (cells) a control point moves, and the support slots ``lo..hi`` it fills in each."""
        cells = self._cells
        assert cells is not None  # the B-spline basis groups its points
        lo, hi = support_slots(np.array(ijk), cells.run_first, self.ffd.lattice.shape, cells.border)
        hit = np.flatnonzero(np.all(lo <= hi, axis=1))
        return hit, lo[hit], hi[hit]

    def _add_control_point(self, plan: tuple, delta: NDArray[np.float64], sorted_only: bool) -> None:
        """Add one control point's ``weight * delta`` to the runs of ``plan`` (see :meth:`_runs_moved_by`)."""
        from scipy.linalg.blas import dger  # here: the engine imports without SciPy (in Blender's Python)

        hit, lo, hi = plan
        cells = self._cells
        assert cells is not None  # the B-spline basis groups its points
        for (s, e), l, h in zip(cells.runs[hit], lo, hi, strict=True):
            w = self._weight(s, e, l, h)
            # rank-one update sorted += w delta^T in place (BLAS dger on the F-ordered transpose)
            dger(1.0, delta, w, a=self._sorted[s:e].T, overwrite_a=1)
            if not sorted_only:
                self._out[cells.order[s:e]] += w[:, None] * delta

    def _weight(self, s: int, e: int, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> NDArray[np.float64]:
        """Weight of one control point on sorted points ``s:e`` that fills support slots ``lo..hi``."""
        (l0, m0, n0), (l1, m1, n1) = lo, hi
        if l0 == l1 and m0 == m1 and n0 == n1:  # one slot (always, with the "zero" border)
            return np.multiply(self._buv[s:e, l0 * 4 + m0], self._bw[s:e, n0], dtype=np.float64)
        # clamp: the control point stands in for the out-of-lattice slots too; add their weights
        buv = self._buv[s:e].reshape(-1, 4, 4)[:, l0 : l1 + 1, m0 : m1 + 1].sum(axis=(1, 2), dtype=np.float64)
        return buv * self._bw[s:e, n0 : n1 + 1].sum(axis=1, dtype=np.float64)
