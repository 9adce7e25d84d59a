"""The Jacobian of an FFD: ``d T_local / d(u, v, w)`` from the basis derivatives, then the chain rule to world axes.

Used by :meth:`FFD.jacobian <ffd_notebook.FFD.jacobian>`, :meth:`Deformer.jacobian_determinant
<ffd_notebook.Deformer.jacobian_determinant>` and the batch evaluator (which keeps the basis factors of
:func:`bspline_jacobian_factors` for many samples on one point set). The B-spline sums read the
offsets through :class:`~ffd_notebook.ffd.support.CellGroups`, so they follow the border rule.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.ffd.support import CellGroups
>>> uvw = np.array([[1.5, 1.5, 1.5]])
>>> offsets = np.zeros((4, 4, 4, 3)); offsets[..., 0] = np.arange(4.0)[:, None, None]   # x offset = u
>>> cells = CellGroups(uvw, (4, 4, 4))
>>> (bspline_lattice_jacobian(cells, offsets, cells.t).round(12) + 0.0).tolist()   # d(offset_x)/du = 1
[[[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .basis import BSPLINE, AxisBasis, bernstein_values
from .support import CellGroups, outer_uv

if TYPE_CHECKING:
    from .lattice import Lattice

__all__ = [
    "bernstein_lattice_jacobian",
    "bspline_jacobian_factors",
    "bspline_lattice_jacobian",
    "det3",
    "jacobian_to_world",
]

Factors = list[tuple[NDArray[np.float64], NDArray[np.float64]]]


def jacobian_to_world(lattice: Lattice, affine: NDArray[np.float64], d_uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """Whole Jacobian from ``d T_local / d(u, v, w)``: ``A + d_uvw @ (R^-1 / spacing)`` (``R^-1 = R^T`` unless sheared).

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> jacobian_to_world(Lattice((4, 4, 4), 2.0), np.eye(4), np.zeros((1, 3, 3))).tolist() == [np.eye(3).tolist()]
    True
    """
    # one (3N x 3) @ (3 x 3) product: a batched matmul of N tiny matrices is 3x slower
    local = (d_uvw.reshape(-1, 3) @ (lattice.rotation_inverse / lattice.spacing[:, None])).reshape(-1, 3, 3)
    return affine[:3, :3] + local


def det3(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Determinants of ``(N, 3, 3)`` matrices by the explicit formula (far faster than batched LU).

    Examples
    --------
    >>> det3(np.diag([1.0, 2.0, 3.0])[None]).tolist()
    [6.0]
    """
    return (
        m[:, 0, 0] * (m[:, 1, 1] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 1])
        - m[:, 0, 1] * (m[:, 1, 0] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 0])
        + m[:, 0, 2] * (m[:, 1, 0] * m[:, 2, 1] - m[:, 1, 1] * m[:, 2, 0])
    )


def bspline_jacobian_factors(t: NDArray[np.float64], bases: Sequence[AxisBasis] = (BSPLINE,) * 3) -> Factors:
    """Per lattice axis, the basis products ``(buv, bw)`` whose cell sum is ``d T_local / d`` that axis.

    ``t`` is ``(N, 3)``, the points' fractions in their cells (sorted like the cell groups): the
    axis differentiated takes the basis's derivative, the other two its values. ``bases``: the
    four-point basis of each axis (the B-spline, or Blender's interpolations).
    """
    vals = [bases[a].weights(t[:, a]) for a in range(3)]
    ders = [bases[a].derivative(t[:, a]) for a in range(3)]
    factors = []
    for axis in range(3):
        bu, bv, bw = (ders[a] if a == axis else vals[a] for a in range(3))
        factors.append((outer_uv(bu, bv), bw))
    return factors


def bspline_lattice_jacobian(
    cells: CellGroups,
    offsets: NDArray[np.float64],
    t: NDArray[np.float64] | None = None,
    factors: Factors | None = None,
    bases: Sequence[AxisBasis] = (BSPLINE,) * 3,
) -> NDArray[np.float64]:
    """``d T_local / d(u, v, w)`` in the cells' sorted order, ``(N, 3 components, 3 lattice axes)``.

    Give the fractions ``t`` (sorted), or ``factors`` from :func:`bspline_jacobian_factors` kept
    from an earlier call on the same points.
    """
    if factors is None:
        factors = bspline_jacobian_factors(t, bases)  # type: ignore[arg-type]
    padded = cells.pad(offsets)
    d_uvw = np.empty((len(factors[0][0]), 3, 3))
    for axis, (buv, bw) in enumerate(factors):
        d_uvw[:, :, axis] = cells.sum(padded, buv, bw)
    return d_uvw


def bernstein_lattice_jacobian(offsets: NDArray[np.float64], uvw: NDArray[np.float64]) -> NDArray[np.float64]:
    """``d T_local / d(u, v, w)`` of the Bernstein FFD, ``(N, 3 components, 3 lattice axes)``.

    Examples
    --------
    >>> offsets = np.zeros((2, 2, 2, 3)); offsets[1, ..., 2] = 1.0   # z offset = u on the unit box
    >>> bernstein_lattice_jacobian(offsets, np.array([[0.5, 0.5, 0.5]]))[0, 2].tolist()
    [1.0, 0.0, 0.0]
    """
    shape = offsets.shape[:3]
    vals = bernstein_values(shape, uvw)
    ders = bernstein_values(shape, uvw, derivative=True)
    d_uvw = np.zeros((len(uvw), 3, 3))
    for axis in range(3):
        factors = [ders[a] if a == axis else vals[a] for a in range(3)]
        d_uvw[:, :, axis] = np.einsum("pi,pj,pk,ijkd->pd", *factors, offsets, optimize=True)
    return d_uvw
