"""The editor's panel controls, described once: both front-ends (Jupyter and the standalone app) render these.

A new control is one :class:`Control` entry in :data:`CONTROLS` (plus the session command it calls,
if that is new): the notebook panel (:mod:`ffd_notebook.view.editor.notebook.panel`) and the app's
page (:mod:`ffd_notebook.view.editor.app.layout`) build their widgets from it, :func:`session_state` is
the one mapping from the session to what the controls show, and :func:`run` the one way a control
acts: it calls an :class:`~.session.EditingSession` command by name (``"undo"``, ``"surface.set_mode"``,
``"files.load_deformation"``: attributes of the session).

Values typed in a panel arrive as they are (text fields send strings): each control's ``parse``
turns them into the command's arguments and names the field in its error (``"displacement x must
be a number, got 'abc'"``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from ....ffd.basis import BASES
from ....ffd.interpolation import LATTICE_INTERPOLATIONS
from .surface_drag import MODES

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = [
    "BASIS_CHOICES",
    "BRUSH_CHOICES",
    "CODE_STYLE",
    "CONTROLS",
    "FIELD_CHOICES",
    "INTERPOLATION_CHOICES",
    "MODE_CHOICES",
    "MOVIE_CHOICES",
    "N_LOG_STEPS",
    "N_MESSAGES",
    "POINTS_CHOICES",
    "RECORD_FPS",
    "RECORD_FRAMES",
    "SECTION_HINTS",
    "Control",
    "by_key",
    "number",
    "numbers",
    "run",
    "session_state",
]

N_MESSAGES = 5  # messages the panels list (newest first)
#: steps of the undo history the panels' running log shows as code (newest last)
N_LOG_STEPS = 3
#: what the panels say beside a section's name (the section of :attr:`Control.section`)
#: The style of a box of code (the log and the Code dialog) in both panels; ``{height}``: its greatest height.
CODE_STYLE = "margin: 0; max-height: {height}; overflow: auto; font-size: 11px; line-height: 1.3; white-space: pre;"

SECTION_HINTS = {"Control point": "drag a sphere, or pick one and type", "Teaching": "the edits as code, a movie"}
#: what an animation recorded from a panel has (frames in all; a second at 12 frames a second is 12)
RECORD_FRAMES, RECORD_FPS = 36, 12.0
#: the animation formats the app's "Record" offers (its file downloads to the browser)
MOVIE_CHOICES = (("gif", "GIF"), ("mp4", "MP4"))
BOTH = frozenset({"notebook", "app"})


def number(value: Any, what: str, kind: type = float) -> Any:
    """``value`` from a text field as ``kind``; a ValueError naming the field otherwise.

    Examples
    --------
    >>> number("2", "size", int), number(0.5, "reduction")
    (2, 0.5)
    >>> number("abc", "displacement x")
    Traceback (most recent call last):
    ...
    ValueError: displacement x must be a number, got 'abc'
    """
    try:
        parsed = float(value)
        if not np.isfinite(parsed) or (kind is int and parsed != int(parsed)):
            raise ValueError
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be {'a whole number' if kind is int else 'a number'}, got {value!r}") from None
    return kind(parsed)


def numbers(values: Sequence[Any], what: str, kind: type = float) -> tuple[Any, ...]:
    """Three numbers from three fields (``what`` names them, e.g. ``"lattice size"``: x, y, z).

    Examples
    --------
    >>> numbers(["4", "5", "6"], "lattice size", int)
    (4, 5, 6)
    """
    values = list(values) if isinstance(values, (list, tuple)) else [values]
    if len(values) != 3:
        raise ValueError(f"{what} needs three values, got {values!r}")
    return tuple(number(v, f"{what} {axis}", kind) for v, axis in zip(values, "xyz", strict=True))


def _as_is(values: Sequence[Any]) -> tuple[Any, ...]:
    return tuple(values)


@dataclass(frozen=True)
class Control:
    """One control of the editor's panels.

    Attributes
    ----------
    key : str
        Its name: the notebook panel's attribute (``f"{key}_button"`` for buttons), the app's
        element id ``f"ffd-{key}"`` with dashes (unless ``element_id``), its css class in Jupyter.
    kind : str
        ``"ints"``/``"floats"`` (three fields), ``"choice"``, ``"choices"`` (three choices, one per
        state key, from the same ``choices``), ``"switch"``, ``"text"``, ``"slider"``, ``"button"``,
        ``"upload"`` (a file from the browser, notebook only: the app has its own uploads),
        ``"label"`` (text from the state), ``"messages"``, ``"log"`` (lines of code from the state, in a box
        the user scrolls), ``"code"`` (a button that shows the session's code: to copy in the notebook, in a
        dialog that downloads it as a ``.py`` file in the app) or ``"record"`` (a button that records the
        deformation as an animation with a progress bar: into a file in the notebook, downloaded by the app).
    label : str
        What the panels show (a button's text; a label's template with ``{state_key}`` fields).
    section : str
        ``"Lattice"``, ``"Control point"``, ``"Files"``, ``"Display"``, ``"Image"``, ``"Teaching"`` or ``"toolbar"``.
    state : tuple of str
        Keys of :func:`session_state` (or panel values) the control shows or edits.
    command : str, optional
        The :class:`~.session.EditingSession` command it calls (an attribute path such as
        ``"files.load_deformation"``): on click for buttons, on change for inputs.
    args : tuple of str
        State keys whose values a button passes to ``command`` (through ``parse``).
    parse : callable
        Panel values -> the command's arguments; raises ValueError naming the field.
    choices : tuple of (value, label)
        A choice's options.
    enabled : str, optional
        State key that enables the control.
    limits : tuple of str
        State keys of the fields' maxima.
    bounds : tuple of float, optional
        A slider's ``(min, max, step)``; by default ``(0, 0.95, 0.05)`` shown as a percentage.
    default : object
        A panel value's initial value.
    row : int
        Controls of a section with the same row share one line.
    panels : frozenset of str
        Where it appears: ``"notebook"``, ``"app"``.
    element_id : str, optional
        The app's element id, to keep one the browser tests and users already know.
    app_trigger : str, optional
        In the app, a named trigger runs the command instead (file actions: root folder, worker thread).
    """

    key: str
    kind: str
    label: str
    section: str
    state: tuple[str, ...] = ()
    command: str | None = None
    args: tuple[str, ...] = ()
    parse: Callable[[Sequence[Any]], tuple[Any, ...]] = _as_is
    choices: tuple[tuple[str, str], ...] = ()
    enabled: str | None = None
    limits: tuple[str, ...] = ()
    bounds: tuple[float, float, float] | None = None
    default: Any = None
    placeholder: str = ""
    tooltip: str = ""
    row: int = 0
    panels: frozenset[str] = BOTH
    element_id: str | None = None
    app_trigger: str | None = None

    @property
    def dom_id(self) -> str:
        """The app's element id."""
        return self.element_id or f"ffd-{self.key.replace('_', '-')}"


