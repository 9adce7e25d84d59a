"""The FFD editor: an editing session shown in a PyVista plotter, with a mesh inside a lattice of draggable spheres.

:class:`Editor` is what a notebook user holds: three parts, and the handful of calls the README and the
tutorials make (``lattice``, ``update``, ``deformed_mesh``, ``undo``, ``save_deformation``...). Every other command is
the session's (``editor.session.set_shape(...)``, ``editor.session.surface.pin(...)``): the panels call
session commands too, so the editor does not repeat them.

:class:`~.session.EditingSession` (``editor.session``)
    Lattice, basis, mesh, selection, undo history, surface drags, files and the commands; NumPy and the
    model only.
:class:`~.scene.EditorScene` (``editor.scene``)
    The plotter and its VTK objects; follows the session.
the notebook widget (``editor.widget``)
    The scene's trame view next to a :class:`~.notebook.ControlPanel`; follows the session too.

Data flows one way: a move of the drag handle -> :meth:`EditingSession.drag` (the lattice's offsets; the
cached :class:`~ffd_notebook.ffd.deformer.Deformer` recomputes only the points the moved control point
influences) -> one :class:`~.session.Change` naming that control point -> the scene rewrites the
plotted points and the lattice lines in place -> the next render shows them.
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ..._util.deprecation import renamed, warn_renamed
from ..._util.paths import StrPath
from ...ffd.basis import BasisName
from ...ffd.deform import FFD
from ...ffd.lattice import Lattice
from ..serving.lifetime import Lifetime, weak_method
from .meshes import PYVISTA_MESH_IO, face_surface, surface_of
from .scene.proxy import INTERACTIVE_CELLS
from .scene.scene import EditorScene
from .session.lattices import copy_ffd
from .session.message_log import MessageLog
from .session.script import MeshOrigin
from .session.session import EditingSession, Field, PointsShown

if TYPE_CHECKING:
    from .animation import Recording

__all__ = ["PYVISTA_MESH_IO", "Editor", "edit", "face_surface"]


def _origin_of(mesh_or_path: Any, image: Any = None) -> MeshOrigin:
    """Where the editor's mesh came from, for its script (:meth:`Editor.to_code`)."""
    from ...face import is_photo

    if mesh_or_path is None:
        return MeshOrigin("image") if image is not None else MeshOrigin("sample")
    path = os.fspath(mesh_or_path) if isinstance(mesh_or_path, (str, os.PathLike)) else None
    if is_photo(mesh_or_path):
        return MeshOrigin("photo", path or "")
    if path is not None:
        return MeshOrigin("file", path)
    return MeshOrigin("given", surface=not isinstance(mesh_or_path, pv.PolyData))


def _end_drag(session: EditingSession) -> Any:
    """The handle's release callback: ``session.end_drag()`` (a function of the session, not of the editor)."""
    return lambda _index: session.end_drag()


