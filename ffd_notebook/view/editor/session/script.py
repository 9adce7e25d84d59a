"""Every edit as code: Python that rebuilds an editing session's lattice from what the session started with.

A teacher drags the lattice; a student asks "how do I do that from code?". :meth:`SessionScript.to_code`
(``editor.to_code()``) answers with a script in the package's public API: the mesh read again (the file the
editor opened, the photo, the bundled sample; or a variable ``mesh`` when the editor was given an object),
the lattice's creation, one readable statement per step of the undo history as it stands (one drag of one
sphere is one step; undone steps are absent), the deformed mesh and the saves the user made. It defines
``mesh``, ``lattice``, ``ffd`` and ``deformed``. :meth:`SessionScript.recent` gives the last few statements,
for the panels' running log (as Blender's Info editor shows each action as the Python line that does it).

Exact, not approximate: run in a fresh interpreter on the same mesh, the script gives the session's offsets
bit for bit, and so the same FFD and deformed points. Floats are written with ``repr`` (which reads back to
the same double); a statement that computes (``+=`` of one displacement over many control points,
``Lattice.around``, ``ffd.fit_points`` for a drag of the mesh itself, the weight brush's strokes) is used
only when running it here gives the recorded values bit for bit; otherwise the step is written as the values
it set. The script replays the history from the state it started from: each step is checked against the
state before it, so a statement is what the step did whatever came before.

What the undo history does not hold is said too: a lattice file loaded (read again by the script), the
mesh decimated (the script decimates it likewise), and anything changed outside the history (a placement
edited in place, weights cleared by a decimation) ends the script with the lattice as it is, written out
(:data:`OUTSIDE_HISTORY` marks it).

NumPy and the model only, as the rest of the session.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from ....ffd.deform import FFD
from .history import HistoryStep, LatticeSwap, OffsetEdit
from .lattices import copy_ffd, fitted_lattice

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = [
    "OUTSIDE_HISTORY",
    "BrushStroke",
    "LoadedFile",
    "MeshOrigin",
    "SessionScript",
    "Statement",
    "SurfaceFit",
]

#: the comment before the statements that set what changed outside the undo history (the script then writes
#: the lattice out as it is)
OUTSIDE_HISTORY = "changed outside the undo history"
#: saves the script repeats (the newest)
MAX_SAVES = 20
#: mesh files whose surface is the mesh as read (others, volume meshes, give their outer surface)
_SURFACE_SUFFIXES = (".obj", ".ply", ".stl", ".vtp")
#: what the script's comments call the labels of the session's commands
_LABELS = {
    "drag": "drag a control point",
    "move": "a typed displacement",
    "reset": "reset",
    "code": "an edit from code (editor.update())",
    "surface drag": "drag the mesh",
    "shape": "rebuild",
    "basis": "basis",
    "interpolation": "interpolation",
    "strength": "strength",
    "weights": "vertex weights",
    "clear weights": "clear the vertex weights",
    "paint weights": "paint vertex weights",
    "load lattice": "load a lattice file",
    "lattice": "a new lattice",
}


# ---------------------------------------------------------------------- what the history records for the script
@dataclass(frozen=True)
class MeshOrigin:
    """Where the session's mesh came from, so the script can make it again.

    Attributes
    ----------
    kind : str
        ``"sample"`` (the bundled face, :func:`ffd_notebook.datasets.sample_mesh`), ``"file"`` (a mesh file,
        read again), ``"photo"`` (the face in a photo file), ``"given"`` (an object the editor was given: the
        script's variable ``mesh``) or ``"image"`` (the box of an image edited alone: also ``mesh``).
    path : str
        The file of ``"file"`` and ``"photo"`` (as the user named it: relative to where the script runs).
    surface : bool
        ``"given"``: whether the object was not a surface mesh (the editor took its outer surface).
    """

    kind: str = "given"
    path: str = ""
    surface: bool = False


@dataclass(frozen=True)
class SurfaceFit:
    """How a drag of the mesh itself moved the control points: :meth:`ffd_notebook.FFD.fit_points` of ``point``
    (a rest position) onto ``target``, the ``pins`` (rest positions) held where they were."""

    point: NDArray[np.float64]
    target: NDArray[np.float64]
    pins: NDArray[np.float64]


@dataclass(frozen=True)
class BrushStroke:
    """A stroke of the weight brush: each dab ``(centre, amount, radius)`` raised the weights near ``centre``."""

    dabs: tuple[tuple[NDArray[np.float64], float, float], ...]


@dataclass(frozen=True)
class LoadedFile:
    """A deformation file loaded onto the lattice: read again by the script.

    ``placement`` is the session's lattice source (``"ffd-placed"``, ``"ffd-min"``, ``"file"``); ``kind`` what the
    file gave: ``"ffd"`` (the FFD it holds, read again by :func:`ffd_notebook.load_deformation`), ``"field"`` (a
    displacement field, with a lattice of shape ``fitted`` fitted to it: :func:`ffd_notebook.fit_lattice`) or
    ``"other"`` (an affine transform, a chain of transforms, a deformation given as an object: the script writes
    the lattice it gave).
    """

    path: str
    placement: str
    kind: str = "ffd"
    fitted: tuple[int, int, int] | None = None


@dataclass
class Statement:
    """One step as code: a comment saying what the user did, the lines that do it, the imports they need."""

    comment: str
    lines: list[str]
    imports: set[str] = field(default_factory=set)

    @property
    def text(self) -> str:
        """The comment and the lines, as the script shows them."""
        return "\n".join([f"# {self.comment}", *self.lines])


# ---------------------------------------------------------------------- writing values
def _num(value: Any) -> str:
    """A float as Python reads it back to the same double (``repr``), an int as an int."""
    return repr(int(value)) if isinstance(value, (int, np.integer)) else repr(float(value))


def _vec(values: Iterable[Any]) -> str:
    return "(" + ", ".join(_num(v) for v in values) + ")"


def _wrapped(items: Sequence[str], indent: str = "    ", width: int = 110) -> str:
    """``[a, b, ...]``, on one line if it fits, else one line per item (a long list, readable)."""
    flat = "[" + ", ".join(items) + "]"
    if len(flat) + len(indent) <= width:
        return flat
    return "[\n" + "".join(f"{indent}{item},\n" for item in items) + "]"


def _same_bits(a: Any, b: Any) -> bool:
    """Whether two float arrays hold the same doubles, bit for bit (-0.0 is not 0.0)."""
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def _box_index(ijk: NDArray[np.int64], shape: tuple[int, ...]) -> str | None:
    """``":, 3, :"``, ``"1:3, 0, 2:"``...: the index of a box of control points if ``ijk`` is exactly one, else None."""
    text = []
    for axis, n in enumerate(shape):
        values = np.unique(ijk[:, axis])
        lo, hi = int(values[0]), int(values[-1])
        if hi - lo + 1 != len(values):
            return None
        if lo == hi and n > 1:
            text.append(str(lo))
        else:
            text.append(f"{lo if lo else ''}:{hi + 1 if hi + 1 < n else ''}")
    if len(ijk) != np.prod([len(np.unique(ijk[:, a])) for a in range(3)]) or len(np.unique(ijk, axis=0)) != len(ijk):
        return None
    return ", ".join(text)


def _rows_assignment(ijk: NDArray[np.int64], values: NDArray[np.float64], shape: tuple[int, ...]) -> list[str]:
    """``lattice.offsets[...] = ...`` setting each control point of ``ijk`` to its row of ``values`` (exact)."""
    if len(ijk) == 1:
        return [f"lattice.offsets[{', '.join(str(int(v)) for v in ijk[0])}] = {_vec(values[0])}"]
    box = _box_index(ijk, shape)
    if box is not None and all(_same_bits(row, values[0]) for row in values):
        return [f"lattice.offsets[{box}] = {_vec(values[0])}"]
    # a few boxes, each set to one value (planes moved apart, say): a line each
    _, group = np.unique(np.ascontiguousarray(values).view(np.uint64).reshape(len(values), 3), axis=0,
                         return_inverse=True)  # fmt: skip
    boxes = [_box_index(ijk[group.ravel() == g], shape) for g in range(int(group.max()) + 1)]
    if len(boxes) <= 4 and all(b is not None for b in boxes):
        first = [int(np.flatnonzero(group.ravel() == g)[0]) for g in range(len(boxes))]  # (in the rows' order)
        order = sorted(range(len(boxes)), key=first.__getitem__)
        return [f"lattice.offsets[{boxes[g]}] = {_vec(values[first[g]])}" for g in order]
    axes = ", ".join("[" + ", ".join(str(int(v)) for v in ijk[:, a]) + "]" for a in range(3))
    return [f"lattice.offsets[{axes}] = " + _wrapped([_vec(row) for row in values])]


def _common_delta(before: NDArray[np.float64], after: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """One displacement ``d`` with ``before + d == after`` bit for bit in every row, the shortest to write; None if
    there is none. ``after - before`` differs between rows in the last bits when ``after`` was ``before + d``
    rounded: the ``d`` the user added (e.g. 0.25) is found among the short decimals near them."""
    found = []
    for c in range(3):
        column, wanted = before[:, c], after[:, c]
        near = float(np.median(wanted - column))
        candidates = [float(f"{near:.{k}g}") for k in range(1, 18)] + np.unique(wanted - column).tolist()
        for d in candidates:
            if _same_bits(column + d, wanted):
                found.append(d)
                break
        else:
            return None
    return np.array(found)


def _same_key(a: Sequence[Any], b: Sequence[Any]) -> bool:
    """Whether two ``(step, after, how, mesh)`` keys are the same objects (and the same mesh)."""
    return a[0] is b[0] and a[1] is b[1] and a[2] is b[2] and a[3] == b[3]


def _moved_rows(offsets: NDArray[np.float64]) -> NDArray[np.int64]:
    """Control points whose offset is not +0.0 in every component (a -0.0 counts: it is another double)."""
    return np.argwhere(np.any((offsets != 0) | np.signbit(offsets), axis=-1))


# ---------------------------------------------------------------------- the lattice and the FFD
def _same_placement(la: Any, lb: Any) -> bool:
    """Whether two lattices rest at the same places (shape, spacing, origin, axes, border), bit for bit."""
    return (la.shape == lb.shape and la.border == lb.border and _same_bits(la.spacing, lb.spacing)
            and _same_bits(la.origin, lb.origin) and _same_bits(la.rotation, lb.rotation))  # fmt: skip


def _same_geometry(a: FFD, b: FFD) -> bool:
    """Whether two FFDs' lattices rest at the same places."""
    return _same_placement(a.lattice, b.lattice)


def _weights_of(ffd: FFD) -> NDArray[np.float64] | None:
    w = ffd.weights
    return None if w is None or isinstance(w, str) else np.asarray(w, dtype=np.float64)


def _same_weights(a: FFD, b: FFD) -> bool:
    wa, wb = _weights_of(a), _weights_of(b)
    if wa is None or wb is None:
        return wa is None and wb is None and a.weights == b.weights
    return _same_bits(wa, wb)


def _same_options(a: FFD, b: FFD) -> bool:
    """Whether two FFDs deform alike given the same lattice (basis, border, affine, rules, strength)."""
    return (a.basis == b.basis and a.border == b.border and _same_bits(a.affine, b.affine)
            and a.only_inside == b.only_inside and a.outside == b.outside and a.strength == b.strength)  # fmt: skip


def _lattice_lines(ffd: FFD, points: NDArray[np.float64] | None) -> list[str]:
    """``lattice = ...``: :meth:`~ffd_notebook.Lattice.around` the mesh where it gives exactly this lattice's
    placement (what the editor fits), else the placement written out; then the offsets that are not zero."""
    lat = ffd.lattice
    shape = _vec(lat.shape)
    try:  # (points None: the mesh is not known here)
        fitted = points is not None and _same_placement(fitted_lattice(points, lat.shape, ffd.basis), lat)
    except ValueError:  # (no lattice of that shape fits around the mesh for this basis)
        fitted = False
    if fitted:
        options = ', border="clamp"' if ffd.basis != "bernstein" else ', basis="bernstein"'
        lines = [f"lattice = fn.Lattice.around(mesh, {shape}{options})"]
    else:
        extra = "" if np.array_equal(lat.rotation, np.eye(3)) else f", rotation={_matrix(lat.rotation)}"
        border = "" if lat.border == "zero" else f', border="{lat.border}"'
        lines = [f"lattice = fn.Lattice({shape}, spacing={_vec(lat.spacing)}, origin={_vec(lat.origin)}"
                 f"{extra}{border})"]  # fmt: skip
    moved = _moved_rows(lat.offsets)
    if len(moved):
        lines += _rows_assignment(moved, lat.offsets[tuple(moved.T)], lat.shape)
    return lines


def _matrix(m: NDArray[np.float64]) -> str:
    return "[" + ", ".join(_vec(row) for row in np.asarray(m)) + "]"


def _basis_text(basis: Any) -> str:
    return f'"{basis}"' if isinstance(basis, str) else "(" + ", ".join(f'"{k}"' for k in basis) + ")"


def _ffd_line(lattice: str, ffd: FFD, weights: str | None) -> tuple[str, set[str]]:
    """``ffd = fn.FFD(<lattice>, ...)`` with ``ffd``'s options that are not the defaults (``weights``: their
    expression, None for none)."""
    parts, imports = [lattice], set()
    if ffd.basis != "bspline":
        parts.append(_basis_text(ffd.basis))
    if ffd.border != ffd.lattice.border:
        parts.append(f'border="{ffd.border}"')
    if not np.array_equal(ffd.affine, np.eye(4)):
        parts.append(f"affine=np.array({_matrix(ffd.affine)})")
        imports.add("numpy")
    if ffd.only_inside:  # (True, or elastix's "half-open")
        parts.append(f"only_inside={ffd.only_inside!r}")
    if ffd.outside:
        parts.append("outside=True")
    if ffd.strength != 1.0:
        parts.append(f"strength={_num(ffd.strength)}")
    if weights is not None:
        parts.append(f"weights={weights}")
    return f"ffd = fn.FFD({', '.join(parts)})", imports


def _weights_literal(weights: NDArray[np.float64] | None) -> tuple[list[str], set[str]]:
    """``weights = ...`` (exact): the most common of 0 and 1 everywhere, the other values at their vertices."""
    if weights is None:
        return ["weights = None"], set()
    n = len(weights)
    base = 1.0 if np.count_nonzero(weights == 1.0) > np.count_nonzero(weights == 0.0) else 0.0
    other = np.flatnonzero(~((weights == base) & ~np.signbit(weights)))
    lines = [f"weights = np.{'ones' if base else 'zeros'}({n})"]
    if len(other):
        ids = _wrapped([str(int(i)) for i in other])
        lines.append(f"weights[{ids}] = " + _wrapped([_num(v) for v in weights[other]]))
    return lines, {"numpy"}


# ---------------------------------------------------------------------- the script
class SessionScript:
    """The code of one :class:`~.session.EditingSession` (``session.script``; see the module docstring).

    The session tells it where the mesh came from (:attr:`origin`, set by the editor and the file commands),
    each step dropped off the history's oldest end (folded into the state the script starts from), a new
    document (:meth:`new_document`), a decimation (:attr:`reduction`) and the saves (:meth:`saved`).

    Parameters
    ----------
    session : EditingSession
        The session it writes (which makes its own: ``session.script``).

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> from ffd_notebook.view.editor.session import EditingSession
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    >>> session.move_control_point((1, 2, 3), (0.0, 0.1, 0.0))
    >>> print(session.script.recent()[-1])
    # a typed displacement
    lattice.offsets[1, 2, 3] = (0.0, 0.1, 0.0)
    """

    def __init__(self, session: EditingSession) -> None:
        self.session = session
        self.origin = MeshOrigin()
        self._saves: list[tuple[Any, str, str]] = []  # (the last step done then, or None; what; path), in order
        #: (the steps done then, the reduction, whether it dropped painted weights)
        self._decimations: list[tuple[tuple[Any, ...], float, bool]] = []
        self._start = copy_ffd(session.ffd)  # the state the kept history starts from
        self._cache: dict[int, tuple[HistoryStep, Any, Any, Any, Statement]] = {}
        self._last: tuple[Any, FFD, list[Statement]] | None = None  # the history's steps, the start, their code

    # ------------------------------------------------------------------ what the session tells it
    def new_document(self, origin: MeshOrigin | None = None) -> None:
        """A new mesh with a new history: the script starts again from the session's FFD now."""
        self.origin = MeshOrigin() if origin is None else origin
        self._saves, self._decimations = [], []
        self._cache.clear()
        self._start = copy_ffd(self.session.ffd)

    def fold(self, step: HistoryStep) -> None:
        """``step`` fell off the history's oldest end: the script starts from the state after it (saves made
        before it are before the script too)."""
        self._start = self._advance(self._start, step)
        self._cache.pop(id(step), None)
        self._saves = [save for save in self._saves if save[0] is not None and save[0] is not step]
        self._decimations = [(tuple(s for s in done if s is not step), r, w) for done, r, w in self._decimations]

    def saved(self, what: str, path: str | os.PathLike[str]) -> None:
        """The user saved ``what`` (``"lattice"`` or ``"mesh"``) to ``path``: the script saves it too, after the
        step the session had done last (what the file holds)."""
        steps = self.session.history.steps
        self._saves = [*self._saves[-(MAX_SAVES - 1) :], (steps[-1] if steps else None, what, os.fspath(path))]

    def decimated(self, reduction: float, *, dropped_weights: bool = False) -> None:
        """The shown mesh was decimated by ``reduction`` (0: back to the mesh as loaded), after the last step done:
        the script decimates its mesh there too (and drops painted weights where the session did)."""
        event = (self.session.history.steps, float(reduction), bool(dropped_weights))
        self._decimations = [*self._decimations[-(MAX_SAVES - 1) :], event]

    # ------------------------------------------------------------------ the code
    def _decimation_anchors(self) -> list[tuple[Any, tuple[float, bool]]]:
        """Each decimation after the last step it shares with the history as it stands (steps undone since and
        done again came after it), the last one again at the end if others would follow it (the shown mesh).
        The event is ``(reduction, drop the weights)``: weights are dropped only where it happened (moved, it
        would drop weights the history brought back; the end of the script sets what differs)."""
        done = self.session.history.steps
        out: list[tuple[Any, tuple[float, bool]]] = []
        for then, reduction, dropped in self._decimations:
            shared = 0
            while shared < min(len(then), len(done)) and then[shared] is done[shared]:
                shared += 1
            out.append((done[shared - 1] if shared else None, (reduction, dropped and shared == len(then))))
        if out:
            position = {id(step): k for k, step in enumerate(done)}
            last = max(range(len(out)), key=lambda k: (-1 if out[k][0] is None else position[id(out[k][0])], k))
            if last != len(out) - 1:
                out.append((done[-1] if done else None, (out[-1][1][0], False)))
        return out

    def _anchored(self, events: list[tuple[Any, Any]]) -> dict[int | None, list[Any]]:
        """Events (``(step or None, event)``) by the step they follow: ``id(step)``, or None for the start (also
        those whose step has been undone since: they came after every step still done before it)."""
        done = {id(step) for step in self.session.history.steps}
        out: dict[int | None, list[Any]] = {}
        for at, event in events:
            out.setdefault(id(at) if at is not None and id(at) in done else None, []).append(event)
        return out

    def _meshes(self) -> tuple[list[int], list[NDArray[np.float64] | None], list[list[tuple[float, bool]]]]:
        """For the start and after each step: how many decimations the script has made there (which mesh it
        deforms), that mesh's points (None where they are not known here: nothing is computed from them), and the
        decimations made there (``(reduction, drop the weights)``)."""
        steps = self.session.history.steps
        anchors = self._decimation_anchors()
        by_step = self._anchored(anchors)
        loaded = np.asarray(self.session.source_mesh.points, dtype=np.float64)
        tags: list[int] = []
        points: list[NDArray[np.float64] | None] = []
        events: list[list[tuple[float, bool]]] = []
        n, now = 0, cast("NDArray[np.float64] | None", loaded)
        for anchor in [None, *(id(step) for step in steps)]:
            here = by_step.get(anchor, [])
            for reduction, _ in here:
                n += 1
                last = n == len(anchors)
                now = loaded if reduction == 0.0 else np.asarray(self.session.rest_points) if last else None
            tags.append(n)
            points.append(now)
            events.append(here)
        return tags, points, events

    @staticmethod
    def _after_events(state: FFD, events: list[tuple[float, bool]]) -> None:
        """The replayed state after decimations: painted weights dropped where the session dropped them."""
        if any(dropped for _, dropped in events):
            state.weights = None

    def statements(self) -> list[Statement]:
        """One :class:`Statement` per step of the undo history as it stands, oldest first."""
        steps = self.session.history.steps
        tags, meshes, events = self._meshes()  # (step k's statement follows the decimations at position k)
        key = [(step, step.after, step.how, tag) for step, tag in zip(steps, tags[:-1], strict=True)]
        last = self._last
        if last is not None and last[1] is self._start and len(last[0]) == len(key):
            if all(_same_key(was, now) for was, now in zip(last[0], key, strict=True)):
                return list(last[2])  # (the panels ask at every sync: nothing changed since)
        state = copy_ffd(self._start)
        self._after_events(state, events[0])
        out, live = [], set()
        for k, ((step, _, _, tag), points) in enumerate(zip(key, meshes[:-1], strict=True)):
            live.add(id(step))
            cached = self._cache.get(id(step))
            if cached is not None and _same_key(cached[:4], (step, step.after, step.how, tag)):
                statement = cached[4]
            else:
                statement = self._statement(step, state, points)
                self._cache[id(step)] = (step, step.after, step.how, tag, statement)
            out.append(statement)
            state = self._advance(state, step, in_place=True)
            self._after_events(state, events[k + 1])
        for gone in set(self._cache) - live:
            del self._cache[gone]
        self._last = (key, self._start, out)
        return list(out)

    def recent(self, n: int = 5) -> list[str]:
        """The last ``n`` steps as code (a comment and its lines each), oldest first: the panels' running log."""
        return [s.text for s in self.statements()[-n:]] if n > 0 else []

    def to_code(self) -> str:
        """Python that rebuilds the session's lattice and deformed mesh (see the module docstring).

        Returns
        -------
        str
            A script defining ``mesh``, ``lattice``, ``ffd`` and ``deformed``.
        """
        steps = self.statements()
        done = self.session.history.steps
        start, start_imports = self._start_lines()
        end = self._outside_history(steps)
        imports = set(start_imports).union(*(s.imports for s in steps), end.imports if end else set())
        if self._decimations:
            imports.add("ffd_notebook.meshing:decimate_keeping_colors")
        n = len(steps)
        body = [f"# What the editor did, as code ({n} step{'s' if n != 1 else ''} of its undo history; "
                "editor.to_code()).", *self._import_lines(imports), "", *start]  # fmt: skip
        decimations = self._anchored(self._decimation_anchors())
        saves = self._anchored([(at, (what, path)) for at, what, path in self._saves])
        state = copy_ffd(self._start)
        body += self._event_lines(decimations.get(None, []), saves.get(None, []), state)
        for step, statement in zip(done, steps, strict=True):
            state = self._advance(state, step, in_place=True)
            body += ["", statement.text, *self._event_lines(decimations.get(id(step), []), saves.get(id(step), []),
                                                            state)]  # fmt: skip
        if end is not None:
            body += ["", end.text]
        body += ["", "# the deformed mesh", "deformed = mesh.copy()", "deformed.points = ffd.deform(mesh.points)"]
        undone = [(what, path) for at, what, path in self._saves
                  if at is not None and not any(at is step for step in done)]  # fmt: skip
        if undone:
            body += ["", *(f"# ({what} saved to {path!r} after steps since undone)" for what, path in undone)]
        return "\n".join(body) + "\n"

    @staticmethod
    def _event_lines(decimations: list[tuple[float, bool]], saves: list[tuple[str, str]], state: FFD) -> list[str]:
        """What the user did after a step besides undoable edits: decimations of the mesh, then saves."""
        lines = []
        for reduction, dropped in decimations:
            if reduction == 0.0:
                lines.append("mesh = loaded.copy()  # the mesh as loaded again (the editor's decimation undone)")
            else:
                lines.append(f"mesh = decimate_keeping_colors(loaded, {_num(reduction)})  # decimated in the editor")
            if dropped and _weights_of(state) is not None:  # painted on the vertices that went
                lines.append("ffd.weights = None  # the decimation dropped the painted weights")
                state.weights = None
        for what, path in saves:
            if what == "lattice":
                lines.append(f"fn.save_deformation({path!r}, ffd)  # saved in the editor")
            else:
                lines += ["saved = mesh.copy()", "saved.points = ffd.deform(mesh.points)",
                          f"fn.write_mesh({path!r}, saved)  # saved in the editor"]  # fmt: skip
        return lines

    # ------------------------------------------------------------------ pieces
    def _points(self) -> NDArray[np.float64]:
        """The points of the mesh the script deforms (the session's mesh: decimated likewise)."""
        return np.asarray(self.session.rest_points, dtype=np.float64)

    @staticmethod
    def _import_lines(imports: set[str]) -> list[str]:
        lines = ["import numpy as np", ""] if "numpy" in imports else []
        lines.append("import ffd_notebook as fn")
        for module, name in sorted(i.split(":") for i in imports if ":" in i):
            lines.append(f"from {module} import {name}")
        return lines

    def _start_lines(self) -> tuple[list[str], set[str]]:
        """The mesh, its decimation, and the lattice and FFD the kept history starts from."""
        origin, imports = self.origin, set()
        if origin.kind == "sample":
            lines = ["mesh = sample_mesh()  # the bundled face scan, the editor's default"]
            imports.add("ffd_notebook.datasets:sample_mesh")
        elif origin.kind == "file" and PurePath(origin.path).suffix.lower() in _SURFACE_SUFFIXES:
            lines = [f"mesh = fn.read_mesh({origin.path!r})"]
        elif origin.kind == "file":
            lines = [f"mesh = as_surface(fn.read_mesh({origin.path!r}))  # its outer surface, as the editor shows"]
            imports.add("ffd_notebook.meshing:as_surface")
        elif origin.kind == "photo":
            lines = [f"mesh = fn.face_from_photo({origin.path!r})"]
        else:
            what = "the mesh the editor was given" if origin.kind == "given" else "the box of the image (editor.mesh)"
            lines = [f"# mesh: {what}, {self.session.source_mesh.n_points} points"]
            if origin.surface:
                lines.append("mesh = as_surface(mesh)  # its outer surface, as the editor shows")
                imports.add("ffd_notebook.meshing:as_surface")
        if self._decimations:
            lines.append("loaded = mesh")
        lines += _lattice_lines(self._start, np.asarray(self.session.source_mesh.points, dtype=np.float64))
        line, more = _ffd_line("lattice", self._start, None)
        weights = _weights_of(self._start)
        if weights is not None:
            literal, _ = _weights_literal(weights)
            lines += literal
            line, more = _ffd_line("lattice", self._start, "weights")
            more.add("numpy")
        return [*lines, line], imports | more

    def _outside_history(self, steps: list[Statement]) -> Statement | None:
        """Statements that set what the history does not explain (the state replayed differs from the session's)."""
        _, _, events = self._meshes()
        state = copy_ffd(self._start)
        self._after_events(state, events[0])
        for k, step in enumerate(self.session.history.steps):
            state = self._advance(state, step, in_place=True)
            self._after_events(state, events[k + 1])
        now = self.session.ffd
        if _same_geometry(state, now) and _same_options(state, now) and _same_weights(state, now):
            if _same_bits(state.lattice.offsets, now.lattice.offsets):
                return None
            moved = np.argwhere(np.any(state.lattice.offsets.view(np.uint64) != now.lattice.offsets.view(np.uint64),
                                       axis=-1))  # fmt: skip
            lines = _rows_assignment(moved, now.lattice.offsets[tuple(moved.T)], now.lattice.shape)
            return Statement(f"offsets {OUTSIDE_HISTORY}", lines)
        weights = _weights_of(now)
        lines, imports = _weights_literal(weights) if weights is not None else ([], set())
        lines += _lattice_lines(now, self._points())
        line, more = _ffd_line("lattice", now, "weights" if weights is not None else None)
        return Statement(f"the lattice as it is now ({OUTSIDE_HISTORY})", [*lines, line], imports | more)

    @staticmethod
    def _advance(state: FFD, step: HistoryStep, in_place: bool = False) -> FFD:
        """The state after ``step``."""
        if isinstance(step, LatticeSwap):
            return copy_ffd(step.after[0])
        state = state if in_place else copy_ffd(state)
        state.lattice.offsets[tuple(step.ijk.T)] = step.after
        return state

    def _statement(self, step: HistoryStep, state: FFD, points: NDArray[np.float64] | None) -> Statement:
        comment = _LABELS.get(step.label, step.label)
        if isinstance(step, OffsetEdit):
            return self._offsets_statement(step, state, comment)
        return self._swap_statement(step, state, points, comment)

    def _offsets_statement(self, step: OffsetEdit, state: FFD, comment: str) -> Statement:
        lat = state.lattice
        ijk, after = step.ijk, step.after
        idx = tuple(ijk.T)
        expected = lat.offsets.copy()
        expected[idx] = after
        if isinstance(step.how, SurfaceFit):
            fit = step.how
            trial = copy_ffd(state)
            pins = fit.pins if len(fit.pins) else None
            trial.fit_points(fit.point[None, :], fit.target[None, :], pinned=pins)
            if _same_bits(trial.lattice.offsets, expected):
                pinned = "" if pins is None else ", pinned=" + _wrapped([_vec(p) for p in fit.pins])
                held = f", {len(fit.pins)} pin{'s' if len(fit.pins) != 1 else ''} held" if pins is not None else ""
                return Statement(f"drag the mesh: its point {_vec(fit.point)} to {_vec(fit.target)}{held}",
                                 [f"ffd.fit_points([{_vec(fit.point)}], [{_vec(fit.target)}]{pinned})"])  # fmt: skip
        if len(ijk) > 1 and not _moved_rows(expected).size and step.label == "reset":
            return Statement(comment + " all", ["lattice.reset()"])
        if len(ijk) > 1:
            box = _box_index(ijk, lat.shape)
            same_value = all(_same_bits(row, after[0]) for row in after)  # then "= value" says it plainly
            delta = None if box is None or same_value else _common_delta(lat.offsets[idx], after)
            if delta is not None:
                return Statement(comment, [f"lattice.offsets[{box}] += {_vec(delta)}"])
        return Statement(comment, _rows_assignment(ijk, after, lat.shape))

    def _swap_statement(
        self, step: LatticeSwap, state: FFD, points: NDArray[np.float64] | None, comment: str
    ) -> Statement:
        after: FFD = step.after[0]
        how = step.how
        if isinstance(how, LoadedFile) and how.kind != "other":
            return self._file_statement(how, after, comment)
        if isinstance(how, LoadedFile):
            comment = f"{comment}: {how.path or 'a deformation given from code'} (the lattice it gave, written out)"
        if isinstance(how, BrushStroke) and _same_geometry(state, after) and _same_options(state, after):
            stroke = self._stroke_statement(how, state, after, points)
            if stroke is not None:
                return stroke
        if _same_geometry(state, after) and _same_bits(state.lattice.offsets, after.lattice.offsets):
            if _same_weights(state, after):
                if _same_options(state, copy_ffd(after, strength=state.strength)):  # the strength alone
                    return Statement(comment, [f"ffd.strength = {_num(after.strength)}"])
                line, needs = _ffd_line("lattice", after, "ffd.weights" if _weights_of(after) is not None else None)
                return Statement(comment, [line], needs)
            if _same_options(state, after):  # the weights alone
                if _weights_of(after) is None:
                    return Statement(comment, ["ffd.weights = None  # every vertex follows the lattice fully"])
                literal, needs = _weights_literal(_weights_of(after))
                return Statement(comment, [*literal, "ffd.weights = weights"], needs)
        # a new lattice (a size, a basis, a lattice given): its placement, then the FFD with the options it has
        shape = "x".join(map(str, after.lattice.shape))
        lines = _lattice_lines(after, points)
        if step.label in ("shape", "basis"):
            comment = f"{comment}: a {shape} lattice around the mesh" + (
                f" ({after.basis if isinstance(after.basis, str) else ' / '.join(after.basis)})"
                if step.label == "basis" else "")  # fmt: skip
        weights = _weights_of(after)
        imports: set[str] = set()
        if weights is None:
            line, more = _ffd_line("lattice", after, None)
        elif _same_weights(state, after):
            line, more = _ffd_line("lattice", after, "ffd.weights")
        else:
            literal, imports = _weights_literal(weights)
            lines = literal + lines
            line, more = _ffd_line("lattice", after, "weights")
        return Statement(comment, [*lines, line], imports | more)

    @staticmethod
    def _file_statement(how: LoadedFile, after: FFD, comment: str) -> Statement:
        if how.fitted is not None:
            lines = [f"ffd = fn.fit_lattice(fn.load_deformation({how.path!r}), {_vec(how.fitted)})"]
            comment = f"{comment}: a displacement field, a {'x'.join(map(str, how.fitted))} lattice fitted to it"
        else:
            lines = [f"ffd = fn.load_deformation({how.path!r})"]
        imports: set[str] = set()
        if how.placement == "ffd-min":  # a .ffd file without placement: at the mesh's minimum corner
            line, imports = _ffd_line("fn.place_at_mesh_minimum(ffd.lattice, mesh)", after, None)
            lines.append(line + "  # the file has no placement: at the mesh's minimum corner")
        return Statement(comment, [*lines, "lattice = ffd.lattice"], imports)

    @staticmethod
    def _stroke_statement(
        how: BrushStroke, state: FFD, after: FFD, points: NDArray[np.float64] | None
    ) -> Statement | None:
        """The brush's dabs as a loop, if running it gives the stroke's weights bit for bit (else None)."""
        target = _weights_of(after)
        start = _weights_of(state)
        if points is None or target is None or len(target) != len(points) or not how.dabs or (start is not None and
                                                                            len(start) != len(points)):  # fmt: skip
            return None  # (painted on a mesh that has been decimated since)
        weights = np.zeros(len(points)) if start is None else start.copy()
        for centre, amount, radius in how.dabs:  # as the lines below do it (the brush's own steps, in order)
            d = np.linalg.norm(points - centre, axis=1)
            near = np.clip(1.0 - (d / radius) ** 2, 0.0, None)
            weights = np.clip(weights + amount * (near * near), 0.0, 1.0)
        if not _same_bits(weights, target):
            return None
        amounts = {a for _, a, _ in how.dabs}
        radii = {r for _, _, r in how.dabs}
        first = "weights = np.zeros(mesh.n_points)" if start is None else "weights = ffd.weights.copy()"
        n = len(how.dabs)
        if len(amounts) == 1 and len(radii) == 1:
            (amount,), (radius,) = amounts, radii
            loop = [f"for centre in {_wrapped([_vec(c) for c, _, _ in how.dabs], indent='    ')}:",
                    "    d = np.linalg.norm(mesh.points - np.array(centre), axis=1)",
                    f"    near = np.clip(1.0 - (d / {_num(radius)}) ** 2, 0.0, None)",
                    f"    weights = np.clip(weights + {_num(amount)} * (near * near), 0.0, 1.0)"]  # fmt: skip
            said = f"{n} dab{'s' if n != 1 else ''} of radius {radius:.3g}, {'raising' if amount > 0 else 'lowering'}"
        else:
            dabs = _wrapped([f"({_vec(c)}, {_num(a)}, {_num(r)})" for c, a, r in how.dabs])
            loop = [f"for centre, amount, radius in {dabs}:",
                    "    d = np.linalg.norm(mesh.points - np.array(centre), axis=1)",
                    "    near = np.clip(1.0 - (d / radius) ** 2, 0.0, None)",
                    "    weights = np.clip(weights + amount * (near * near), 0.0, 1.0)"]  # fmt: skip
            said = f"{n} dabs"
        comment = f"paint vertex weights: one brush stroke, {said}"
        return Statement(comment, [first, *loop, "ffd.weights = weights"], {"numpy"})
