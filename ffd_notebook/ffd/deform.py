"""Free-form deformation: a global affine part plus a lattice of control-point offsets.

``T(x) = A x + b + T_local(x)`` (Rueckert et al. 1999). ``T_local`` is either the tensor
product of uniform cubic B-splines over the lattice cells, or the Sederberg-Parry Bernstein form
over the lattice's whole box. Beyond the lattice the B-spline form assumes either zero control
points (``border="zero"``: identical to SimpleITK's ``BSplineTransform`` of order 3 on the same
grid) or copies of the border ones (``border="clamp"``, Blender's lattice).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from . import oneshot
from .basis import BasisName
from .deformer import Deformer
from .fit import fit_points as _fit_points
from .influence import blend, check_strength, influence, point_weights
from .interpolation import axis_bases, check_basis
from .jacobian import bernstein_lattice_jacobian, bspline_lattice_jacobian, det3, jacobian_to_world
from .lattice import Lattice
from .outside import outside_offsets
from .support import Border, CellGroups, check_border, check_only_inside, in_domain

__all__ = ["FFD"]


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
    basis : {"bspline", "bernstein"} or tuple of str
        ``"bspline"``: uniform cubic B-splines, local support (each point moves with the 4x4x4
        control points around it). ``"bernstein"``: Sederberg-Parry, every control point moves
        every point inside the lattice box (points outside are extrapolated polynomially). Or
        Blender's interpolations, one per axis: a tuple of three of ``"linear"``, ``"cardinal"``,
        ``"catmull-rom"``, ``"bspline"`` (one name alone means it on every axis), each with
        Blender's weights (:mod:`~ffd_notebook.ffd.interpolation`) on the B-spline's support, so
        with the border rules below (Blender's is ``"clamp"``).
    border : {"zero", "clamp"}, optional
        B-spline basis only: what lies beyond the lattice. ``"zero"``: nothing (the FFD
        report, SimpleITK; the weights sum to one only one spacing inside the lattice).
        ``"clamp"``: copies of the border control points (Blender), so the weights sum to one
        everywhere and the lattice can be the mesh's own bounding box. By default the
        lattice's own :attr:`~ffd_notebook.Lattice.border` (``"zero"`` unless it was made
        with ``"clamp"`` or loaded from a .ffd file that says so), read at every evaluation.
    affine : array_like, optional
        4x4 homogeneous (or 3x4) matrix of the global part ``x -> A x + b``; identity if omitted.
    only_inside : bool or "half-open"
        If true, the lattice displaces only the points inside its domain and leaves the others
        to the affine part alone: the box ``0 <= u <= n - 1`` (lattice coordinates) for the
        Bernstein basis, as PyGeM does, and the region where the B-spline weights sum to one,
        ``1 <= u <= n - 2``, for the B-spline basis, as ITK's ``BSplineTransform`` does. The
        deformation is then discontinuous where the offsets near the domain's faces are not zero.
        ``"half-open"``: the same domain without its far faces (``u < n - 2``), elastix's valid
        region (a point exactly on such a face moves under ITK and not under elastix).
    outside : bool
        Blender's "outside" lattice: only the control points on the lattice's surface are free;
        each inner one follows them, at the mean of the linear interpolations between opposite
        faces (:mod:`~ffd_notebook.ffd.outside`). Its own offset is then ignored.
    strength : float
        Scales the displacement ``T(x) - x`` of every point: 1 the whole deformation, 0 none,
        negative or above 1 allowed (Blender's modifier strength).
    weights : array_like or str, optional
        Per-point weights in [0, 1] that scale each point's displacement (Blender's vertex group),
        used by :meth:`deform` and :meth:`bind` when they get none: one per point of the point set
        they belong to, or the name of a point-data array of the mesh deformed.

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
        basis: BasisName | tuple[str, str, str] = "bspline",
        border: Border | None = None,
        affine: ArrayLike | None = None,
        only_inside: bool | str = False,
        *,
        outside: bool = False,
        strength: float = 1.0,
        weights: ArrayLike | str | None = None,
    ) -> None:
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        basis = check_basis(basis)
        self._border = None if border is None else check_border(border)
        self.lattice = lattice
        if basis != "bernstein" and self.border == "zero" and min(lattice.shape) < 4:
            what = "the cubic B-spline basis" if basis == "bspline" else f"the {basis!r} basis"
            raise ValueError(f"{what} with border 'zero' needs at least 4 control points per axis, got {lattice.shape}")
        self.basis: BasisName | tuple[str, str, str] = basis
        self.affine = _check_affine(affine)
        self.only_inside: bool | str = check_only_inside(only_inside)
        self.outside = bool(outside)
        self.strength = strength
        self.weights = weights

    @property
    def strength(self) -> float:
        """Scale of every point's displacement (1: the whole deformation; Blender's modifier strength)."""
        return self._strength

    @strength.setter
    def strength(self, value: float) -> None:
        self._strength = check_strength(value)

    @property
    def weights(self) -> NDArray[np.float64] | str | None:
        """Default per-point weights of :meth:`deform` and :meth:`bind`: an array, a point-data name or None."""
        return self._weights

    @weights.setter
    def weights(self, value: ArrayLike | str | None) -> None:
        if value is not None and not isinstance(value, str):
            value = np.array(value, dtype=np.float64)
            point_weights(value, len(value))  # checked now: one number each, in [0, 1]
        self._weights = value

    def offsets_in_use(self) -> NDArray[np.float64]:
        """The offsets the deformation uses: the lattice's, or with ``outside`` the inner ones derived.

        Returns
        -------
        numpy.ndarray
            ``(nx, ny, nz, 3)``: ``lattice.offsets`` itself without ``outside``, else a new array.

        Examples
        --------
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((3, 3, 3), 1.0, border="clamp")
        >>> lat.offsets[1, 1, 1] = (5.0, 0.0, 0.0)          # an inner point: ignored with outside=True
        >>> float(FFD(lat, outside=True).offsets_in_use()[1, 1, 1, 0])
        0.0
        """
        offsets = self.lattice.offsets
        return outside_offsets(offsets) if self.outside else offsets

    def copy(self, lattice: Lattice | None = None, **changes: Any) -> FFD:
        """A new FFD with every option of this one, on a copy of its lattice or on ``lattice``.

        The options are the basis, the border rule in use, the affine part, ``only_inside``,
        ``outside``, the strength and the per-point weights (copied); ``changes`` replace some
        of them by name, as :func:`dataclasses.replace` does. Whatever makes a second FFD like
        a first one (a batch sample on its own lattice, an undo step) goes through here, so a
        new option is carried everywhere by being added once.

        Parameters
        ----------
        lattice : Lattice, optional
            The lattice of the new FFD (used as it is, not copied); a copy of this one's by default.
        **changes
            New values for some of ``basis``, ``border``, ``affine``, ``only_inside``,
            ``outside``, ``strength``, ``weights``.

        Returns
        -------
        FFD
            The new FFD; this one is unchanged.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> ffd = FFD(Lattice((4, 4, 4), 1.0), border="clamp", outside=True, strength=0.4)
        >>> other = ffd.copy(Lattice((5, 5, 5), 2.0))
        >>> other.border, other.outside, other.strength, other.lattice.shape
        ('clamp', True, 0.4, (5, 5, 5))
        >>> ffd.copy(strength=1.0).strength, ffd.copy().lattice is ffd.lattice
        (1.0, False)
        """
        weights = self.weights.copy() if isinstance(self.weights, np.ndarray) else self.weights
        options: dict[str, Any] = {"basis": self.basis, "border": self.border, "affine": self.affine.copy(),
                                   "only_inside": self.only_inside, "outside": self.outside,
                                   "strength": self.strength, "weights": weights}  # fmt: skip
        unknown = set(changes) - set(options)
        if unknown:
            raise TypeError(f"FFD.copy() got unknown options {sorted(unknown)}; known: {sorted(options)}")
        options.update(changes)
        return FFD(self.lattice.copy() if lattice is None else lattice, **options)

    def baked(self) -> FFD:
        """The same deformation with strength 1 and no ``outside`` rule: their effect put in the offsets and affine.

        ``x + s (A x + b + T_local(x) - x)`` is an FFD with affine ``I + s (A - I)``, ``s b`` and offsets
        ``s * offsets_in_use()``; file formats without those options hold this. Per-point weights
        belong to one point set and are not part of it.

        Returns
        -------
        FFD
            A new FFD with a copied lattice; this one is unchanged.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((4, 4, 4), 1.0, border="clamp")
        >>> lat.offsets[2, 1, 3] = (0.0, 1.0, 0.0)
        >>> ffd = FFD(lat, affine=np.diag([2.0, 1.0, 1.0, 1.0]), strength=0.5, outside=True)
        >>> pts = np.random.default_rng(0).random((20, 3)) * 3
        >>> bool(np.allclose(ffd.baked().deform(pts), ffd.deform(pts))), ffd.baked().strength
        (True, 1.0)
        """
        s = self.strength
        lattice = self.lattice.copy()
        affine = self.affine.copy()
        if self.outside:
            lattice.offsets[...] = self.offsets_in_use()
        if s != 1.0:  # (with s == 1 nothing is computed: the copy is bit-identical)
            lattice.offsets *= s
            affine[:3, :3] = np.eye(3) + s * (affine[:3, :3] - np.eye(3))
            affine[:3, 3] *= s
        return self.copy(lattice, affine=affine, outside=False, strength=1.0, weights=None)

    def _factor(self, points: Any, n: int, strength: Any, weights: Any) -> NDArray[np.float64] | None:
        """Per-point ``strength * weight`` of a call (the FFD's own where the call gives none)."""
        s = self.strength if strength is None else check_strength(strength)
        w = point_weights(self.weights if weights is None else weights, n, mesh=points)
        return influence(s, w, n)

    @property
    def border(self) -> Border:
        """The B-spline border rule in use: the one given, else the lattice's."""
        return self.lattice.border if self._border is None else self._border

    # ------------------------------------------------------------------ evaluation
    def apply_affine(self, points: ArrayLike) -> NDArray[np.float64]:
        """The global part ``A x + b`` alone.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in world coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64: each point moved by the affine part only.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> ffd = FFD(Lattice((4, 4, 4), 1.0), affine=np.diag([2.0, 1.0, 1.0, 1.0]))
        >>> ffd.apply_affine([[1.0, 1.0, 1.0]]).tolist()
        [[2.0, 1.0, 1.0]]
        """
        pts = as_points(points)
        return pts @ self.affine[:3, :3].T + self.affine[:3, 3]

    def displacement(self, points: ArrayLike) -> NDArray[np.float64]:
        """The local part ``T_local(x)``: lattice-driven displacement of each point, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in world coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64: the local displacement of each point (without the affine part).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
        >>> lat.offsets[...] = (0.0, 2.0, 0.0)
        >>> FFD(lat, affine=np.diag([3.0, 3.0, 3.0, 1.0])).displacement([[0.5, 0.5, 0.5]]).round(12).tolist()
        [[0.0, 2.0, 0.0]]
        """
        return np.ascontiguousarray(self._local_rows(as_points(points)).T)

    def _local_rows(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """``T_local`` of points already checked, as rows ``(3, N)`` (the one-shot :mod:`.oneshot`)."""
        lat = self.lattice
        rows = oneshot.displacement(self.basis, self.offsets_in_use(), oneshot.lattice_rows(lat, pts), self.border)
        if self.only_inside:  # the domain test on to_lattice's coordinates, as the cached path does
            rows[:, ~in_domain(self.basis, lat.shape, lat.to_lattice(pts), self.only_inside)] = 0.0
        return rows

    def deform(self, points: ArrayLike, *, strength: float | None = None, weights: Any = None) -> NDArray[np.float64]:
        """Deformed positions ``A x + b + T_local(x)`` of ``(N, 3)`` points (or a mesh's points).

        With a strength ``s`` and per-point weights ``w`` (Blender's modifier strength and vertex
        group), point ``x`` goes to ``x + s w (T(x) - x)``.

        Parameters
        ----------
        points : array_like or mesh
            ``(N, 3)`` points, or an object with ``points`` (a PyVista mesh).
        strength : float, optional
            Overrides :attr:`strength` for this call.
        weights : array_like or str, optional
            ``(N,)`` weights in [0, 1], or the name of a point-data array of ``points`` (a mesh);
            by default :attr:`weights` (none: every point gets the whole deformation).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64: the deformed points (new array; ``points`` is not changed).

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(1).random((50, 3))
        >>> ffd = FFD(Lattice.around(pts, shape=4), affine=np.diag([2.0, 2.0, 2.0, 1.0]))
        >>> bool(np.allclose(ffd.deform(pts), 2 * pts))
        True
        >>> w = np.linspace(0.0, 1.0, 50)                 # the first point stays, the last moves fully
        >>> moved = ffd.deform(pts, strength=0.5, weights=w)
        >>> bool(np.allclose(moved, pts + 0.5 * w[:, None] * pts))
        True
        """
        pts = as_points(points)
        factor = self._factor(points, len(pts), strength, weights)
        rows = self._local_rows(pts)
        rows += self.affine[:3, 3, None]
        linear = self.affine[:3, :3]
        base = pts if np.array_equal(linear, np.eye(3)) else pts @ linear.T
        out = np.empty_like(base)
        for d in range(3):  # column by column: adding (N, 3) to rows.T would run along the short axis
            np.add(base[:, d], rows[d], out=out[:, d])
        return blend(pts, out, factor)

    __call__ = deform

    def jacobian(self, points: ArrayLike, *, strength: float | None = None, weights: Any = None) -> NDArray[np.float64]:
        """Jacobian matrices ``dT/dx`` of the whole deformation at each point, ``(N, 3, 3)``.

        Analytic: the affine matrix plus the local part's derivative from the basis
        derivatives, chained through the lattice frame (``d uvw / dx = R^T / spacing``). With a
        strength ``s`` and weights ``w`` (see :meth:`deform`): ``I + s w (J - I)``, the weights
        being constants of the points.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in world coordinates.
        strength : float, optional
            Overrides :attr:`strength` for this call.
        weights : array_like or str, optional
            Per-point weights as in :meth:`deform`; by default :attr:`weights`.

        Returns
        -------
        numpy.ndarray
            ``(N, 3, 3)`` float64: ``J[n, i, j] = d T_i / d x_j`` at point ``n``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> pts = np.random.default_rng(2).random((5, 3))
        >>> bool(np.allclose(FFD(Lattice.around(pts, 5)).jacobian(pts), np.eye(3)))
        True
        """
        pts = as_points(points)
        factor = self._factor(points, len(pts), strength, weights)
        lat = self.lattice
        offsets = self.offsets_in_use()
        uvw = lat.to_lattice(pts)
        # d T_local / d(u, v, w): (N, 3 components, 3 lattice axes)
        if self.basis == "bernstein":
            d_uvw = bernstein_lattice_jacobian(offsets, uvw)
        else:
            cells = CellGroups(uvw, lat.shape, self.border)
            bases = axis_bases(self.basis)
            assert cells.t is not None  # a fresh grouping keeps its t
            d_uvw = cells.unsort(bspline_lattice_jacobian(cells, offsets, cells.t, bases=bases))
        if self.only_inside:
            d_uvw[~in_domain(self.basis, lat.shape, uvw, self.only_inside)] = 0.0
        jacobian = jacobian_to_world(lat, self.affine, d_uvw)
        if factor is not None:
            jacobian -= np.eye(3)
            jacobian *= factor[:, None, None]
            jacobian += np.eye(3)
        return jacobian

    def jacobian_determinant(
        self, points: ArrayLike, *, strength: float | None = None, weights: Any = None
    ) -> NDArray[np.float64]:
        """Determinant of the Jacobian at each point; ``<= 0`` where the deformation folds.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in world coordinates.
        strength : float, optional
            Overrides :attr:`strength` for this call.
        weights : array_like or str, optional
            Per-point weights as in :meth:`deform`; by default :attr:`weights`.

        Returns
        -------
        numpy.ndarray
            ``(N,)`` float64 determinants.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
        >>> lat.offsets[2, :, :, 0] = -3.0            # pull a whole layer far back in x: folds
        >>> bool(FFD(lat).jacobian_determinant([[0.5, 0.5, 0.5]])[0] < 0)
        True
        """
        return det3(self.jacobian(points, strength=strength, weights=weights))

    def bind(
        self, points: ArrayLike, dtype: Any = np.float32, *, strength: float | None = None, weights: Any = None
    ) -> Deformer:
        """Bind to one point set: a :class:`~ffd_notebook.Deformer` that caches what does not change.

        ``strength`` and ``weights`` as in :meth:`deform` (the FFD's own by default).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` rest points in world coordinates.
        dtype : numpy dtype
            Of the deformed points the deformer returns (float32 for rendering by default).
        strength : float, optional
            Overrides :attr:`strength` for this point set.
        weights : array_like or str, optional
            Per-point weights as in :meth:`deform`; by default :attr:`weights`.

        Returns
        -------
        Deformer
            Its ``current()`` is ``deform(points)``; ``update(changed)`` recomputes only the points
            the changed control points reach.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> lat = Lattice((6, 6, 6), 1.0, border="clamp")
        >>> ffd = FFD(lat)
        >>> pts = np.random.default_rng(0).random((1000, 3)) * 5
        >>> deformer = ffd.bind(pts, dtype=np.float64)
        >>> lat.offsets[1, 1, 1] = (0.0, 0.0, 0.5)
        >>> moved = deformer.update([(1, 1, 1)])
        >>> bool(np.allclose(moved, ffd.deform(pts))), moved.dtype
        (True, dtype('float64'))
        """
        return Deformer(self, points, dtype=dtype, strength=strength, weights=weights)

    def fit_points(
        self,
        points: ArrayLike,
        targets: ArrayLike,
        pinned: ArrayLike | None = None,
        weights: ArrayLike | None = None,
        *,
        point_weights: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """Change ``lattice.offsets`` (in place) by the least-norm amount that puts ``deform(points)`` on ``targets``.

        Least squares when not every target can be met; ``pinned`` points stay where they are.
        Returns the change, ``(nx, ny, nz, 3)``. See :func:`ffd_notebook.ffd.fit.fit_points`.

        Parameters
        ----------
        points : array_like
            ``(K, 3)`` rest positions of the points to move.
        targets : array_like
            ``(K, 3)`` where ``deform(points)`` must land.
        pinned : array_like, optional
            ``(P, 3)`` rest positions whose deformed positions must not change.
        weights : array_like, optional
            ``(K,)`` relative weights of the targets when they cannot all be met.
        point_weights : array_like, optional
            ``(K + P,)`` weights in [0, 1] of the rows (``points`` then ``pinned``) in the deformation
            itself, as the FFD's per-point weights; 1 by default.

        Returns
        -------
        numpy.ndarray
            ``(nx, ny, nz, 3)``: the change made to ``lattice.offsets``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import Lattice, FFD
        >>> ffd = FFD(Lattice((5, 5, 5), 1.0, border="clamp"))
        >>> change = ffd.fit_points([[2.0, 2.0, 2.0]], [[2.0, 2.5, 2.0]])
        >>> ffd.deform([[2.0, 2.0, 2.0]]).round(12).tolist(), int(change.any(axis=-1).sum())
        ([[2.0, 2.5, 2.0]], 27)
        """
        return _fit_points(self, points, targets, pinned=pinned, weights=weights, point_weights=point_weights)

    def __repr__(self) -> str:
        affine = "identity" if np.array_equal(self.affine, np.eye(4)) else "set"
        extra = f", only_inside={self.only_inside!r}" if self.only_inside else ""
        extra += ", outside=True" if self.outside else ""
        extra += f", strength={self.strength:g}" if self.strength != 1.0 else ""
        extra += ", weights=set" if self.weights is not None else ""
        return f"FFD({self.lattice!r}, basis={self.basis!r}, border={self.border!r}, affine={affine}{extra})"
