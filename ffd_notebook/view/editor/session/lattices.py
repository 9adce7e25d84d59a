"""The lattices an editing session makes: fitted around a mesh, and copies of an FFD for the undo history."""

from __future__ import annotations

from typing import Any

from ....ffd.basis import BasisName
from ....ffd.deform import FFD
from ....ffd.interpolation import check_basis
from ....ffd.lattice import Lattice

__all__ = ["copy_ffd", "fitted_lattice", "refitted"]


def fitted_lattice(mesh: Any, shape: tuple[int, ...], basis: BasisName | tuple[str, str, str]) -> Lattice:
    """The lattice the editor fits around ``mesh`` (initial fit, new size, new basis, new mesh).

    For the B-spline basis (and Blender's per-axis interpolations, on the same support) it uses the
    "clamp" border: the lattice's box is the mesh's own, at most 2% larger, so every control point,
    the outer ring included, visibly moves the mesh (with "zero" the outer ring lies a whole spacing
    outside the mesh). Bernstein lattices span their box.
    """
    local = check_basis(basis) != "bernstein"
    return Lattice.around(mesh, shape, basis="bspline" if local else "bernstein", border="clamp" if local else "zero")


def copy_ffd(ffd: FFD, lattice: Lattice | None = None, **changes: Any) -> FFD:
    """A new FFD with ``ffd``'s basis, border, affine part, ``only_inside``, ``outside``, strength and
    weights on a copy of its lattice (or on ``lattice``); ``changes`` replace some of them
    (``basis=...``, ``strength=...``, ``weights=...``): :meth:`FFD.copy <ffd_notebook.FFD.copy>`."""
    return ffd.copy(lattice, **changes)


def refitted(ffd: FFD, mesh: Any, shape: tuple[int, ...], basis: Any = None, **changes: Any) -> FFD:
    """``ffd`` on a new lattice of ``shape`` fitted around ``mesh`` (a new size, basis or mesh), offsets at zero.

    What belongs to the deformation rather than to the lattice stays: the interpolation (or ``basis``), the
    strength, Blender's "outside" rule and the vertex weights (``changes`` replace some, e.g. ``weights=None``
    for a mesh with other vertices). What belonged to the old lattice's placement goes: the border is the fitted
    lattice's, no affine part, no ``only_inside``.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
    >>> ffd = FFD(fitted_lattice(sphere, (4, 4, 4), "bspline"), strength=0.5, weights=np.ones(sphere.n_points))
    >>> new = refitted(ffd, sphere, (5, 4, 4), "bernstein")
    >>> new.lattice.shape, new.basis, new.strength, new.weights.shape
    ((5, 4, 4), 'bernstein', 0.5, (50,))
    """
    basis = ffd.basis if basis is None else basis
    lattice = fitted_lattice(mesh, shape, basis)
    return copy_ffd(ffd, lattice, basis=basis, border=None, affine=None, only_inside=False, **changes)
