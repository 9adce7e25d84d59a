"""A deformation evaluated on a regular grid, slab by slab: the one evaluator of an FFD on an image's voxels.

``warp_image``, displacement-field sampling (``sample_displacement_field``, ``save_displacement_field``,
``fit_lattice(region=<grid>)``) and the editor's image slices all evaluate ``T(x)`` here. A regular
grid places voxel ``(i, j, k)`` at ``placement @ (i, j, k, 1)`` (an image's index-to-physical
matrix; a 2D image is a grid one voxel deep along ``k``, in the plane ``z = 0``); its values are
listed in array order, ``k`` slowest, as NumPy and SimpleITK index images, and made a slab of the
slowest axis at a time so the working memory stays small whatever the grid.

**Separable path.** When each lattice coordinate changes along one grid axis only (a lattice fitted
to the image, a registration's control grid, a sheared lattice over a grid with the same shear),
lattice coordinate ``u_a`` of voxel ``(i, j, k)`` depends on one index, the basis weights of the whole
grid are three small per-axis matrices (:func:`axis_matrix`) and

    T_local(i, j, k) = sum_abc W_i[i, a] W_j[j, b] W_k[k, c] P[a, b, c]

is contracted one axis at a time (``K n^3``, then ``K J n^2`` values, then one BLAS product per
component for the slab), the affine part and the output's frame folded in as two more columns of
``W_i``. Every option of :class:`~ffd_notebook.FFD` holds there: the basis, per axis too (its
:class:`~.basis.AxisBasis` weights through the border rule of :mod:`.support`, or Bernstein's),
``border``, ``strength`` (a scale of the coefficients), ``outside`` (the offsets in use),
``only_inside`` (the domain is a box in lattice coordinates: rows of the per-axis matrices set to
zero, :func:`~.support.axis_in_domain`), per-point ``weights`` (:func:`grid_weights`), the affine part.

**Plain path.** Anything else (a lattice turned against the grid, any other deformation: an elastix
chain, a displacement field) is evaluated point by point by its ``deform`` on each slab's voxel
centres; :attr:`GridEvaluator.separable` says which path runs. ``tests/test_grid.py``
proves the separable path equal to ``FFD.deform`` point by point, and that the plain path is taken
exactly where the separable one cannot hold.

On the faces of an ``only_inside`` domain the deformation is discontinuous: there a voxel whose
lattice coordinate lies within rounding (about ``1e-13`` cells) of a face may be inside by one
path's arithmetic and outside by the other's.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook import FFD, Lattice
>>> placement = np.diag([0.5, 0.5, 0.5, 1.0])                 # 0.5 mm voxels from the origin
>>> lat = Lattice((5, 5, 5), 2.0, origin=(-2.0, -2.0, -2.0))
>>> lat.offsets[2, 2, 2] = (0.3, 0.0, 0.0)
>>> evaluator = GridEvaluator(FFD(lat, strength=0.5), placement, (6, 7, 8))     # array order: k, j, i
>>> evaluator.separable, evaluator.displacements(0, 6).shape
(True, (3, 6, 7, 8))
>>> points = np.array([[1.5, 1.0, 0.5]])                    # voxel (3, 2, 1)
>>> bool(np.allclose(evaluator.displacements(1, 2)[:, 0, 2, 3], FFD(lat, strength=0.5).deform(points)[0] - points[0]))
True
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .basis import bernstein
from .deform import FFD
from .influence import point_weights
from .interpolation import AXIS_BASES, axis_bases
from .lattice import Lattice
from .oneshot import SERIAL_MADDS
from .support import axis_in_domain, axis_support

__all__ = ["GridEvaluator", "axis_matrix", "grid_axes", "grid_weights"]

#: The largest change of a lattice coordinate, across the whole grid, along a grid axis other than
#: the one it is paired with, that the separable path may ignore (larger: the plain path).
ALIGNED = 1e-10


def axis_matrix(
    kind: str, u: ArrayLike, n: int, border: str = "zero", only_inside: bool | str = False
) -> NDArray[np.float64]:
    """Weights of the ``n`` control points of one lattice axis at lattice coordinates ``u``, ``(len(u), n)``.

    Parameters
    ----------
    kind : str
        ``"bernstein"`` (over the lattice's box, ``u / (n - 1)``), or one of the local bases of
        :data:`~.interpolation.AXIS_BASES` (``"bspline"``, ``"linear"``, ``"cardinal"``, ``"catmull-rom"``).
    u : array_like
        Lattice coordinates along the axis (control point ``i`` at ``u = i``).
    n : int
        Control points along the axis.
    border : {"zero", "clamp"}
        The border rule of a local basis (:func:`~.support.axis_support`).
    only_inside : bool or "half-open"
        Zero rows for coordinates outside the domain (:func:`~.support.axis_in_domain`).

    Returns
    -------
    numpy.ndarray
        Dense weights; row ``p`` sums to one where the basis is a partition of unity.

    Examples
    --------
    >>> axis_matrix("bspline", [1.0, 2.5], 4).round(4).tolist()
    [[0.1667, 0.6667, 0.1667, 0.0], [0.0, 0.0208, 0.4792, 0.4792]]
    >>> axis_matrix("bspline", [0.0], 4, border="clamp").round(4).tolist()   # the point beyond: the border's
    [[0.8333, 0.1667, 0.0, 0.0]]
    >>> axis_matrix("linear", [0.5, 1.5], 4, only_inside=True).tolist()    # the domain: 1 <= u <= 2
    [[0.0, 0.0, 0.0, 0.0], [0.0, 0.5, 0.5, 0.0]]
    """
    u = np.asarray(u, dtype=np.float64).reshape(-1)
    if kind == "bernstein":
        dense = bernstein(u / (n - 1), n - 1)
    else:
        index, weight = axis_support(u, n, border, AXIS_BASES[kind])
        dense = np.zeros((len(u), n))
        np.add.at(dense, (np.arange(len(u))[:, None], index), weight)  # "clamp" repeats a border index
    if only_inside:
        dense[~axis_in_domain(kind, n, u, only_inside)] = 0.0
    return dense


def grid_axes(
    lattice: Lattice, placement: ArrayLike, size: Sequence[int]
) -> list[tuple[int, NDArray[np.float64]]] | None:
    """The lattice axis running along each grid axis, and its coordinates at the grid's voxels; None if none does.

    Lattice coordinate ``u_a`` of voxel ``(i, j, k)`` is affine in the indices. The grid runs along
    the lattice when each ``u_a`` changes (by more than :data:`ALIGNED` across the grid) along one
    grid axis at most, a different one for each lattice axis: rotated, permuted, flipped or sheared
    alike, as long as the grid's axes are the lattice's (the exact inverse of a sheared lattice's
    axes is used, as ``Lattice.to_lattice`` does).

    Parameters
    ----------
    lattice : Lattice
        The lattice.
    placement : array_like
        ``4 x 4`` (or ``3 x 4``) matrix taking ``(i, j, k, 1)`` to physical points.
    size : sequence of int
        Voxels along ``i, j, k`` (x first; 1 along ``k`` for a 2D image).

    Returns
    -------
    list of (int, numpy.ndarray) or None
        Per grid axis ``g`` (``i``, ``j``, ``k``): the lattice axis ``a`` and ``u_a`` at indices
        ``0 .. size[g] - 1`` along it (the other indices at 0).

    Examples
    --------
    >>> import numpy as np
    >>> lat = Lattice((4, 5, 6), 2.0)
    >>> swap = np.array([[0.0, 1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    >>> [(a, u.tolist()) for a, u in grid_axes(lat, swap, (3, 2, 1))]    # i runs along y, j along x
    [(1, [0.0, 0.5, 1.0]), (0, [0.0, 0.5]), (2, [0.0])]
    >>> turned = np.eye(4); turned[:2, :2] = [[0.8, -0.6], [0.6, 0.8]]
    >>> grid_axes(lat, turned, (3, 2, 1)) is None
    True
    """
    matrix = np.asarray(placement, dtype=np.float64)
    to_u = lattice.rotation_inverse / lattice.spacing[:, None]  # x -> u, as lattice_rows
    along = to_u @ matrix[:3, :3]  # du_a / d index_g
    start = to_u @ matrix[:3, 3] - to_u @ lattice.origin
    counts = np.asarray(size, dtype=np.int64)
    moving = np.abs(along) * (counts - 1) > ALIGNED
    if (moving.sum(axis=0) > 1).any() or (moving.sum(axis=1) > 1).any():
        return None
    lattice_axis = [-1, -1, -1]  # per grid axis
    for a, g in zip(*np.nonzero(moving), strict=True):
        lattice_axis[int(g)] = int(a)
    idle = [a for a in range(3) if a not in lattice_axis]  # constant over the grid: any axis left will do
    for axis in range(3):
        if lattice_axis[axis] < 0:
            lattice_axis[axis] = idle.pop(0)
    return [(a, start[a] + along[a, g] * np.arange(counts[g], dtype=np.float64)) for g, a in enumerate(lattice_axis)]


def grid_weights(weights: Any, shape: Sequence[int]) -> NDArray[np.float64] | None:
    """An FFD's per-point weights as a grid's voxel weights, ``shape`` (array order); None for none.

    An FFD's weights are one per point of the point set they belong to. On a grid that point set is
    the voxels, in array order (``k`` slowest, ``i`` fastest, as ``ImageGrid.physical_points`` lists
    them): ``weights.reshape(shape)`` is a weight image. Weights of another point set (a mesh's
    vertex weights, a point-data name) say nothing of the voxels and are refused.

    Raises
    ------
    ValueError
        Weights that are not one per voxel, or not in [0, 1].

    Examples
    --------
    >>> grid_weights(np.linspace(0.0, 1.0, 6), (2, 3)).tolist()
    [[0.0, 0.2, 0.4], [0.6000000000000001, 0.8, 1.0]]
    >>> grid_weights(np.ones(5), (2, 3))
    Traceback (most recent call last):
    ...
    ValueError: the FFD's per-point weights are 5 values, one per point of another point set (...); on a grid ...
    """
    if weights is None:
        return None
    count = int(np.prod(shape))
    if isinstance(weights, str):
        raise ValueError(f"the FFD's weights name a point-data array of a mesh ({weights!r}); a grid's voxels have "
                         "none: an FFD without weights deforms the whole grid")  # fmt: skip
    w = np.asarray(weights, dtype=np.float64)
    if w.size != count:
        raise ValueError(
            f"the FFD's per-point weights are {w.size} values, one per point of another point set (a mesh's "
            f"vertices?); on a grid of shape {tuple(shape)} they must be one per voxel ({count}, in array "
            "order); an FFD without weights deforms the whole grid"
        )
    checked = point_weights(w.reshape(-1), count)
    assert checked is not None  # weights were given
    return checked.reshape(tuple(shape))


class _Plan:
    """What the separable path keeps between calls: the per-axis matrices of one lattice placement and basis."""

    def __init__(self, ffd: FFD, axes: list[tuple[int, NDArray[np.float64]]], ffd_key: tuple) -> None:
        lat = ffd.lattice
        kinds = ["bernstein"] * 3 if ffd.basis == "bernstein" else [b.name for b in axis_bases(ffd.basis)]
        # per grid axis g: (size_g, n_a) weights of the lattice axis a running along it
        self.mats = [axis_matrix(kinds[a], u, lat.shape[a], ffd.border, ffd.only_inside) for a, u in axes]
        self.order = [a for a, _ in axes]  # the lattice axes in grid order (i, j, k)
        i = np.arange(self.mats[0].shape[0], dtype=np.float64)
        # the x weights transposed, with two more rows: those of i and 1, for the part affine in the indices
        self.w_i = np.ascontiguousarray(np.column_stack([self.mats[0], i, np.ones_like(i)]).T)  # (n_i + 2, I)
        self.key = ffd_key


class GridEvaluator:
    """``T(x)`` of a deformation at the voxels of a regular grid, a slab of the slowest array axis at a time.

    Separable for an FFD whose lattice runs along the grid (:func:`grid_axes`), point by point
    through ``deform`` otherwise (see the module). The FFD's offsets, strength, options and lattice
    placement are read at each call (the per-axis weights are made again when they changed); its
    per-point weights, one per voxel (:func:`grid_weights`), when they are set to another array.

    Parameters
    ----------
    deformation : FFD or object with ``deform(points)``
        ``(N, 3) -> (N, 3)`` physical points.
    placement : array_like
        ``4 x 4`` (or ``3 x 4``) matrix taking voxel indices ``(i, j, k, 1)`` to physical points.
    shape : sequence of int
        The grid in array order: ``(K, J, I)``, or ``(J, I)`` for a 2D grid (``k = 0``).
    output : array_like, optional
        ``4 x 4`` (or ``3 x 4``) affine map applied to the deformed points by :meth:`points` (an
        input image's physical-to-index matrix); the identity by default.
    weights : array_like, optional
        Per-voxel weights of this grid (``shape``, array order) used instead of an FFD's own (a
        slice of a larger grid takes its voxels' share of the whole grid's weights).

    Attributes
    ----------
    separable : bool
        Whether :meth:`points` and :meth:`displacements` run the separable path (re-checked at
        each call: a lattice turned later is evaluated point by point).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 4.0, origin=(-4.0, -4.0, -4.0)); lat.offsets[...] = (1.0, 0.0, 0.0)
    >>> to_index = np.diag([0.5, 0.5, 0.5, 1.0])                   # an input image with 2 mm voxels
    >>> evaluator = GridEvaluator(FFD(lat), np.eye(4), (2, 3), output=to_index)
    >>> evaluator.points(0, 1, components=(1, 0)).round(12).tolist()   # rows (j, i) of the input, for j = 0
    [[[0.0, 0.0, 0.0]], [[0.5, 1.0, 1.5]]]
    """

    def __init__(
        self,
        deformation: Any,
        placement: ArrayLike,
        shape: Sequence[int],
        *,
        output: ArrayLike | None = None,
        weights: ArrayLike | None = None,
    ) -> None:
        if not callable(getattr(deformation, "deform", None)):
            raise TypeError(f"a deformation needs a deform(points) method, got {type(deformation).__name__}")
        self.deformation = deformation
        self.placement = _homogeneous(placement, "placement")
        self.output = np.eye(4) if output is None else _homogeneous(output, "output")
        self.shape: tuple[int, ...] = tuple(int(n) for n in shape)
        if len(self.shape) not in (2, 3) or min(self.shape) < 1:
            raise ValueError(f"a grid's shape is 2 or 3 positive counts (array order), got {tuple(shape)}")
        self.size = self.shape[::-1] + (1,) * (3 - len(self.shape))  # (I, J, K)
        if weights is not None and not isinstance(deformation, FFD):
            raise TypeError(f"per-voxel weights scale an FFD's displacement; a {type(deformation).__name__} takes none")
        self._plan: _Plan | None = None
        self._own_weights = weights is not None
        self._weights_given: Any = None
        self._weights = None if weights is None else grid_weights(np.asarray(weights).reshape(-1), self.shape)

    # ------------------------------------------------------------------ the state read at each call
    def _ffd_key(self, ffd: FFD) -> tuple:
        lat = ffd.lattice
        geometry = (lat.shape, lat.spacing.tobytes(), lat.origin.tobytes(), lat.rotation.tobytes())
        return (ffd.basis, ffd.border, ffd.only_inside, *geometry)

    def _current_plan(self) -> _Plan | None:
        ffd = self.deformation
        if not isinstance(ffd, FFD):
            return None
        key = self._ffd_key(ffd)
        if self._plan is None or self._plan.key != key:
            axes = grid_axes(ffd.lattice, self.placement, self.size)
            self._plan = None if axes is None else _Plan(ffd, axes, key)
        return self._plan

    def _voxel_weights(self) -> NDArray[np.float64] | None:
        if self._own_weights:
            return self._weights
        ffd = self.deformation
        given = ffd.weights if isinstance(ffd, FFD) else None
        if given is not self._weights_given or (given is None) != (self._weights is None):
            self._weights = grid_weights(given, self.shape)
            self._weights_given = given
        return self._weights

    @property
    def separable(self) -> bool:
        """Whether the separable path runs (an FFD whose lattice runs along the grid)."""
        return self._current_plan() is not None

    # ------------------------------------------------------------------ evaluation
    def slab_index(self, start: int, stop: int) -> NDArray[np.float64]:
        """``(4, n)`` homogeneous indices ``(i, j, k, 1)`` of array rows ``start:stop``, in C order.

        Parameters
        ----------
        start, stop : int
            Rows of the grid's first (slowest) array axis.

        Returns
        -------
        numpy.ndarray
            ``(4, n)`` float64, ``n`` the voxels of those rows, ``i`` fastest.

        Examples
        --------
        >>> GridEvaluator(FFD(Lattice((4, 4, 4), 1.0)), np.eye(4), (2, 3)).slab_index(1, 2)[:2].tolist()
        [[0.0, 1.0, 2.0], [1.0, 1.0, 1.0]]
        """
        rows = (stop - start, *self.shape[1:])
        axes = [np.arange(start, stop, dtype=np.float64)] + [np.arange(n, dtype=np.float64) for n in rows[1:]]
        grids = np.meshgrid(*axes, indexing="ij")  # array order: (k, j, i) or (j, i)
        index = np.zeros((4, grids[0].size))
        for axis, values in enumerate(reversed(grids)):  # i first
            index[axis] = values.ravel()
        index[3] = 1.0
        return index

    def points(self, start: int, stop: int, *, components: Sequence[int] = (0, 1, 2)) -> NDArray[np.float64]:
        """``output @ T(x)`` for the voxels of array rows ``start:stop``.

        Parameters
        ----------
        start, stop : int
            Rows of the grid's first (slowest) array axis.
        components : sequence of int
            The rows of the result and their order: ``(2, 1, 0)`` gives an input image's indices in
            array order ``(k, j, i)``, ready for ``scipy.ndimage.map_coordinates``.

        Returns
        -------
        numpy.ndarray
            ``(len(components), stop - start, *shape[1:])`` float64.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1.0, -1.0, -1.0)); lat.offsets[...] = (0.0, 0.0, 2.0)
        >>> GridEvaluator(FFD(lat), np.eye(4), (1, 1, 2)).points(0, 1).round(12).tolist()
        [[[[0.0, 1.0]]], [[[0.0, 0.0]]], [[[2.0, 2.0]]]]
        """
        return self._evaluate(start, stop, list(components), displacement=False)

    def displacements(self, start: int, stop: int) -> NDArray[np.float64]:
        """``T(x) - x`` (physical) for the voxels of array rows ``start:stop``.

        Parameters
        ----------
        start, stop : int
            Rows of the grid's first (slowest) array axis.

        Returns
        -------
        numpy.ndarray
            ``(3, stop - start, *shape[1:])`` float64 displacements.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1.0, -1.0, -1.0)); lat.offsets[...] = (0.0, 0.0, 2.0)
        >>> GridEvaluator(FFD(lat, strength=0.5), np.eye(4), (2, 2)).displacements(0, 2)[2].round(12).tolist()
        [[1.0, 1.0], [1.0, 1.0]]
        """
        return self._evaluate(start, stop, [0, 1, 2], displacement=True)

    def _evaluate(self, start: int, stop: int, components: list[int], displacement: bool) -> NDArray[np.float64]:
        if not 0 <= start < stop <= self.shape[0]:
            raise ValueError(f"rows {start}:{stop} are not within the grid's {self.shape[0]} rows")
        plan = self._current_plan()
        weights = self._voxel_weights()
        w = None if weights is None else weights[start:stop]
        if plan is None:
            return self._plain(start, stop, components, displacement, w)
        return self._separable(plan, start, stop, components, displacement, w)

    def _plain(
        self, start: int, stop: int, components: list[int], displacement: bool, w: NDArray[np.float64] | None
    ) -> NDArray[np.float64]:
        """The plain path: ``deform`` of the slab's voxel centres."""
        points = (self.placement @ self.slab_index(start, stop))[:3].T
        if w is None:
            moved = np.asarray(self.deformation.deform(points), dtype=np.float64)
        else:
            moved = np.asarray(self.deformation.deform(points, weights=w.reshape(-1)), dtype=np.float64)
        if moved.shape != points.shape:
            raise ValueError(f"deformation.deform returned shape {moved.shape} for {points.shape} points")
        with np.errstate(invalid="ignore", over="ignore"):  # a deformation's NaN or inf is its own (images: outside)
            if displacement:
                values = (moved - points).T
            else:
                values = self.output[:3, :3] @ moved.T
                values += self.output[:3, 3, None]
        return np.ascontiguousarray(values[components]).reshape(len(components), stop - start, *self.shape[1:])

    def _separable(
        self,
        plan: _Plan,
        start: int,
        stop: int,
        components: list[int],
        displacement: bool,
        w: NDArray[np.float64] | None,
    ) -> NDArray[np.float64]:
        """The separable path: ``base(x) + factor * Q ((A - I) x + b + T_local(x))``, ``x`` affine in the indices."""
        ffd = cast(FFD, self.deformation)
        s = ffd.strength
        linear, shift = ffd.affine[:3, :3] - np.eye(3), ffd.affine[:3, 3]
        g, g0 = self.placement[:3, :3], self.placement[:3, 3]
        q_mat = np.eye(3) if displacement else self.output[:3, :3]
        q_mat = q_mat[components]
        # the part scaled by strength * weight: s Q ((A - I) x + b) + s Q T_local(x)
        scaled_lin = s * (q_mat @ linear @ g)
        scaled_const = s * (q_mat @ (linear @ g0 + shift))
        # the part that is not: x itself in the output frame (none for a displacement)
        base_lin = np.zeros_like(scaled_lin) if displacement else q_mat @ g
        base_const = np.zeros(len(components)) if displacement else q_mat @ g0 + self.output[components, 3]
        offsets = np.transpose(ffd.offsets_in_use(), (*plan.order, 3)) @ (s * q_mat).T  # grid order, output frame
        if w is None:  # one factor for all: everything in one contraction
            return self._contract(plan, offsets, scaled_lin + base_lin, scaled_const + base_const, start, stop)
        values = self._contract(plan, offsets, scaled_lin, scaled_const, start, stop)
        values *= w
        index = self.slab_index(start, stop)
        values += (base_lin @ index[:3] + base_const[:, None]).reshape(values.shape)
        return values

    def _contract(
        self,
        plan: _Plan,
        offsets: NDArray[np.float64],
        linear: NDArray[np.float64],
        constant: NDArray[np.float64],
        start: int,
        stop: int,
    ) -> NDArray[np.float64]:
        """``sum W_i W_j W_k offsets + linear @ (i, j, k) + constant`` on rows ``start:stop``, ``(m, rows, ...)``.

        Every product is cut below OpenBLAS's threading threshold (:func:`_product`): the evaluator
        runs on its caller's thread and needs no process-wide limit on BLAS threads.
        """
        _, w_j, w_k = plan.mats
        w_i = plan.w_i
        if w_i.shape[1] == 1:  # one voxel along i (a slice across it): contract x first, into the offsets
            offsets = np.tensordot(plan.mats[0][0], offsets, axes=(0, 0))[None]
            w_i = np.array([[1.0], [0.0], [1.0]])  # its weight 1, then the columns of i (= 0) and 1
        n_i, n_j, n_k, m = offsets.shape
        # z first: (rows_k, n_k) @ (n_k, n_j n_i m), then y: (rows_j, n_j) @ (n_j, rows_k n_i m)
        by_z = np.ascontiguousarray(offsets.transpose(2, 1, 0, 3)).reshape(n_k, n_j * n_i * m)
        if len(self.shape) == 3:
            ks = np.arange(start, stop, dtype=np.float64)
            js = np.arange(self.size[1], dtype=np.float64)
            w_rows, w_ys = w_k[start:stop], w_j
        else:  # a plane: k = 0, rows are j
            ks = np.zeros(1)
            js = np.arange(start, stop, dtype=np.float64)
            w_rows, w_ys = w_k[:1], w_j[start:stop]
        q = _product(w_rows, by_z).reshape(len(ks), n_j, n_i * m)
        r = _product(w_ys, np.ascontiguousarray(q.transpose(1, 0, 2)).reshape(n_j, -1))  # (rows_j, rows_k n_i m)
        # (m, rows_k, rows_j, n_i + 2): the x weights' coefficients, then those of i and 1 (the affine part)
        augmented = np.empty((m, len(ks), len(js), n_i + 2))
        augmented[..., :n_i] = r.reshape(len(js), len(ks), n_i, m).transpose(3, 1, 0, 2)
        augmented[..., n_i] = linear[:, 0, None, None]
        rest = augmented[..., n_i + 1]
        rest[...] = constant[:, None, None]
        rest += linear[:, 1, None, None] * js[None, None, :]
        rest += linear[:, 2, None, None] * ks[None, :, None]
        out = np.empty((m, len(ks) * len(js), w_i.shape[1]))
        for c in range(m):
            _product(augmented[c].reshape(-1, n_i + 2), w_i, out=out[c])
        return out.reshape(m, stop - start, *self.shape[1:])


def _product(a: NDArray[np.float64], b: NDArray[np.float64], out: NDArray[np.float64] | None = None) -> NDArray:
    """``a @ b`` on the calling thread: in row blocks of at most :data:`~.oneshot.SERIAL_MADDS` multiply-adds."""
    if out is None:
        out = np.empty((a.shape[0], b.shape[1]))
    rows = max(1, SERIAL_MADDS // max(1, a.shape[1] * b.shape[1]))
    for s in range(0, a.shape[0], rows):
        np.matmul(a[s : s + rows], b, out=out[s : s + rows])
    return out


def _homogeneous(matrix: ArrayLike, name: str) -> NDArray[np.float64]:
    m = np.array(matrix, dtype=np.float64)
    if m.shape == (3, 4):
        m = np.vstack([m, [0.0, 0.0, 0.0, 1.0]])
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise ValueError(f"{name} must be a finite 4x4 (or 3x4) affine matrix, got shape {m.shape}")
    return m
