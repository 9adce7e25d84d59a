"""File commands of an :class:`~.session.EditingSession`: lattice files, meshes, decimation.

Lattice files are any deformation file :func:`ffd_notebook.io.load_deformation` reads, by
extension: ``.ffd``, ITK transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``) and PyGeM ``.prm``.
A loaded file brings its whole FFD (basis, border, affine part, ``only_inside``); saving writes the
session's FFD, or refuses (a message, no file) where the format cannot hold it exactly.

Functions of a session, using only its public interface. Each load reads and checks everything
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

from ...ffd.deform import FFD
from ...ffd.deformer import Deformer
from ...ffd.lattice import Lattice
from ...io import load_deformation, place_at_mesh_minimum, save_deformation
from .session import copy_ffd, fitted_lattice

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = [
    "decimate",
    "load_ffd",
    "load_mesh",
    "read_ffd_file",
    "read_mesh_file",
    "save_ffd",
    "save_mesh",
    "use_ffd",
    "use_mesh",
]

Path = str | os.PathLike[str]


def read_ffd_file(session: EditingSession, path: Path) -> tuple[FFD, str]:
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
    return copy_ffd(ffd, place_at_mesh_minimum(ffd.lattice, session.mesh)), "ffd-min"


_PLACES = {
    "ffd-placed": "its quaternion placement",
    "ffd-min": "the mesh's minimum corner",
    "file": "the file's own placement",
}


def use_ffd(session: EditingSession, ffd: FFD, source: str, name: str) -> None:
    """Install an FFD from :func:`read_ffd_file` (one undo step); ``name`` is what messages call the file."""
    session.swap_ffd(ffd, label="load lattice", source=source)
    session.info(f"loaded a {'x'.join(map(str, ffd.lattice.shape))} lattice from {name} "
                 f"({ffd.basis}, at {_PLACES[source]})")  # fmt: skip


def load_ffd(session: EditingSession, path: Path) -> Lattice:
    """Load a lattice file (.ffd, ITK, PyGeM .prm; undoable) and return its lattice (the session's
    :attr:`~.session.EditingSession.ffd` holds the rest). A bad file raises and changes nothing."""
    try:
        ffd, source = read_ffd_file(session, path)
    except (OSError, ValueError) as exc:
        session.error(f"could not load the lattice {os.fspath(path)!r}: {exc}")
        raise
    use_ffd(session, ffd, source, os.fspath(path))
    return ffd.lattice


def save_ffd(session: EditingSession, path: Path) -> None:
    """Save the session's FFD to a lattice file (format by extension), atomically.

    A format that cannot hold the FFD exactly (e.g. a Bernstein lattice in an ITK file) raises,
    with a message, and writes nothing.
    """
    try:
        save_deformation(path, session.ffd)
    except (OSError, ValueError) as exc:
        session.error(f"could not save the lattice to {os.fspath(path)!r}: {exc}")
        raise
    session.info(f"saved the lattice to {os.fspath(path)}")


def read_mesh_file(session: EditingSession, path: Path) -> tuple[Any, Deformer]:
    """Read a mesh and bind the lattice it will get, without changing anything: ``(surface, deformer)``.

    Safe to run in a worker thread: the file is read into new objects, and the slow part of
    installing it (the deformer's weights) is done here too.
    """
    mesh = session.mesh_io.read(path)
    if session.lattice_source in ("ffd-placed", "given", "file"):
        ffd = copy_ffd(session.ffd)
    elif session.lattice_source == "ffd-min":
        ffd = copy_ffd(session.ffd, place_at_mesh_minimum(session.lattice, mesh))
    else:
        ffd = FFD(fitted_lattice(mesh, session.lattice.shape, session.basis), session.basis)
    return mesh, ffd.bind(mesh.points)


def use_mesh(session: EditingSession, mesh: Any, deformer: Deformer, name: str) -> None:
    """Use a mesh from :func:`read_mesh_file` (a new undo history); ``name`` is what messages call the file."""
    session.replace_mesh(mesh, deformer, label="load mesh", new_document=True)
    session.info(f"loaded {name}: {mesh.n_points} vertices, {mesh.n_cells} faces")


def load_mesh(session: EditingSession, path: Path) -> Any:
    """Load a mesh (OBJ with colors, or anything PyVista reads); starts a new undo history.

    A bad file raises and changes nothing.
    """
    try:
        mesh, deformer = read_mesh_file(session, path)
    except (OSError, ValueError) as exc:
        session.error(f"could not load the mesh {os.fspath(path)!r}: {exc}")
        raise
    use_mesh(session, mesh, deformer, os.fspath(path))
    return mesh


def save_mesh(session: EditingSession, path: Path) -> None:
    """Save the deformed mesh (OBJ with colors, PLY, VTP, ... by extension), atomically."""
    try:
        session.mesh_io.write(path, session.deformed_mesh)
    except (OSError, ValueError, TypeError) as exc:
        session.error(f"could not save the mesh to {os.fspath(path)!r}: {exc}")
        raise
    session.info(f"saved the deformed mesh to {os.fspath(path)}")


def decimate(session: EditingSession, reduction: float) -> Any:
    """Decimate the loaded mesh by ``reduction`` (fraction of faces removed, ``0`` restores it).

    Always starts from the mesh as loaded, so repeated calls do not compound. Per-vertex colors
    are kept; the lattice and its offsets are kept and the deformer is re-bound to the new
    vertices; the undo history stays valid.
    """
    try:
        reduction = float(reduction)
        source = session.source_mesh
        mesh = source.copy(deep=True) if reduction == 0.0 else session.mesh_io.decimate(source, reduction)
        if mesh.n_points == 0:
            raise ValueError("nothing left after decimation")
    except (TypeError, ValueError) as exc:
        session.error(f"could not decimate: {exc}")
        raise
    session.replace_mesh(mesh, session.ffd.bind(mesh.points), label="decimate", new_document=False)
    session.info(f"decimated by {reduction:.0%}: {mesh.n_points} vertices, {mesh.n_cells} faces")
    return mesh
