"""File commands of an :class:`~.session.EditingSession` (``session.files``): lattice files and meshes.

Lattice files are any deformation file :func:`ffd_notebook.io.load_deformation` reads, by
extension: ``.ffd``, ITK and ANTs transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``, ``.mat``), elastix
transform parameter files (``.txt``, by content: the whole chain, as one FFD), PyGeM ``.prm``, NiftyReg
control-point grids (an editable lattice as they are), and displacement fields (``.nii``, ``.nii.gz``,
``.nrrd``, ``.mha``), which become a lattice of the session's shape fitted to the field over its voxels
(:func:`ffd_notebook.io.fit_lattice`; the message tells the residual). An affine transform (ANTs'
``GenericAffine.mat``) becomes the FFD's affine part on the session's lattice at rest; a chain of transforms
(ANTs' composite ``.h5``) a lattice fitted to it over the mesh's points. FSL FNIRT files need their reference
and source images: load them with :func:`ffd_notebook.io.load_deformation` and hand the editor the result
(``fn.edit(mesh, deformation=...)``).
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
    again around the new mesh (same size, interpolation and strength, offsets zero). Undo brings back a
    lattice together with this rule. Painted vertex weights belong to the old mesh's vertices: they
    go, and a message says so.
"""

from __future__ import annotations

import os
from pathlib import Path as _PathType
from typing import TYPE_CHECKING, Any, cast

from ...._util.deprecation import renamed, warn_renamed
from ...._util.paths import StrPath
from ....ffd.deform import FFD
from ....ffd.deformer import Deformer
from ....ffd.lattice import Lattice
from ....io import AffineTransform, DisplacementField, fit_lattice, place_at_mesh_minimum
from ....io import load_deformation as _load_deformation
from ....io import save_deformation as _save_deformation
from .lattices import copy_ffd, refitted
from .script import LoadedFile, MeshOrigin

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = ["SessionFiles", "photo_name"]


_PLACES = {
    "ffd-placed": "its quaternion placement",
    "ffd-min": "the mesh's minimum corner",
    "file": "the file's own placement",
}


def photo_name(photo: Any) -> str:
    """What messages call a photo: its path quoted, an upload's name, or "the photo (an HxW array)".

    Examples
    --------
    >>> import numpy as np
    >>> photo_name("me.jpg"), photo_name(np.zeros((30, 40, 3), np.uint8))
    ("'me.jpg'", 'the photo (a 40x30 array)')
    """
    if isinstance(photo, (str, os.PathLike)):
        return repr(os.fspath(photo))
    name = getattr(photo, "name", None)
    if isinstance(name, str):
        return name
    shape = getattr(photo, "shape", (0, 0))
    return f"the photo (a {shape[1]}x{shape[0]} array)"


