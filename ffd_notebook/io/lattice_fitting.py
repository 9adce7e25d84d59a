"""Any deformation into an editable lattice: the least-squares B-spline FFD that best reproduces it.

:func:`fit_lattice` samples a deformation (a displacement field, an elastix chain, an FFD, a GP
sample, any callable on points) over a region and finds the lattice offsets ``c`` minimising
``sum_p w_p |A x_p + b + sum B(u_p) c - T(x_p)|^2``, with the affine part ``(A, b)`` fitted first
when asked (else the identity).

On a regular grid aligned with the lattice (a field's own voxels, an elastix chain's fixed image,
any reference grid) the B-spline matrix is a Kronecker product ``Bx (x) By (x) Bz`` of per-axis
matrices, and so is its pseudo-inverse: the solve is three small pseudo-inverses applied along
each axis in turn (about ``nx * Nx * Ny * Nz`` multiply-adds), never the ``N x n`` matrix. Any
other region (a mesh's vertices, a mask, weights) goes through the sparse normal equations.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from ..ffd.deform import FFD
from ..ffd.fit import control_weights
from ..ffd.grid import axis_matrix, grid_axes
from ..ffd.lattice import Lattice
from ..images.geometry import ImageGrid
from ..images.reference import is_reference_grid
from .displacement_field import DisplacementField, sample_displacement_field

__all__ = ["fit_lattice"]

_MAX_SPARSE_ENTRIES = 64 * 2_000_000  # the general path's matrix: 2M points (about 2 GB with its normal matrix)
_MAX_FACTOR_BYTES = 2 * 2**30  # the general path's factorisation (see _factor_bytes)
_MAX_OFFSETS_BYTES = 2**30  # a new lattice's offsets (the fit holds two copies of them)


def _as_shape(shape: Any) -> tuple[int, int, int]:
    values = (int(cast(int, shape)),) * 3 if np.isscalar(shape) else tuple(int(s) for s in shape)
    if len(values) != 3 or min(values) < 4:
        raise ValueError(
            f"shape must be an int or three ints, each at least 4 (a cubic B-spline lattice), got {shape!r}"
        )
    size = 24 * float(np.prod(values, dtype=np.float64))  # three float64 offsets a control point
    if size > _MAX_OFFSETS_BYTES:
        raise ValueError(f"a {'x'.join(map(str, values))} lattice's offsets alone would take {size / 2**30:.3g} GiB "
                         f"(at most {_MAX_OFFSETS_BYTES / 2**30:.0f}); use a smaller shape")  # fmt: skip
    return values


def _unit_columns(direction: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The direction itself if its columns are unit vectors (to rounding): a lattice's axes, sheared or not."""
    if np.abs(np.linalg.norm(direction, axis=0) - 1.0).max() > 1e-9:
        return None
    return direction


def _lattice_over_grid(field: DisplacementField, shape: tuple[int, int, int]) -> Lattice:
    """A zero-border lattice whose domain is the field's grid box exactly, its axes along the grid's (sheared too)."""
    rotation = _unit_columns(field.direction)
    if rotation is None:
        return Lattice.around(field.grid_points(), shape, margin=0.0)
    extent = (np.array(field.size) - 1) * field.spacing
    extent = np.where(extent > 0, extent, field.spacing)  # a single-voxel axis still spans one spacing
    spacing = extent / (np.array(shape) - 3)
    return Lattice(shape, spacing, field.origin - rotation @ spacing, rotation)