class Editor:
    """Interactive FFD editor (see the module docstring).

    Parameters
    ----------
    mesh_or_path : pyvista.DataSet, path or photo, optional
        The mesh to deform (its surface is used), or a file to read; a photo of a face (a
        ``.jpg``/``.png``... path or an ``(H, W, 3)`` uint8 array) gives the coloured face in it
        (:func:`ffd_notebook.face_from_photo`); the bundled sample mesh
        (:func:`ffd_notebook.datasets.sample_mesh`) if omitted.
    lattice : Lattice, optional
        The control lattice (used as is); fitted around the mesh with ``shape`` if omitted.
    shape : tuple of int
        Control points per axis of a fitted lattice.
    basis : {"bspline", "bernstein"}
        The FFD basis.
    window_size : tuple of int
        Render window size in pixels.
    off_screen : bool, optional
        Render off-screen (the default: images go to the notebook view, the app or screenshots).
    interactive_cells : int or None
        While a mouse button is held (a drag, a camera turn), a mesh with at least twice as many
        cells is drawn from a copy with about this many, at the view's reduced drag size; the
        release brings back the full mesh. None always draws the full mesh.
    image : SimpleITK.Image, path or (array, geometry), optional
        An image shown with the mesh as three orthogonal slices warped by the lattice, live
        (``editor.session.image``: slice positions, window/level, saving the warped image); a NumPy
        array comes with its geometry as ``(array, {"spacing": ..., "origin": ..., "direction": ...})``.
        Without a mesh (``mesh_or_path=None``), the lattice is fitted to the image's box alone.
    deformation : path or deformation, optional
        A deformation file to start from (any format :func:`ffd_notebook.io.load_deformation` reads: its
        lattice, editable, where it is one), or a deformation already loaded (an FSL FNIRT file needs its
        images: ``load_deformation(path, reference=..., source=...)``); see :meth:`load_deformation`.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view import Editor
    >>> editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(200, 150))
    >>> editor.lattice.offsets[1, 1, 2] = (0.0, 0.0, 0.2)
    >>> editor.update()
    >>> float(editor.deformed_mesh.points[:, 2].max()) > float(editor.mesh.points[:, 2].max())
    True
    >>> editor.undo(); float(abs(editor.lattice.offsets).sum())
    True
    0.0
    >>> editor.close()
    """

    def __init__(
        self,
        mesh_or_path: Any = None,
        *,
        lattice: Lattice | None = None,
        shape: tuple[int, ...] = (5, 5, 5),
        basis: BasisName = "bspline",
        window_size: tuple[int, int] = (800, 600),
        off_screen: bool | None = None,
        interactive_cells: int | None = INTERACTIVE_CELLS,
        image: Any = None,
        deformation: Any = None,
    ) -> None:
        if isinstance(image, str | os.PathLike):
            from ...images import read_image

            image, path = read_image(image), image  # read once: for its box and for the slices
        else:
            path = None
        self.session = EditingSession(
            surface_of(mesh_or_path, image), mesh_io=PYVISTA_MESH_IO, lattice=lattice, shape=shape, basis=basis
        )
        self.session.script.origin = _origin_of(mesh_or_path, image)
        if image is not None and mesh_or_path is None:
            self.session.image.box = self.session.mesh  # the image's box stands in for a mesh
        if image is not None:
            self.session.image.use(self.session.image.read(image), path if path is not None else image,
                                   os.path.basename(os.fspath(path)) if path is not None else "image")  # fmt: skip
        if deformation is not None:  # a file or a loaded deformation: its lattice, or one fitted to it
            self.session.files.load_deformation(deformation)
        # the scene's VTK callbacks are held by C++ objects, out of the garbage collector's sight: they refer to
        # the editor weakly, and nothing the lifetime closes refers to it, so an editor nobody uses is freed
        self.scene = EditorScene(
            self.session,
            on_start=self.session.begin_drag,
            on_move=weak_method(self.on_widget_moved),
            on_end=_end_drag(self.session),
            window_size=window_size,
            off_screen=True if off_screen is None else bool(off_screen),
            interactive_cells=interactive_cells,
        )
        self.last_callback_ms = 0.0
        self._widget: Any = None
        self._shown_in_cell: int | None = None
        self.scene.frame()
        # what the editor made goes when it is closed, or when nobody refers to it any more (a variable
        # reassigned, the output that showed it replaced: see ..jupyter.keep_while_shown)
        self.lifetime = Lifetime(self, self.scene.close, self.session.close)

    # ------------------------------------------------------------------ what a notebook user reads
    @property
    def plotter(self) -> pv.Plotter:
        """The PyVista plotter (``editor.scene.plotter``)."""
        return self.scene.plotter

    @property
    def mesh(self) -> pv.PolyData:
        """The rest mesh (undeformed surface)."""
        return self.session.mesh

    @property
    def lattice(self) -> Lattice:
        """The control lattice; edit ``lattice.offsets`` in place, then call :meth:`update`.

        Assigning a new lattice replaces it (one undo step: :meth:`EditingSession.set_lattice`).
        """
        return self.session.lattice

    @lattice.setter
    def lattice(self, lattice: Lattice) -> None:
        self.session.set_lattice(lattice)

    @property
    def weights(self) -> NDArray[np.float64] | None:
        """The mesh vertices' weights in [0, 1] (a copy), or None: every vertex follows the lattice fully.

        Assigning an array (one weight per vertex; Blender's vertex group) or None is one undo step;
        in "paint weights" mode a drag over the mesh paints them (:class:`.session.weights.WeightPaint`).
        """
        return self.session.weights

    @weights.setter
    def weights(self, weights: ArrayLike | None) -> None:
        self.session.paint.set(weights)

    @property
    def deformed_mesh(self) -> pv.PolyData:
        """A new mesh: the current deformed points with the rest mesh's faces and point data."""
        return self.session.deformed_mesh

    @property
    def messages(self) -> MessageLog:
        """The editor's messages, newest last (bounded): what went wrong, what was loaded or saved."""
        return self.session.messages

    # ------------------------------------------------------------------ the drag path
    def on_widget_moved(self, center: ArrayLike, index: int) -> None:
        """Drag-handle callback: control point ``index`` (flat C order) was dragged to ``center``.

        Errors are logged to :attr:`messages` (PyVista would turn them into warnings nobody sees);
        :attr:`last_callback_ms` is how long the session's drag took.

        Parameters
        ----------
        center : array_like
            The handle's new position (world coordinates).
        index : int
            The control point's flat C-order index.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.on_widget_moved(editor.session.control_points()[5] + (0.0, 0.0, 0.2), 5)
        >>> editor.lattice.offsets.reshape(-1, 3)[5].round(3).tolist(), editor.last_callback_ms > 0
        ([0.0, 0.0, 0.2], True)
        >>> editor.on_widget_moved((0.0, 0.0, 0.0), 999)
        >>> print(editor.messages[-1])  # doctest: +ELLIPSIS
        Error: widget callback failed for control point 999: ValueError('index 999 is out of bounds ...')
        >>> editor.close()
        """
        t0 = time.perf_counter()
        try:
            self.session.drag(index, center, started=t0)
        except Exception as exc:  # a callback must never raise into VTK
            self.session.error(f"widget callback failed for control point {index}: {exc!r}")
            return
        self.last_callback_ms = (time.perf_counter() - t0) * 1000.0

    # ------------------------------------------------------------------ what a notebook user calls
    # The session has every command (``editor.session``: select, set_shape, set_basis, show_colors,
    # surface drags, decimate...); these are the ones the README and the tutorials use on the editor.
    def update(self, changed: Any = None) -> None:
        """Show edits made in place to ``editor.lattice.offsets`` (one undo step): :meth:`EditingSession.update`.

        Parameters
        ----------
        changed : list of tuple of int, optional
            Control points ``(i, j, k)`` edited in place (a hint; points found to differ are always included).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[1, 1, 2] = (0.0, 0.0, 0.2)
        >>> editor.update([(1, 1, 2)])
        >>> bool(editor.deformed_mesh.points[:, 2].max() > editor.mesh.points[:, 2].max())
        True
        >>> editor.close()
        """
        self.session.update(changed)

    def undo(self) -> bool:
        """Revert the last step; False if there was none.

        Returns
        -------
        bool
            Whether a step was reverted.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.undo()
        False
        >>> editor.lattice.offsets[0, 0, 0] = (0.1, 0.0, 0.0)
        >>> editor.update()
        >>> editor.undo(), float(abs(editor.lattice.offsets).sum())
        (True, 0.0)
        >>> editor.close()
        """
        return self.session.undo()

    def redo(self) -> bool:
        """Re-apply the last undone step; False if there was none.

        Returns
        -------
        bool
            Whether a step was re-applied.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[0, 0, 0] = (0.1, 0.0, 0.0)
        >>> editor.update()
        >>> editor.undo(), editor.redo(), editor.redo(), editor.lattice.offsets[0, 0, 0].tolist()
        (True, True, False, [0.1, 0.0, 0.0])
        >>> editor.close()
        """
        return self.session.redo()

    def reset(self, ijk: ArrayLike | None = None) -> None:
        """Zero the offset of control point ``ijk``, or of all of them (one undo step).

        Parameters
        ----------
        ijk : array_like, optional
            The control point ``(i, j, k)``; all of them if omitted.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[0, 0, 0] = (0.1, 0.0, 0.0)
        >>> editor.lattice.offsets[3, 3, 3] = (0.0, 0.2, 0.0)
        >>> editor.update()
        >>> editor.reset((0, 0, 0))
        >>> float(abs(editor.lattice.offsets).sum())
        0.2
        >>> editor.reset()
        >>> float(abs(editor.lattice.offsets).sum())
        0.0
        >>> editor.close()
        """
        self.session.reset(ijk)

    def set_field(self, field: Field | None) -> None:
        """Color the mesh by ``"displacement"``, by folding (``"jacobian"``), or not (None).

        Parameters
        ----------
        field : {None, "displacement", "jacobian", "weights"}
            The field shown on the mesh (``"weights"``: the vertices' painted weights).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.set_field("jacobian")
        >>> editor.session.field, editor.messages[-1]
        ('jacobian', 'folding (det J <= 0) at 0 of 50 vertices')
        >>> editor.close()
        """
        self.session.set_field(field)

    def show_points(self, which: PointsShown) -> None:
        """Draw all control points (``"all"``), those near the selection (``"near"``), the hull or ``"auto"``.

        Parameters
        ----------
        which : {"auto", "all", "near", "hull"}
            The control points drawn (``"auto"``: all up to 1000 control points, else the hull).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.show_points("hull")
        >>> editor.session.points_shown
        'hull'
        >>> editor.close()
        """
        self.session.show_points(which)

    def load_deformation(self, path: StrPath | Any) -> FFD:
        """Load a deformation file (.ffd, ITK and ANTs .tfm/.txt/.h5/.hdf5/.mat, elastix, PyGeM .prm, NiftyReg
        grids, displacement fields; one undo step), or a deformation already loaded, and return the FFD.

        A lattice file gives its lattice; a field, or a chain of transforms, a lattice of the editor's shape fitted
        to it (the message tells the residual); an affine transform the FFD's affine part.

        A bad file raises and changes nothing (:meth:`.session.files.SessionFiles.load_deformation`).

        Parameters
        ----------
        path : str, os.PathLike or deformation
            The file (its extension, and a NIfTI file's header, say the format), or what
            :func:`ffd_notebook.io.load_deformation` returned.

        Returns
        -------
        FFD
            The deformation now applied to the mesh.

        Examples
        --------
        >>> import os, tempfile
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.2)
        >>> editor.update()
        >>> folder = tempfile.mkdtemp()
        >>> editor.save_deformation(os.path.join(folder, "bulge.ffd"))
        >>> editor.reset()
        >>> ffd = editor.load_deformation(os.path.join(folder, "bulge.ffd"))
        >>> ffd.lattice.offsets[1, 2, 1].tolist(), editor.lattice is ffd.lattice
        ([0.0, 0.0, 0.2], True)
        >>> editor.close()
        """
        return self.session.files.load_deformation(path)

    def save_deformation(self, path: StrPath) -> None:
        """Save the FFD to a deformation file (format by extension), atomically.

        Parameters
        ----------
        path : str or os.PathLike
            Where to write (.ffd, ITK .tfm/.txt/.h5/.hdf5, PyGeM .prm...).

        Examples
        --------
        >>> import os, tempfile
        >>> from ffd_notebook.io import load_ffd
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.2)
        >>> editor.update()
        >>> path = os.path.join(tempfile.mkdtemp(), "bulge.ffd")
        >>> editor.save_deformation(path)
        >>> load_ffd(path).offsets[1, 2, 1].tolist()
        [0.0, 0.0, 0.2]
        >>> editor.close()
        """
        self.session.files.save_deformation(path)

    def load_ffd(self, path: StrPath) -> Lattice:
        """Deprecated: :meth:`load_deformation` (which returns the FFD); this returns its lattice.

        .. deprecated:: 0.2.0
           Removed in 0.3.0.
        """
        warn_renamed("Editor.load_ffd", "Editor.load_deformation")
        return self.load_deformation(path).lattice

    save_ffd = renamed(save_deformation, "save_ffd")

    def load_mesh(self, path: StrPath) -> pv.PolyData:
        """Load a mesh (OBJ with colours, or anything PyVista reads; a new undo history). A bad file changes nothing.

        Parameters
        ----------
        path : str or os.PathLike
            The mesh file.

        Returns
        -------
        pyvista.PolyData
            The loaded surface, now the editor's mesh.

        Examples
        --------
        >>> import os, tempfile
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> path = os.path.join(tempfile.mkdtemp(), "cube.ply")
        >>> pv.Cube().triangulate().save(path)
        >>> editor.load_mesh(path).n_points, editor.mesh.n_points
        (8, 8)
        >>> editor.close()
        """
        return self.session.files.load_mesh(path)

    def save_mesh(self, path: StrPath) -> None:
        """Save the deformed mesh (OBJ with colours, PLY, VTP, ... by extension), atomically.

        Parameters
        ----------
        path : str or os.PathLike
            Where to write; the extension says the format.

        Examples
        --------
        >>> import os, tempfile
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[1, 1, 3] = (0.0, 0.0, 0.3)
        >>> editor.update()
        >>> path = os.path.join(tempfile.mkdtemp(), "bulged.ply")
        >>> editor.save_mesh(path)
        >>> bool(pv.read(path).points[:, 2].max() > sphere.points[:, 2].max())
        True
        >>> editor.close()
        """
        self.session.files.save_mesh(path)

    def load_face(self, photo: Any) -> pv.PolyData:
        """Replace the mesh with the coloured face of a photo (a new undo history), as loading a mesh does.

        A photo without a face raises :class:`~ffd_notebook.errors.NoFaceError` and changes nothing.

        Parameters
        ----------
        photo : str, os.PathLike, numpy.ndarray or Photo
            The photo: a file, an RGB array, or a :class:`~ffd_notebook.face.photo.Photo`.

        Returns
        -------
        pyvista.PolyData
            The face mesh (``"RGB"`` point colours, millimetres), now the editor's mesh.

        Examples
        --------
        >>> import pyvista as pv
        >>> from skimage import data
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> face = editor.load_face(data.astronaut())
        >>> face.n_points, editor.mesh is face, editor.session.has_colors
        (28881, True, True)
        >>> editor.load_face(data.coins())
        Traceback (most recent call last):
        ...
        ffd_notebook.errors.NoFaceError: the photo (a 384x303 array): no face found in the photo
        >>> editor.mesh is face
        True
        >>> editor.close()
        """
        return self.session.files.load_face(photo)

    def to_code(self) -> str:
        """Python that rebuilds the lattice from what the editor started with: every edit as code.

        The mesh read again (the file the editor opened, the photo, the bundled sample; a variable ``mesh`` when
        the editor was given an object), the lattice's creation, one statement per step of the undo history as
        it stands (one drag is one step; undone steps are absent), the deformed mesh and the saves made. Run in
        a fresh interpreter on the same mesh it gives these offsets bit for bit
        (:class:`~.session.script.SessionScript`).

        Returns
        -------
        str
            The script; it defines ``mesh``, ``lattice``, ``ffd`` and ``deformed``.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.25)
        >>> editor.update()
        >>> print(editor.to_code())  # doctest: +ELLIPSIS
        # What the editor did, as code (1 step of its undo history; editor.to_code()).
        import ffd_notebook as fn
        <BLANKLINE>
        # mesh: the mesh the editor was given, 50 points
        lattice = fn.Lattice.around(mesh, (4, 4, 4), border="clamp")
        ffd = fn.FFD(lattice)
        <BLANKLINE>
        # an edit from code (editor.update())
        lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.25)
        <BLANKLINE>
        # the deformed mesh
        deformed = mesh.copy()
        deformed.points = ffd.deform(mesh.points)
        <BLANKLINE>
        >>> editor.close()
        """
        return self.session.script.to_code()

    def code_cell(self) -> None:
        """Put :meth:`to_code` in a new cell below the cell that runs this (JupyterLab, Notebook 7 and VS Code do).

        IPython's ``set_next_input`` answers the request that ran the cell: it works from a cell, not from a
        click in the panel (a click runs no cell; JupyterLab would add the cell only after the next one runs),
        so the panel's "Code" button shows the code to copy and this puts it in a cell. Outside IPython it
        prints the code.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.code_cell()  # doctest: +ELLIPSIS
        # What the editor did, as code (0 steps of its undo history; editor.to_code()).
        ...
        >>> editor.close()
        """
        from IPython import get_ipython

        shell, code = get_ipython(), self.to_code()
        if shell is None:
            print(code, end="")
        else:
            shell.set_next_input(code, replace=False)

    def recording(
        self,
        *,
        frames: int = 24,
        fps: float = 12.0,
        orbit: float | bool = False,
        lattice: bool = True,
        states: Sequence[FFD] | None = None,
    ) -> Recording:
        """A :class:`~.animation.Recording` of the deformation as the editor shows it (see :meth:`animate`), to
        write frame by frame (the panels do, with a progress bar).

        Parameters
        ----------
        frames, fps, orbit, lattice, states
            As for :meth:`animate`.

        Returns
        -------
        Recording
            Its :meth:`~.animation.Recording.write` yields after each frame; :meth:`~.animation.Recording.run`
            writes them all.

        Examples
        --------
        >>> import os, tempfile
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> recording = editor.recording(frames=3)
        >>> list(recording.write(os.path.join(tempfile.mkdtemp(), "rest.gif")))
        [1, 2, 3]
        >>> recording.close(); editor.close()
        """
        from .animation import Recording

        session = self.session
        chosen = [copy_ffd(session.ffd)] if states is None else list(states)
        size = tuple(self.plotter.window_size)
        return Recording(session.mesh, chosen, frames=frames, fps=fps, orbit=orbit, lattice=lattice, window_size=size,
                         camera=self.plotter.camera, field=session.field, colors=session.colors_shown,
                         points_shown=session.points_shown)  # fmt: skip

    def animate(
        self,
        path: StrPath,
        *,
        frames: int = 24,
        fps: float = 12.0,
        orbit: float | bool = False,
        lattice: bool = True,
        states: Sequence[FFD] | None = None,
        progress: Callable[[int, int], None] | None = None,
    ) -> Path:
        """Write a GIF or MP4 of the mesh going from rest to the deformation (or through saved ``states``).

        As the editor shows it: its camera, window size, colours or field and control points; drawn in a
        scene of its own, so the editor is not touched while it records (:func:`~.animation.animate`).

        Parameters
        ----------
        path : str or path-like
            ``.gif`` or a movie (``.mp4``...); written whole or not at all.
        frames : int, default 24
            Frames in all: the first at rest, the last at the deformation.
        fps : float, default 12
            Frames a second.
        orbit : float or bool, default False
            Turn the camera around the mesh by this many degrees over the animation (True: a whole turn).
        lattice : bool, default True
            Draw the lattice.
        states : sequence of FFD, optional
            States to go through instead (``copy_ffd(editor.session.ffd)`` saved along a lesson, say): from rest
            to the first, then on to each next one; they share the lattice and options, only offsets differ.
        progress : callable, optional
            ``progress(done, total)`` after each frame.

        Returns
        -------
        pathlib.Path
            The file written.

        Examples
        --------
        >>> import os, tempfile
        >>> import imageio.v3 as iio
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lattice.offsets[3, 3, 3] = (0.0, 0.0, 0.5)
        >>> editor.update()
        >>> path = editor.animate(os.path.join(tempfile.mkdtemp(), "bulge.gif"), frames=4)
        >>> iio.imread(path).shape
        (4, 48, 64, 3)
        >>> editor.close()
        """
        return self.recording(frames=frames, fps=fps, orbit=orbit, lattice=lattice, states=states).run(path, progress)

    def screenshot(self, path: StrPath | None = None) -> NDArray[np.uint8]:
        """Render and return the image ``(h, w, 3)`` uint8; also write a PNG if ``path`` is given.

        Parameters
        ----------
        path : str or os.PathLike, optional
            A PNG file to write too.

        Returns
        -------
        numpy.ndarray
            The rendered view, ``(height, width, 3)`` uint8.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> image = editor.screenshot()
        >>> image.shape, image.dtype.name, bool(image.std() > 0)
        ((48, 64, 3), 'uint8', True)
        >>> editor.close()
        """
        return self.scene.screenshot(path)

    # ------------------------------------------------------------------ Jupyter
    @property
    def widget(self) -> Any:
        """The editor's notebook widget: its view next to a control panel (made once)."""
        if self._widget is None:
            from .notebook.output import close_editor_widget, editor_widget

            self._widget = editor_widget(self)
            self.lifetime.actions.insert(0, functools.partial(close_editor_widget, self._widget))
        return self._widget

    def display(self) -> None:
        """Show the editor in the notebook, once per cell (showing it again in the same cell does nothing).

        Examples
        --------
        Outside a notebook, IPython's ``display`` prints what would be shown:

        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.display()  # doctest: +ELLIPSIS
        <ffd_notebook.view.editor.notebook.output.EditorOutput object at ...>
        >>> editor.close()
        """
        from IPython.display import display

        from ..serving.jupyter import execution_count, keep_while_shown
        from .notebook.output import EditorOutput

        cell = execution_count()
        if cell is not None and cell == self._shown_in_cell:
            return
        display(EditorOutput(self))
        keep_while_shown(self)  # until its cell runs again
        self._shown_in_cell = cell

    def _ipython_display_(self) -> None:
        self.display()

    def close(self) -> None:
        """Release the plotter, its browser views and the widgets now (the editor cannot be used afterwards).

        An editor nobody refers to any more is released the same way when it is collected.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> editor = Editor(sphere, shape=(4, 4, 4), window_size=(64, 48))
        >>> editor.lifetime.alive
        True
        >>> editor.close()
        >>> editor.lifetime.alive
        False
        """
        from ..serving.jupyter import forget_shown

        forget_shown(self)
        self.lifetime.close()

    def __repr__(self) -> str:
        return (
            f"Editor(mesh={self.mesh.n_points} points, lattice={'x'.join(map(str, self.lattice.shape))}, "
            f"basis={self.session.basis!r}, history={len(self.session.history)})"
        )


def edit(mesh_or_path: Any = None, **kw: Any) -> Editor:
    """Open an FFD editor on a mesh in the notebook and return it.

    Parameters
    ----------
    mesh_or_path, **kw
        As for :class:`Editor` (``lattice``, ``shape``, ``basis``, ``window_size``, ``off_screen``):
        a mesh, a mesh file, or a photo of a face (``fn.edit("me.jpg")``: the face in it).

    Returns
    -------
    Editor
        Keep it to work with the result: ``editor.deformed_mesh``, ``editor.lattice``,
        ``editor.save_deformation(...)``. Showing the returned editor again in the same cell does not
        draw a second copy.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view import edit
    >>> editor = edit(pv.Sphere(), shape=(4, 4, 4), window_size=(300, 200))  # doctest: +SKIP
    """
    editor = Editor(mesh_or_path, **kw)
    editor.display()
    return editor
