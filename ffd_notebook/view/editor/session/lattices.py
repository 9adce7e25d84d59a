"""The lattices an editing session makes: fitted around a mesh, and copies of an FFD for the undo history."""

from __future__ import annotations

from typing import Any

from ....ffd.basis import BasisName
from ....ffd.deform import FFD
from ....ffd.interpolation import check_basis
from ....ffd.lattice import Lattice

__all__ = ["copy_ffd", "fitted_lattice"]


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