def _apply_along(matrix: NDArray[np.float64], data: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    """``matrix`` applied along one of the first three axes of ``data`` (``(n0, n1, n2, ...)``)."""
    moved = np.moveaxis(data, axis, 0)
    out = (matrix @ moved.reshape(moved.shape[0], -1)).reshape((matrix.shape[0],) + moved.shape[1:])
    return np.moveaxis(out, 0, axis)


def _affine_fit(points: NDArray[np.float64], targets: NDArray[np.float64], weights: NDArray[np.float64] | None):
    """Least-squares ``(A, b)`` with ``A x + b ~ targets``."""
    design = np.column_stack([points, np.ones(len(points))])
    if weights is not None:
        root = np.sqrt(weights)[:, None]
        design, targets = design * root, targets * root
    solution, *_ = np.linalg.lstsq(design, targets, rcond=None)
    return solution[:3].T, solution[3]


def _grid_fit(field, lattice, axes, affine):
    """The separable solve on a full grid along the lattice; returns offsets, affine (A, b) and the residual vectors.

    ``axes`` (:func:`~ffd_notebook.ffd.grid.grid_axes`): per grid axis ``i, j, k`` the lattice axis along
    it and its coordinates. The B-spline matrix is ``W_i (x) W_j (x) W_k`` (:func:`~ffd_notebook.ffd.grid.axis_matrix`,
    the engine's weights, "zero" border), so its pseudo-inverse is the per-axis ones'. The field's
    vectors ``[k, j, i]`` are put in grid order ``(i, j, k)``, solved, and the offsets in the lattice's order."""
    targets = field.vectors
    a, b = np.eye(3), np.zeros(3)
    if affine:
        points = field.grid_points()
        a, b = _affine_fit(points, points + targets.reshape(-1, 3), None)
        targets = (points + targets.reshape(-1, 3) - points @ a.T - b).reshape(targets.shape)
    targets = targets.transpose(2, 1, 0, 3)
    mats = [axis_matrix("bspline", u, lattice.shape[axis], "zero") for axis, u in axes]
    offsets = targets
    for g in range(3):
        offsets = _apply_along(np.linalg.pinv(mats[g]), offsets, g)
    predicted = offsets
    for g in range(3):
        predicted = _apply_along(mats[g], predicted, g)
    order = [axis for axis, _ in axes]  # the lattice axis along each grid axis
    offsets = np.transpose(offsets, (*np.argsort(order), 3))
    return offsets, (a, b), (targets - predicted).transpose(2, 1, 0, 3).reshape(-1, 3)


def _factor_bytes(reached: int) -> float:
    """Memory the factorisation of the normal equations over ``reached`` control points may take.

    Measured with SuperLU (minimum degree on ``A + A^T``, the matrix's symmetric mode): 1,728,
    8,000 and 13,824 control points reached by points filling a box took 15 MB, 270 MB and
    790 MB; the factors' entries grow as ``reached ** 1.55`` (about 17 times that, 18 bytes each;
    points on a surface fill half as much). The estimate is that of a filled box.
    """
    return 18.0 * 17.0 * reached**1.55


def _sparse_fit(points, targets, lattice, weights, affine):
    """The general solve: the normal equations over scattered points, on the control points they reach.

    Only the control points some sample moves enter the system (a 200^3 lattice around 20 points
    solves for at most 1,280 of its 8 million); the others keep a zero offset, the least-norm
    choice. A ridge at rounding level of each diagonal entry keeps a rank-deficient sample set
    solvable. The factorisation is SuperLU's in symmetric mode (the matrix is symmetric positive
    definite): 3-4x less time and fill than its default ordering. A system whose factors would
    not fit in :data:`_MAX_FACTOR_BYTES` is refused before any of it is built.
    """
    from scipy import sparse
    from scipy.sparse.linalg import splu

    a, b = np.eye(3), np.zeros(3)
    if affine:
        a, b = _affine_fit(points, targets, weights)
    local = targets - points @ a.T - b
    n = len(points)
    if n * 64 > _MAX_SPARSE_ENTRIES:
        raise ValueError(f"{n} scattered points are too many for the general fit (at most "
                         f"{_MAX_SPARSE_ENTRIES // 64}); fit on a regular grid along the lattice axes")  # fmt: skip
    index, weight = control_weights(FFD(lattice, border="zero"), points)  # (n, 64): the engine's rows
    moving = weight != 0
    reached = np.unique(index[moving])
    if _factor_bytes(len(reached)) > _MAX_FACTOR_BYTES:
        shape = "x".join(map(str, lattice.shape))
        raise ValueError(f"the samples reach {len(reached)} control points of the {shape} lattice: solving for them "
                         f"would take about {_factor_bytes(len(reached)) / 2**30:.1f} GiB (at most "
                         f"{_MAX_FACTOR_BYTES / 2**30:.0f}); use a smaller shape")  # fmt: skip
    starts = np.concatenate([[0], np.cumsum(moving.sum(axis=1))])
    columns = np.searchsorted(reached, index[moving])
    matrix = sparse.csr_matrix((weight[moving], columns, starts), shape=(n, len(reached)))
    weighted = matrix if weights is None else sparse.diags(weights) @ matrix
    normal = (matrix.T @ weighted).tocsc()
    # a ridge at rounding level of each control point's own diagonal (a rank-deficient sample set stays
    # solvable; one relative to the largest diagonal would swamp the corners'); those only points of weight
    # zero reach get 1 (and so a zero offset)
    diagonal = normal.diagonal()
    normal = normal + sparse.diags(np.where(diagonal > 0, 1e-13 * diagonal, 1.0))
    rhs = weighted.T @ local
    offsets = np.zeros((lattice.n_points, 3))
    if len(reached):
        factors = splu(normal, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        offsets[reached] = factors.solve(rhs)
    residual = local - matrix @ offsets[reached]
    return offsets.reshape(*lattice.shape, 3), (a, b), residual


def _samples(deformation: Any, region: Any) -> tuple[DisplacementField | None, NDArray | None, NDArray | None]:
    """What to fit: a field on a grid (and a mask), or scattered points and their targets."""
    if region is not None and is_reference_grid(region):
        return sample_displacement_field(deformation, region), None, None
    if isinstance(deformation, DisplacementField):
        if region is None:
            return deformation, None, None
        mask = np.asarray(region)
        if mask.dtype == bool:
            if mask.shape != deformation.shape:
                raise ValueError(f"a mask region must have the field's shape {deformation.shape}, got {mask.shape}")
            return deformation, mask, None
    if region is None:
        grid = getattr(deformation, "grid", None)  # an elastix chain: its fixed image grid
        if isinstance(grid, ImageGrid):
            return sample_displacement_field(deformation, grid), None, None
        raise ValueError("a region is needed: points, a mesh, a mask on a field, or a reference grid")
    points = as_points(region)
    if isinstance(deformation, np.ndarray):  # displacements at the region's points (a GP sample on a mesh)
        if deformation.shape != points.shape or not np.all(np.isfinite(deformation)):
            raise ValueError(f"displacements given as an array must be finite and match the region's points "
                             f"{points.shape}, got {deformation.shape}")  # fmt: skip
        return None, points, points + deformation
    deform = deformation.deform if hasattr(deformation, "deform") else deformation
    if not callable(deform):
        raise TypeError(f"expected a deformation (deform(points) or a callable), got {type(deformation).__name__}")
    targets = np.asarray(deform(points), dtype=np.float64)
    if targets.shape != points.shape or not np.all(np.isfinite(targets)):
        raise ValueError(f"the deformation returned {targets.shape} values for {points.shape} points (or non-finite)")
    return None, points, targets


def fit_lattice(
    deformation: Any,
    shape: tuple[int, int, int] | int | Lattice,
    *,
    region: Any = None,
    weights: ArrayLike | None = None,
    affine: bool = False,
) -> FFD:
    """The least-squares B-spline FFD that best reproduces a deformation over a region.

    Parameters
    ----------
    deformation : DisplacementField, ElastixTransform, FFD, callable or array
        Anything with ``deform(points)``, a callable taking ``(N, 3)`` points to where they go, or
        an ``(N, 3)`` array of displacements at the ``region`` points (a GP sample on a mesh).
    shape : int, tuple of int, or Lattice
        Control points per axis of a new lattice whose domain (the "zero" border's, where the
        weights sum to one) is the region's box, its axes along the field's grid when there is
        one; or a :class:`~ffd_notebook.Lattice` to fit onto (its placement; offsets replaced).
    region : optional
        Where the deformation must be matched: ``None`` (a field's own voxels, an elastix chain's
        fixed image grid), a boolean mask on a field's grid (its array shape ``(nz, ny, nx)``),
        ``(N, 3)`` points or a mesh, or a reference grid on which the deformation is sampled
        (anything :func:`~ffd_notebook.images.reference_grid` reads: an image or image file, an
        ``ImageGrid``, a field, a mapping ``{"size", "spacing", "origin", "direction"}``).
    weights : array_like, optional
        Non-negative weight per sample (on a field: the array's shape ``(nz, ny, nx)``, or one per
        masked voxel).
    affine : bool
        Separate the affine part first (least squares), so the lattice holds only what no
        affine map does; else the FFD's affine part is the identity.

    Returns
    -------
    FFD
        B-spline, "zero" border. ``ffd.lattice.metadata["fit"]`` holds the residual over the
        samples: ``{"rms": ..., "max": ..., "samples": N}`` (lengths of the residual vectors).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> from ffd_notebook.io import DisplacementField, sample_displacement_field
    >>> truth = Lattice((5, 5, 5), 2.0, origin=(-2.0, -2.0, -2.0))
    >>> truth.offsets[...] = np.random.default_rng(0).normal(0.0, 0.3, truth.offsets.shape)
    >>> field = sample_displacement_field(FFD(truth), {"size": (9, 9, 9), "spacing": 0.5})
    >>> fitted = fit_lattice(field, truth)          # the same lattice: the offsets come back
    >>> bool(np.allclose(fitted.lattice.offsets, truth.offsets, atol=1e-9))
    True
    >>> fitted.lattice.metadata["fit"]["max"] < 1e-9
    True
    """
    if isinstance(shape, Lattice):
        lattice = Lattice(shape.shape, shape.spacing, shape.origin, shape.rotation)
        if min(lattice.shape) < 4:
            raise ValueError(f"a cubic B-spline lattice needs at least 4 control points per axis, got {lattice.shape}")
    else:
        lattice = None
        counts = _as_shape(shape)
    field, mask_or_points, targets = _samples(deformation, region)
    w = None if weights is None else np.asarray(weights, dtype=np.float64)
    if w is not None and (not np.all(np.isfinite(w)) or np.any(w < 0)):
        raise ValueError("weights must be finite and non-negative")
    if field is not None:
        if lattice is None:
            lattice = _lattice_over_grid(field, counts)
        axes = grid_axes(lattice, field.grid.index_to_physical(), field.size)
        if axes is not None and mask_or_points is None and w is None:
            offsets, (a, b), residual = _grid_fit(field, lattice, axes, affine)
        else:
            points = field.grid_points()
            moved = points + field.vectors.reshape(-1, 3)
            keep = None if mask_or_points is None else mask_or_points.reshape(-1)
            if w is not None:
                w = w.reshape(-1)
                if keep is not None and len(w) == int(keep.sum()):
                    w_full = np.zeros(len(points))
                    w_full[keep] = w
                    w = w_full
                if len(w) != len(points):
                    raise ValueError(f"weights must have one value per voxel ({len(points)}) or per masked voxel")
            if keep is not None:
                points, moved = points[keep], moved[keep]
                w = None if w is None else w[keep]
            offsets, (a, b), residual = _sparse_fit(points, moved, lattice, w, affine)
    else:
        assert mask_or_points is not None and targets is not None  # scattered points come with their targets
        points, moved = mask_or_points, targets
        if lattice is None:
            lattice = Lattice.around(points, counts, margin=0.0)
        if w is not None and w.shape != (len(points),):
            raise ValueError(f"weights must have one value per point ({len(points)}), got shape {w.shape}")
        offsets, (a, b), residual = _sparse_fit(points, moved, lattice, w, affine)
    lattice.set_offsets(offsets)
    lengths = np.linalg.norm(residual, axis=1) if len(residual) else np.zeros(1)
    rms, largest = float(np.sqrt(np.mean(lengths**2))), float(lengths.max())
    lattice.metadata["fit"] = {"rms": rms, "max": largest, "samples": len(residual)}
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = a, b
    return FFD(lattice, "bspline", border="zero", affine=matrix)