BASIS_CHOICES = tuple((b, b) for b in BASES)
# ipywidgets shows a ``None`` value as an empty dropdown: the panels use "none" for "no field"
FIELD_CHOICES = (
    ("none", "mesh colours"),
    ("displacement", "|displacement|"),
    ("jacobian", "folding (det J <= 0)"),
    ("weights", "vertex weights"),
)
MODE_CHOICES = tuple(zip(MODES, ("control points", "the mesh surface", "paint weights"), strict=True))
INTERPOLATION_CHOICES = tuple((k, k) for k in LATTICE_INTERPOLATIONS)
BRUSH_CHOICES = (("raise", "raise"), ("lower", "lower"))
_INTERPOLATION = ("interp_x", "interp_y", "interp_z")
POINTS_CHOICES = (("auto", "all (hull above 1000)"), ("all", "all"), ("near", "near the selected"), ("hull", "hull"))
_IJK, _XYZ = ("sel_i", "sel_j", "sel_k"), ("dx", "dy", "dz")
_SLICE = ("img_i", "img_j", "img_k")


def _index_and_vector(values: Sequence[Any]) -> tuple[Any, ...]:
    return numbers(values[:3], "index", int), numbers(values[3:], "displacement")


def _uploaded_file(values: Sequence[Any]) -> tuple[str, bytes]:
    """``(name, content)`` of the file in an upload widget's value (ipywidgets' FileUpload: a tuple of dicts).

    Examples
    --------
    >>> _uploaded_file([({"name": "me.jpg", "content": memoryview(b"...")},)])
    ('me.jpg', b'...')
    >>> _uploaded_file([()])
    Traceback (most recent call last):
    ...
    ValueError: no file uploaded
    """
    files = values[0] if values else ()
    if not files:
        raise ValueError("no file uploaded")  # the widget emptied: nothing to do
    first = files[0]
    return str(first.get("name") or "upload"), bytes(first["content"])


