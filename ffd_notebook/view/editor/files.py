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

import pyvista as pv

from ...deform import FFD, Deformer
from ...lattice import Lattice
from ...meshing import as_surface, decimate_keeping_colors

__all__ = ["EditorFilesMixin"]


class EditorFilesMixin:
    """Load/save/decimate methods of :class:`~ffd_notebook.view.editor.Editor` (see the module docstring)."""

    @staticmethod
    def _read_mesh_arg(mesh_or_path: Any) -> pv.PolyData:
        if mesh_or_path is None:
            from ...datasets import sample_mesh

            return as_surface(sample_mesh())
        if isinstance(mesh_or_path, (str, os.PathLike)):
            from ...io import read_mesh

            return as_surface(read_mesh(mesh_or_path))
        return as_surface(mesh_or_path)

    # ------------------------------------------------------------------ .ffd files
    def read_ffd_file(self, path: str | os.PathLike[str]) -> tuple[Lattice, bool]:
        """Read and check a .ffd file for this editor without changing anything: ``(lattice, placed)``.

        ``placed`` says whether the file carried its own placement; otherwise the lattice is put at
        the current mesh's minimum corner. Safe to run in a worker thread (no VTK object is touched).
        """
        from ...io import load_ffd, place_at_mesh_minimum

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
        from ...io import save_ffd

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
        from ...io import place_at_mesh_minimum, read_mesh

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
        from ...io import write_mesh

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
