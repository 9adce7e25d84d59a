"""The editor's control panel for Jupyter (ipywidgets), built from :data:`..session.controls.CONTROLS`.

Every control calls one :class:`~ffd_notebook.view.editor.EditingSession` command through
:func:`..session.controls.run`; the panel has no logic of its own. It follows the editor's session: dragging a
sphere selects that control point here and shows its displacement in the X/Y/Z fields, undo/redo
buttons are enabled when there is something to undo/redo, and the last message (errors in red) is
shown at the bottom. What each control shows comes from :func:`..session.controls.session_state`.
"""

from __future__ import annotations

import html
import weakref
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import ipywidgets as widgets

from ..session import controls as panel_controls
from ..session.changes import Change, DragSync
from ..session.controls import CODE_STYLE, RECORD_FPS, RECORD_FRAMES, SECTION_HINTS, Control, run, session_state

if TYPE_CHECKING:
    from ..editor import Editor

__all__ = ["ControlPanel"]

PANEL_WIDTH = "410px"
#: what the notebook panel says under the code it shows (a widget's click cannot add a cell: see ``Editor.code_cell``)
CODE_HINT = ("Copy it into a cell (select it, Ctrl+C), or run <code>editor.code_cell()</code> in a cell: "
             "a new cell below it holds this code.")  # fmt: skip
ICONS = {"undo": "undo", "redo": "repeat"}
WIDTHS = {"ints": "58px", "floats": "84px", "choice": "170px", "choices": "110px"}


def _stretch() -> widgets.Layout:
    """A field that takes the room its row leaves."""
    return widgets.Layout(flex="1 1 auto", width="auto", min_width="90px")


def _label(text: str, own_line: bool = False) -> widgets.Label:
    # at least the common width, so rows line up; a longer label grows, never cut off. Above three choices
    # ("interpolation x, y, z"), on a line of its own: they fit together below it, not beside it
    flex = "0 0 calc(100% - 4px)" if own_line else "0 0 auto"  # (its margins: 2 px each side)
    return widgets.Label(text, layout=widgets.Layout(width="auto", min_width="104px", flex=flex))