CONTROLS: tuple[Control, ...] = (
    Control(
        "undo",
        "button",
        "Undo",
        "toolbar",
        command="undo",
        enabled="can_undo",
        app_trigger="ffd_undo",
        tooltip="Undo the last change",
    ),
    Control(
        "redo", "button", "Redo", "toolbar", command="redo", enabled="can_redo", app_trigger="ffd_redo", tooltip="Redo"
    ),
    Control("shape", "ints", "points per axis", "Lattice", state=("nx", "ny", "nz")),
    Control(
        "rebuild",
        "button",
        "Rebuild",
        "Lattice",
        command="set_shape",
        args=("nx", "ny", "nz"),
        parse=lambda v: (numbers(v, "lattice size", int),),
        app_trigger="ffd_rebuild",
        tooltip="Fit a new lattice of this size around the mesh",
    ),
    Control(
        "basis",
        "choice",
        "basis",
        "Lattice",
        state=("basis",),
        command="set_basis",
        choices=BASIS_CHOICES,
        row=1,
        app_trigger="ffd_basis",
    ),
    Control(
        "interpolation",
        "choices",
        "interpolation x, y, z",
        "Lattice",
        state=_INTERPOLATION,
        command="set_interpolation",
        choices=INTERPOLATION_CHOICES,
        parse=lambda v: (tuple(str(k) for k in v),),
        enabled="has_interpolation",
        row=2,
        tooltip="Blender's interpolation of each lattice axis (the B-spline basis only)",
    ),
    Control(
        "strength",
        "slider",
        "strength",
        "Lattice",
        state=("strength",),
        command="set_strength",
        parse=lambda v: (number(v[0], "the strength"),),
        bounds=(-1.0, 2.0, 0.05),
        default=1.0,
        row=3,
        tooltip="How much of the deformation the mesh gets: 1 all, 0 none (Blender's modifier strength)",
    ),
    Control(
        "ijk",
        "ints",
        "i, j, k",
        "Control point",
        state=_IJK,
        command="select",
        limits=("max_i", "max_j", "max_k"),
        parse=lambda v: (numbers(v, "index", int),),
        row=0,
    ),
    Control("xyz", "floats", "displacement", "Control point", state=_XYZ, row=1),
    Control(
        "apply",
        "button",
        "Apply",
        "Control point",
        command="move_control_point",
        args=_IJK + _XYZ,
        parse=_index_and_vector,
        row=2,
        tooltip="Set the displacement of control point (i, j, k)",
    ),
    Control(
        "reset_point",
        "button",
        "Reset point",
        "Control point",
        command="reset",
        args=_IJK,
        parse=lambda v: (numbers(v, "index", int),),
        row=2,
        tooltip="Zero this control point's displacement",
    ),
    Control(
        "reset_all", "button", "Reset all", "Control point", command="reset", row=2, tooltip="Zero every displacement"
    ),
    Control(
        "moved_points",
        "label",
        "{moved_points} control point(s) moved",
        "Control point",
        state=("moved_points",),
        row=3,
    ),
    Control(
        "pick_help",
        "label",
        "Alt + drag grabs a control point behind the mesh (drawn faint through it)",
        "Control point",
        row=3,
    ),
    Control(
        "mode",
        "choice",
        "mouse drags",
        "Control point",
        state=("mode",),
        command="surface.set_mode",
        choices=MODE_CHOICES,
        row=4,
        tooltip="What a drag in the view moves: the spheres, or the mesh itself (click the mesh to pin a point)",
    ),
    Control(
        "clear_pins",
        "button",
        "Clear pins",
        "Control point",
        command="surface.clear_pins",
        enabled="has_pins",
        row=4,
        tooltip="Unpin every pinned point of the mesh",
    ),
    Control(
        "brush",
        "choice",
        "weight brush",
        "Control point",
        state=("brush",),
        command="paint.set_brush",
        choices=BRUSH_CHOICES,
        row=5,
        tooltip="In 'paint weights' mode a drag over the mesh raises (or lowers) the weights of the vertices "
        "near it: only the weighted part of the mesh follows the lattice",
    ),
    Control(
        "clear_weights",
        "button",
        "Clear weights",
        "Control point",
        command="paint.clear",
        enabled="has_weights",
        row=5,
        tooltip="Remove the vertex weights: the whole mesh follows the lattice again",
    ),
    Control(
        "ffd_path",
        "text",
        "lattice file (.ffd, .tfm, .h5, .prm)",
        "Files",
        default="lattice.ffd",
        placeholder="path/to/lattice.ffd",
        element_id="ffd-path",
    ),
    Control(
        "load_ffd",
        "button",
        "Load lattice",
        "Files",
        command="files.load_deformation",
        args=("ffd_path",),
        element_id="ffd-load",
        app_trigger="ffd_load_ffd",
        tooltip="Load a deformation file: .ffd, ITK and ANTs .tfm/.txt/.h5/.mat, elastix, PyGeM .prm, NiftyReg "
        "grids and fields (.nii.gz); a field or chain becomes a fitted lattice",
    ),
    Control(
        "save_ffd",
        "button",
        "Save lattice",
        "Files",
        command="files.save_deformation",
        args=("ffd_path",),
        element_id="ffd-save",
        app_trigger="ffd_save_ffd",
        tooltip="Save the lattice: .ffd, ITK .tfm/.txt/.h5/.hdf5, PyGeM .prm (by extension)",
    ),
    Control(
        "mesh_path", "text", "mesh to load", "Files", default="", placeholder="mesh.obj / .ply / .vtp / ...", row=1
    ),
    Control(
        "load_mesh",
        "button",
        "Load mesh",
        "Files",
        command="files.load_mesh",
        args=("mesh_path",),
        row=1,
        app_trigger="ffd_load_mesh",
        tooltip="Load a mesh (OBJ with colours, PLY, VTP, STL, anything PyVista reads)",
    ),
    Control("mesh_save_path", "text", "save deformed mesh as", "Files", default="deformed.obj", row=2),
    Control(
        "save_mesh",
        "button",
        "Save mesh",
        "Files",
        command="files.save_mesh",
        args=("mesh_save_path",),
        row=2,
        app_trigger="ffd_save_mesh",
        tooltip="Save the deformed mesh: OBJ keeps colours; PLY, VTP, STL...",
    ),
    Control("photo_path", "text", "photo of a face", "Files", default="", placeholder="me.jpg / .png", row=3),
    Control(
        "load_face",
        "button",
        "Face from photo",
        "Files",
        command="files.load_face",
        args=("photo_path",),
        row=3,
        app_trigger="ffd_load_face",
        tooltip="Replace the mesh with the coloured 3D face in a photo (JPEG, PNG), made offline",
    ),
    Control(
        "face_upload",
        "upload",
        "Face from photo",
        "Files",
        state=("face_upload",),
        default=(),  # the widget's value: the uploaded files (none yet)
        command="files.load_face_upload",
        parse=_uploaded_file,
        row=4,
        panels=frozenset({"notebook"}),  # the app's mesh upload takes photos too
        tooltip="Upload a photo (JPEG, PNG): its face replaces the mesh",
    ),
    Control(
        "colors",
        "switch",
        "vertex colours",
        "Display",
        state=("colors",),
        command="show_colors",
        enabled="has_colors",
        parse=lambda v: (bool(v[0]),),
    ),
    Control(
        "field",
        "choice",
        "colour by",
        "Display",
        state=("field",),
        command="set_field",
        choices=FIELD_CHOICES,
        parse=lambda v: (None if v[0] in (None, "none") else v[0],),
    ),
    Control(
        "points_shown",
        "choice",
        "control points",
        "Display",
        state=("points_shown",),
        command="show_points",
        choices=POINTS_CHOICES,
        row=1,
        tooltip="Dense lattices: draw every control point, those near the selected one, or the hull "
        "(auto: all up to 1000 control points, else the hull)",
    ),
    Control("reduction", "slider", "decimate", "Display", default=0.5, row=2),
    Control(
        "decimate",
        "button",
        "Decimate",
        "Display",
        command="decimate",
        args=("reduction",),
        row=2,
        app_trigger="ffd_decimate",
        parse=lambda v: (number(v[0], "the reduction"),),
        tooltip="Remove this fraction of the faces, keeping colours (0 restores the mesh)",
    ),
    Control("mesh_info", "label", "{mesh_info}", "Display", state=("mesh_info",), row=3),
    Control(
        "blend",
        "slider",
        "show",
        "Teaching",
        state=("blend",),
        command="set_blend",
        parse=lambda v: (number(v[0], "the blend"),),
        bounds=(0.0, 1.0, 0.05),
        default=1.0,
        tooltip="Show this much of the deformation (rest + t x offsets; the folding colours follow t): slide from 0 "
        "to 1 to show it growing. Below 1 nothing can be dragged; an edit applies to the whole deformation and "
        "brings the slider back to 1",
    ),
    Control("blend_help", "label", "{blend_help}", "Teaching", state=("blend_help",), row=1),
    Control(
        "code",
        "code",
        "Code",
        "Teaching",
        row=2,
        tooltip="Your edits as Python: the lattice made, one statement per step of the undo history, the "
        "deformed mesh (editor.to_code())",
    ),
    Control("code_log", "log", "Last steps as code", "Teaching", state=("code_log",), row=3),
    Control(
        "movie_path",
        "text",
        "animation file (.gif, .mp4)",
        "Teaching",
        default="deformation.gif",
        row=4,
        panels=frozenset({"notebook"}),
    ),
    Control(
        "movie_format",
        "choice",
        "animation",
        "Teaching",
        state=("movie_format",),
        choices=MOVIE_CHOICES,
        default="gif",
        row=4,
        panels=frozenset({"app"}),
    ),
    Control("orbit", "switch", "orbit the camera", "Teaching", state=("orbit",), default=False, row=5),
    Control(
        "record",
        "record",
        "Record",
        "Teaching",
        args=("movie_path", "orbit"),
        row=5,
        app_trigger="ffd_record",
        tooltip=f"The mesh going from rest to the deformation, {RECORD_FRAMES} frames at {RECORD_FPS:.0f} a "
        "second, as the view shows it (editor.animate)",
    ),
    Control("image_path", "text", "image to show", "Image", default="", placeholder="image.nii.gz / .nrrd / .png"),
    Control(
        "load_image",
        "button",
        "Load image",
        "Image",
        command="image.load",
        args=("image_path",),
        app_trigger="ffd_load_image",
        tooltip="Show an image (NIfTI, NRRD, MetaImage, PNG...) as three slices warped by the lattice",
    ),
    Control(
        "image_slices",
        "ints",
        "slice i, j, k",
        "Image",
        state=_SLICE,
        command="image.set_positions",
        limits=("img_max_i", "img_max_j", "img_max_k"),
        parse=lambda v: (numbers(v, "slice", int),),
        enabled="has_image",
        row=1,
    ),
    Control(
        "image_window",
        "floats",
        "level, width",
        "Image",
        state=("img_level", "img_width"),
        command="image.set_window",
        parse=lambda v: ((number(v[0], "level"), number(v[1], "width")),),
        enabled="grey_image",
        row=2,
    ),
    Control("image_save_path", "text", "save warped image as", "Image", default="warped.nii.gz", row=3),
    Control(
        "save_image",
        "button",
        "Save image",
        "Image",
        command="image.save",
        args=("image_save_path",),
        enabled="has_image",
        app_trigger="ffd_save_image",
        row=3,
        tooltip="Write the image warped by the lattice (ITK's convention, as the saved lattice file does it)",
    ),
    Control("image_info", "label", "{image_info}", "Image", state=("image_info",), row=4),
    Control("message", "messages", "Messages", "Display", state=("messages",), row=4, element_id="ffd-messages"),
)


