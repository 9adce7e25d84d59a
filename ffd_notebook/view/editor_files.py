"""The editor's file and mesh operations: .ffd lattices, meshes, decimation.

Every load reads and checks everything first and changes the editor only once nothing can fail
any more: a bad file leaves mesh, lattice and undo history exactly as they were, adds a message
to ``editor.messages`` and raises.

Where a loaded lattice goes
    A .ffd file with a ``#quaternion ...#`` placement is used as is. Without one, the lattice is
    put where the FFD platform put it: control point (0, 0, 0) at the minimum corner of the
    mesh's bounding box (:func:`ffd_notebook.io.place_at_mesh_minimum`).
What happens to the lattice when a mesh is loaded
    A lattice placed by a file's quaternion (or passed to the editor, or assigned with
    ``editor.lattice = ...``) stays where it is; a .ffd lattice without placement is placed again
    at the new mesh's minimum corner (offsets kept); a lattice fitted by the editor is fitted again
    around the new mesh (same size, offsets zero). Undo brings back a lattice together with this rule.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pyvista as pv

from ..deform import FFD, Deformer
from ..io.mesh_checks import check_cells
from ..lattice import Lattice
from . import fields

__all__ = ["EditorFilesMixin", "as_surface", "decimate_keeping_colors"]


def as_surface(mesh: Any) -> pv.PolyData:
    """A deep copy of ``mesh`` as a :class:`pyvista.PolyData` surface (volumes give their outer surface).

    Cells that refer to missing points raise :class:`~ffd_notebook.errors.FileFormatError` (a
    ValueError) before any VTK filter sees them (:func:`ffd_notebook.io.mesh_checks.check_cells`).

    Examples
    --------
    >>> import pyvista as pv
    >>> as_surface(pv.ImageData(dimensions=(3, 3, 3))).n_cells
    24
    >>> as_surface(pv.PolyData([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[3, 0, 1, 7]))
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: the mesh: polygon 0 uses point 7: there are 3 points
    """
    if not isinstance(mesh, pv.DataSet):
        mesh = pv.wrap(mesh)
    if isinstance(mesh, pv.PolyData | pv.UnstructuredGrid):  # other grids' cells are implicit
        check_cells("the mesh", mesh)
    if not isinstance(mesh, pv.PolyData):
        mesh = mesh.extract_surface(algorithm="dataset_surface")
    if mesh.n_points == 0:
        raise ValueError("the mesh has no points")
    return mesh.copy(deep=True)


def decimate_keeping_colors(mesh: pv.PolyData, reduction: float, attribute_error: bool = False) -> pv.PolyData:
    """Quadric decimation that carries per-vertex colours (and all other point data) to the new vertices.

    VTK's ``vtkQuadricDecimation`` with ``MapPointData`` on: each remaining vertex gets the
    point data interpolated on the original surface where it lands. Colours are decimated as
    floats and rounded back to uint8. With ``attribute_error=True`` the colours also enter the
    error metric (``AttributeErrorMetric`` + ``ScalarsAttribute``) and VTK then solves vertex
    colours from the quadrics instead; measured on the shared face scans (80 % reduction, mean
    |colour error| of the decimated surface against every original vertex, 0-255 scale):
    template 0.16 without vs 1.05 with, james 8.9 vs 11.8, so mapping alone is the default.

    Parameters
    ----------
    mesh : pyvista.PolyData
        A surface (triangulated first if needed).
    reduction : float
        Fraction of triangles to remove, in ``[0, 1)``.
    attribute_error : bool
        Let colour differences steer the decimation too (see above).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> m = pv.Sphere(theta_resolution=40, phi_resolution=40)
    >>> m.point_data["RGB"] = np.where(m.points[:, 2:] > 0, [255, 0, 0], [0, 0, 255]).astype(np.uint8)
    >>> d = decimate_keeping_colors(m, 0.75)
    >>> d.n_cells < 0.3 * m.n_cells, d.point_data["RGB"].dtype.name
    (True, 'uint8')
    """
    from vtkmodules.vtkFiltersCore import vtkQuadricDecimation

    if not 0.0 <= reduction < 1.0:
        raise ValueError(f"reduction must be in [0, 1), got {reduction!r}")
    surf = mesh.triangulate() if not mesh.is_all_triangles else mesh.copy()
    color_names = [n for n in fields.COLOR_ARRAYS if n in surf.point_data]
    for name in color_names:  # interpolate as floats: uint8 would be truncated
        surf.point_data[name] = np.asarray(surf.point_data[name], dtype=np.float32) / 255.0
    alg = vtkQuadricDecimation()
    alg.SetInputData(surf)
    alg.SetTargetReduction(float(reduction))
    alg.SetVolumePreservation(True)
    alg.SetMapPointData(True)
    if attribute_error and color_names:
        surf.point_data.active_scalars_name = color_names[0]
        alg.SetAttributeErrorMetric(True)
        alg.SetScalarsAttribute(True)
    alg.Update()
    out = pv.wrap(alg.GetOutput())
    for name in color_names:
        out.point_data[name] = np.clip(np.rint(np.asarray(out.point_data[name]) * 255.0), 0, 255).astype(np.uint8)
    return out


class EditorFilesMixin:
    """Load/save/decimate methods of :class:`~ffd_notebook.view.editor.Editor` (see the module docstring)."""

    @staticmethod
    def _read_mesh_arg(mesh_or_path: Any) -> pv.PolyData:
        if mesh_or_path is None:
            from ..datasets import sample_mesh

            return as_surface(sample_mesh())
        if isinstance(mesh_or_path, (str, os.PathLike)):
            from ..io import read_mesh

            return as_surface(read_mesh(mesh_or_path))
        return as_surface(mesh_or_path)

    # ------------------------------------------------------------------ .ffd files
    def read_ffd_file(self, path: str | os.PathLike[str]) -> tuple[Lattice, bool]:
        """Read and check a .ffd file for this editor without changing anything: ``(lattice, placed)``.

        ``placed`` says whether the file carried its own placement; otherwise the lattice is put at
        the current mesh's minimum corner. Safe to run in a worker thread (no VTK object is touched).
        """
        from ..io import load_ffd, place_at_mesh_minimum

        lattice = load_ffd(path)
        placed = isinstance(lattice.metadata.get("placement"), dict)
        if not placed:
            lattice = place_at_mesh_minimum(lattice, self.mesh)
        FFD(lattice, self.basis)  # e.g. a 3x3x3 file cannot drive the B-spline basis
        return lattice, placed

    def use_ffd(self, lattice: Lattice, placed: bool, name: str) -> None:
        """Install a lattice from :meth:`read_ffd_file` (one undo step); ``name`` is what messages call the file."""
        self._swap_lattice(lattice, None, "load .ffd", source="ffd-placed" if placed else "ffd-min")
        where = "its quaternion placement" if placed else "the mesh's minimum corner"
        self._info(f"loaded a {'x'.join(map(str, lattice.shape))} lattice from {name} (at {where})")

    def load_ffd(self, path: str | os.PathLike[str]) -> Lattice:
        """Load a lattice from a .ffd file (undoable). A bad file raises and changes nothing."""
        try:
            lattice, placed = self.read_ffd_file(path)
        except (OSError, ValueError) as exc:
            self._error(f"could not load the lattice {os.fspath(path)!r}: {exc}")
            raise
        self.use_ffd(lattice, placed, os.fspath(path))
        return lattice

    def save_ffd(self, path: str | os.PathLike[str]) -> None:
        """Save the lattice (offsets and placement) to a .ffd file, atomically."""
        from ..io import save_ffd

        try:
            save_ffd(path, self.lattice)
        except (OSError, ValueError) as exc:
            self._error(f"could not save the lattice to {os.fspath(path)!r}: {exc}")
            raise
        self._info(f"saved the lattice to {os.fspath(path)}")

    # ------------------------------------------------------------------ meshes
    def read_mesh_file(self, path: str | os.PathLike[str]) -> tuple[pv.PolyData, Deformer]:
        """Read a mesh and bind the lattice it will get, without changing anything: ``(surface, deformer)``.

        Safe to run in a worker thread: the file is read into new objects, none of the editor's own,
        and the slow part of installing it (the deformer's weights) is done here too.
        """
        from ..io import place_at_mesh_minimum, read_mesh

        mesh = as_surface(read_mesh(path))
        if self._lattice_source in ("ffd-placed", "given"):
            lattice = self.lattice.copy()
        elif self._lattice_source == "ffd-min":
            lattice = place_at_mesh_minimum(self.lattice, mesh)
        else:
            lattice = Lattice.around(mesh, self.lattice.shape, basis=self.basis)
        return mesh, FFD(lattice, self.basis).bind(mesh.points)

    def use_mesh(self, mesh: pv.PolyData, deformer: Deformer, name: str) -> None:
        """Show a mesh from :meth:`read_mesh_file` (a new undo history); ``name`` is what messages call the file."""
        self._replace_mesh(mesh, deformer.ffd, deformer)
        self.plotter.reset_camera(render=False)
        self._render()
        self._info(f"loaded {name}: {mesh.n_points} vertices, {mesh.n_cells} faces")

    def load_mesh(self, path: str | os.PathLike[str]) -> pv.PolyData:
        """Load a mesh (OBJ with colours, or anything PyVista reads); starts a new undo history.

        A bad file raises and changes nothing.
        """
        try:
            mesh, deformer = self.read_mesh_file(path)
        except (OSError, ValueError) as exc:
            self._error(f"could not load the mesh {os.fspath(path)!r}: {exc}")
            raise
        self.use_mesh(mesh, deformer, os.fspath(path))
        return mesh

    def save_mesh(self, path: str | os.PathLike[str]) -> None:
        """Save the deformed mesh (OBJ with colours, PLY, VTP, ... by extension), atomically."""
        from ..io import write_mesh

        try:
            write_mesh(path, self.deformed_mesh)
        except (OSError, ValueError, TypeError) as exc:
            self._error(f"could not save the mesh to {os.fspath(path)!r}: {exc}")
            raise
        self._info(f"saved the deformed mesh to {os.fspath(path)}")

    def decimate(self, reduction: float) -> pv.PolyData:
        """Decimate the loaded mesh by ``reduction`` (fraction of faces removed, ``0`` restores it).

        Always starts from the mesh as loaded, so repeated calls do not compound. Per-vertex
        colours are kept (:func:`decimate_keeping_colors`); the lattice and its offsets are kept
        and the deformer is re-bound to the new vertices; the undo history stays valid.
        """
        try:
            reduction = float(reduction)
            source = self._source_mesh
            mesh = source.copy(deep=True) if reduction == 0.0 else decimate_keeping_colors(source, reduction)
            if mesh.n_points == 0:
                raise ValueError("nothing left after decimation")
        except (TypeError, ValueError) as exc:
            self._error(f"could not decimate: {exc}")
            raise
        self._install_mesh(mesh, self._ffd, source=source)
        self._render()
        self._info(f"decimated by {reduction:.0%}: {mesh.n_points} vertices, {mesh.n_cells} faces")
        self._notify("mesh")
        return mesh

    def _replace_mesh(self, mesh: pv.PolyData, ffd: FFD, deformer: Deformer | None = None) -> None:
        """Swap in a new mesh and its lattice (a new document: history cleared); ``deformer``: ``ffd``
        bound to ``mesh.points`` already, or None."""
        self.history.clear()
        deformer = ffd.bind(mesh.points) if deformer is None else deformer
        self._install_mesh(mesh, ffd, deformer=deformer)
        self._install_lattice(ffd.lattice, ffd.basis, deformer=deformer)
        self._notify("lattice")
        self._notify("mesh")
