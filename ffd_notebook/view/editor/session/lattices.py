"""The lattices an editing session makes: fitted around a mesh, and copies of an FFD for the undo history."""

from __future__ import annotations

from typing import Any

from ....ffd.deform import FFD
from ....ffd.lattice import Lattice

__all__ = ["copy_ffd", "fitted_lattice"]


def fitted_lattice(mesh: Any, shape: tuple[int, int, int], basis: str) -> Lattice:
    """The lattice the editor fits around ``mesh`` (initial fit, new size, new basis, new mesh).

    For the B-spline basis it uses the "clamp" border: the lattice's box is the mesh's own, at most
    2% larger, so every control point, the outer ring included, visibly moves the mesh (with
    "zero" the outer ring lies a whole spacing outside the mesh). Bernstein lattices span their box.
    """
    return Lattice.around(mesh, shape, basis=basis, border="clamp" if basis == "bspline" else "zero")


def copy_ffd(ffd: FFD, lattice: Lattice | None = None) -> FFD:
    """A new FFD with ``ffd``'s basis, border, affine part and ``only_inside`` on a copy of its
    lattice (or on ``lattice``)."""
    lattice = ffd.lattice.copy() if lattice is None else lattice
    return FFD(lattice, ffd.basis, ffd.border, ffd.affine.copy(), ffd.only_inside)
