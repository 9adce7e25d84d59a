"""Free-form deformation: a global affine part plus a lattice of control-point offsets.

``T(x) = A x + b + T_local(x)`` (Rueckert et al. 1999). ``T_local`` is either the tensor
product of uniform cubic B-splines over the lattice cells, or the Sederberg-Parry Bernstein form
over the lattice's whole box. Beyond the lattice the B-spline form assumes either zero control
points (``border="zero"``: identical to SimpleITK's ``BSplineTransform`` of order 3 on the same
grid) or copies of the border ones (``border="clamp"``, Blender's lattice).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _oneshot
from .basis import bernstein, bernstein_derivative, bspline, bspline_cells, bspline_derivative, check_border
from .fit import fit_points as _fit_points
from .lattice import Lattice, _as_points

if TYPE_CHECKING:
    from .deformer import Deformer

__all__ = ["BASES", "FFD"]

BASES = ("bspline", "bernstein")


def __getattr__(name: str) -> Any:
    """``Deformer`` moved to :mod:`ffd_notebook.deformer`; still importable from here."""
    if name == "Deformer":
        from .deformer import Deformer

        return Deformer
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    border : {"zero", "clamp"}, optional
        B-spline basis only: what lies beyond the lattice. ``"zero"``: nothing (the FFD
        report, SimpleITK; the weights sum to one only one spacing inside the lattice).
        ``"clamp"``: copies of the border control points (Blender), so the weights sum to one
        everywhere and the lattice can be the mesh's own bounding box. By default the
        lattice's own :attr:`~ffd_notebook.Lattice.border` (``"zero"`` unless it was made
        with ``"clamp"`` or loaded from a .ffd file that says so), read at every evaluation.
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
    >>> lat.offsets[0, 1, 1] = (0.0, 0.0, 9.0)          # on the border, and a point far beyond it:
    >>> far = [[-9.0, 0.0, 0.0]]
    >>> FFD(lat).deform(far).tolist(), FFD(lat, border="clamp").deform(far).round(6).tolist()
    ([[-9.0, 0.0, 0.0]], [[-9.0, 0.0, 4.0]])
    """

    def __init__(
        self,
        lattice: Lattice,
        basis: str = "bspline",
        border: str | None = None,
        affine: ArrayLike | None = None,
        only_inside: bool = False,
    ) -> None:
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        if basis not in BASES:
            raise ValueError(f"basis must be one of {BASES}, got {basis!r}")
        self._border = None if border is None else check_border(border)
        self.lattice = lattice
        if basis == "bspline" and self.border == "zero" and min(lattice.shape) < 4:
            raise ValueError(
                f"the cubic B-spline basis with border 'zero' needs at least 4 control points per axis, "
                f"got {lattice.shape}"
            )
        self.basis = basis
        self.affine = _check_affine(affine)
        self.only_inside = bool(only_inside)

    @property
    def border(self) -> str:
        """The B-spline border rule in use: the one given, else the lattice's."""
        return self.lattice.border if self._border is None else self._border

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
        return np.ascontiguousarray(self._local_rows(_as_points(points)).T)

    def _local_rows(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """``T_local`` of points already checked, as rows ``(3, N)`` (one-shot: see ``_oneshot``)."""
        lat = self.lattice
        rows = _oneshot.displacement(self.basis, lat.offsets, _oneshot.lattice_rows(lat, pts), self.border)
        if self.only_inside:  # the domain test on to_lattice's coordinates, as the cached path does
            rows[:, ~_oneshot.in_domain(self.basis, lat.shape, lat.to_lattice(pts))] = 0.0
        return rows

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
        rows = self._local_rows(pts)
        rows += self.affine[:3, 3, None]
        linear = self.affine[:3, :3]
        base = pts if np.array_equal(linear, np.eye(3)) else pts @ linear.T
        out = np.empty_like(base)
        for d in range(3):  # column by column: adding (N, 3) to rows.T would run along the short axis
            np.add(base[:, d], rows[d], out=out[:, d])
        return out

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
            cells = _CellGroups(uvw, lat.shape, self.border)
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
        """Bind to one point set: a :class:`~ffd_notebook.Deformer` that caches what does not change."""
        from .deformer import Deformer  # here, not at the top: deformer imports this module

        return Deformer(self, points, dtype=dtype)

    def fit_points(
        self,
        points: ArrayLike,
        targets: ArrayLike,
        pinned: ArrayLike | None = None,
        weights: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """Change ``lattice.offsets`` (in place) by the least-norm amount that puts ``deform(points)`` on ``targets``.

        Least squares when not every target can be met; ``pinned`` points stay where they are.
        Returns the change, ``(nx, ny, nz, 3)``. See :func:`ffd_notebook.fit.fit_points`.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> ffd = FFD(Lattice((5, 5, 5), 1.0, border="clamp"))
        >>> change = ffd.fit_points([[2.0, 2.0, 2.0]], [[2.0, 2.5, 2.0]])
        >>> ffd.deform([[2.0, 2.0, 2.0]]).round(12).tolist(), int(change.any(axis=-1).sum())
        ([[2.0, 2.5, 2.0]], 27)
        """
        return _fit_points(self, points, targets, pinned=pinned, weights=weights)

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
        return f"FFD({self.lattice!r}, basis={self.basis!r}, border={self.border!r}, affine={affine}{inside})"


def _pad(offsets: NDArray[np.float64], dtype: Any = np.float64, border: str = "zero") -> NDArray[Any]:
    """Offsets with three layers around, zeros or copies of the border (the border rule).

    Supports reaching outside the lattice read these layers: copying the border layer there is
    the same as clamping the support's indices, the clamp rule.
    """
    mode = "constant" if border == "zero" else "edge"
    return np.pad(offsets, ((3, 3), (3, 3), (3, 3), (0, 0)), mode=mode).astype(dtype, copy=False)


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
    padded = cells.pad(offsets)
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
    run is then one small matrix product with that cell's 64 offsets. With the "zero" border,
    points whose support lies wholly outside the lattice are put in a run with zero weights;
    with "clamp" their support is moved to the nearest one reaching the lattice, whose indices
    all clamp to the same border control points.
    """

    def __init__(self, uvw: NDArray[np.float64], shape: tuple[int, int, int], border: str = "zero") -> None:
        n = len(uvw)
        first, t = bspline_cells(uvw)
        dims = np.array(shape)
        self.border = border
        if border == "clamp":
            first = np.clip(first, -3, dims - 1)
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

    def pad(self, offsets: NDArray[np.float64], dtype: Any = np.float64) -> NDArray[Any]:
        """Offsets padded by this grouping's border rule (see :func:`_pad`)."""
        return _pad(offsets, dtype, self.border)

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