def by_key(key: str, controls: Sequence[Control] | None = None) -> Control:
    """The control named ``key``."""
    for control in CONTROLS if controls is None else controls:
        if control.key == key:
            return control
    raise KeyError(f"no control {key!r}")


def session_state(session: EditingSession) -> dict[str, Any]:
    """What the controls show, from the session: THE mapping both front-ends use.

    The selection's index and displacement (``sel_i``..., ``dx``...) are included when a control
    point is selected. ``field`` is ``"none"`` for no field; ``messages`` lists the newest
    :data:`N_MESSAGES`, newest first, as ``{"text", "error"}``.

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> from ffd_notebook.view.editor.session import EditingSession
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 5, 4))
    >>> state = session_state(session)
    >>> state["nx"], state["ny"], state["max_j"], state["field"], "sel_i" in state
    (4, 5, 4, 'none', False)
    """
    lattice, mesh, selected = session.lattice, session.mesh, session.selected
    shape = lattice.shape
    state: dict[str, Any] = {
        **dict(zip(("nx", "ny", "nz"), shape, strict=True)),
        **dict(zip(("max_i", "max_j", "max_k"), (n - 1 for n in shape), strict=True)),
        "basis": "bernstein" if session.basis == "bernstein" else "bspline",
        **dict(zip(_INTERPOLATION, session.interpolation or ("bspline",) * 3, strict=True)),
        "has_interpolation": session.interpolation is not None,
        "strength": session.ffd.strength,
        "brush": "lower" if session.paint.amount < 0 else "raise",
        "has_weights": session.ffd.weights is not None,
        "colors": session.colors_shown,
        "has_colors": session.has_colors,
        "field": session.field or "none",
        "points_shown": session.points_shown,
        "can_undo": session.can_undo,
        "can_redo": session.can_redo,
        "has_selection": selected is not None,
        "mesh_info": f"{mesh.n_points} vertices, {mesh.n_cells} faces",
        "mode": session.surface.mode,
        "has_pins": len(session.surface.pins) > 0,
        "moved_points": int(np.any(lattice.offsets != 0, axis=-1).sum()),
        "blend": session.blend,
        "blend_help": "t = 1: the whole deformation; edit it"
        if session.blend == 1.0
        else f"t = {session.blend:.2f}: showing, nothing to drag; an edit goes back to 1",
        "code_log": "\n\n".join(session.script.recent(N_LOG_STEPS)) or "# (no edits yet)",
        "messages": [{"text": t, "error": t.startswith("Error")} for t in list(session.messages)[-N_MESSAGES:][::-1]],
    }
    state.update(_image_state(session))
    if selected is not None:
        state.update(zip(_IJK, selected, strict=True))
        state.update(zip(_XYZ, (float(f"{v:.6g}") for v in lattice.offsets[selected]), strict=True))
    return state


