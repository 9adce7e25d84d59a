"""Free-form deformation: a global affine part plus a lattice of control-point offsets.

``T(x) = A x + b + T_local(x)`` (Rueckert et al. 1999). ``T_local`` is either the tensor
product of uniform cubic B-splines over the lattice cells (control points outside the lattice
contribute zero; identical to SimpleITK's ``BSplineTransform`` of order 3 on the same grid), or
the Sederberg-Parry Bernstein form over the lattice's whole box.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg.blas import dger

from . import _oneshot
from .basis import bernstein, bernstein_derivative, bspline, bspline_cells, bspline_derivative
from .lattice import Lattice, _as_points

__all__ = ["BASES", "FFD", "Deformer"]

BASES = ("bspline", "bernstein")


def _check_affine(affine: ArrayLike | None) -> NDArray[np.float64]:
    if affine is None:
        return np.eye(4)
    a = np.array(affine, dtype=np.float64)
    if a.shape == (3, 4):
        a = np.vstack([a, [0.0, 0.0, 0.0, 1.0]])
    if a.shape != (4, 4) or not np.allclose(a[3], [0, 0, 0, 1]) or not np.all(np.isfinite(a)):
        raise ValueError("affine must be a finite 4x4 homogeneous matrix (or 3x4 [A | b])")
    return a


class FFD:
    """A free-form deformation defined by a lattice and an optional affine part.

    Parameters
    ----------
    lattice : Lattice
        The control lattice; its ``offsets`` are read at every evaluation (edit them in place).
    basis : {"bspline", "bernstein"}
        ``"bspline"``: uniform cubic B-splines, local support (each point moves with the 4x4x4
        control points around it). ``"bernstein"``: Sederberg-Parry, every control point moves
        every point inside the lattice box (points outside are extrapolated polynomially).
    affine : array_like, optional
        4x4 homogeneous (or 3x4) matrix of the global part ``x -> A x + b``; identity if omitted.
    only_inside : bool
        If true, the lattice displaces only the points inside its domain and leaves the others
        to the affine part alone: the box ``0 <= u <= n - 1`` (lattice coordinates) for the
        Bernstein basis, as PyGeM does, and the region where the B-spline weights sum to one,
        ``1 <= u <= n - 2``, for the B-spline basis, as ITK's ``BSplineTransform`` does. The
        deformation is then discontinuous where the offsets near the domain's faces are not zero.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice, FFD
    >>> lat = Lattice((4, 4, 4), spacing=1.0, origin=(-1, -1, -1))
    >>> lat.offsets[1, 1, 1] = (0.0, 0.0, 6.0)
    >>> FFD(lat).deform([[0.0, 0.0, 0.0]]).round(6).tolist()   # B1(0)^3 * 6 = (2/3)^3 * 6
    [[0.0, 0.0, 1.777778]]
    """

    def __init__(
        self, lattice: Lattice, basis: str = "bspline", affine: ArrayLike | None = None, only_inside: bool = False
    ) -> None:
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        if basis not in BASES:
            raise ValueError(f"basis must be one of {BASES}, got {basis!r}")
        if basis == "bspline" and min(lattice.shape) < 4:
            raise ValueError(f"the cubic B-spline basis needs at least 4 control points per axis, got {lattice.shape}")
        self.lattice = lattice
        self.basis = basis
        self.affine = _check_affine(affine)
        self.only_inside = bool(only_inside)

    # ------------------------------------------------------------------ evaluation
    def apply_affine(self, points: ArrayLike) -> NDArray[np.float64]:
        """The global part ``A x + b`` alone."""
        pts = _as_points(points)
        return pts @ self.affine[:3, :3].T + self.affine[:3, 3]

    def displacement(self, points: ArrayLike) -> NDArray[np.float64]:
        """The local part ``T_local(x)``: lattice-driven displacement of each point, ``(N, 3)``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
        >>> lat.offsets[...] = (0.0, 2.0, 0.0)
        >>> FFD(lat, affine=np.diag([3.0, 3.0, 3.0, 1.0])).displacement([[0.5, 0.5, 0.5]]).round(12).tolist()
        [[0.0, 2.0, 0.0]]
        """
        return self._displacement(_as_points(points))

    def _displacement(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`displacement` of points already checked (one-shot: see ``_oneshot``)."""
        uvw = self.lattice.to_lattice(pts)
        local = _oneshot.displacement(self.basis, self.lattice.offsets, uvw)
        if self.only_inside:
            local[~_oneshot.in_domain(self.basis, self.lattice.shape, uvw)] = 0.0
        return local

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Deformed positions ``A x + b + T_local(x)`` of ``(N, 3)`` points.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(1).random((50, 3))
        >>> ffd = FFD(Lattice.around(pts, shape=4), affine=np.diag([2.0, 2.0, 2.0, 1.0]))
        >>> bool(np.allclose(ffd.deform(pts), 2 * pts))
        True
        """
        pts = _as_points(points)
        local = self._displacement(pts)
        local += pts @ self.affine[:3, :3].T
        local += self.affine[:3, 3]
        return local

    __call__ = deform

    def jacobian(self, points: ArrayLike) -> NDArray[np.float64]:
        """Jacobian matrices ``dT/dx`` of the whole deformation at each point, ``(N, 3, 3)``.

        Analytic: the affine matrix plus the local part's derivative from the basis
        derivatives, chained through the lattice frame (``d uvw / dx = R^T / spacing``).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(2).random((5, 3))
        >>> bool(np.allclose(FFD(Lattice.around(pts, 5)).jacobian(pts), np.eye(3)))
        True
        """
        pts = _as_points(points)
        lat = self.lattice
        uvw = lat.to_lattice(pts)
        # d T_local / d(u, v, w): (N, 3 components, 3 lattice axes)
        d_uvw = np.zeros((len(pts), 3, 3))
        if self.basis == "bernstein":
            vals = self._bernstein_values(uvw)
            ders = self._bernstein_values(uvw, derivative=True)
            for axis in range(3):
                factors = [ders[a] if a == axis else vals[a] for a in range(3)]
                d_uvw[:, :, axis] = np.einsum("pi,pj,pk,ijkd->pd", *factors, lat.offsets, optimize=True)
        else:
            cells = _CellGroups(uvw, lat.shape)
            d_uvw = cells.unsort(_bspline_lattice_jacobian(cells, lat.offsets, cells.t))
        if self.only_inside:
            d_uvw[~_oneshot.in_domain(self.basis, lat.shape, uvw)] = 0.0
        return self._chain(d_uvw)

    def _chain(self, d_uvw: NDArray[np.float64]) -> NDArray[np.float64]:
        """Whole Jacobian from ``d T_local / d(u, v, w)``: ``A + d_uvw @ (R^T / spacing)``."""
        lat = self.lattice
        # one (3N x 3) @ (3 x 3) product: a batched matmul of N tiny matrices is 3x slower
        local = (d_uvw.reshape(-1, 3) @ (lat.rotation.T / lat.spacing[:, None])).reshape(-1, 3, 3)
        return self.affine[:3, :3] + local

    def jacobian_determinant(self, points: ArrayLike) -> NDArray[np.float64]:
        """Determinant of the Jacobian at each point; ``<= 0`` where the deformation folds.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
        >>> lat.offsets[2, :, :, 0] = -3.0            # pull a whole layer far back in x: folds
        >>> bool(FFD(lat).jacobian_determinant([[0.5, 0.5, 0.5]])[0] < 0)
        True
        """
        return _det3(self.jacobian(points))

    def bind(self, points: ArrayLike, dtype: Any = np.float32) -> Deformer:
        """Bind to one point set: a :class:`Deformer` that caches what does not change."""
        return Deformer(self, points, dtype=dtype)

    # ------------------------------------------------------------------ helpers
    def _bernstein_values(self, uvw: NDArray[np.float64], derivative: bool = False) -> list[NDArray[np.float64]]:
        """Per-axis Bernstein values (or d/du) over the lattice box: parameter ``u / (n - 1)``."""
        out = []
        for axis, n in enumerate(self.lattice.shape):
            s = uvw[:, axis] / (n - 1)
            if derivative:
                out.append(bernstein_derivative(s, n - 1) / (n - 1))
            else:
                out.append(bernstein(s, n - 1))
        return out

    def __repr__(self) -> str:
        affine = "identity" if np.array_equal(self.affine, np.eye(4)) else "set"
        inside = ", only_inside=True" if self.only_inside else ""
        return f"FFD({self.lattice!r}, basis={self.basis!r}, affine={affine}{inside})"


def _pad(offsets: NDArray[np.float64], dtype: Any = np.float64) -> NDArray[Any]:
    """Offsets with three zero layers around: supports reaching outside the lattice read zeros."""
    return np.pad(offsets, ((3, 3), (3, 3), (3, 3), (0, 0))).astype(dtype, copy=False)


def _outer(bu: NDArray[Any], bv: NDArray[Any]) -> NDArray[Any]:
    """Row-wise outer product of the u and v weights, ``(N, 16)`` with index ``4 * l + m``."""
    return (bu[:, :, None] * bv[:, None, :]).reshape(len(bu), 16)


def _det3(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Determinants of ``(N, 3, 3)`` matrices by the explicit formula (far faster than batched LU)."""
    return (
        m[:, 0, 0] * (m[:, 1, 1] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 1])
        - m[:, 0, 1] * (m[:, 1, 0] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 0])
        + m[:, 0, 2] * (m[:, 1, 0] * m[:, 2, 1] - m[:, 1, 1] * m[:, 2, 0])
    )


