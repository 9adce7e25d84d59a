"""The standalone app's file actions and lattice rebuilds: paths inside its root folder, browser uploads and
downloads, slow work off the event loop.

Every typed path goes through :class:`~ffd_notebook.view.serving.file_root.FileRoot` (inside the root,
regular files of bounded size, the right extension to write) and every message the page shows goes
through :func:`~ffd_notebook.view.serving.file_root.client_message` (no file content, the root-relative
name). A remote user needs no server path at all: lattice files (.ffd, ITK .tfm/.txt/.h5/.hdf5,
PyGeM .prm), meshes and photos of a face (the mesh upload makes the face in a photo) can be uploaded
from the browser, and the lattice and the deformed mesh downloaded to it. A file that names other
files (an elastix chain, a MetaImage or NRRD header) reads them only inside the app's folder, and an
upload, stored alone in a private folder, cannot name any.

Reading and writing files run in a worker thread (:meth:`AppFiles.in_background`) so the
event loop keeps answering (HTTP, other clients, the page's own messages) and the page shows a
progress bar. The worker also does the slow parts of installing: binding the lattice to a loaded
mesh (the deformer's weights and first evaluation), the plotted copy of the mesh and its normals
(:func:`~.scene.prepare_display`), and binding a rebuilt lattice (:meth:`AppFiles.rebuild`);
only swapping the result into the editor (VTK actors) runs on the loop. Without a running event
loop (scripts, unit tests) the same work runs synchronously.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ...._util.deprecation import renamed
from ....face.photo import PHOTO_SUFFIXES
from ....io.mesh import MESH_SUFFIXES
from ...serving.file_root import (
    FFD_SUFFIXES,
    FileRoot,
    PathRefused,
    ScratchFolder,
    client_message,
    refuse_special_or_oversize,
)
from ..scene.scene import prepare_display
from ..session.controls import number, numbers
from ..session.lattices import copy_ffd
from ..session.session import ChangedMeanwhile

__all__ = ["MESH_FORMATS", "AppFiles", "upload_bytes"]


def _write_deformation(target: Path, ffd: Any, shown: str) -> None:
    """``save_deformation(target, ffd)``; a refusal (the format cannot hold ``ffd``) becomes a
    :class:`PathRefused` whose whole reason the page may show, naming the file as the page does."""
    from ....io import save_deformation

    try:
        save_deformation(target, ffd)
    except ValueError as exc:  # the reason is made from the FFD, never from a file's content
        raise PathRefused(str(exc).replace(os.fspath(target), shown)) from None


MESH_FORMATS = ["obj", "ply", "stl", "vtp"]


def upload_bytes(upload: Any) -> tuple[str, bytes] | None:
    """Name and content of a file from a Vuetify file input (a dict, or a list of one dict).

    Examples
    --------
    >>> upload_bytes([{"name": "a.ffd", "content": [b"ab", b"c"]}])
    ('a.ffd', b'abc')
    >>> upload_bytes(None) is None
    True
    """
    if isinstance(upload, list):
        upload = upload[0] if upload else None
    if not isinstance(upload, dict) or upload.get("content") is None:
        return None
    content = upload["content"]
    if isinstance(content, list):  # large files arrive in chunks
        content = b"".join(bytes(c) for c in content)
    return str(upload.get("name") or "upload"), bytes(content)


class AppFiles:
    """The file actions of one :class:`~ffd_notebook.view.editor.app.EditorApp` (``app.files``; see the module
    docstring).

    Parameters
    ----------
    editor : Editor
        The editor the files are loaded into and saved from.
    state : trame state
        The page's state (``busy``, ``busy_text``, the upload inputs).
    root : FileRoot
        The folder typed paths are confined to.
    sync : callable
        Called after every action that changed the editor or added a message: the app copies the
        editor's state to the page.
    """

    def __init__(self, editor: Any, state: Any, root: FileRoot, *, sync: Callable[[], None]) -> None:
        self.editor = editor
        self.session = editor.session
        self.state = state
        self.root = root
        self.sync = sync
        self._scratch: ScratchFolder | None = None
        self._tasks: set[Any] = set()

    # ------------------------------------------------------------------ running work
    def _report(self, exc: BaseException, shown: str, verb: str) -> None:
        self.session.messages.append(f"Error: could not {verb}: {client_message(exc, shown)}")
        self.sync()

    def _set_busy(self, text: str | None) -> None:
        with self.state:
            self.state.busy = text is not None
            self.state.busy_text = text or ""

    def in_background(self, what: str, work: Callable[[], Any], done: Callable[[Any], None], shown: str,
                       verb: str) -> None:  # fmt: skip
        """Run ``work()`` in a worker thread, then ``done(result)`` on the event loop; errors become messages.

        One file action at a time: a second one while the first runs is refused with a message.
        """
        if self.state.busy:
            self.session.messages.append(f"Error: still busy ({self.state.busy_text}); try again when it is done")
            self.sync()
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no event loop (a script, a unit test): just do it
            try:
                result = work()
            except Exception as exc:
                self._report(exc, shown, verb)
                return
            self._finish(done, result, shown, verb)
            return

        async def run() -> None:
            try:
                result = await asyncio.to_thread(work)
            except Exception as exc:
                self._set_busy(None)
                self._report(exc, shown, verb)
                return
            self._set_busy(None)
            self._finish(done, result, shown, verb)

        self._set_busy(what)
        task = loop.create_task(run())
        self._tasks.add(task)  # keep a reference until it is done
        task.add_done_callback(self._tasks.discard)

    def _finish(self, done: Callable[[Any], None], result: Any, shown: str, verb: str) -> None:
        try:
            done(result)
        except Exception as exc:
            self._report(exc, shown, verb)
            return
        self.sync()

    def _typed(self, typed: Any, resolve: Callable[[str], Path], verb: str) -> Path | None:
        """``resolve(typed)`` or None after a message (a refused path never reaches the file system)."""
        try:
            return resolve(str(typed if typed is not None else ""))
        except (PathRefused, OSError) as exc:
            self._report(exc, str(typed), verb)
            return None

    # ------------------------------------------------------------------ reading
    def _read_ffd(self, path: Path, shown: str, within: Path, name: str | None = None) -> None:
        """Read a deformation file in a worker; the files it names (an elastix chain, a field's data files) must be
        in ``within``: the app's folder for a typed path, the upload's own folder for an upload. ``name`` is what
        the session's code reads (the path shown by default)."""
        files = self.session.files
        self.in_background(f"reading {shown}", lambda: files.read_deformation(path, within=within),
                            lambda result: files.use_deformation(*result, shown, path=name), shown, "load")  # fmt: skip

    def _read_mesh(self, path: Path, shown: str, name: str | None = None) -> None:
        def work() -> tuple[Any, Any, Any]:
            mesh, deformer = self.session.files.read_mesh(path)
            return mesh, deformer, prepare_display(mesh, deformer.current(), self.editor.scene.interactive_cells)

        def done(result: tuple[Any, Any, Any]) -> None:
            mesh, deformer, prepared = result
            self.editor.scene.offer_display(prepared)
            self.session.files.use_mesh(mesh, deformer, shown, path=name)

        self.in_background(f"reading {shown}", work, done, shown, "load")

    def _read_face(self, path: Path, shown: str, name: str | None = None) -> None:
        """The face of a photo (a path checked by the root folder, or an upload) as the mesh, made in a worker."""

        def work() -> tuple[Any, Any, Any]:
            mesh, deformer = self.session.files.read_face(path)
            return mesh, deformer, prepare_display(mesh, deformer.current(), self.editor.scene.interactive_cells)

        def done(result: tuple[Any, Any, Any]) -> None:
            mesh, deformer, prepared = result
            self.editor.scene.offer_display(prepared)
            self.session.files.use_face(mesh, deformer, shown, path=shown if name is None else name)

        self.in_background(f"finding the face in {shown}", work, done, shown, "make a face")

    # ------------------------------------------------------------------ lattice
    def rebuild(self, *values: Any) -> None:
        """Fit a lattice of the typed size (``nx, ny, nz``) around the mesh; binding it to the mesh
        (seconds on a big mesh) runs in a worker thread.

        Edits made meanwhile stay: weights painted or set are weighed into the result; another strength or
        interpolation starts the fit again with it (:class:`~..session.session.ChangedMeanwhile`)."""
        session = self.session
        try:
            shape = numbers(list(values), "lattice size", int)
            ffd = session.fitted_ffd(shape)  # checks the size (a message if it cannot be built)
        except ValueError as exc:
            if not session.messages or not session.messages[-1].endswith(str(exc)):
                session.error(str(exc))  # a typing error (fitted_ffd has said why it cannot fit)
            self.sync()
            return
        mesh, name = session.mesh, "x".join(map(str, shape))

        def done(deformer: Any) -> None:
            if session.mesh is not mesh:
                raise ValueError("the mesh changed meanwhile; rebuild again")
            try:
                session.set_shape(shape, deformer)
            except ChangedMeanwhile as exc:
                session.info(f"{exc}: fitting again")
                self.rebuild(*values)

        self.in_background(f"fitting a {name} lattice", lambda: ffd.bind(mesh.points), done,
                            f"the {name} lattice", "rebuild")  # fmt: skip

    def undo(self) -> None:
        """Undo: a step that replaces the lattice is bound to the mesh in a worker thread (about a second on a
        500k-point mesh), any other on the loop at once."""
        self._step(forward=False)

    def redo(self) -> None:
        """Redo, as :meth:`undo`."""
        self._step(forward=True)

    def _step(self, forward: bool) -> None:
        session, verb = self.session, "redo" if forward else "undo"
        prepared = session.prepare_step(forward)
        act = session.redo if forward else session.undo
        if prepared is None:
            session.attempt(act)
            self.sync()
            return
        self.in_background(f"{verb}: binding the lattice to the mesh", prepared.bind, act, "the lattice", verb)

    def set_basis(self, basis: Any) -> None:
        """Switch the basis; the refitted lattice is bound to the mesh in a worker thread (edits made meanwhile
        stay, as for :meth:`rebuild`)."""
        session = self.session
        if basis == session.basis:
            return
        try:
            ffd = session.basis_ffd(str(basis))  # a message if it cannot be built
        except (TypeError, ValueError):
            self.sync()
            return
        mesh = session.mesh

        def done(deformer: Any) -> None:
            if session.mesh is not mesh:
                raise ValueError("the mesh changed meanwhile; choose the basis again")
            try:
                session.set_basis(str(basis), deformer)
            except ChangedMeanwhile as exc:
                session.info(f"{exc}: switching again")
                self.set_basis(basis)

        self.in_background(f"switching to the {basis} basis", lambda: ffd.bind(mesh.points), done,
                            f"the {basis} basis", "switch the basis")  # fmt: skip

    def decimate(self, reduction: Any) -> None:
        """Decimate the mesh in a worker thread (seconds on a 500k-point mesh), with the lattice bound to the
        result and its plotted copy prepared there too; the loop only swaps them in. A reduction that is not
        a number is refused at once; what fails in the worker is one message, posted from the loop."""
        session, scene = self.session, self.editor.scene
        try:
            reduction = number(reduction, "the reduction")
        except ValueError as exc:
            session.error(f"could not decimate: {exc}")
            self.sync()
            return

        def work() -> tuple[Any, Any]:
            done = session.decimation(reduction)
            points = done.mesh.points if done.deformer is None else done.deformer.current()  # (bound when used)
            return done, prepare_display(done.mesh, points, scene.interactive_cells)

        def done(result: tuple[Any, Any]) -> None:
            decimation, prepared = result
            scene.offer_display(prepared)
            session.use_decimated(decimation)

        self.in_background("decimating the mesh", work, done, "the mesh", "decimate")

    def load_deformation_in_background(self, path: str) -> None:
        """Start loading a deformation file (.ffd, ITK, PyGeM .prm) from a path in the app's folder.

        The file is read in a worker thread and installed on the event loop; what happened is told
        in the app's messages (nothing is returned)."""
        target = self._typed(path, self.root.for_reading, "load")
        if target is not None:
            self._read_ffd(target, self.root.shown(target), self.root.path)

    def load_image_in_background(self, path: str) -> None:
        """Start showing an image (NIfTI, NRRD, MetaImage, PNG...) from a path in the app's folder (a worker thread).

        A header that names data files (MetaImage, NRRD: one name, a ``LIST`` or a pattern) is read only if every
        one of them is in the folder too (:func:`~ffd_notebook.images.read_image` with ``within=`` the folder).
        """
        from ....images import read_image

        target = self._typed(path, self.root.for_reading, "load")
        if target is None:
            return
        shown, folder = self.root.shown(target), self.root.path
        image = self.session.image
        self.in_background(f"reading {shown}", lambda: image.read(read_image(target, within=folder)),
                            lambda slices: image.use(slices, target, shown), shown, "load")  # fmt: skip

    def save_image_in_background(self, path: str) -> None:
        """Start writing the warped image in the app's folder (format from the extension, atomically)."""
        from ....images.files import IMAGE_WRITE_SUFFIXES

        target = self._typed(path, lambda p: self.root.for_writing(p, IMAGE_WRITE_SUFFIXES), "save")
        if target is not None:
            shown = self.root.shown(target)
            image, ffd = self.session.image, copy_ffd(self.session.ffd)  # the deformation as it is now
            self.in_background(f"writing {shown}", lambda: image.save(target, announce=False, ffd=ffd),
                                lambda _: self.session.messages.append(f"saved the warped image to {shown}"),
                                shown, "save")  # fmt: skip

    def load_mesh_in_background(self, path: str) -> None:
        """Start loading a mesh (OBJ, PLY, VTP, STL, ...) from a path in the app's folder (a worker thread)."""
        target = self._typed(path, self.root.for_reading, "load")
        if target is not None:
            self._read_mesh(target, self.root.shown(target))

    def load_face_in_background(self, path: str) -> None:
        """Replace the mesh with the coloured face of a photo (JPEG, PNG...) at a path in the app's folder."""
        target = self._typed(path, self.root.for_reading, "make a face")
        if target is not None:
            self._read_face(target, self.root.shown(target))

    # ------------------------------------------------------------------ writing
    def save_deformation_in_background(self, path: str) -> None:
        """Start saving the FFD to a deformation file in the app's folder (format by extension, atomically).

        A format that cannot hold the FFD exactly is refused with the reason, and writes nothing.
        """
        target = self._typed(path, lambda p: self.root.for_writing(p, FFD_SUFFIXES), "save")
        if target is not None:
            ffd, shown = copy_ffd(self.session.ffd), self.root.shown(target)
            self.in_background(f"writing {shown}", lambda: _write_deformation(target, ffd, shown),
                                lambda _: self._saved("lattice", shown), shown, "save")  # fmt: skip

    def save_mesh_in_background(self, path: str) -> None:
        """Start saving the deformed mesh in the app's folder (format from the extension, atomically)."""
        from ....io import write_mesh

        target = self._typed(path, lambda p: self.root.for_writing(p, MESH_SUFFIXES), "save")
        if target is not None:
            mesh, shown = self.session.deformed_mesh, self.root.shown(target)
            self.in_background(f"writing {shown}", lambda: write_mesh(target, mesh),
                                lambda _: self._saved("mesh", shown), shown, "save")  # fmt: skip

    def _saved(self, what: str, shown: str) -> None:
        """A save is written: say so, and the session's code saves there too (a path in the root folder)."""
        self.session.messages.append(f"saved the {'lattice' if what == 'lattice' else 'deformed mesh'} to {shown}")
        self.session.script.saved(what, shown)

    # the names of 0.1, which did not say that they return before the work is done; kept until 0.3
    load_ffd = renamed(load_deformation_in_background, "load_ffd")
    save_ffd = renamed(save_deformation_in_background, "save_ffd")
    load_mesh = renamed(load_mesh_in_background, "load_mesh")
    save_mesh = renamed(save_mesh_in_background, "save_mesh")

    # ------------------------------------------------------------------ the browser's files
    def _scratch_file(self, name: str) -> Path:
        if self._scratch is None:
            self._scratch = ScratchFolder()
        return self._scratch.file(name)

    def _receive(self, upload: Any, suffixes: tuple[str, ...], key: str) -> tuple[Path, str] | None:
        """Store an uploaded file in the scratch folder; None (after a message) if refused."""
        received = upload_bytes(upload)
        self.state[key] = None
        if received is None:
            return None
        name, content = received
        shown = f"{Path(name).name} (uploaded)"
        try:
            if not Path(name).name.lower().endswith(suffixes):  # endswith: ".nii.gz" is one suffix here
                raise PathRefused(f"{Path(name).name!r}: expected a file ending with {', '.join(suffixes)}")
            if len(content) > self.root.max_bytes:
                raise PathRefused(f"{Path(name).name!r} is bigger than the limit of "
                                  f"{self.root.max_bytes / 2**20:.0f} MiB")  # fmt: skip
            if self._scratch is None:
                self._scratch = ScratchFolder()
            target = self._scratch.private_file(name)  # alone in its folder: it can name no other file
            target.write_bytes(content)
            refuse_special_or_oversize(target, self.root.max_bytes)
        except (PathRefused, OSError) as exc:
            self._report(exc, shown, "load")
            return None
        return target, shown

    def receive_ffd_upload(self, ffd_upload: Any, **_: Any) -> None:
        """A .ffd file arrived from the browser's file input: load it."""
        received = self._receive(ffd_upload, FFD_SUFFIXES, "ffd_upload")
        if received is not None:
            target, shown = received
            self._read_ffd(target, shown, target.parent, name=target.name)  # (the code reads it by its own name)

    def receive_mesh_upload(self, mesh_upload: Any, **_: Any) -> None:
        """A mesh arrived from the browser's file input: load it; a photo (JPEG, PNG...): the face in it."""
        received = self._receive(mesh_upload, MESH_SUFFIXES + PHOTO_SUFFIXES, "mesh_upload")
        if received is None:
            return
        if received[0].suffix.lower() in PHOTO_SUFFIXES:
            self._read_face(*received, name=received[0].name)
        else:
            self._read_mesh(*received, name=received[0].name)

    async def _written_bytes(self, name: str, write: Callable[[Path], None]) -> bytes:
        target = self._scratch_file(name)
        try:
            await asyncio.to_thread(write, target)
            return target.read_bytes()
        finally:
            target.unlink(missing_ok=True)

    async def download_ffd(self) -> bytes:
        """The FFD as the bytes of a .ffd file (the page's download button saves them in the browser)."""
        ffd = copy_ffd(self.session.ffd)
        return await self._written_bytes("download.ffd", lambda path: _write_deformation(path, ffd, "lattice.ffd"))

    async def download_mesh(self, fmt: str = "obj") -> bytes:
        """The deformed mesh as the bytes of a ``fmt`` file (one of :data:`MESH_FORMATS`)."""
        from ....io import write_mesh

        if fmt not in MESH_FORMATS:
            raise ValueError(f"mesh format must be one of {MESH_FORMATS}")
        mesh = self.session.deformed_mesh
        return await self._written_bytes(f"download.{fmt}", lambda path: write_mesh(path, mesh))

    # ------------------------------------------------------------------ teaching: the code, an animation
    def show_code(self) -> None:
        """Show the editor's code (:meth:`~..editor.Editor.to_code`) in the page's code dialog."""
        with self.state:
            self.state.code_text = self.editor.to_code()
            self.state.code_open = True

    async def download_code(self) -> bytes:
        """The editor's code as the bytes of a ``.py`` file (the code dialog's download button saves them)."""
        return self.editor.to_code().encode("utf-8")

    async def record(self, fmt: str = "gif", orbit: Any = False) -> bytes:
        """Record the deformation as the view shows it (``fmt`` ``"gif"`` or ``"mp4"``); returns the file's bytes
        (the page downloads them). A frame at a time, the progress on the page between frames: the event loop
        keeps answering. Edits made meanwhile are not in it (the deformation as it was at the click)."""
        from ..session.controls import MOVIE_CHOICES, RECORD_FPS, RECORD_FRAMES

        if fmt not in dict(MOVIE_CHOICES):
            raise ValueError(f"an animation is one of {', '.join(dict(MOVIE_CHOICES))}, got {fmt!r}")
        if self.state.recording:
            self._report(ValueError("already recording; wait for it"), "the animation", "record")
            return b""
        recording = self.editor.recording(frames=RECORD_FRAMES, fps=RECORD_FPS, orbit=bool(orbit))
        target = self._scratch_file(f"animation.{fmt}")
        with self.state:
            self.state.recording, self.state.record_progress = True, 0
        try:
            for done in recording.write(target):
                with self.state:
                    self.state.record_progress = round(100 * done / len(recording))
                await asyncio.sleep(0)  # the page gets the progress, the loop its other work
            content = target.read_bytes()
        except (OSError, ValueError) as exc:
            self._report(exc, "the animation", "record")
            return b""
        finally:
            recording.close()
            target.unlink(missing_ok=True)
            with self.state:
                self.state.recording = False
        self.session.messages.append(f"recorded the deformation ({RECORD_FRAMES} frames): deformation.{fmt}")
        self.sync()
        return content

    def cleanup(self) -> None:
        """Remove the folder of uploads and downloads (at exit)."""
        if self._scratch is not None:
            self._scratch.cleanup()
            self._scratch = None
