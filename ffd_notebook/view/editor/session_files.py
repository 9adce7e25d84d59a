"""File commands of an :class:`~.session.EditingSession`: .ffd lattices, meshes, decimation.

Functions of a session, using only its public interface. Each load reads and checks everything
first (``read_*`` may run in a worker thread: it touches nothing of the session's) and changes the
session only once nothing can fail any more (``use_*``, on the session's thread): a bad file leaves
mesh, lattice and undo history exactly as they were, adds a message and raises.

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
from typing import TYPE_CHECKING, Any

from ...deform import FFD
from ...deformer import Deformer
from ...io import load_ffd as _read_ffd_lattice
from ...io import place_at_mesh_minimum
from ...io import save_ffd as _write_ffd
from ...lattice import Lattice

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


def read_ffd_file(session: EditingSession, path: Path) -> tuple[Lattice, bool]:
    """Read and check a .ffd file for ``session`` without changing anything: ``(lattice, placed)``.

    ``placed`` says whether the file carried its own placement; otherwise the lattice is put at
    the current mesh's minimum corner. Safe to run in a worker thread.
    """
    lattice = _read_ffd_lattice(path)
    placed = isinstance(lattice.metadata.get("placement"), dict)
    if not placed:
        lattice = place_at_mesh_minimum(lattice, session.mesh)
    FFD(lattice, session.basis)  # e.g. a 3x3x3 file cannot drive the B-spline basis
    return lattice, placed


def use_ffd(session: EditingSession, lattice: Lattice, placed: bool, name: str) -> None:
    """Install a lattice from :func:`read_ffd_file` (one undo step); ``name`` is what messages call the file."""
    session.swap_lattice(lattice, None, label="load .ffd", source="ffd-placed" if placed else "ffd-min")
    where = "its quaternion placement" if placed else "the mesh's minimum corner"
    session.info(f"loaded a {'x'.join(map(str, lattice.shape))} lattice from {name} (at {where})")


def load_ffd(session: EditingSession, path: Path) -> Lattice:
    """Load a lattice from a .ffd file (undoable). A bad file raises and changes nothing."""
    try:
        lattice, placed = read_ffd_file(session, path)
    except (OSError, ValueError) as exc:
        session.error(f"could not load the lattice {os.fspath(path)!r}: {exc}")
        raise
    use_ffd(session, lattice, placed, os.fspath(path))
    return lattice


def save_ffd(session: EditingSession, path: Path) -> None:
    """Save the lattice (offsets and placement) to a .ffd file, atomically."""
    try:
        _write_ffd(path, session.lattice)
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
    if session.lattice_source in ("ffd-placed", "given"):
        lattice = session.lattice.copy()
    elif session.lattice_source == "ffd-min":
        lattice = place_at_mesh_minimum(session.lattice, mesh)
    else:
        lattice = Lattice.around(mesh, session.lattice.shape, basis=session.basis)
    return mesh, FFD(lattice, session.basis).bind(mesh.points)


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
