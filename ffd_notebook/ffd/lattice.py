"""The control lattice of a free-form deformation.

A :class:`Lattice` is a regular grid of ``nx x ny x nz`` control points placed in space by an
``origin``, a per-axis ``spacing`` and a ``rotation`` whose columns are the lattice axes (a
reflection is allowed: the real .ffd files of the FFD platform have one). The axes are orthogonal
unless the lattice is sheared: a B-spline placed by a general affine map, what an elastix
affine-then-B-spline chain is (``rotation`` then has unit columns that are not orthogonal, like
ITK's image directions). Each control point carries a displacement in world units, stored in the
writable ``offsets`` array.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from .basis import BASES, BasisName
from .support import Border, check_border

__all__ = ["ROTATION_TOLERANCE", "Lattice", "nearest_rotation", "orthogonality_error"]


#: How far from orthogonal a matrix may be, as the largest entry of ``|R.T @ R - I|``, and still count as a
#: rotation: unit vectors rounded to float32 (SimpleITK's initialiser writes its rotations so, Blender keeps its
#: matrices so) are within about 4e-7 of one. Within it a rotation read from a file or given to a
#: :class:`Lattice` is replaced by the nearest orthogonal matrix (:func:`nearest_rotation`), which moves a
#: point at distance ``r`` from the origin by about ``1e-6 r`` at most; beyond it the axes are a sheared
#: lattice's (or a file that cannot hold one refuses them).
ROTATION_TOLERANCE = 1e-6
_ROUNDING = 1e-12  # orthogonal to float64 rounding already: kept bit for bit (files' round trips stay exact)
_UNIT = 1e-9  # how far from 1 the length of a sheared lattice's axis may be


def orthogonality_error(matrix: ArrayLike) -> float:
    """The largest entry of ``|M.T @ M - I|``: 0 for a rotation (or reflection), what :data:`ROTATION_TOLERANCE` bounds.

    Examples
    --------
    >>> orthogonality_error(np.diag([1.0, 1.0, -1.0])), round(orthogonality_error(np.diag([1.0, 1.0, 1.1])), 6)
    (0.0, 0.21)
    """
    m = np.asarray(matrix, dtype=np.float64)
    return float(np.abs(m.T @ m - np.eye(3)).max())


def nearest_rotation(matrix: ArrayLike) -> NDArray[np.float64] | None:
    """The orthogonal matrix nearest to ``matrix``, or None when it is not within :data:`ROTATION_TOLERANCE` of one.

    The nearest in the Frobenius norm: the polar factor ``U V^T`` of the SVD ``U S V^T`` (a
    reflection stays a reflection). A matrix already orthogonal to float64 rounding is returned
    as it is (a copy), bit for bit. Every reader of rotations (ITK and elastix grids, Blender's
    lattice objects) and :class:`Lattice` itself decide with it, so they agree on what is a
    rotation and what a sheared grid.

    Parameters
    ----------
    matrix : array_like
        A 3x3 matrix whose columns are meant to be orthonormal axes.

    Returns
    -------
    numpy.ndarray or None
        The orthogonal 3x3 matrix, or None (a sheared or scaled matrix: the caller decides).

    Examples
    --------
    >>> c, s = np.cos(0.5), np.sin(0.5)
    >>> r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    >>> rounded = r.astype(np.float32).astype(np.float64)          # a rotation written in float32
    >>> snapped = nearest_rotation(rounded)
    >>> orthogonality_error(rounded) > 1e-9, orthogonality_error(snapped) < 1e-15
    (True, True)
    >>> bool(np.abs(snapped - r).max() < 1e-7)
    True
    >>> nearest_rotation(r) is not r and np.array_equal(nearest_rotation(r), r)
    True
    >>> print(nearest_rotation([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))   # sheared
    None
    """
    m = np.array(matrix, dtype=np.float64)
    error = orthogonality_error(m)
    if error <= _ROUNDING:
        return m
    if not error <= ROTATION_TOLERANCE:  # (NaN too)
        return None
    u, _, vt = np.linalg.svd(m)
    return cast("NDArray[np.float64]", u @ vt)


def _check_rotation(rotation: ArrayLike | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The rotation and its inverse (``R.T`` for an orthogonal one, as always; the inverse for a sheared one)."""
    if rotation is None:
        return np.eye(3), np.eye(3)
    r = np.array(rotation, dtype=np.float64)
    if r.shape != (3, 3):
        raise ValueError(f"rotation must be a 3x3 matrix, got shape {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ValueError("rotation contains NaN or infinite values")
    snapped = nearest_rotation(r)
    if snapped is not None:
        return snapped, snapped.T
    if np.abs(np.linalg.norm(r, axis=0) - 1.0).max() > _UNIT:
        raise ValueError("rotation must be orthogonal (R.T @ R == I), or for a sheared lattice have unit columns "
                         "(the axes' directions); scaling belongs in spacing")  # fmt: skip
    if np.linalg.cond(r) > 1e12:
        raise ValueError("a sheared lattice's axes must be independent (rotation is singular)")
    return r, cast("NDArray[np.float64]", np.linalg.inv(r))


class Lattice:
    """A regular grid of control points with per-point displacements.

    Control point ``(i, j, k)`` rests at ``origin + rotation @ ((i, j, k) * spacing)`` and is
    displaced by ``offsets[i, j, k]`` (world units).

    Parameters
    ----------
    shape : tuple of int
        Control points per axis ``(nx, ny, nz)``, each at least 2.
    spacing : float or array_like
        Distance between neighbouring control points, per axis (positive).
    origin : array_like, optional
        Rest position of control point ``(0, 0, 0)``.
    rotation : array_like, optional
        3x3 matrix whose columns are the lattice axes in world coordinates: orthogonal
        (identity by default; a reflection, determinant -1, is allowed; one within
        :data:`ROTATION_TOLERANCE` of orthogonal is kept as the :func:`nearest_rotation`), or unit
        columns at any angles for a sheared lattice (:attr:`sheared`; .ffd, ITK and PyGeM files cannot hold one,
        elastix files can).
    offsets : array_like, optional
        Initial ``(nx, ny, nz, 3)`` displacements; zeros by default.
    border : {"zero", "clamp"}
        What the B-spline FFD assumes beyond the lattice (:data:`~ffd_notebook.ffd.support.BORDERS`):
        ``"zero"`` (the FFD report's formula, SimpleITK's) or ``"clamp"`` (copies of the border
        control points, Blender's lattice). It belongs to the lattice because it decides where
        a lattice must sit around a mesh (:meth:`around`); :class:`~ffd_notebook.FFD` follows it
        unless told otherwise, and .ffd files record it.

    Attributes
    ----------
    offsets : numpy.ndarray
        Writable ``(nx, ny, nz, 3)`` float64 displacements.
    metadata : dict
        Free-form information carried along (for example unknown .ffd sections kept on a
        round trip).

    Examples
    --------
    >>> lat = Lattice((2, 3, 4), spacing=10.0, origin=(1, 0, 0))
    >>> lat.control_points()[1, 2, 3].tolist()
    [11.0, 20.0, 30.0]
    >>> lat.offsets[1, 2, 3] = (0, 0, 5)
    >>> lat.control_points(deformed=True)[1, 2, 3].tolist()
    [11.0, 20.0, 35.0]
    """

    def __init__(
        self,
        shape: tuple[int, int, int] | ArrayLike,
        spacing: float | ArrayLike,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        rotation: ArrayLike | None = None,
        offsets: ArrayLike | None = None,
        border: Border = "zero",
    ) -> None:
        shape_arr = np.asarray(shape)
        if shape_arr.shape != (3,) or not np.all(shape_arr == np.round(shape_arr)) or np.any(shape_arr < 2):
            raise ValueError(f"shape must be three integers >= 2, got {shape!r}")
        self.shape: tuple[int, int, int] = tuple(int(s) for s in shape_arr)  # type: ignore[assignment]
        spacing_arr = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,)).copy()
        if not np.all(np.isfinite(spacing_arr)) or np.any(spacing_arr <= 0):
            raise ValueError(f"spacing must be positive and finite, got {spacing!r}")
        self.spacing: NDArray[np.float64] = spacing_arr
        origin_arr = np.array(origin, dtype=np.float64)
        if origin_arr.shape != (3,) or not np.all(np.isfinite(origin_arr)):
            raise ValueError(f"origin must be three finite numbers, got {origin!r}")
        self.origin: NDArray[np.float64] = origin_arr
        self.rotation = rotation
        self.offsets: NDArray[np.float64] = np.zeros(self.shape + (3,))
        if offsets is not None:
            self.set_offsets(offsets)
        self.border = border
        self.metadata: dict[str, Any] = {}

    @property
    def rotation(self) -> NDArray[np.float64]:
        """The lattice axes as columns (orthogonal, or unit vectors at any angles for a sheared lattice)."""
        return self._rotation

    @rotation.setter
    def rotation(self, value: ArrayLike | None) -> None:
        self._rotation, self._inverse = _check_rotation(value)

    @property
    def rotation_inverse(self) -> NDArray[np.float64]:
        """The inverse of :attr:`rotation`: its transpose for an orthogonal one, the inverse for a sheared one.

        Lattice coordinates are ``rotation_inverse @ (p - origin) / spacing``.

        Examples
        --------
        >>> import numpy as np
        >>> s = np.sqrt(0.5)
        >>> lat = Lattice((2, 2, 2), 1.0, rotation=[[1.0, s, 0.0], [0.0, s, 0.0], [0.0, 0.0, 1.0]])
        >>> lat.sheared, bool(np.allclose(lat.rotation_inverse @ lat.rotation, np.eye(3)))
        (True, True)
        """
        return self._inverse

    @property
    def sheared(self) -> bool:
        """Whether the axes are not orthogonal (a lattice placed by a general affine map)."""
        return orthogonality_error(self._rotation) > ROTATION_TOLERANCE

    @property
    def border(self) -> Border:
        """``"zero"`` or ``"clamp"``: what the B-spline FFD assumes beyond the lattice."""
        return self._border

    @border.setter
    def border(self, value: str) -> None:
        self._border = check_border(value)

    # ------------------------------------------------------------------ construction
    @classmethod
    def around(
        cls,
        points_or_mesh: Any,
        shape: tuple[int, ...] | int = (5, 5, 5),
        margin: float | None = None,
        basis: BasisName = "bspline",
        border: Border = "zero",
    ) -> Lattice:
        """Fit an axis-aligned lattice around a point set or mesh.

        Parameters
        ----------
        points_or_mesh : array_like or mesh
            ``(N, 3)`` points, or anything with a ``points`` attribute (a PyVista mesh).
        shape : tuple of int or int
            Control points per axis, counting every control point of the lattice. For the
            B-spline basis with ``border="zero"`` the outer ring of control points lies one
            spacing outside the fitted box: the box spans ``shape - 3`` cells, so each count must
            be at least 4. Otherwise (Bernstein, or ``border="clamp"``) the lattice spans the
            box exactly (at least 2 per axis; the B-spline FFD needs 4 with ``"zero"``).
        margin : float, optional
            Extra room on each side of the points' bounding box. With ``border="zero"``: a
            fraction of the largest extent, 0.05 by default. With ``"clamp"``: a fraction of
            each axis's own extent, 0.01 by default, so the box is at most ``2 * margin`` larger
            than the points' box on every axis (the lattice hugs the mesh).
        basis : {"bspline", "bernstein"}
            Which FFD basis the lattice is meant for (it decides where the points sit).
        border : {"zero", "clamp"}
            The border rule of the B-spline FFD the lattice is meant for; the lattice keeps it
            (:attr:`border`). The Bernstein basis has no border: it only changes the margin.

        Returns
        -------
        Lattice
            For ``"bspline"`` every point lies where the B-spline weights sum to one, so moving
            every control point by ``d`` moves every point by exactly ``d``.

        Examples
        --------
        >>> import numpy as np
        >>> pts = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]])
        >>> lat = Lattice.around(pts, shape=(5, 4, 4), margin=0.0)
        >>> lat.spacing.tolist(), lat.origin.tolist()
        ([1.0, 1.0, 1.0], [-1.0, -1.0, -1.0])
        >>> hug = Lattice.around(pts, shape=(5, 3, 3), margin=0.0, border="clamp")
        >>> hug.spacing.tolist(), hug.origin.tolist(), hug.border
        ([0.5, 0.5, 0.5], [0.0, 0.0, 0.0], 'clamp')
        """
        pts = as_points(points_or_mesh)
        shape_t = (
            (int(cast(int, shape)),) * 3
            if np.isscalar(shape)
            else tuple(int(s) for s in cast("tuple[int, ...]", shape))
        )
        if len(shape_t) != 3:
            raise ValueError(f"shape must be an int or three ints, got {shape!r}")
        if basis not in BASES:
            raise ValueError(f"basis must be 'bspline' or 'bernstein', got {basis!r}")
        check_border(border)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        extent = hi - lo
        largest = float(extent.max())
        if largest == 0.0:
            largest = 1.0
        # a flat axis (a planar mesh) still needs a cell of non-zero size
        extent = np.maximum(extent, 1e-3 * largest)
        if border == "clamp":
            pad = (0.01 if margin is None else margin) * extent
        else:
            pad = (0.05 if margin is None else margin) * largest
        lo = lo - pad
        extent = extent + 2 * pad
        counts = np.asarray(shape_t)
        if basis == "bspline" and border == "zero":
            if np.any(counts < 4):
                raise ValueError(f"a cubic B-spline lattice needs at least 4 control points per axis, got {shape_t}")
            spacing = extent / (counts - 3)
            origin = lo - spacing
        else:
            if np.any(counts < 2):
                raise ValueError(f"a lattice spanning the box needs at least 2 control points per axis, got {shape_t}")
            spacing = extent / (counts - 1)
            origin = lo
        return cls(shape_t, spacing, origin, border=border)

    def copy(self) -> Lattice:
        """Return an independent copy (offsets and metadata included).

        Returns
        -------
        Lattice
            A new lattice with copies of the offsets, placement and metadata.

        Examples
        --------
        >>> a = Lattice((2, 2, 2), 1.0)
        >>> b = a.copy(); b.offsets += 1
        >>> float(a.offsets.sum())
        0.0
        """
        out = Lattice(self.shape, self.spacing, self.origin, self.rotation, self.offsets, self.border)
        out.metadata = {k: (v.copy() if hasattr(v, "copy") else v) for k, v in self.metadata.items()}
        return out

    # ------------------------------------------------------------------ queries
    @property
    def n_points(self) -> int:
        """Number of control points ``nx * ny * nz``."""
        return int(np.prod(self.shape))

    def set_offsets(self, offsets: ArrayLike) -> None:
        """Replace all offsets (in place, so views of ``offsets`` stay valid).

        Parameters
        ----------
        offsets : array_like
            ``(nx, ny, nz, 3)`` finite values.

        Raises
        ------
        ValueError
            A wrong shape, or NaN or infinite values (the offsets are then unchanged).

        Examples
        --------
        >>> lat = Lattice((2, 2, 2), 1.0)
        >>> view = lat.offsets
        >>> lat.set_offsets(lat.offsets + 1.0)
        >>> float(view.sum())
        24.0
        """
        arr = np.asarray(offsets, dtype=np.float64)
        if arr.shape != self.shape + (3,):
            raise ValueError(f"offsets must have shape {self.shape + (3,)}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("offsets contain NaN or infinite values")
        self.offsets[...] = arr

    def reset(self) -> None:
        """Set every offset to zero.

        Examples
        --------
        >>> lat = Lattice((2, 2, 2), 1.0)
        >>> lat.offsets += 1.0
        >>> lat.reset()
        >>> float(abs(lat.offsets).sum())
        0.0
        """
        self.offsets[...] = 0.0

    def indices(self) -> NDArray[np.int64]:
        """All control-point indices as an ``(nx, ny, nz, 3)`` integer array.

        Returns
        -------
        numpy.ndarray
            ``(nx, ny, nz, 3)`` int: entry ``[i, j, k]`` is ``(i, j, k)``.

        Examples
        --------
        >>> Lattice((2, 3, 2), 1.0).indices()[1, 2, 0].tolist()
        [1, 2, 0]
        """
        return np.stack(np.meshgrid(*[np.arange(n) for n in self.shape], indexing="ij"), axis=-1)

    def control_points(self, deformed: bool = False) -> NDArray[np.float64]:
        """Control-point positions as an ``(nx, ny, nz, 3)`` array.

        Parameters
        ----------
        deformed : bool
            If true, add the offsets to the rest positions.

        Returns
        -------
        numpy.ndarray
            ``(nx, ny, nz, 3)`` float64 world positions.

        Examples
        --------
        >>> Lattice((2, 2, 2), 2.0).control_points().reshape(-1, 3)[-1].tolist()
        [2.0, 2.0, 2.0]
        """
        rest = (self.indices() * self.spacing) @ self.rotation.T + self.origin
        return rest + self.offsets if deformed else rest

    def to_lattice(self, points: ArrayLike) -> NDArray[np.float64]:
        """Lattice coordinates ``(u, v, w)`` of world points (control point (i, j, k) is at (i, j, k)).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` world points (or one point).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64 lattice coordinates.

        Examples
        --------
        >>> Lattice((3, 3, 3), 2.0, origin=(1, 1, 1)).to_lattice([[3.0, 2.0, 1.0]]).tolist()
        [[1.0, 0.5, 0.0]]
        """
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return ((pts - self.origin) @ self._inverse.T) / self.spacing

    def to_world(self, lattice_coords: ArrayLike) -> NDArray[np.float64]:
        """World positions of lattice coordinates (the inverse of :meth:`to_lattice`).

        Parameters
        ----------
        lattice_coords : array_like
            ``(N, 3)`` lattice coordinates ``(u, v, w)``.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64 world positions.

        Examples
        --------
        >>> lat = Lattice((3, 3, 3), 2.0, origin=(1, 1, 1))
        >>> lat.to_world(lat.to_lattice([[3.0, 2.0, 1.0]])).tolist()
        [[3.0, 2.0, 1.0]]
        """
        uvw = np.asarray(lattice_coords, dtype=np.float64).reshape(-1, 3)
        return (uvw * self.spacing) @ self.rotation.T + self.origin

    def bounds(self) -> NDArray[np.float64]:
        """World bounding box of the rest lattice as ``[xmin, xmax, ymin, ymax, zmin, zmax]``.

        Returns
        -------
        numpy.ndarray
            ``(6,)`` float64, PyVista's bounds order.

        Examples
        --------
        >>> Lattice((3, 2, 2), 1.0, origin=(1, 0, 0)).bounds().tolist()
        [1.0, 3.0, 0.0, 1.0, 0.0, 1.0]
        """
        pts = self.control_points().reshape(-1, 3)
        return np.column_stack([pts.min(0), pts.max(0)]).ravel()

    def edges(self) -> NDArray[np.int64]:
        """Pairs of flat control-point indices joined by a lattice line, shape ``(E, 2)``.

        Flat index of ``(i, j, k)`` is ``(i * ny + j) * nz + k`` (C order, like ``offsets``).

        Returns
        -------
        numpy.ndarray
            ``(E, 2)`` int64 pairs of flat indices.

        Examples
        --------
        >>> len(Lattice((2, 2, 2), 1.0).edges())
        12
        """
        ids = np.arange(self.n_points).reshape(self.shape)
        pairs = []
        for axis in range(3):
            a = np.moveaxis(ids, axis, 0)
            pairs.append(np.stack([a[:-1].ravel(), a[1:].ravel()], axis=1))
        return np.concatenate(pairs)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Lattice):
            return NotImplemented
        return (
            self.shape == other.shape
            and np.array_equal(self.spacing, other.spacing)
            and np.array_equal(self.origin, other.origin)
            and np.array_equal(self.rotation, other.rotation)
            and np.array_equal(self.offsets, other.offsets)
            and self.border == other.border
        )

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __repr__(self) -> str:
        moved = int(np.count_nonzero(np.any(self.offsets != 0, axis=-1)))
        return (
            f"Lattice(shape={self.shape}, spacing={self.spacing.tolist()}, origin={self.origin.tolist()}, "
            f"rotation={'identity' if np.array_equal(self.rotation, np.eye(3)) else self.rotation.tolist()}, "
            f"moved={moved}/{self.n_points}{'' if self.border == 'zero' else f', border={self.border!r}'})"
        )