def _fitted(ffd: FFD, what: str) -> FFD:
    """``ffd`` with what it was fitted to in its fit report (for the message that tells the residual)."""
    ffd.lattice.metadata["fit"]["of"] = what
    return ffd


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

    def read_deformation(self, path: StrPath | Any, *, within: StrPath | None = None) -> tuple[FFD, str]:
        """Read and check a deformation file for ``session`` without changing anything: ``(ffd, source)``.

        ``path`` may also be a deformation already loaded (an FFD, a field, an affine, a chain: what
        :func:`ffd_notebook.io.load_deformation` returns). ``source`` is how the lattice is placed: ``"ffd-placed"``
        (a .ffd with its own placement), ``"ffd-min"`` (a .ffd without one, put at the current mesh's minimum
        corner) or ``"file"`` (every other format: by its own numbers). Safe to run in a worker thread.
        ``within``: the folder the files it names must be in (:func:`ffd_notebook.io.load_deformation`; the app's).
        """
        if isinstance(path, str | os.PathLike):
            loaded = _load_deformation(path, within=within)
        else:
            loaded = path
        shape = cast("tuple[int, int, int]", tuple(max(4, n) for n in self.session.lattice.shape))
        if isinstance(loaded, DisplacementField):  # a lattice of the session's shape, fitted over the field's voxels
            return _fitted(fit_lattice(loaded, shape), "the displacement field"), "file"
        if isinstance(loaded, AffineTransform):  # exactly the FFD's affine part, on the session's lattice at rest
            lattice = self.session.lattice
            rest = Lattice(lattice.shape, lattice.spacing, lattice.origin, lattice.rotation, border=lattice.border)
            rest.metadata["read_as"] = "affine"  # (for the session's code: not an FFD the file holds)
            return FFD(rest, self.session.basis, affine=loaded.matrix), "file"
        if not isinstance(loaded, FFD):  # a chain of transforms: a lattice fitted to it over the mesh's points
            if not callable(getattr(loaded, "deform", None)):
                raise TypeError(f"expected a deformation file or a deformation, got {type(loaded).__name__}")
            fitted = fit_lattice(loaded, shape, region=self.session.mesh.points, affine=True)
            return _fitted(fitted, "the transforms of"), "file"
        ffd = loaded
        if not isinstance(path, str | os.PathLike) or _PathType(path).suffix.lower() != ".ffd":
            return ffd, "file"
        if isinstance(ffd.lattice.metadata.get("placement"), dict):
            return ffd, "ffd-placed"
        return copy_ffd(ffd, place_at_mesh_minimum(ffd.lattice, self.session.mesh)), "ffd-min"

    def use_deformation(self, ffd: FFD, source: str, name: str, *, path: str | None = None) -> None:
        """Install an FFD from :meth:`read_deformation` (one undo step); ``name`` is what messages call the file,
        ``path`` what the session's script reads again (``name`` by default)."""
        fit = ffd.lattice.metadata.get("fit")
        field = isinstance(fit, dict) and fit.get("of") == "the displacement field"
        kind = "field" if field else "other" if fit or ffd.lattice.metadata.get("read_as") or path == "" else "ffd"
        how = LoadedFile(name if path is None else path, source, kind, ffd.lattice.shape if field else None)
        self.session.swap_ffd(ffd, label="load lattice", source=source, how=how)
        shape = "x".join(map(str, ffd.lattice.shape))
        if isinstance(fit, dict):
            self.session.info(f"loaded a {shape} lattice fitted to {fit.get('of', '')} {name} (residual RMS "
                              f"{fit['rms']:.3g}, max {fit['max']:.3g}, over {fit['samples']} points)")  # fmt: skip
            return
        self.session.info(f"loaded a {shape} lattice from {name} ({ffd.basis}, at {_PLACES[source]})")

    def load_deformation(self, path: StrPath | Any) -> FFD:
        """Load a deformation file (see the module docstring; undoable), or a deformation already loaded, and
        return the FFD now in use.

        A bad file raises and changes nothing."""
        name = os.fspath(path) if isinstance(path, str | os.PathLike) else type(path).__name__
        try:
            ffd, source = self.read_deformation(path)
        except (OSError, ValueError, TypeError) as exc:
            self.session.error(f"could not load the lattice {name!r}: {exc}")
            raise
        self.use_deformation(ffd, source, name, path=None if isinstance(path, str | os.PathLike) else "")
        return self.session.ffd

    def save_deformation(self, path: StrPath) -> None:
        """Save the session's FFD to a deformation file (format by extension), atomically; with an image shown,
        the image warped by it too, beside it (:meth:`~.image.SessionImage.beside`).

        A format that cannot hold the FFD exactly (e.g. a Bernstein lattice in an ITK file) raises,
        with a message, and writes nothing.
        """
        try:
            _save_deformation(path, self.session.ffd)
        except (OSError, ValueError) as exc:
            self.session.error(f"could not save the lattice to {os.fspath(path)!r}: {exc}")
            raise
        self.session.info(f"saved the lattice to {os.fspath(path)}")
        self.session.script.saved("lattice", path)
        image = self.session.image
        if image.loaded:  # the image warped by that lattice, beside it: lattice.warped.nii.gz
            target = image.beside(path)
            try:
                image.save(target)
            except (OSError, ValueError) as exc:
                self.session.error(f"could not save the warped image to {os.fspath(target)!r}: {exc}")
                raise

    def read_mesh(self, path: StrPath) -> tuple[Any, Deformer]:
        """Read a mesh and bind the lattice it will get, without changing anything: ``(surface, deformer)``.

        Safe to run in a worker thread: the file is read into new objects, and the slow part of
        installing it (the deformer's weights) is done here too.
        """
        return self._bound(self.session.mesh_io.read(path))

    def read_face(self, photo: Any) -> tuple[Any, Deformer]:
        """Make the coloured face of a photo and bind the lattice it will get, without changing anything.

        ``photo`` is a path, an ``(H, W, 3)`` uint8 array or a :class:`ffd_notebook.face.Photo`
        (:func:`ffd_notebook.face.decode_photo` of an upload). Like :meth:`read_mesh`: ``(surface,
        deformer)``, safe in a worker thread.
        """
        return self._bound(self.session.mesh_io.face(photo))

    def _bound(self, mesh: Any) -> tuple[Any, Deformer]:
        """``mesh`` and its deformer: the lattice the session gives a new mesh, bound to its points."""
        # vertex weights belong to the old mesh's vertices: the new mesh starts without
        if self.session.lattice_source in ("ffd-placed", "given", "file"):
            ffd = copy_ffd(self.session.ffd, weights=None)
        elif self.session.lattice_source == "ffd-min":
            ffd = copy_ffd(self.session.ffd, place_at_mesh_minimum(self.session.lattice, mesh), weights=None)
        else:  # the interpolation and strength stay, as for a new lattice size
            ffd = refitted(self.session.ffd, mesh, self.session.lattice.shape, weights=None)
        return mesh, ffd.bind(mesh.points)

    def use_mesh(self, mesh: Any, deformer: Deformer, name: str, *, path: str | None = None) -> None:
        """Use a mesh from :meth:`read_mesh` (a new undo history); ``name`` is what messages call the file, ``path``
        what the session's script reads again (``name`` by default)."""
        self.session.replace_mesh(mesh, deformer, label="load mesh", new_document=True)
        self.session.script.origin = MeshOrigin("file", name if path is None else path)
        self.session.info(f"loaded {name}: {mesh.n_points} vertices, {mesh.n_cells} faces")

    def load_mesh(self, path: StrPath) -> Any:
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

    def use_face(self, mesh: Any, deformer: Deformer, name: str, *, path: str | None = None) -> None:
        """Use a face from :meth:`read_face` as the mesh (a new undo history, as a loaded mesh); ``path`` is the
        photo file the session's script reads again (none: the script's variable ``photo``)."""
        self.session.replace_mesh(mesh, deformer, label="face from photo", new_document=True)
        self.session.script.origin = MeshOrigin("photo", path or "")
        self.session.info(f"made the face in {name}: {mesh.n_points} vertices, {mesh.n_cells} faces")

    def load_face(self, photo: Any) -> Any:
        """Replace the mesh with the coloured face of a photo (path, array or :class:`ffd_notebook.face.Photo`).

        A new undo history, as for a loaded mesh. A photo with no face (:class:`~ffd_notebook.errors.NoFaceError`),
        a file that is not an image, or no face runtime raise with a message and change nothing.
        """
        name = photo_name(photo)
        try:
            mesh, deformer = self.read_face(photo)
        except (OSError, ValueError, ImportError) as exc:  # ImportError: no LiteRT (it says what to install)
            detail = getattr(exc, "problem", None) or str(exc)  # NoFaceError, FileFormatError name the photo
            self.session.error(f"could not make a face from {name}: {detail}")
            raise
        self.use_face(mesh, deformer, name, path=os.fspath(photo) if isinstance(photo, (str, os.PathLike)) else None)
        return mesh

    def load_face_upload(self, name: str, content: bytes) -> Any:
        """:meth:`load_face` for the bytes of an uploaded photo file called ``name`` (a notebook's FileUpload)."""
        from ....face import decode_photo

        try:
            photo = decode_photo(content, name)
        except ValueError as exc:
            self.session.error(f"could not make a face from {name}: {getattr(exc, 'problem', exc)}")
            raise
        return self.load_face(photo)

    def save_mesh(self, path: StrPath) -> None:
        """Save the deformed mesh (OBJ with colors, PLY, VTP, ... by extension), atomically."""
        try:
            self.session.mesh_io.write(path, self.session.deformed_mesh)
        except (OSError, ValueError, TypeError) as exc:
            self.session.error(f"could not save the mesh to {os.fspath(path)!r}: {exc}")
            raise
        self.session.info(f"saved the deformed mesh to {os.fspath(path)}")
        self.session.script.saved("mesh", path)

    # the names of 0.1 (a lattice file is a deformation file of any format), kept until 0.3
    read_lattice = renamed(read_deformation, "read_lattice")
    use_lattice = renamed(use_deformation, "use_lattice")
    save_lattice = renamed(save_deformation, "save_lattice")

    def load_lattice(self, path: StrPath) -> Lattice:
        """Deprecated: :meth:`load_deformation` (which returns the FFD); this returns its lattice.

        .. deprecated:: 0.2.0
           Removed in 0.3.0.
        """
        warn_renamed("load_lattice", "load_deformation")
        return self.load_deformation(path).lattice
