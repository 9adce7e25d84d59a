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
from .basis import BASES
from .deformer import Deformer
from .fit import fit_points as _fit_points
from .jacobian import bernstein_lattice_jacobian, bspline_lattice_jacobian, det3, jacobian_to_world
from .lattice import Lattice
from .support import CellGroups, check_border, in_domain

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
        pts = as_points(points)
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
        return np.ascontiguousarray(self._local_rows(as_points(points)).T)

    def _local_rows(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """``T_local`` of points already checked, as rows ``(3, N)`` (the one-shot :mod:`.oneshot`)."""
        lat = self.lattice
        rows = oneshot.displacement(self.basis, lat.offsets, oneshot.lattice_rows(lat, pts), self.border)
        if self.only_inside:  # the domain test on to_lattice's coordinates, as the cached path does
            rows[:, ~in_domain(self.basis, lat.shape, lat.to_lattice(pts))] = 0.0
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
        pts = as_points(points)
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
        pts = as_points(points)
        lat = self.lattice
        uvw = lat.to_lattice(pts)
        # d T_local / d(u, v, w): (N, 3 components, 3 lattice axes)
        if self.basis == "bernstein":
            d_uvw = bernstein_lattice_jacobian(lat.offsets, uvw)
        else:
            cells = CellGroups(uvw, lat.shape, self.border)
            d_uvw = cells.unsort(bspline_lattice_jacobian(cells, lat.offsets, cells.t))
        if self.only_inside:
            d_uvw[~in_domain(self.basis, lat.shape, uvw)] = 0.0
        return jacobian_to_world(lat, self.affine, d_uvw)

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
        return det3(self.jacobian(points))

    def bind(self, points: ArrayLike, dtype: Any = np.float32) -> Deformer:
        """Bind to one point set: a :class:`~ffd_notebook.Deformer` that caches what does not change."""
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
        Returns the change, ``(nx, ny, nz, 3)``. See :func:`ffd_notebook.ffd.fit.fit_points`.

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

    def __repr__(self) -> str:
        affine = "identity" if np.array_equal(self.affine, np.eye(4)) else "set"
        inside = ", only_inside=True" if self.only_inside else ""
        return f"FFD({self.lattice!r}, basis={self.basis!r}, border={self.border!r}, affine={affine}{inside})"