class ControlPanel(widgets.VBox):
    """ipywidgets panel bound to an :class:`Editor`.

    Attributes are named after the controls' keys (``panel.ijk``, ``panel.xyz``, ``panel.basis``,
    ``panel.ffd_path``...; buttons ``panel.apply_button``, ``panel.undo_button``...).

    Parameters
    ----------
    editor : Editor
        The editor the controls act on.
    controls : sequence of Control, optional
        What to show (default: :data:`..session.controls.CONTROLS`, those meant for the notebook).

    Examples
    --------
    >>> import pyvista as pv
    >>> from ffd_notebook.view import Editor, ControlPanel
    >>> editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(200, 150))
    >>> panel = ControlPanel(editor)
    >>> panel.ijk[0].value, panel.ijk[1].value, panel.ijk[2].value = 1, 2, 1
    >>> panel.xyz[2].value = 0.25
    >>> panel.apply_button.click()
    >>> editor.lattice.offsets[1, 2, 1].tolist()
    [0.0, 0.0, 0.25]
    >>> editor.close()
    """

    def __init__(self, editor: Editor, controls: Sequence[Control] | None = None) -> None:
        # ipywidgets keeps every widget until it is closed: the panel must not keep its editor alive
        self._editor = weakref.ref(editor)
        controls = panel_controls.CONTROLS if controls is None else controls
        self.controls = [c for c in controls if "notebook" in c.panels]
        self._syncing = False
        self._fields: dict[str, Any] = {}  # value key (state key or control key) -> widget
        self._widgets: dict[str, Any] = {}  # control key -> widget or list of widgets
        rows: dict[tuple[str, int], list[widgets.Widget]] = {}
        for control in self.controls:
            rows.setdefault((control.section, control.row), []).extend(self._build(control))
        children: list[widgets.Widget] = []
        for section in dict.fromkeys(section for section, _ in rows):
            if section != "toolbar":
                hint = f" <small>({SECTION_HINTS[section]})</small>" if section in SECTION_HINTS else ""
                children.append(widgets.HTML(f"<b>{html.escape(section)}</b>{hint}"))
            wrapping = widgets.Layout(flex_flow="row wrap")  # a row wider than the panel continues below
            children += [widgets.HBox(row, layout=wrapping) for (s, _), row in rows.items() if s == section]
        super().__init__(children, layout=widgets.Layout(padding="0 0 0 12px", width=PANEL_WIDTH, flex="0 0 auto"))
        self.add_class("ffd-panel")
        self._drag_sync = DragSync()
        editor.session.subscribe(self._follow)
        self.sync()

    @property
    def editor(self) -> Editor:
        """The editor the controls act on (the panel refers to it weakly)."""
        editor = self._editor()
        if editor is None:
            raise RuntimeError("this panel's editor is closed")
        return editor

    # ------------------------------------------------------------------ building, one kind at a time
    def _build(self, control: Control) -> list[widgets.Widget]:
        """The widgets of one control (a row label first for inputs), stored under its key."""
        kind, css = control.kind, f"ffd-{control.key.replace('_', '-')}"
        if kind in ("code", "record"):
            return self._build_teaching(control, css)
        if kind == "button":
            button = widgets.Button(
                description=control.label,
                tooltip=control.tooltip or control.label,
                icon=ICONS.get(control.key, ""),
                layout=widgets.Layout(width="auto", flex="0 0 auto"),
            )
            button.add_class(css)  # buttons never shrink below their label; css classes let tests and users style them
            button.on_click(lambda _b: self.act(control, [self._fields[k].value for k in control.args]))
            setattr(self, f"{control.key}_button", button)
            self._widgets[control.key] = button
            return [button]
        if kind in ("ints", "floats"):
            cls = widgets.BoundedIntText if kind == "ints" else widgets.FloatText
            bounds = {"min": 0 if control.limits else 2, "max": 40} if kind == "ints" else {}
            made: Any = [cls(value=0, layout=widgets.Layout(width=WIDTHS[kind]), **bounds) for _ in control.state]
            for field in made:
                field.add_class(css)
            self._fields.update(zip(control.state, made, strict=True))
        elif kind == "choice":
            options = [(label, value) for value, label in control.choices]
            layout = widgets.Layout(width=WIDTHS[kind])
            made = widgets.Dropdown(options=options, value=control.choices[0][0], layout=layout)
        elif kind == "choices":
            options = [(label, value) for value, label in control.choices]
            made = [
                widgets.Dropdown(
                    options=options, value=control.choices[0][0], layout=widgets.Layout(width=WIDTHS[kind])
                )
                for _ in control.state
            ]
            for field in made:
                field.add_class(css)
            self._fields.update(zip(control.state, made, strict=True))
        elif kind == "switch":
            made = widgets.Checkbox(value=False, description=control.label, indent=False)
        elif kind == "text":
            made = widgets.Text(value=control.default, placeholder=control.placeholder, layout=_stretch())
        elif kind == "upload":
            made = widgets.FileUpload(accept="image/*", multiple=False, description=control.label, icon="upload")
            made.tooltip = control.tooltip
            made.layout = widgets.Layout(width="auto", flex="0 0 auto")
        elif kind == "slider":
            low, high, step = control.bounds or (0.0, 0.95, 0.05)
            made = widgets.FloatSlider(
                value=control.default,
                min=low,
                max=high,
                step=step,
                readout_format=".0%" if control.bounds is None else ".2f",
                layout=_stretch(),
            )
        else:  # "label", "messages", "log"
            made = widgets.HTML(value="")
            if kind == "log":
                made.layout = widgets.Layout(width="100%")
        if not isinstance(made, list):
            self._fields[control.state[0] if control.state else control.key] = made
            if kind in ("text", "choice", "upload", "log"):
                made.add_class(css)
        setattr(self, control.key, made)
        self._widgets[control.key] = made
        if control.command is not None:
            for widget in made if isinstance(made, list) else [made]:
                widget.observe(lambda _change, c=control: self._on_input(c), names="value")
        shown = made if isinstance(made, list) else [made]
        labelled = kind in ("ints", "floats", "choice", "choices", "slider")
        return ([_label(control.label, own_line=kind == "choices")] if labelled else []) + shown

    def _build_teaching(self, control: Control, css: str) -> list[widgets.Widget]:
        """ "Code" (a button and the code to copy, shown when clicked) or "Record" (a button and its progress)."""
        button = widgets.Button(description=control.label, tooltip=control.tooltip or control.label,
                                layout=widgets.Layout(width="auto", flex="0 0 auto"))  # fmt: skip
        button.add_class(css)
        setattr(self, f"{control.key}_button", button)
        self._widgets[control.key] = button
        if control.kind == "code":
            self.code_text = widgets.Textarea(value="", layout=widgets.Layout(width="100%", height="220px",
                                                                              display="none"))  # fmt: skip
            self.code_text.add_class("ffd-scroll")
            self.code_text.add_class("ffd-code-text")
            self.code_hint = widgets.HTML(f"<small>{CODE_HINT}</small>", layout=widgets.Layout(display="none"))
            button.on_click(lambda _b: self.show_code())
            return [button, self.code_text, self.code_hint]
        hidden = widgets.Layout(width="120px", visibility="hidden")  # (shown while it records)
        self.record_progress = widgets.IntProgress(value=0, min=0, max=RECORD_FRAMES, layout=hidden)
        self.record_progress.add_class("ffd-record-progress")
        button.on_click(lambda _b: self.record(*(self._fields[k].value for k in control.args)))
        return [button, self.record_progress]

    def show_code(self) -> None:
        """Show the editor's code (:meth:`~ffd_notebook.view.editor.editor.Editor.to_code`) in the panel, to copy.

        A click in a widget cannot add a cell to the notebook (IPython's ``set_next_input`` answers the request
        that ran a cell, and a click runs none; JupyterLab shows it only after the next cell runs): the panel
        shows the code, and ``editor.code_cell()`` run in a cell puts it in a new cell below.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor, ControlPanel
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> panel = ControlPanel(editor)
        >>> editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
        >>> panel.show_code()
        >>> "lattice.offsets[1, 2, 1] = (0.0, 0.0, 0.25)" in panel.code_text.value
        True
        >>> editor.close()
        """
        self.code_text.value = self.editor.to_code()
        self.code_text.layout.display = "block"
        self.code_hint.layout.display = "block"

    def record(self, path: Any, orbit: Any = False) -> None:
        """Record the deformation into ``path`` (a ``.gif`` or a movie, in the kernel's folder) with a progress bar.

        A failure (a bad name, a folder that cannot be written) becomes the editor's message.

        Parameters
        ----------
        path : str
            The file to write (the panel's "animation file" field).
        orbit : bool, default False
            Turn the camera by a whole turn over the animation.

        Examples
        --------
        >>> import os, tempfile
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor, ControlPanel
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> panel = ControlPanel(editor)
        >>> panel.record(os.path.join(tempfile.mkdtemp(), "rest.gif"))
        >>> editor.messages[-1]  # doctest: +ELLIPSIS
        'recorded .../rest.gif: 36 frames'
        >>> editor.close()
        """
        editor = self.editor
        session = editor.session
        bar = self.record_progress
        self.record_button.disabled = True
        bar.value, bar.layout.visibility = 0, "visible"

        def progress(done: int, total: int) -> None:
            bar.max, bar.value = total, done

        try:
            target = str(path).strip() or "deformation.gif"
            recording = editor.recording(frames=RECORD_FRAMES, fps=RECORD_FPS, orbit=bool(orbit))
            recording.run(target, progress)
            session.info(f"recorded {target}: {RECORD_FRAMES} frames")
        except (OSError, ValueError) as exc:
            session.error(f"could not record {path!r}: {exc}")
        finally:
            self.record_button.disabled = False
            bar.layout.visibility = "hidden"
            self.sync()

    # ------------------------------------------------------------------ actions (one editor call each)
    def act(self, control: Control, values: Sequence[Any]) -> None:
        """Run ``control`` with ``values`` (a failure becomes the editor's last message, shown below).

        Parameters
        ----------
        control : Control
            One of the panel's ``controls`` (:data:`..session.controls.CONTROLS`).
        values : sequence
            The values of the control's fields (``control.state``), in order.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor, ControlPanel
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> panel = ControlPanel(editor)
        >>> editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
        >>> undo = next(control for control in panel.controls if control.key == "undo")
        >>> panel.act(undo, [])
        >>> editor.lattice.offsets[1, 2, 1].tolist(), panel.undo_button.disabled
        ([0.0, 0.0, 0.0], True)
        >>> editor.close()
        """
        run(self.editor.session, control, values)
        self.sync()

    def _on_input(self, control: Control) -> None:
        if self._syncing:
            return
        self.act(control, [self._fields[k].value for k in control.state])
        if control.kind == "upload":  # empty it, so that the same file can be uploaded again
            self._syncing = True
            try:
                self._fields[control.state[0]].value = ()
            finally:
                self._syncing = False

    # ------------------------------------------------------------------ following the editor
    def _follow(self, change: Change) -> None:
        if not self._syncing and self._drag_sync.wanted(change):  # drags: at most every DRAG_SYNC_S
            self.sync()

    def sync(self) -> None:
        """Show the editor's state (:func:`..session.controls.session_state`) in every control.

        Examples
        --------
        A value typed in a field but not applied goes back to the editor's:

        >>> import pyvista as pv
        >>> from ffd_notebook.view import Editor, ControlPanel
        >>> editor = Editor(pv.Sphere(theta_resolution=8, phi_resolution=8), shape=(4, 4, 4), window_size=(64, 48))
        >>> panel = ControlPanel(editor)
        >>> editor.session.move_control_point((1, 2, 1), (0.0, 0.0, 0.25))
        >>> panel.xyz[2].value = 0.9
        >>> panel.sync()
        >>> panel.xyz[2].value
        0.25
        >>> editor.close()
        """
        state = session_state(self.editor.session)
        if "sel_i" not in state:  # nothing selected: keep the typed index, show its displacement
            ijk = tuple(int(self._fields[k].value) for k in ("sel_i", "sel_j", "sel_k") if k in self._fields)
            if len(ijk) == 3 and all(0 <= i < n for i, n in zip(ijk, self.editor.lattice.shape, strict=True)):
                state.update(zip(("dx", "dy", "dz"), (float(v) for v in self.editor.lattice.offsets[ijk]), strict=True))
        self._syncing = True
        try:
            for control in self.controls:
                self._show(control, state)
        finally:
            self._syncing = False

    def _show(self, control: Control, state: dict[str, Any]) -> None:
        widget = self._widgets[control.key]
        if control.kind == "button":
            widget.disabled = control.enabled is not None and not state.get(control.enabled, True)
        elif control.kind == "label":
            widget.value = html.escape(control.label.format(**state))
        elif control.kind == "log":
            lines, style = html.escape(state[control.state[0]]), CODE_STYLE.format(height="7.5em")
            widget.value = (
                f'<small>{html.escape(control.label)}</small><pre class="ffd-scroll" style="{style}">{lines}</pre>'
            )

        elif control.kind == "code":
            if self.code_text.layout.display != "none":  # shown: it follows the edits
                self.code_text.value = self.editor.to_code()
        elif control.kind == "record":
            pass
        elif control.kind == "messages":
            if state["messages"]:
                text = state["messages"][0]["text"]
                color = "#c62828" if state["messages"][0]["error"] else "#2e7d32"
                widget.value = f'<span style="color: {color}">{html.escape(text)}</span>'
        elif control.kind == "choices":
            for i, key in enumerate(control.state):
                widget[i].disabled = control.enabled is not None and not state.get(control.enabled, True)
                if key in state:
                    widget[i].value = state[key]
        elif control.kind in ("ints", "floats"):
            for i, key in enumerate(control.state):
                if control.limits:
                    widget[i].max = state[control.limits[i]]
                if key in state:
                    widget[i].value = round(float(state[key]), 9) if control.kind == "floats" else state[key]
        elif control.state and control.state[0] in state:
            widget.value = state[control.state[0]]
