"""How the editor colours the mesh: per-vertex colours, plain, or a view of the deformation field.

The mesh actor is made once; switching what it shows only changes which point array its mapper
reads and how (direct RGB colours or scalars through a lookup table), so no actor is re-created.

Fields (:data:`~ffd_notebook.view.editor.session.FIELDS`)
---------------------------------------------------------
``"displacement"``
    ``|T(x) - x|`` at each vertex (what the user sees move), through a colour map from 0 to the
    largest value.
``"jacobian"``
    Where the deformation folds: vertices with ``det J <= 0`` (the local volume turns inside
    out) in red, the rest in light grey.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DISPLACEMENT_ARRAY",
    "FOLDING_ARRAY",
    "WEIGHTS_ARRAY",
    "displacement_magnitude",
    "folding_mask",
    "show_field",
    "show_plain",
    "show_rgb",
]

DISPLACEMENT_ARRAY = "ffd_displacement"
FOLDING_ARRAY = "ffd_folding"
WEIGHTS_ARRAY = "ffd_weights"
_FIELD_ARRAYS = {"displacement": DISPLACEMENT_ARRAY, "jacobian": FOLDING_ARRAY, "weights": WEIGHTS_ARRAY}
FOLD_COLOR = "red"
NO_FOLD_COLOR = "lightgray"


def displacement_magnitude(rest: ArrayLike, deformed: ArrayLike) -> NDArray[np.float32]:
    """``|deformed - rest|`` per point, float32.

    Examples
    --------
    >>> displacement_magnitude([[0, 0, 0]], [[3, 4, 0]]).tolist()
    [5.0]
    """
    diff = np.asarray(deformed, dtype=np.float64) - np.asarray(rest, dtype=np.float64)
    return np.sqrt(np.einsum("ij,ij->i", diff, diff)).astype(np.float32)


def folding_mask(ffd: Any, points: ArrayLike) -> NDArray[np.bool_]:
    """True where the deformation folds: ``det J <= 0`` at the point.

    Examples
    --------
    >>> from ffd_notebook import Lattice, FFD
    >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1, -1, -1))
    >>> lat.offsets[2, :, :, 0] = -3.0
    >>> folding_mask(FFD(lat), [[0.5, 0.5, 0.5], [5.0, 5.0, 5.0]]).tolist()
    [True, False]
    """
    return ffd.jacobian_determinant(points) <= 0.0


def show_rgb(actor: Any, name: str) -> None:
    """Colour the actor by its per-vertex colour array ``name`` (used as is, no lookup table).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> mesh = pv.Sphere()
    >>> mesh.point_data["RGB"] = np.zeros((mesh.n_points, 3), dtype=np.uint8)
    >>> actor = pv.Plotter(off_screen=True).add_mesh(mesh)
    >>> show_rgb(actor, "RGB")
    >>> actor.GetMapper().GetArrayName(), bool(actor.GetMapper().GetScalarVisibility())
    ('RGB', True)
    """
    mapper = actor.GetMapper()
    mapper.SetScalarVisibility(True)
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray(name)
    mapper.SetColorModeToDirectScalars()
    mapper.Modified()


def show_plain(actor: Any) -> None:
    """Show the actor in its property's single colour.

    Examples
    --------
    >>> import pyvista as pv
    >>> actor = pv.Plotter(off_screen=True).add_mesh(pv.Sphere(), scalars=pv.Sphere().points[:, 2])
    >>> show_plain(actor)
    >>> bool(actor.GetMapper().GetScalarVisibility())
    False
    """
    actor.GetMapper().SetScalarVisibility(False)
    actor.GetMapper().Modified()


def _lookup_table(field: str) -> Any:
    if field == "jacobian":
        lut = pv.LookupTable(cmap=[NO_FOLD_COLOR, FOLD_COLOR], n_values=2)
        lut.scalar_range = (0.0, 1.0)
        return lut
    # vertex weights as Blender paints them: blue (0) to red (1)
    return pv.LookupTable(cmap="jet" if field == "weights" else "viridis")


def show_field(actor: Any, field: str, vmax: float) -> None:
    """Colour the actor by a field array through a lookup table (range ``0..vmax``).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> mesh = pv.Sphere()
    >>> mesh.point_data[DISPLACEMENT_ARRAY] = np.linspace(0, 2, mesh.n_points)
    >>> actor = pv.Plotter(off_screen=True).add_mesh(mesh)
    >>> show_field(actor, "displacement", 2.0)
    >>> actor.GetMapper().GetArrayName(), actor.GetMapper().GetScalarRange()
    ('ffd_displacement', (0.0, 2.0))
    >>> set_field_range(actor, 0.5)
    >>> actor.GetMapper().GetScalarRange()
    (0.0, 0.5)
    """
    name = _FIELD_ARRAYS[field]
    mapper = actor.GetMapper()
    lut = _lookup_table(field)
    vmax = 1.0 if field in ("jacobian", "weights") else max(float(vmax), 1e-12)
    lut.SetTableRange(0.0, vmax)
    mapper.SetLookupTable(lut)
    mapper.SetScalarVisibility(True)
    mapper.SetScalarModeToUsePointFieldData()
    mapper.SelectColorArray(name)
    mapper.SetColorModeToMapScalars()
    mapper.SetUseLookupTableScalarRange(False)
    mapper.SetScalarRange(0.0, vmax)
    mapper.Modified()


def set_field_range(actor: Any, vmax: float) -> None:
    """Update the colour range of a displacement view (keeps the lookup table; see :func:`show_field`)."""
    vmax = max(float(vmax), 1e-12)
    actor.GetMapper().SetScalarRange(0.0, vmax)
    actor.GetMapper().GetLookupTable().SetTableRange(0.0, vmax)