def _image_state(session: EditingSession) -> dict[str, Any]:
    """The image controls' state: slice positions and their limits, window, what is shown."""
    image = session.image
    if not image.loaded:
        none = {"has_image": False, "grey_image": False, "img_level": 0.0, "img_width": 1.0, "image_info": "no image"}
        return {**none, **dict.fromkeys(_SLICE, 0), **dict.fromkeys(("img_max_i", "img_max_j", "img_max_k"), 0)}
    slices = image.slices
    assert slices is not None  # loaded
    size = list(slices.grid.size) + [1] * (3 - slices.grid.dim)
    positions = list(slices.positions) + [0] * (3 - slices.grid.dim)
    level, width = image.window if image.window is not None else (0.0, 1.0)
    return {
        "has_image": True,
        "grey_image": image.window is not None,
        **dict(zip(_SLICE, positions, strict=True)),
        **dict(zip(("img_max_i", "img_max_j", "img_max_k"), (n - 1 for n in size), strict=True)),
        "img_level": float(f"{level:.6g}"),
        "img_width": float(f"{width:.6g}"),
        "image_info": f"{image.name}: {' x '.join(map(str, slices.grid.size))} voxels",
    }


def run(session: EditingSession, control: Control, values: Sequence[Any]) -> bool:
    """Run ``control`` with the panel's ``values`` on ``session``; False if it failed (then a message says why).

    Inputs bound to state (basis, selection, colors, field) do nothing when the session already
    shows the value, and ignore a value that does not parse yet (a half-typed number).

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> from ffd_notebook.view.editor.session import EditingSession
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    >>> run(session, by_key("apply"), ["1", "2", "1", "0", "0", "0.25"])
    True
    >>> session.lattice.offsets[1, 2, 1].tolist()
    [0.0, 0.0, 0.25]
    >>> run(session, by_key("apply"), [1, 2, 1, "abc", 0, 0]), session.messages[-1]
    (False, "Error: displacement x must be a number, got 'abc'")
    """
    if control.command is None:
        return True
    is_input = control.kind != "button"
    try:
        args = control.parse(list(values))
    except ValueError as exc:
        if is_input:
            return False  # half-typed: wait for the rest
        return session.attempt(_raise, exc)
    if is_input and control.state:
        shown = session_state(session)
        current = [shown.get(k) for k in control.state]
        wanted = list(args[0]) if control.kind in ("ints", "floats", "choices") else [values[0]]
        if current == wanted or (control.kind == "switch" and current == [bool(values[0])]):
            return True
    return session.attempt(attrgetter(control.command)(session), *args)


def _raise(exc: Exception) -> None:
    raise exc