def _bspline_lattice_jacobian(cells: _CellGroups, offsets: NDArray[np.float64], t: NDArray[np.float64]):
    """``d T_local / d(u, v, w)`` in sorted order, ``(N, 3 components, 3 lattice axes)``."""
    padded = _pad(offsets)
    vals = [bspline(t[:, a]) for a in range(3)]
    ders = [bspline_derivative(t[:, a]) for a in range(3)]
    d_uvw = np.empty((len(t), 3, 3))
    for axis in range(3):
        bu, bv, bw = (ders[a] if a == axis else vals[a] for a in range(3))
        d_uvw[:, :, axis] = cells.sum(padded, _outer(bu, bv), cells.masked(bw))
    return d_uvw


class _CellGroups:
    """Points grouped by the lattice cell whose 4x4x4 support moves them.

    Points are sorted by cell so that each cell's points form one contiguous run; a sum over a
    run is then one small matrix product with that cell's 64 offsets. Points whose support
    lies wholly outside the lattice are put in a run with zero weights.
    """

    def __init__(self, uvw: NDArray[np.float64], shape: tuple[int, int, int]) -> None:
        n = len(uvw)
        first, t = bspline_cells(uvw)
        dims = np.array(shape)
        self.inside = np.all((first >= -3) & (first <= dims - 1), axis=1)
        first = np.where(self.inside[:, None], first, 0)
        grid = tuple(dims + 3)
        cell = np.ravel_multi_index(tuple((first + 3).T), grid)
        order = np.argsort(cell, kind="stable")
        cells, starts = np.unique(cell[order], return_index=True)
        self.order = order.astype(np.int32 if n < 2**31 else np.int64)
        self.inside = self.inside[order]
        self.t = t[order]
        self.runs = np.column_stack([starts, np.r_[starts[1:], n]])
        self.run_first = np.column_stack(np.unravel_index(cells, grid)) - 3

    def masked(self, bw: NDArray[Any]) -> NDArray[Any]:
        """Zero the weights of points outside every support (applied to one factor only)."""
        bw[~self.inside] = 0.0
        return bw

    def sum(self, padded: NDArray[Any], buv: NDArray[Any], bw: NDArray[Any]) -> NDArray[Any]:
        """``sum_lmn buv[4l+m] bw[n] offsets[first + (l, m, n)]`` per point, in sorted order."""
        out = np.empty((len(buv), 3), dtype=np.result_type(buv, padded))
        for (s, e), (i, j, k) in zip(self.runs, self.run_first + 3, strict=True):
            # (l m) x (n d): contract the 16 (l, m) weights by BLAS, then the 4 n weights
            x = (buv[s:e] @ padded[i : i + 4, j : j + 4, k : k + 4].reshape(16, 12)).reshape(-1, 4, 3)
            np.einsum("pnd,pn->pd", x, bw[s:e], out=out[s:e])
        return out

    def unsort(self, values: NDArray[Any]) -> NDArray[Any]:
        """Values given in sorted order, returned in the points' original order."""
        out = np.empty_like(values)
        out[self.order] = values
        return out


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
        Precision of the cached weights: ``float32`` (default, 84 bytes a point for the
        B-spline basis, about 1e-7 relative error) or ``float64`` (exact to rounding).

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

    def __init__(self, ffd: FFD, points: ArrayLike, dtype: Any = np.float32) -> None:
        self.ffd = ffd
        self.points = _as_points(points)
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64, got {self.dtype}")
        self._bind()

    # ------------------------------------------------------------------ set-up
    def _geometry_key(self) -> tuple:
        lat = self.ffd.lattice
        geometry = (lat.shape, lat.spacing.tobytes(), lat.origin.tobytes(), lat.rotation.tobytes())
        return (self.ffd.basis, getattr(self.ffd, "only_inside", False), *geometry)

    def _bind(self) -> None:
        lat, n = self.ffd.lattice, len(self.points)
        self._key = self._geometry_key()
        self._affine = self.ffd.affine.copy()
        uvw = lat.to_lattice(self.points)
        self._cells = None
        # points the lattice may displace (all unless only_inside): the others get zero weights
        movable = _oneshot.in_domain(self.ffd.basis, lat.shape, uvw) if self.ffd.only_inside else None
        if self.ffd.basis == "bspline":
            cells = _CellGroups(uvw, lat.shape)
            bu, bv, bw = (bspline(cells.t[:, a]) for a in range(3))
            self._buv = _outer(bu, bv).astype(self.dtype)
            bw = cells.masked(bw)
            if movable is not None:
                bw[~movable[cells.order]] = 0.0
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
            bx, by, bz = self.ffd._bernstein_values(uvw)
            nx, ny, _ = lat.shape
            self._bxy = (bx[:, :, None] * by[:, None, :]).reshape(n, nx * ny).astype(self.dtype)
            if movable is not None:
                bz[~movable] = 0.0
            self._bz = bz.astype(self.dtype)
        self._base = np.asarray(self.ffd.apply_affine(self.points), dtype=np.float64)
        if self._cells is not None:
            self._base = self._base[self._cells.order]  # only ever used in sorted order
        self._out = np.empty((n, 3), dtype=np.float64)
        self._last_offsets = lat.offsets.copy()
        self._full()

    @property
    def cache_bytes(self) -> int:
        """Bytes of weights and indices held for fast updates.

        Not counted: the rest points, the affine image of the points and the working and
        output buffers (three ``(N, 3)`` float64 arrays any evaluation needs).
        """
        arrays = [getattr(self, k) for k in ("_buv", "_bw", "_inverse", "_bxy", "_bz") if hasattr(self, k)]
        if self._cells is not None:
            arrays += [self._cells.order, self._cells.inside, self._cells.runs, self._cells.run_first]
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
        """
        if self._geometry_key() != self._key or not np.array_equal(self.ffd.affine, self._affine):
            self._bind()
            return self._out
        if changed is None:
            self._full()
            return self._out
        ijk = np.asarray(changed, dtype=np.int64).reshape(-1, 3)
        if np.any(ijk < 0) or np.any(ijk >= np.array(self.ffd.lattice.shape)):
            raise IndexError(f"control point index out of range for lattice {self.ffd.lattice.shape}: {changed!r}")
        offsets = self.ffd.lattice.offsets
        for i, j, k in {tuple(map(int, c)) for c in ijk}:
            delta = offsets[i, j, k] - self._last_offsets[i, j, k]
            if delta.any():
                self._add_control_point(i, j, k, delta)
                self._last_offsets[i, j, k] = offsets[i, j, k]
        return self._out

    def jacobian_determinant(self) -> NDArray[np.float64]:
        """``det dT/dx`` at the bound points for the current offsets (``<= 0`` where it folds).

        The same values as :meth:`FFD.jacobian_determinant` on the bound points, reusing the
        cached grouping of points by cell (the editor's folding view calls it on every drag).

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
        if self._geometry_key() != self._key or not np.array_equal(self.ffd.affine, self._affine):
            self._bind()
        if self._cells is None:  # Bernstein: every control point reaches every point
            return self.ffd.jacobian_determinant(self.points)
        uvw = self.ffd.lattice.to_lattice(self.points)[self._cells.order]
        d_uvw = _bspline_lattice_jacobian(self._cells, self.ffd.lattice.offsets, uvw - np.floor(uvw))
        return _det3(self.ffd._chain(d_uvw))[self._inverse]

    def _full(self) -> None:
        offsets = self.ffd.lattice.offsets
        self._last_offsets[...] = offsets
        if self.ffd.basis == "bernstein":
            nx, ny, nz = self.ffd.lattice.shape
            x = self._bxy @ offsets.reshape(nx * ny, nz * 3).astype(self.dtype)
            local = np.einsum("pkd,pk->pd", x.reshape(-1, nz, 3), self._bz)
            np.add(self._base, local, out=self._out)
            return
        local = self._cells.sum(_pad(offsets, self.dtype), self._buv, self._bw)
        np.add(self._base, local, out=self._sorted)
        self._refresh_all()

    def _refresh_all(self) -> None:
        """Bring the sorted deformed positions back to the points' order (one gather)."""
        np.take(self._sorted, self._inverse, axis=0, out=self._out)

    def _add_control_point(self, i: int, j: int, k: int, delta: NDArray[np.float64]) -> None:
        if self.ffd.basis == "bernstein":
            ny = self.ffd.lattice.shape[1]
            w = self._bxy[:, i * ny + j] * self._bz[:, k]
            self._out += w[:, None].astype(np.float64) * delta
            return
        cells = self._cells
        rel = np.array([i, j, k]) - cells.run_first  # (i, j, k) inside each cell's 4x4x4 support
        hit = np.flatnonzero(np.all((rel >= 0) & (rel <= 3), axis=1))
        spans = cells.runs[hit]
        n_hit = int((spans[:, 1] - spans[:, 0]).sum())
        # many points: add in sorted order (contiguous) and gather once; few: touch only those rows
        gather_all = n_hit > len(self.points) // 4
        for r, (s, e) in zip(hit, spans, strict=True):
            l, m, n = rel[r]
            w = np.multiply(self._buv[s:e, l * 4 + m], self._bw[s:e, n], dtype=np.float64)
            # rank-one update sorted += w delta^T in place (BLAS dger on the F-ordered transpose)
            dger(1.0, delta, w, a=self._sorted[s:e].T, overwrite_a=1)
            if not gather_all:
                self._out[cells.order[s:e]] += w[:, None] * delta
        if gather_all:
            self._refresh_all()
