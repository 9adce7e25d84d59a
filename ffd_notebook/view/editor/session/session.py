"""An editing session: lattice, basis, mesh, selection, undo history and the commands that change them.

No VTK, PyVista, trame or ipywidgets here (a test checks it): the session is plain NumPy and the
model, fully testable without rendering. The VTK scene and the two control panels subscribe to it
(:meth:`EditingSession.subscribe`) and get one :class:`~.changes.Change` per command that says what
changed, down to which control points moved. Mesh operations it must not import (reading, writing,
decimating, copying a PyVista mesh) come in through a :class:`MeshIO`.

Every command checks everything first and changes the session only once nothing can fail any more:
a bad file or a bad value leaves mesh, lattice and undo history as they were, adds a message to
:attr:`EditingSession.messages` and raises. Undo: one drag is one step (moves of the same sphere
merge until it is released or another edit happens); a typed displacement, a reset, a programmatic
edit picked up by :meth:`~EditingSession.update`, a new lattice size, basis or a loaded .ffd file
are one step each. Loading a mesh starts a new history (the old steps belong to the old mesh).

Copies of the offsets: ``lattice.offsets`` is the truth (a plain writable array: writes to it
cannot be observed). ``_committed`` follows it row by row through the session's own commands and
is compared with it in one place only, :meth:`~EditingSession.update`, which exists to pick up
edits made in place by user code.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ....ffd.basis import BasisName
from ....ffd.deform import FFD
from ....ffd.deformer import Deformer
from ....ffd.interpolation import check_basis
from ....ffd.lattice import Lattice
from .changes import Change, Subscribers
from .files import SessionFiles
from .history import History, LatticeSwap
from .image import SessionImage
from .lattices import copy_ffd, fitted_lattice, refitted
from .message_log import MessageLog
from .script import SessionScript
from .surface_drag import SurfaceDrag
from .weights import WeightPaint

__all__ = [
    "EDITS",
    "FIELDS",
    "POINTS_SHOWN",
    "WEIGHTS_CLEARED",
    "ChangedMeanwhile",
    "Decimation",
    "EditingSession",
    "Field",
    "MeshIO",
    "PointsShown",
    "PreparedStep",
]

#: what the mesh can be colored by: nothing (its own colors), |displacement|, folding (det J <= 0), the
#: vertices' weights (how much of the deformation each follows, see :mod:`.weights`)
FIELDS = (None, "displacement", "jacobian", "weights")
#: The type of a coloured field: one of :data:`FIELDS` other than None.
Field = Literal["displacement", "jacobian", "weights"]
#: which control points the view draws: all, those near the selection, the lattice's hull (dense lattices)
POINTS_SHOWN = ("auto", "all", "near", "hull")
#: The type of a choice of control points shown: one of :data:`POINTS_SHOWN`.
PointsShown = Literal["auto", "all", "near", "hull"]
#: the changes that edit the deformation: the blend (:meth:`EditingSession.set_blend`) goes back to 1 before them
EDITS = ("drag", "offsets", "lattice", "mesh")
#: what the editor says when painted weights go with the vertices they were painted on (a decimation, a new mesh)
WEIGHTS_CLEARED = "the vertex weights were cleared: the mesh has other vertices now"


class ChangedMeanwhile(ValueError):
    """Work prepared from the session (in a worker thread, say) no longer fits it: the session changed meanwhile.

    The app then does the work again from the session as it is now, or says so.
    """


@dataclass(frozen=True)
class MeshIO:
    """The mesh operations a session needs but must not import (the editor passes PyVista's).

    Parameters
    ----------
    read : callable
        ``read(path)``: the surface mesh in a file.
    write : callable
        ``write(path, mesh)``: save a mesh, atomically.
    decimate : callable
        ``decimate(mesh, reduction)``: a new mesh with that fraction of its faces removed.
    with_points : callable
        ``with_points(mesh, points)``: a new mesh with those points and the mesh's faces and point data.
    color_array : callable
        ``color_array(mesh)``: the name of its per-vertex color array, or None.
    face : callable
        ``face(photo)``: a coloured face mesh from a photo (path, array or ``face.Photo``).

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
    >>> PYVISTA_MESH_IO.color_array(sphere), sphere.n_cells, PYVISTA_MESH_IO.decimate(sphere, 0.5).n_cells
    (None, 96, 48)
    """

    read: Callable[[Any], Any]  # path -> surface mesh
    write: Callable[[Any, Any], None]  # (path, mesh) -> None, atomically
    decimate: Callable[[Any, float], Any]  # (mesh, reduction) -> new mesh
    with_points: Callable[[Any, Any], Any]  # (mesh, points) -> new mesh with those points
    color_array: Callable[[Any], str | None]  # mesh -> name of its per-vertex color array, or None
    face: Callable[[Any], Any]  # photo (path, array, face.Photo) -> a coloured face mesh (face.face_from_photo)


@dataclass
class PreparedStep:
    """An undo or redo step that replaces the lattice (:meth:`EditingSession.prepare_step`): the FFD it installs
    and, once :meth:`bind` has run (in a worker thread, say), that FFD bound to the mesh."""

    step: Any
    ffd: FFD
    mesh: Any
    deformer: Deformer | None = None

    def bind(self) -> PreparedStep:
        """Bind the FFD to the mesh's points (the slow part); returns self."""
        self.deformer = self.ffd.bind(self.mesh.points)
        return self


@dataclass
class Decimation:
    """A decimated mesh and the session's lattice bound to it (:meth:`EditingSession.decimation`)."""

    reduction: float
    source: Any
    ffd: FFD
    offsets: NDArray[np.float64]
    mesh: Any
    deformer: Deformer | None  # None: bound when used (the lattice had vertex weights)


def _inside(ijk: NDArray[Any], shape: tuple[int, ...]) -> bool:
    """Whether every row of ``ijk`` (whole numbers) indexes a control point of a lattice of ``shape``."""
    return bool(np.all(np.isfinite(ijk)) and np.all(ijk == np.round(ijk)) and np.all(ijk >= 0)
                and np.all(ijk < shape))  # fmt: skip


def _same_weights(a: Any, b: Any) -> bool:
    """Whether two FFDs' vertex weights (arrays or None) are the same."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(a, b))


class EditingSession:
    """The editor's state and commands, without rendering (see the module docstring).

    Surface drags, pins and the interaction mode are the session's :class:`~.surface_drag.SurfaceDrag`,
    ``session.surface`` (``session.surface.pin(...)``, ``session.surface.begin(...)``...).

    Parameters
    ----------
    mesh : mesh object
        The rest surface (the session reads ``mesh.points``, ``n_points`` and ``n_cells``).
    mesh_io : MeshIO
        How to read, write, decimate and copy meshes.
    lattice : Lattice, optional
        The control lattice (used as is); fitted around the mesh with ``shape`` if omitted.
    shape : tuple of int
        Control points per axis of a fitted lattice.
    basis : {"bspline", "bernstein"}
        The FFD basis.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    >>> changes = []
    >>> _ = session.subscribe(changes.append)
    >>> session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
    >>> [(c.kind, c.points.tolist() if c.points is not None else None) for c in changes]
    [('offsets', [25]), ('select', None)]
    >>> session.undo(), float(abs(session.lattice.offsets).sum())
    (True, 0.0)
    """

    def __init__(
        self,
        mesh: Any,
        *,
        mesh_io: MeshIO,
        lattice: Lattice | None = None,
        shape: tuple[int, ...] = (5, 5, 5),
        basis: BasisName = "bspline",
    ) -> None:
        self.mesh_io = mesh_io
        self.messages = MessageLog()  # bounded: the newest MAX_MESSAGES, newest last
        self.history = History(on_drop=self._dropped)
        self.field: str | None = None
        self.colors_shown = True
        self.points_shown = "auto"
        #: how much of the deformation is shown: 1 all of it, 0 the rest mesh (:meth:`set_blend`)
        self.blend = 1.0
        self.selected: tuple[int, ...] | None = None
        self._subscribers = Subscribers(self.messages.append)
        self._dragged: int | None = None
        self._rest_control: NDArray[np.float64]  # control points at rest, flat (set with the mesh)
        self._committed: NDArray[np.float64]  # the offsets as last recorded in the history
        self.surface = SurfaceDrag(self)  # pins, interaction mode, surface drags
        self.files = SessionFiles(self)  # lattice files and meshes
        self.image = SessionImage(self)  # an image shown as warped slices, if any
        if lattice is None:
            lattice, self.lattice_source = fitted_lattice(mesh, shape, basis), "fit"
        else:
            self.lattice_source = "given"
        self._bind_mesh(mesh, FFD(lattice, basis).bind(mesh.points))
        self.paint = WeightPaint(self)  # the vertices' weights and the brush that paints them
        self.script = SessionScript(self)  # the undo history as code (editor.to_code())

    # ------------------------------------------------------------------ state
    @property
    def lattice(self) -> Lattice:
        """The control lattice; edit ``lattice.offsets`` in place, then call :meth:`update`."""
        return self.ffd.lattice

    @property
    def ffd(self) -> FFD:
        """The :class:`~ffd_notebook.ffd.deform.FFD` applied to the mesh: lattice, basis, border, affine
        part and ``only_inside`` (a loaded deformation file brings all of them)."""
        return self.deformer.ffd

    @property
    def basis(self) -> BasisName | tuple[str, str, str]:
        """The FFD basis, ``"bspline"``, ``"bernstein"`` or Blender's interpolations per axis (a tuple)."""
        return self.ffd.basis

    @property
    def interpolation(self) -> tuple[str, str, str] | None:
        """Blender's interpolation of each axis (``("bspline",) * 3`` for the B-spline), None for Bernstein."""
        basis = self.ffd.basis
        return None if basis == "bernstein" else ("bspline",) * 3 if basis == "bspline" else basis

    @property
    def weights(self) -> NDArray[np.float64] | None:
        """The vertices' weights (a copy; see :class:`~.weights.WeightPaint`), or None: all follow fully."""
        return self.paint.weights

    @property
    def can_undo(self) -> bool:
        """Whether :meth:`undo` has a step to revert."""
        return self.history.can_undo

    @property
    def can_redo(self) -> bool:
        """Whether :meth:`redo` has a step to re-apply."""
        return self.history.can_redo

    @property
    def has_colors(self) -> bool:
        """Whether the mesh has per-vertex colors."""
        return self.mesh_io.color_array(self.mesh) is not None

    @property
    def deformed_mesh(self) -> Any:
        """A new mesh: the current deformed points with the rest mesh's faces and point data."""
        return self.mesh_io.with_points(self.mesh, self.deformed_points)

    def control_points(self) -> NDArray[np.float64]:
        """Deformed control points, flat C order ``(M, 3)``: rest position + offset.

        Returns
        -------
        numpy.ndarray
            ``(M, 3)`` float64 positions, one row per control point (row :meth:`flat_index` of ``(i, j, k)``).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.0, 0.0, 0.5))
        >>> moved = session.control_points() - session.lattice.control_points().reshape(-1, 3)
        >>> session.control_points().shape, moved[0].tolist()
        ((64, 3), [0.0, 0.0, 0.5])
        """
        return self._rest_control + self.lattice.offsets.reshape(-1, 3)

    def shown_points(self) -> NDArray[np.float64]:
        """The mesh as shown: the deformed points, or with a :attr:`blend` below 1 ``rest + blend * (deformed -
        rest)`` (a new array then).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)``: :attr:`deformed_points` itself at blend 1 (exactly the deformation).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((3, 3, 3), (0.0, 0.0, 0.4))
        >>> session.set_blend(0.5)
        >>> half = session.shown_points() - session.rest_points
        >>> bool(np.allclose(half, (session.deformed_points - session.rest_points) / 2))
        True
        """
        if self.blend == 1.0:
            return self.deformed_points
        rest = self.rest_points
        return rest + self.blend * (np.asarray(self.deformed_points, dtype=np.float64) - rest)

    def shown_control_points(self) -> NDArray[np.float64]:
        """Control points as shown: :meth:`control_points`, or with a :attr:`blend` below 1 ``rest + blend *
        offsets``.

        Returns
        -------
        numpy.ndarray
            ``(M, 3)`` positions, flat C order.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.0, 0.0, 0.4))
        >>> session.set_blend(0.5)
        >>> (session.shown_control_points() - session.lattice.control_points().reshape(-1, 3))[0].tolist()
        [0.0, 0.0, 0.2]
        """
        if self.blend == 1.0:
            return self.control_points()
        return self._rest_control + self.blend * self.lattice.offsets.reshape(-1, 3)

    def set_blend(self, t: float) -> None:
        """Show ``t`` of the deformation: ``rest + t * (deformed - rest)`` (0 the rest mesh, 1 all of it); no undo step.

        A teacher shows a deformation growing, and where it folds first: the folding colours follow ``t`` (the
        Jacobian of ``x + t (T(x) - x)``). Nothing is edited: below 1 the mouse grabs nothing in the view (the
        spheres are where ``t`` puts them), and any edit (a typed displacement, undo, code...) applies to the
        whole deformation and brings the blend back to 1.

        Parameters
        ----------
        t : float
            In [0, 1].

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((3, 3, 3), (0.0, 0.0, 0.4))
        >>> session.set_blend(0.0)
        >>> bool(np.array_equal(session.shown_points(), session.rest_points)), len(session.history)
        (True, 1)
        >>> session.move_control_point((0, 0, 0), (0.1, 0.0, 0.0))
        >>> session.blend
        1.0
        """
        value = float(t)
        if not 0.0 <= value <= 1.0:  # (NaN too)
            raise ValueError(f"the blend must be in [0, 1], got {t!r}")
        if value != self.blend:
            self.blend = value
            self.notify("display", None, "blend")

    def field_values(self) -> NDArray[np.float32] | None:
        """The shown field per vertex: ``|displacement|``, folding (1 where det J <= 0), or None.

        Returns
        -------
        numpy.ndarray or None
            One float32 value per vertex of the mesh for the field set with :meth:`set_field`; None when no
            field is shown.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.field_values() is None
        True
        >>> session.move_control_point((0, 0, 0), (0.0, 0.0, 0.5))
        >>> session.set_field("displacement")
        >>> values = session.field_values()
        >>> values.shape, values.dtype.name, bool(values.max() > 0)
        ((50,), 'float32', True)
        """
        if self.field == "displacement":
            diff = np.asarray(self.shown_points(), dtype=np.float64) - self.rest_points
            return np.sqrt(np.einsum("ij,ij->i", diff, diff)).astype(np.float32)
        if self.field == "jacobian":
            # the deformer reuses its cached grouping of points by cell (~20 ms on 53k points); with a blend t the
            # map is x + t s (T(x) - x): the strength s times t
            strength = None if self.blend == 1.0 else self.deformer.strength * self.blend
            return (self.deformer.jacobian_determinant(strength=strength) <= 0.0).astype(np.float32)
        if self.field == "weights":
            weights = self.deformer.weights  # during a brush stroke: the stroke's, not yet the FFD's
            return np.ones(len(self.rest_points), np.float32) if weights is None else weights.astype(np.float32)
        return None

    def flat_index(self, ijk: tuple[int, ...]) -> int:
        """Flat C-order index of control point ``(i, j, k)`` (its sphere widget's index).

        Parameters
        ----------
        ijk : tuple of int
            The control point's indices along x, y and z.

        Returns
        -------
        int
            Its row in ``lattice.offsets.reshape(-1, 3)`` and in :meth:`control_points`.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.flat_index((1, 2, 1))
        25
        """
        return int(np.ravel_multi_index(ijk, self.lattice.shape))

    def check_ijk(self, ijk: ArrayLike) -> tuple[int, int, int]:
        """``ijk`` as a tuple of three ints inside the lattice; a ValueError otherwise.

        Parameters
        ----------
        ijk : array_like
            Three whole numbers, each within the lattice's shape on its axis.

        Returns
        -------
        tuple of int
            ``(i, j, k)`` as Python ints.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.check_ijk([1, 2, 3.0])
        (1, 2, 3)
        >>> session.check_ijk((4, 0, 0))
        Traceback (most recent call last):
        ...
        ValueError: control point index must be (i, j, k) within the lattice (4, 4, 4), got (4, 0, 0)
        """
        arr = np.asarray(ijk)
        shape = self.lattice.shape
        if arr.shape != (3,) or not _inside(arr, shape):
            raise ValueError(f"control point index must be (i, j, k) within the lattice {shape}, got {ijk!r}")
        return tuple(int(v) for v in arr)  # type: ignore[return-value]

    def check_points(self, points: ArrayLike) -> NDArray[np.int64]:
        """``points`` (a list of ``(i, j, k)``) as an ``(n, 3)`` int array inside the lattice; a ValueError otherwise.

        Commands check their control points with it before they change anything.

        Parameters
        ----------
        points : array_like
            Rows of three whole numbers, each within the lattice's shape on its axis (may be empty).

        Returns
        -------
        numpy.ndarray
            ``(n, 3)`` int64.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.check_points([(1, 2, 3), (0, 0, 0)]).tolist()
        [[1, 2, 3], [0, 0, 0]]
        >>> session.check_points([(-1, 0, 0)])
        Traceback (most recent call last):
        ...
        ValueError: control points must be (i, j, k) rows within the lattice (4, 4, 4), got [(-1, 0, 0)]
        """
        shape = self.lattice.shape
        try:
            arr = np.asarray(points if points is not None else [], dtype=np.float64)
        except (TypeError, ValueError):  # ragged rows, or not numbers
            arr = np.empty((0, 0))
        if arr.size == 0 and arr.ndim <= 2 and arr.shape[-1:] in ((0,), (3,)):
            return np.empty((0, 3), dtype=np.int64)
        if arr.ndim != 2 or arr.shape[1] != 3 or not _inside(arr, shape):
            raise ValueError(f"control points must be (i, j, k) rows within the lattice {shape}, got {points!r}")
        return arr.astype(np.int64)

    # ------------------------------------------------------------------ notification and messages
    def subscribe(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        """Call ``callback(change)`` after every command; returns a function that unsubscribes.

        Parameters
        ----------
        callback : callable
            Called with each :class:`~.changes.Change`, in subscription order.

        Returns
        -------
        callable
            Call it (no arguments) to stop the notifications.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> changes = []
        >>> unsubscribe = session.subscribe(changes.append)
        >>> session.select((1, 1, 1))
        >>> unsubscribe()
        >>> session.select(None)
        >>> [(change.kind, change.label) for change in changes]
        [('select', 'select')]
        """
        return self._subscribers.add(callback)

    def close(self) -> None:
        """Unsubscribe everybody.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> changes = []
        >>> _ = session.subscribe(changes.append)
        >>> session.close()
        >>> session.select((1, 1, 1))
        >>> changes
        []
        """
        self._subscribers.clear()

    def notify(self, kind: Any, points: Any = None, label: str = "", started: float | None = None) -> None:
        """Tell every subscriber about one :class:`~.changes.Change` (from the session's commands and parts).

        Parameters
        ----------
        kind : str
            The change's kind (one of :data:`~.changes.KINDS`).
        points : array_like of int, optional
            Flat indices of the control points concerned; None for all (or none, as the kind says).
        label : str, default ""
            The command that made the change.
        started : float, optional
            :func:`time.perf_counter` when the command began; now by default.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> changes = []
        >>> _ = session.subscribe(changes.append)
        >>> session.notify("offsets", [3, 7], "code")
        >>> changes[0].kind, changes[0].points.tolist(), changes[0].label
        ('offsets', [3, 7], 'code')
        """
        if kind in EDITS and self.blend != 1.0:  # an edit applies to the whole deformation: show all of it first
            self.blend = 1.0
            self.notify("display", None, "blend")
        change = Change(kind, points, label) if started is None else Change(kind, points, label, started)
        self.image.follow(change)  # the warped slices first: every view then sees them up to date
        self._subscribers.emit(change)

    def info(self, text: str) -> None:
        """Add a message (and tell the views).

        Parameters
        ----------
        text : str
            The message, as the user reads it.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> changes = []
        >>> _ = session.subscribe(changes.append)
        >>> session.info("lattice saved")
        >>> list(session.messages)[-1], changes[-1].kind
        ('lattice saved', 'message')
        """
        self.messages.append(text)
        self.notify("message")

    def error(self, text: str) -> None:
        """Add an error message ``"Error: text"`` (and tell the views).

        Parameters
        ----------
        text : str
            What went wrong.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.error("no such file")
        >>> list(session.messages)[-1]
        'Error: no such file'
        """
        self.info(f"Error: {text}")

    def attempt(self, action: Callable[..., Any], *args: Any) -> bool:
        """Run ``action(*args)`` for a user interface: a failure becomes a message, not an exception.

        The session's own commands log what went wrong themselves; any other failure (e.g. a value
        typed in a panel that is not a number) is logged as ``"Error: <exception>"``.

        Parameters
        ----------
        action : callable
            What to run.
        *args
            Its positional arguments.

        Returns
        -------
        bool
            Whether ``action`` succeeded.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.attempt(float, "abc"), list(session.messages)[-1]
        (False, "Error: could not convert string to float: 'abc'")
        >>> session.attempt(session.move_control_point, (0, 0, 0), (0.1, 0.0, 0.0))
        True
        """
        n_messages = self.messages.n_added
        try:
            action(*args)
        except Exception as exc:
            if self.messages.n_added == n_messages:  # the command did not explain it itself
                self.error(str(exc))
            return False
        return True

    # ------------------------------------------------------------------ dragging a handle
    def begin_drag(self, index: int) -> None:
        """A handle was grabbed: close the open undo step and select its control point.

        Parameters
        ----------
        index : int
            The control point's flat C-order index (its handle's index).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.begin_drag(25)
        >>> session.selected
        (1, 2, 1)
        """
        self.history.close()
        self._dragged = int(index)
        self._select(tuple(int(v) for v in np.unravel_index(int(index), self.lattice.shape)), "drag")

    def drag(self, index: int, position: ArrayLike, started: float | None = None) -> None:
        """The handle of control point ``index`` (flat C order) is at ``position``: move it there.

        One ``"drag"`` change with that one point; consecutive drags of the same point are one undo step.

        Parameters
        ----------
        index : int
            The control point's flat C-order index.
        position : array_like
            Where its handle is now (world coordinates, 3 values).
        started : float, optional
            :func:`time.perf_counter` when the handle moved (passed on to the change, for timing).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.begin_drag(5)
        >>> rest = session.control_points()[5]
        >>> session.drag(5, rest + (0.0, 0.0, 0.1))
        >>> session.drag(5, rest + (0.0, 0.0, 0.2))
        >>> session.end_drag()
        >>> session.lattice.offsets.reshape(-1, 3)[5].round(3).tolist(), len(session.history)
        ([0.0, 0.0, 0.2], 1)
        """
        index = int(index)
        ijk = tuple(int(v) for v in np.unravel_index(index, self.lattice.shape))
        before = self.lattice.offsets[ijk].copy()
        self.lattice.offsets[ijk] = np.asarray(position, dtype=np.float64) - self._rest_control[index]
        self.history.record([ijk], [before], [self.lattice.offsets[ijk]], key=("drag", index), label="drag")
        self._committed[ijk] = self.lattice.offsets[ijk]
        self.deformed_points = self.deformer.update([ijk])
        self._dragged = index
        if self.selected != ijk:
            self._select(ijk, "drag")
        self.notify("drag", [index], "drag", started)

    def end_drag(self) -> None:
        """The handle was released: the drag's undo step is closed.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> changes = []
        >>> _ = session.subscribe(changes.append)
        >>> session.begin_drag(5)
        >>> session.drag(5, session.control_points()[5] + (0.0, 0.1, 0.0))
        >>> session.end_drag()
        >>> changes[-1].kind, changes[-1].points.tolist(), session.undo()
        ('offsets', [5], True)
        """
        self.history.close()
        points = [] if self._dragged is None else [self._dragged]
        self._dragged = None
        self.notify("offsets", points, "drag")

    # ------------------------------------------------------------------ offsets from code and panels
    def update(self, changed: Any = None) -> None:
        """Pick up edits made in place to ``lattice.offsets`` (or its placement) by code; one undo step.

        Offsets that differ from what the session last committed become one ``"code"`` step.
        ``changed`` (a list of ``(i, j, k)``) is a hint; points found to differ are always included.
        With neither, everything is recomputed (e.g. the lattice's origin was changed in place).

        Parameters
        ----------
        changed : list of tuple of int, optional
            Control points ``(i, j, k)`` edited in place, to recompute even if their offsets look unchanged.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.lattice.offsets[3, 3, 3] = (0.0, 0.0, 0.1)
        >>> session.update()
        >>> len(session.history), float(abs(session.deformed_points - session.rest_points).max()) > 0
        (1, True)
        """
        lat = self.lattice
        if lat.shape != self._committed.shape[:3]:
            raise ValueError("the lattice's shape changed: assign a new lattice with set_lattice(...)")
        hint = self.check_points(changed)  # before anything changes
        self.history.close()
        self._rest_control = lat.control_points().reshape(-1, 3)
        moved = np.argwhere(np.any(lat.offsets != self._committed, axis=-1))  # the one comparison of copies
        if len(moved):
            idx = tuple(moved.T)
            self.history.record(moved, self._committed[idx], lat.offsets[idx], label="code")
            self._committed[idx] = lat.offsets[idx]
        todo = np.unique(np.vstack([moved, hint]), axis=0)
        if changed is None and not len(todo):
            self.deformed_points = self.deformer.update(None)
            self.notify("offsets", None, "code")
        else:
            self.deformed_points = self.deformer.update([tuple(v) for v in todo])
            self.notify("offsets", np.ravel_multi_index(tuple(todo.T), lat.shape), "code")

    def move_control_point(self, ijk: ArrayLike, displacement: ArrayLike) -> None:
        """Set the offset of control point ``ijk`` to ``displacement`` (world units; one undo step).

        Parameters
        ----------
        ijk : array_like
            The control point ``(i, j, k)``.
        displacement : array_like
            Its new offset from the rest position: three finite numbers.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
        >>> session.lattice.offsets[1, 2, 1].tolist(), session.selected
        ([0.0, 0.0, 0.25], (1, 2, 1))
        """
        ijk_t = self.check_ijk(ijk)
        value = np.asarray(displacement, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"displacement must be three finite numbers, got {displacement!r}")
        self.set_offsets([ijk_t], value[None, :], label="move")
        self._select(ijk_t, "move")

    def reset(self, ijk: ArrayLike | None = None) -> None:
        """Zero the offset of one control point, or of all of them (one undo step; none if nothing moves).

        Parameters
        ----------
        ijk : array_like, optional
            The control point ``(i, j, k)`` to reset; all of them if omitted.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.1, 0.0, 0.0))
        >>> session.move_control_point((3, 3, 3), (0.0, 0.1, 0.0))
        >>> session.reset((0, 0, 0))
        >>> float(abs(session.lattice.offsets).sum())
        0.1
        >>> session.reset()
        >>> float(abs(session.lattice.offsets).sum()), len(session.history)
        (0.0, 4)
        """
        if ijk is None:  # (an offset of -0.0 too: afterwards every offset is the same +0.0 double)
            offsets = self.lattice.offsets
            points = [tuple(v) for v in np.argwhere(np.any((offsets != 0) | np.signbit(offsets), axis=-1))]
        else:
            point = self.check_ijk(ijk)
            points = [point] if np.any(self.lattice.offsets[point] != 0) else []  # an unmoved point: no undo step
        if points:
            self.set_offsets(points, np.zeros((len(points), 3)), label="reset")

    def set_offsets(self, points: list[tuple[int, int, int]], values: ArrayLike, *, label: str) -> None:
        """Set the offsets of control points ``points`` (a list of ``(i, j, k)``) to ``values``: one undo step.

        Parameters
        ----------
        points : list of tuple of int
            The control points ``(i, j, k)``.
        values : array_like
            ``(len(points), 3)`` new offsets (or one row for all).
        label : str
            The command's name in the history and the change.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_offsets([(0, 0, 1), (0, 0, 2)], [[0, 0, 0.1], [0, 0, 0.2]], label="code")
        >>> session.lattice.offsets[0, 0, 1:3].tolist(), session.undo()
        ([[0.0, 0.0, 0.1], [0.0, 0.0, 0.2]], True)
        """
        ijk = self.check_points(points)  # everything is checked before anything is written
        try:
            rows = np.broadcast_to(np.asarray(values, dtype=np.float64), (len(ijk), 3))
        except (TypeError, ValueError):
            raise ValueError(f"offsets must be one row of three numbers or one per control point ({len(ijk)}), "
                             f"got {values!r}") from None  # fmt: skip
        if not np.all(np.isfinite(rows)):
            raise ValueError(f"offsets must be finite numbers, got {values!r}")
        self.history.close()
        idx = tuple(ijk.T)
        before = self.lattice.offsets[idx].copy()
        self.lattice.offsets[idx] = rows
        self.history.record(ijk, before, self.lattice.offsets[idx], label=label)
        self.commit_rows(idx, label)

    def commit_rows(
        self, idx: tuple[NDArray[np.intp], ...], label: str, *, kind: str = "offsets", started: float | None = None
    ) -> None:
        """Offsets at ``idx`` were written: commit them, update the deformer, tell the views (a ``kind`` change).

        Parameters
        ----------
        idx : tuple of numpy.ndarray
            ``(i, j, k)`` index arrays of the control points whose ``lattice.offsets`` were written.
        label : str
            The command's name for the change.
        kind : str, default "offsets"
            The change's kind.
        started : float, optional
            :func:`time.perf_counter` when the command began.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> import numpy as np
        >>> idx = (np.array([0]), np.array([0]), np.array([0]))
        >>> session.lattice.offsets[idx] = (0.0, 0.0, 0.3)
        >>> session.commit_rows(idx, "code")
        >>> bool(np.abs(session.deformed_points - session.rest_points).max() > 0)
        True
        """
        self._committed[idx] = self.lattice.offsets[idx]
        self.deformed_points = self.deformer.update(list(zip(*(i.tolist() for i in idx), strict=True)))
        self.notify(kind, np.ravel_multi_index(idx, self.lattice.shape), label, started)

    # ------------------------------------------------------------------ selection
    def select(self, ijk: ArrayLike | None) -> None:
        """Select control point ``(i, j, k)`` (highlighted; the panels edit it), or None.

        Parameters
        ----------
        ijk : array_like or None
            The control point, or None to clear the selection.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.select((1, 1, 1))
        >>> session.selected
        (1, 1, 1)
        >>> session.select(None)
        >>> session.selected is None
        True
        """
        self._select(None if ijk is None else self.check_ijk(ijk), "select")

    def _select(self, ijk: tuple[int, ...] | None, label: str) -> None:
        self.selected = ijk
        self.notify("select", None, label)

    # ------------------------------------------------------------------ undo / redo
    def undo(self, prepared: PreparedStep | None = None) -> bool:
        """Revert the last step; False if there was none.

        Parameters
        ----------
        prepared : PreparedStep, optional
            :meth:`prepare_step` of the step (its lattice bound to the mesh in a worker thread).

        Returns
        -------
        bool
            Whether a step was reverted.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.1, 0.0, 0.0))
        >>> session.undo(), session.undo(), float(abs(session.lattice.offsets).sum())
        (True, False, 0.0)
        """
        return self._apply(self.history.undo, prepared, forward=False)

    def redo(self, prepared: PreparedStep | None = None) -> bool:
        """Re-apply the last undone step; False if there was none.

        Parameters
        ----------
        prepared : PreparedStep, optional
            As for :meth:`undo`.

        Returns
        -------
        bool
            Whether a step was re-applied.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.1, 0.0, 0.0))
        >>> session.undo(), session.redo(), session.redo()
        (True, True, False)
        >>> session.lattice.offsets[0, 0, 0].tolist()
        [0.1, 0.0, 0.0]
        """
        return self._apply(self.history.redo, prepared, forward=True)

    def prepare_step(self, forward: bool = False) -> PreparedStep | None:
        """The next undo (``forward``: redo) step if it replaces the lattice, with a copy of the FFD it installs.

        None for any other step. Binding that FFD to the mesh (``prepared.bind()``, about a second on a
        500k-point mesh) is the slow part of undoing it: a worker thread may do it and pass the result to
        :meth:`undo` / :meth:`redo`, which check that the history and the mesh have not changed meanwhile.

        Parameters
        ----------
        forward : bool, default False
            The next redo step instead of the next undo step.

        Returns
        -------
        PreparedStep or None
            The step and its FFD (bound by ``prepared.bind()``), or None if the step only moves control points.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_strength(0.5)
        >>> prepared = session.prepare_step()
        >>> session.undo(prepared.bind()), session.ffd.strength
        (True, 1.0)
        >>> session.move_control_point((0, 0, 0), (0.1, 0.0, 0.0))
        >>> print(session.prepare_step())
        None
        """
        step = self.history.peek(forward)
        if not isinstance(step, LatticeSwap):
            return None
        ffd, _ = step.after if forward else step.before
        return PreparedStep(step, self._step_ffd(ffd), self.mesh)

    def _step_ffd(self, ffd: FFD) -> FFD:
        """A copy of an undo step's FFD to install on the current mesh."""
        ffd = copy_ffd(ffd)
        if isinstance(ffd.weights, np.ndarray) and len(ffd.weights) != len(self.rest_points):
            ffd.weights = None  # weights of the mesh before a decimation
        return ffd

    def _apply(self, pop: Callable[[], Any], prepared: PreparedStep | None, forward: bool) -> bool:
        self.paint.end()  # a brush stroke under way is a step: the one undone next
        if prepared is not None and (self.history.peek(forward) is not prepared.step or prepared.mesh is not self.mesh):
            raise ChangedMeanwhile("the history or the mesh changed meanwhile; try again")
        step = pop()
        if step is None:
            return False
        label = "redo" if forward else "undo"
        if isinstance(step, LatticeSwap):
            ffd, self.lattice_source = step.after if forward else step.before
            if prepared is not None and prepared.deformer is not None:
                self._bind_lattice(prepared.deformer, label)  # bound in a worker thread
            else:
                self._bind_lattice(self._step_ffd(ffd).bind(self.mesh.points), label)
        else:
            idx = tuple(step.ijk.T)
            self.lattice.offsets[idx] = step.after if forward else step.before
            self.commit_rows(idx, label)
        return True

    # ------------------------------------------------------------------ lattice and basis
    def set_lattice(self, lattice: Lattice, basis: BasisName | None = None, *, label: str = "lattice") -> None:
        """Replace the lattice (and optionally the basis); one undo step. Invalid input changes nothing.

        A lattice given this way stays where it is when another mesh is loaded.

        Parameters
        ----------
        lattice : Lattice
            The new lattice (used as is).
        basis : {"bspline", "bernstein"}, optional
            The FFD basis; the current one if omitted.
        label : str, default "lattice"
            The command's name in the history.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> from ffd_notebook import Lattice
        >>> lattice = Lattice.around(session.mesh.points, (6, 4, 4))
        >>> session.set_lattice(lattice)
        >>> session.lattice is lattice, session.lattice_source, session.can_undo
        (True, 'given', True)
        """
        self.swap_lattice(lattice, basis, label=label, source="given")

    def swap_lattice(self, lattice: Lattice, basis: BasisName | None, *, label: str, source: str) -> None:
        """Install ``FFD(lattice, basis)`` as one undo step (see :meth:`swap_ffd`).

        Parameters
        ----------
        lattice : Lattice
            The new lattice; a TypeError for anything else.
        basis : {"bspline", "bernstein"} or None
            The FFD basis; None keeps the current one.
        label : str
            The command's name in the history.
        source : str
            How the lattice was made (see :meth:`swap_ffd`).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> from ffd_notebook import Lattice
        >>> lattice = Lattice.around(session.mesh.points, (4, 4, 4), basis="bernstein")
        >>> session.swap_lattice(lattice, "bernstein", label="code", source="fit")
        >>> session.basis, session.lattice_source
        ('bernstein', 'fit')
        """
        if not isinstance(lattice, Lattice):
            raise TypeError(f"lattice must be a Lattice, got {type(lattice).__name__}")
        # validates (e.g. a B-spline lattice needs 4 points per axis) before any change
        self.swap_ffd(FFD(lattice, self.basis if basis is None else basis), label=label, source=source)

    def swap_ffd(self, ffd: FFD, *, label: str, source: str, deformer: Deformer | None = None, how: Any = None) -> None:
        """Install ``ffd`` (its lattice, basis, border, affine part, ``only_inside``) as one undo step.

        Parameters
        ----------
        ffd : FFD
            What to install; a TypeError for anything else.
        label : str
            The command's name in the history.
        source : {"fit", "given", "ffd-placed", "ffd-min", "file"}
            How the lattice was made: decides what loading a mesh does with it, and is undone with it.
        deformer : Deformer, optional
            ``ffd`` already bound to the mesh's points (e.g. in a worker thread); bound here if omitted.
        how : object, optional
            How it was made, for :attr:`script` (e.g. a :class:`~.script.LoadedFile`).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> from ffd_notebook.ffd.deform import FFD
        >>> from ffd_notebook import Lattice
        >>> ffd = FFD(Lattice.around(session.mesh.points, (5, 5, 5)), "bspline")
        >>> session.swap_ffd(ffd, label="code", source="given")
        >>> session.lattice.shape, session.undo(), session.lattice.shape
        ((5, 5, 5), True, (4, 4, 4))
        """
        if not isinstance(ffd, FFD):
            raise TypeError(f"ffd must be an FFD, got {type(ffd).__name__}")
        self.paint.end()  # a brush stroke under way is a step of the lattice it was painted on
        self.history.close()
        before = (copy_ffd(self.ffd), self.lattice_source)
        self.lattice_source = source
        self.history.record_lattice(before, (copy_ffd(ffd), source), label=label, how=how)
        self._bind_lattice(ffd.bind(self.mesh.points) if deformer is None else deformer, label)

    def fitted_ffd(self, shape: ArrayLike) -> FFD:
        """The FFD of a new lattice with ``shape`` control points per axis fitted around the mesh.

        It changes nothing (a message and a ValueError if it cannot be built). Binding it to the mesh
        (``ffd.bind(session.mesh.points)``, seconds on a 500k-point mesh) is the slow part of
        :meth:`set_shape`: a worker thread may do it and hand the deformer over.

        Parameters
        ----------
        shape : array_like of int
            Control points per axis.

        Returns
        -------
        FFD
            The session's FFD (basis, strength, weights) on the new lattice, offsets at zero.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> ffd = session.fitted_ffd((5, 4, 4))
        >>> ffd.lattice.shape, session.lattice.shape
        ((5, 4, 4), (4, 4, 4))
        """
        try:
            return refitted(self.ffd, self.mesh, tuple(int(s) for s in np.ravel(shape)))
        except (ValueError, TypeError) as exc:
            self.error(f"cannot build a {shape!r} lattice: {exc}")
            raise

    def set_shape(self, shape: ArrayLike, deformer: Deformer | None = None) -> None:
        """Fit a new lattice with ``shape`` control points per axis around the mesh (undoable).

        Parameters
        ----------
        shape : array_like of int
            Control points per axis.
        deformer : Deformer, optional
            :meth:`fitted_ffd` of this shape, already bound to the current mesh's points.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_shape((5, 4, 4))
        >>> session.lattice.shape, list(session.messages)[-1]
        ((5, 4, 4), 'new 5x4x4 lattice around the mesh')
        """
        self.paint.end()  # a brush stroke under way is a step of the lattice it was painted on
        if deformer is None:
            deformer = self.fitted_ffd(shape).bind(self.mesh.points)
        elif deformer.ffd.lattice.shape != tuple(np.ravel(shape)) or len(deformer.points) != len(self.rest_points):
            raise ValueError(f"the deformer is not a {shape!r} lattice bound to this mesh")
        else:
            self._adopt(deformer, "fitting the lattice", basis=True)
        self.swap_ffd(deformer.ffd, label="shape", source="fit", deformer=deformer)
        self.info(f"new {'x'.join(map(str, deformer.ffd.lattice.shape))} lattice around the mesh")

    def basis_ffd(self, basis: BasisName) -> FFD:
        """The FFD :meth:`set_basis` installs for ``basis`` (the lattice refitted for it).

        It changes nothing (a message and a ValueError if it cannot be built). Binding it to the mesh is
        the slow part.

        Parameters
        ----------
        basis : {"bspline", "bernstein"}
            The basis to switch to.

        Returns
        -------
        FFD
            A lattice of the current shape fitted around the mesh for ``basis``, offsets at zero; the strength,
            the "outside" rule and the vertex weights stay (as for a new size: :func:`.lattices.refitted`).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> ffd = session.basis_ffd("bernstein")
        >>> ffd.basis, ffd.lattice.shape, session.basis
        ('bernstein', (4, 4, 4), 'bspline')
        """
        try:
            return refitted(self.ffd, self.mesh, self.lattice.shape, basis)
        except ValueError as exc:
            self.error(f"cannot switch to the {basis!r} basis: {exc}")
            raise

    def set_basis(self, basis: BasisName, deformer: Deformer | None = None) -> None:
        """Switch the basis; refits the lattice around the mesh for it (offsets start at zero; undoable).

        Parameters
        ----------
        basis : {"bspline", "bernstein"}
            The new basis (nothing happens if it is the current one).
        deformer : Deformer, optional
            :meth:`basis_ffd` of ``basis``, already bound to the current mesh's points.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_basis("bernstein")
        >>> session.basis, list(session.messages)[-1]
        ('bernstein', 'basis: bernstein')
        """
        if basis == self.basis:
            return
        self.paint.end()  # a brush stroke under way is a step of the lattice it was painted on
        if deformer is None:
            deformer = self.basis_ffd(basis).bind(self.mesh.points)
        elif deformer.ffd.basis != basis or len(deformer.points) != len(self.rest_points):
            raise ValueError(f"the deformer is not a {basis!r} lattice bound to this mesh")
        else:
            self._adopt(deformer, f"switching to the {basis} basis", basis=False)
        self.swap_ffd(deformer.ffd, label="basis", source="fit", deformer=deformer)
        self.info(f"basis: {basis}")

    def _adopt(self, deformer: Deformer, what: str, *, basis: bool) -> None:
        """Bring ``deformer`` (made by :meth:`fitted_ffd` or :meth:`basis_ffd` from this session's FFD, bound in
        a worker thread) up to the options changed while it was bound, so installing it overwrites none of them.

        Weights painted or set meanwhile are weighed in (milliseconds); another strength, "outside" rule or
        (``basis``) interpolation needs the binding done again: a :class:`ChangedMeanwhile` naming them.
        """
        ffd, current = deformer.ffd, self.ffd
        changed = [name for name, differs in (("interpolation", basis and ffd.basis != current.basis),
                                              ("strength", ffd.strength != current.strength),
                                              ("outside rule", ffd.outside != current.outside)) if differs]  # fmt: skip
        if changed:
            raise ChangedMeanwhile(f"the {' and '.join(changed)} changed while {what}")
        weights = self.paint.weights  # a copy
        if not _same_weights(ffd.weights, weights):
            ffd.weights = weights
            deformer.weights = weights

    def set_interpolation(self, interpolation: Any) -> None:
        """Blender's interpolation per axis (``("bspline", "catmull-rom", "linear")``; one name: every axis).

        The offsets stay (as in Blender, where the interpolation is a property of the lattice); one
        undo step. A Bernstein lattice has none: switch the basis to ``"bspline"`` first.

        Parameters
        ----------
        interpolation : str or tuple of str
            One interpolation for every axis, or three (x, y, z).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_interpolation(("bspline", "catmull-rom", "linear"))
        >>> session.interpolation, list(session.messages)[-1]
        (('bspline', 'catmull-rom', 'linear'), 'interpolation: bspline / catmull-rom / linear')
        """
        try:
            if self.basis == "bernstein":
                raise ValueError("a Bernstein lattice has no per-axis interpolation: switch the basis to bspline")
            basis = check_basis(interpolation)
            if basis == "bernstein":
                raise ValueError("use set_basis for the Bernstein basis")
            ffd = copy_ffd(self.ffd, basis=basis)
        except ValueError as exc:
            self.error(f"cannot set the interpolation: {exc}")
            raise
        if ffd.basis == self.basis:
            return
        self.swap_ffd(ffd, label="interpolation", source=self.lattice_source)
        interpolation = self.interpolation
        assert interpolation is not None  # per-axis interpolations are installed
        self.info(f"interpolation: {' / '.join(interpolation)}")

    def set_strength(self, strength: float) -> None:
        """Scale the whole deformation: 1 full, 0 none, negative the other way (Blender's strength); one undo step.

        Parameters
        ----------
        strength : float
            The factor applied to every control point's offset.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.move_control_point((0, 0, 0), (0.0, 0.0, 1.0))
        >>> full = abs(session.deformed_points - session.rest_points).max()
        >>> session.set_strength(0.5)
        >>> bool(abs(abs(session.deformed_points - session.rest_points).max() - full / 2) < 1e-9)
        True
        """
        try:
            ffd = copy_ffd(self.ffd, strength=strength)
        except ValueError as exc:
            self.error(f"cannot set the strength: {exc}")
            raise
        if ffd.strength != self.ffd.strength:
            self.swap_ffd(ffd, label="strength", source=self.lattice_source)

    def decimate(self, reduction: float) -> Any:
        """Decimate the loaded mesh by ``reduction`` (fraction of faces removed, ``0`` restores it).

        Always starts from the mesh as loaded, so repeated calls do not compound. Per-vertex colors
        are kept; the lattice and its offsets are kept and the deformer is re-bound to the new
        vertices; the undo history stays valid.

        Parameters
        ----------
        reduction : float
            Fraction of the loaded mesh's faces to remove, in ``[0, 1)``.

        Returns
        -------
        mesh
            The decimated mesh, now the session's mesh.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.decimate(0.5).n_cells, session.decimate(0.5).n_cells, session.decimate(0).n_cells
        (48, 48, 96)
        """
        try:
            done = self.decimation(reduction)
        except (TypeError, ValueError) as exc:
            self.error(f"could not decimate: {exc}")
            raise
        return self.use_decimated(done)

    def decimation(self, reduction: float) -> Decimation:
        """The work of :meth:`decimate`, changing nothing and telling nobody (a worker thread may do it).

        A ValueError if it cannot be done (the caller says so: :meth:`decimate` in the messages, the app on
        its page, each once and from its own thread).

        Parameters
        ----------
        reduction : float
            Fraction of the loaded mesh's faces to remove.

        Returns
        -------
        Decimation
            The decimated mesh and the lattice bound to it, for :meth:`use_decimated`.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> done = session.decimation(0.5)
        >>> done.mesh.n_cells, session.mesh.n_cells
        (48, 96)
        """
        reduction = float(reduction)
        source = self.source_mesh
        mesh = source.copy(deep=True) if reduction == 0.0 else self.mesh_io.decimate(source, reduction)
        if mesh.n_points == 0:
            raise ValueError("nothing left after decimation")
        ffd = self.ffd
        # vertex weights belong to the mesh as it was: they are cleared when the result is used, and the lattice
        # is bound then (the weights would not fit the new vertices)
        deformer = None if ffd.weights is not None else ffd.bind(mesh.points)
        return Decimation(reduction, source, ffd, ffd.lattice.offsets.copy(), mesh, deformer)

    def use_decimated(self, done: Decimation) -> Any:
        """Use a :meth:`decimation` (made from this session's current mesh and lattice: else a ValueError).

        Parameters
        ----------
        done : Decimation
            What :meth:`decimation` returned.

        Returns
        -------
        mesh
            The decimated mesh, now the session's mesh.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> done = session.decimation(0.5)
        >>> session.use_decimated(done).n_cells, list(session.messages)[-1]
        (48, 'decimated by 50%: 26 vertices, 48 faces')
        """
        if done.source is not self.source_mesh or done.ffd is not self.ffd:
            raise ChangedMeanwhile("the mesh or the lattice changed meanwhile; decimate again")
        self.paint.end()  # a brush stroke under way is a step of the mesh it was painted on
        dropped = self.ffd.weights is not None
        if dropped:  # one per vertex of the mesh as it was
            self.ffd.weights = None
            self.info(WEIGHTS_CLEARED)
        deformer = done.deformer
        if deformer is None or not np.array_equal(done.offsets, self.ffd.lattice.offsets):  # (edited meanwhile)
            deformer = self.ffd.bind(done.mesh.points)
        self.replace_mesh(done.mesh, deformer, label="decimate", new_document=False)
        self.script.decimated(done.reduction, dropped_weights=dropped)
        self.info(f"decimated by {done.reduction:.0%}: {done.mesh.n_points} vertices, {done.mesh.n_cells} faces")
        return done.mesh

    # ------------------------------------------------------------------ coloring
    def show_colors(self, show: bool = True) -> None:
        """Show the mesh's per-vertex colors (or a plain color).

        Parameters
        ----------
        show : bool, default True
            Show the colors (a message says so if the mesh has none), or a plain color.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.show_colors()
        >>> session.colors_shown, list(session.messages)[-1]
        (True, 'this mesh has no per-vertex colours')
        >>> session.show_colors(False)
        >>> session.colors_shown
        False
        """
        self.colors_shown = bool(show)
        if show and not self.has_colors:
            self.info("this mesh has no per-vertex colours")
        self.notify("display", None, "colors")

    def set_field(self, field: str | None) -> None:
        """Color the mesh by a deformation field: None, ``"displacement"`` or ``"jacobian"`` (folding).

        Parameters
        ----------
        field : {None, "displacement", "jacobian", "weights"}
            The field (:data:`FIELDS`); None for the mesh's own colors.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.set_field("jacobian")
        >>> list(session.messages)[-1]
        'folding (det J <= 0) at 0 of 50 vertices'
        >>> session.set_field("curl")
        Traceback (most recent call last):
        ...
        ValueError: field must be one of (None, 'displacement', 'jacobian', 'weights'), got 'curl'
        """
        if field not in FIELDS:
            raise ValueError(f"field must be one of {FIELDS}, got {field!r}")
        self.field = field
        self.notify("display", None, "field")
        if field == "jacobian":
            values = self.field_values()
            assert values is not None  # the jacobian field is set
            n = int(values.sum())
            self.info(f"folding (det J <= 0) at {n} of {self.mesh.n_points} vertices")

    def show_points(self, which: str) -> None:
        """Which control points the view draws (:data:`POINTS_SHOWN`).

        ``"all"``, ``"near"`` (those within two index steps of the selection), ``"hull"`` (the lattice's
        boundary) or ``"auto"`` (the default: all of them up to 1000 control points, the hull of a denser lattice).

        Parameters
        ----------
        which : {"auto", "all", "near", "hull"}
            The control points to draw.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.show_points("hull")
        >>> session.points_shown
        'hull'
        """
        if which not in POINTS_SHOWN:
            raise ValueError(f"points shown must be one of {POINTS_SHOWN}, got {which!r}")
        self.points_shown = which
        self.notify("display", None, "points")

    # ------------------------------------------------------------------ binding the model
    def replace_mesh(self, mesh: Any, deformer: Deformer, *, label: str, new_document: bool) -> None:
        """Use another mesh with ``deformer`` (its lattice bound to ``mesh.points``).

        The deformer is made by :class:`~.files.SessionFiles`, possibly in a worker thread. A new
        document (a loaded mesh) clears the history; a decimation keeps it and the mesh it started
        from. Emits ``"mesh"``, then ``"lattice"`` when the lattice is another one.

        Parameters
        ----------
        mesh : mesh object
            The new rest surface.
        deformer : Deformer
            The FFD to use, bound to ``mesh.points``.
        label : str
            The command's name for the changes.
        new_document : bool
            Whether the mesh is a new document (clears the history and pins) rather than a decimation.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> session = EditingSession(sphere, mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> cube = pv.Cube().triangulate()
        >>> changes = []
        >>> _ = session.subscribe(changes.append)
        >>> session.replace_mesh(cube, session.ffd.bind(cube.points), label="load mesh", new_document=True)
        >>> [change.kind for change in changes], session.mesh.n_points
        (['mesh'], 8)
        """
        self.paint.end()  # a brush stroke under way is a step of the mesh it was painted on
        new_lattice, selected = deformer.ffd is not self.ffd, self.selected
        weights_cleared = new_lattice and self.ffd.weights is not None and deformer.ffd.weights is None
        if new_document:
            self.history.clear()
            self.surface.drop_pins()  # pins are points of the old mesh
        self._bind_mesh(mesh, deformer, source=None if new_document else self.source_mesh)
        if new_document:
            self.script.new_document()  # (the caller says where the mesh came from: script.origin)
        if not new_lattice:
            self.selected = selected
        self.notify("mesh", None, label)
        if new_lattice:
            self.notify("lattice", None, label)
        if weights_cleared:
            self.info(WEIGHTS_CLEARED)

    def _dropped(self, step: Any) -> None:
        """A step fell off the history's oldest end: the script starts after it."""
        self.script.fold(step)

    def _bind_mesh(self, mesh: Any, deformer: Deformer, source: Any = None) -> None:
        """Use ``mesh`` (rest shape) with ``deformer`` (its FFD bound to ``mesh.points``)."""
        self.mesh = mesh
        self.source_mesh = mesh if source is None else source  # what decimation starts from
        self.rest_points = np.asarray(mesh.points, dtype=np.float64)
        self._bind_lattice(deformer, None)

    def _bind_lattice(self, deformer: Deformer, label: str | None) -> None:
        """Use ``deformer`` (a lattice bound to the mesh's points); emits ``"lattice"`` unless ``label`` is None."""
        self.deformer = deformer
        self._rest_control = deformer.ffd.lattice.control_points().reshape(-1, 3)
        self._committed = deformer.ffd.lattice.offsets.copy()
        self.deformed_points = deformer.current()  # bound in a worker thread: evaluated there already
        self.selected = None
        self._dragged = None
        if label is not None:
            self.notify("lattice", None, label)

    def __repr__(self) -> str:
        return (
            f"EditingSession(mesh={self.mesh.n_points} points, lattice={'x'.join(map(str, self.lattice.shape))}, "
            f"basis={self.basis!r}, history={len(self.history)})"
        )
