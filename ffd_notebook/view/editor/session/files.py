"""File commands of an :class:`~.session.EditingSession` (``session.files``): lattice files and meshes.

Lattice files are any deformation file :func:`ffd_notebook.io.load_deformation` reads, by
extension: ``.ffd``, ITK transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``) and PyGeM ``.prm``.
A loaded file brings its whole FFD (basis, border, affine part, ``only_inside``); saving writes the
session's FFD, or refuses (a message, no file) where the format cannot hold it exactly.

A :class:`SessionFiles` belongs to one session and uses only its public interface. Each load reads and checks everything
first (``read_*`` may run in a worker thread: it touches nothing of the session's) and changes the
session only once nothing can fail any more (``use_*``, on the session's thread): a bad file leaves
mesh, lattice and undo history exactly as they were, adds a message and raises.

Where a loaded lattice goes
    ITK and PyGeM files place their lattice by their own numbers. A .ffd file with a
    ``#quaternion ...#`` placement is used as is. Without one, the lattice is put where the FFD
    platform put it: control point (0, 0, 0) at the minimum corner of the mesh's bounding box
    (:func:`ffd_notebook.io.place_at_mesh_minimum`).
What happens to the lattice when a mesh is loaded
    A lattice placed by a file (a .ffd quaternion, ITK, PyGeM), passed to the editor or assigned
    with ``editor.lattice = ...`` stays where it is; a .ffd lattice without placement is placed
    again at the new mesh's minimum corner (offsets kept); a lattice fitted by the editor is fitted
    again around the new mesh (same size, offsets zero). Undo brings back a lattice together with
    this rule.
"""

from __future__ import annotations

import os
from pathlib import Path as _PathType
from typing import TYPE_CHECKING, Any

from ....ffd.deform import FFD
from ....ffd.deformer import Deformer
from ....ffd.lattice import Lattice
from ....io import load_deformation, place_at_mesh_minimum, save_deformation
from .lattices import copy_ffd, fitted_lattice

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = ["SessionFiles"]

Path = str | os.PathLike[str]


_PLACES = {
    "ffd-placed": "its quaternion placement",
    "ffd-min": "the mesh's minimum corner",
    "file": "the file's own placement",
}


class SessionFiles:
    """Lattice files and meshes of one :class:`~.session.EditingSession` (``session.files``; see the module
    docstring).

    ``read_*`` only read and check (safe in a worker thread), ``use_*`` install what they read (on
    the session's thread), ``load_*`` do both; ``save_*`` write atomically.

    Parameters
    ----------
    session : EditingSession
        The session it loads into and saves from (which makes its own: ``session.files``).
    """

    def __init__(self, session: EditingSession) -> None:
        self.session = session

    def read_lattice(self, path: Path) -> tuple[FFD, str]:
        """Read and check a lattice file for ``session`` without changing anything: ``(ffd, source)``.

        ``source`` is how the lattice is placed: ``"ffd-placed"`` (a .ffd with its own placement),
        ``"ffd-min"`` (a .ffd without one, put at the current mesh's minimum corner) or ``"file"``
        (ITK, PyGeM: by the file's own numbers). Safe to run in a worker thread.
        """
        ffd = load_deformation(path)
        if _PathType(path).suffix.lower() != ".ffd":
            return ffd, "file"
        if isinstance(ffd.lattice.metadata.get("placement"), dict):
            return ffd, "ffd-placed"
        return copy_ffd(ffd, place_at_mesh_minimum(ffd.lattice, self.session.mesh)), "ffd-min"

    def use_lattice(self, ffd: FFD, source: str, name: str) -> None:
        """Install an FFD from :meth:`read_lattice` (one undo step); ``name`` is what messages call the file."""
        self.session.swap_ffd(ffd, label="load lattice", source=source)
        self.session.info(f"loaded a {'x'.join(map(str, ffd.lattice.shape))} lattice from {name} "
                     f"({ffd.basis}, at {_PLACES[source]})")  # fmt: skip

    def load_lattice(self, path: Path) -> Lattice:
        """Load a lattice file (.ffd, ITK, PyGeM .prm; undoable) and return its lattice (the session's
        :attr:`~.self.session.EditingSession.ffd` holds the rest). A bad file raises and changes nothing."""
        try:
            ffd, source = self.read_lattice(path)
        except (OSError, ValueError) as exc:
            self.session.error(f"could not load the lattice {os.fspath(path)!r}: {exc}")
            raise
        self.use_lattice(ffd, source, os.fspath(path))
        return ffd.lattice

    def save_lattice(self, path: Path) -> None:
        """Save the session's FFD to a lattice file (format by extension), atomically.

        A format that cannot hold the FFD exactly (e.g. a Bernstein lattice in an ITK file) raises,
        with a message, and writes nothing.
        """
        try:
            save_deformation(path, self.session.ffd)
        except (OSError, ValueError) as exc:
            self.session.error(f"could not save the lattice to {os.fspath(path)!r}: {exc}")
            raise
        self.session.info(f"saved the lattice to {os.fspath(path)}")

    def read_mesh(self, path: Path) -> tuple[Any, Deformer]:
        """Read a mesh and bind the lattice it will get, without changing anything: ``(surface, deformer)``.

        Safe to run in a worker thread: the file is read into new objects, and the slow part of
        installing it (the deformer's weights) is done here too.
        """
        mesh = self.session.mesh_io.read(path)
        if self.session.lattice_source in ("ffd-placed", "given", "file"):
            ffd = copy_ffd(self.session.ffd)
        elif self.session.lattice_source == "ffd-min":
            ffd = copy_ffd(self.session.ffd, place_at_mesh_minimum(self.session.lattice, mesh))
        else:
            ffd = FFD(fitted_lattice(mesh, self.session.lattice.shape, self.session.basis), self.session.basis)
        return mesh, ffd.bind(mesh.points)

    def use_mesh(self, mesh: Any, deformer: Deformer, name: str) -> None:
        """Use a mesh from :meth:`read_mesh` (a new undo history); ``name`` is what messages call the file."""
        self.session.replace_mesh(mesh, deformer, label="load mesh", new_document=True)
        self.session.info(f"loaded {name}: {mesh.n_points} vertices, {mesh.n_cells} faces")

    def load_mesh(self, path: Path) -> Any:
        """Load a mesh (OBJ with colors, or anything PyVista reads); starts a new undo history.

        A bad file raises and changes nothing.
        """
        try:
            mesh, deformer = self.read_mesh(path)
        except (OSError, ValueError) as exc:
            self.session.error(f"could not load the mesh {os.fspath(path)!r}: {exc}")
            raise
        self.use_mesh(mesh, deformer, os.fspath(path))
        return mesh

    def save_mesh(self, path: Path) -> None:
        """Save the deformed mesh (OBJ with colors, PLY, VTP, ... by extension), atomically."""
        try:
            self.session.mesh_io.write(path, self.session.deformed_mesh)
        except (OSError, ValueError, TypeError) as exc:
            self.session.error(f"could not save the mesh to {os.fspath(path)!r}: {exc}")
            raise
        self.session.info(f"saved the deformed mesh to {os.fspath(path)}")
