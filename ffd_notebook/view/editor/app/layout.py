"""The standalone app's page: a Vuetify 3 side panel built from :data:`..session.controls.CONTROLS`, beside the view.

Every button passes the values it needs as arguments (``click=(app.run, "['apply', [sel_i, ...]]")``),
so an action never runs with a text field's previous value; file actions call the app's named
triggers (root folder, worker thread). Element ids (``ffd-save``, ``ffd-path``, ``ffd-view``, ...) are
stable: the browser tests use them. The uploads, downloads and the progress bar are the app's own
(a notebook reads files from the kernel's folder).

How the panel fits (every label, value and button readable in full from 1280x800 up; a browser test measures it):

- Each section folds (:data:`OPEN_SECTIONS` are open when the page opens), so a short screen shows what the
  user works with; the messages stay at the bottom of the panel, whatever is folded.
- A control's row is a wrapping flex line: a button takes the width of its text; an input grows from a basis
  that holds its longest text (:func:`min_width_px`: a select's longest choice and label, a number field's
  widest value), so what does not fit beside the others moves to the next line instead of being cut.
- A slider shows its value as text beside it, not in a bubble over the row above; a label wraps.

A new control in :data:`..session.controls.CONTROLS` gets all of this from its kind and its texts: nothing to
size by hand (see ``/work/coord/editor.md`` and ``tests/browser/test_panel_fit_browser.py``).
"""

from __future__ import annotations

import math
import re
from typing import Any

from ....face.photo import PHOTO_SUFFIXES
from ....io import MESH_SUFFIXES
from ...serving.file_root import FFD_SUFFIXES
from ..session.controls import CODE_STYLE, SECTION_HINTS, Control

__all__ = ["DRAWER_WIDTH", "OPEN_SECTIONS", "build_layout", "min_width_px"]

#: the side panel's width in px (the view takes the rest: 820 px of a 1280 px window)
DRAWER_WIDTH = 460
#: sections open when the page opens (the others fold; each tab remembers its own)
OPEN_SECTIONS = ("Lattice", "Control point")

_FIELD = {"density": "compact", "hide_details": True, "variant": "outlined"}
#: widths of the panel's 16 px Roboto in px, by kind of character, each the widest of its kind rounded up (measured
#: in Chromium: digits 9.0, lowercase 6.9-9.1, uppercase 10.1 on average, "m" 14.0, "i" 3.9, "-" 4.4)
_NARROW, _WIDE = set("iljtfr.,:;'!|()[] -/"), set("mwMW")
_NARROW_PX, _WIDE_PX, _UPPER_PX, _CHAR_PX = 5.0, 14.0, 10.5, 9.2
#: an outlined field's room around its text (padding 8 + 4, border, a margin) and a select's arrow, in px (see _CSS)
_FIELD_PX, _ARROW_PX = 16, 32
#: widest value a number field shows: session_state gives 6 significant digits ("-0.000123457")
_WIDEST = {"ints": "000", "floats": "-0.000123457"}
#: the panel's own rules, scoped to it: less padding inside fields and sections than Vuetify's defaults
_CSS = """
.ffd-panel .v-expansion-panel-text__wrapper { padding: 0 12px 12px; }
.ffd-panel .v-expansion-panel-title { padding: 8px 12px; min-height: 40px; }
.ffd-panel .v-field { --v-field-padding-start: 8px; --v-field-padding-end: 4px; }
.ffd-panel .v-field__append-inner > .v-icon { margin-inline-start: 0; }
.ffd-row { display: flex; flex-wrap: wrap; align-items: center; gap: 8px; margin-top: 8px; }
.ffd-row > * { min-width: 0; }
.ffd-wrap { overflow-wrap: anywhere; }
"""
#: a box of code lines (the running log, the code dialog): the user scrolls it (class ffd-scroll); % its max height
#: the upload's file filter: every lattice file suffix the app reads, in both cases
_LATTICE_ACCEPT = ",".join(s for suffix in FFD_SUFFIXES for s in (suffix, suffix.upper()))
#: the mesh upload's filter: meshes, and photos (the face in a photo becomes the mesh)
_MESH_ACCEPT = ",".join(s for suffix in (*MESH_SUFFIXES, *PHOTO_SUFFIXES) for s in (suffix, suffix.upper()))
_DOWNLOAD_MESH = "utils.download('deformed.' + mesh_format, trigger('ffd_download_mesh', [mesh_format]))"

#: a client-only state variable: each browser tab's own id (the origin of its view's mouse events)
TAB_ID = "ffd_tab"
#: a client-only state variable: the sections a tab shows unfolded
_OPEN_STATE = "ffd_sections_open"


def _text_px(text: str, scale: float = 1.0) -> int:
    """At least the width of ``text`` in the panel's font (``scale`` 0.75: a floating label's 12 px)."""

    def width(char: str) -> float:
        if char in _NARROW:
            return _NARROW_PX
        if char in _WIDE:
            return _WIDE_PX
        return _UPPER_PX if char.isupper() else _CHAR_PX

    return math.ceil(sum(width(c) for c in text) * scale)


def min_width_px(control: Control) -> int | None:
    """The width one of ``control``'s inputs needs to show its longest text in full; None for a button (its text
    decides) and for what fills its row (a label, messages).

    A floating label is 12 px (0.75 of the text). A control of another kind gets the basis of a text field.

    Examples
    --------
    >>> from ffd_notebook.view.editor.session.controls import by_key
    >>> min_width_px(by_key("basis")), min_width_px(by_key("xyz")), min_width_px(by_key("apply"))
    (119, 119, None)
    """
    kind = control.kind
    if kind in ("button", "label", "messages", "log", "code", "record"):
        return None
    if kind in ("choice", "choices"):
        longest = max([_text_px(title) for _, title in control.choices] + [0])
        label = _text_px(_input_labels(control)[0], 0.75)
        return max(longest + _ARROW_PX, label) + _FIELD_PX
    if kind in _WIDEST:
        return _text_px(_WIDEST[kind]) + _FIELD_PX + (16 if kind == "ints" else 0)  # ints: the spin buttons
    if kind == "switch":
        return _text_px(control.label) + 56  # the switch itself
    if kind == "slider":
        return 260
    return 200  # a text field: a file name


def _input_labels(control: Control) -> list[str]:
    """The label of each input of ``control`` (one per state key for the three-field kinds)."""
    if control.kind == "choices":  # "interp. x": the control's label names the axes together
        return [f"{control.key[:6]}. {name[-1]}" for name in control.state]
    if control.kind in ("ints", "floats"):
        parts = control.label.split(", ")  # "level, width": one name per field
        if control.limits:  # indices: i, j, k
            return [name[-1] for name in control.state]
        return parts if len(parts) == len(control.state) else list(control.state)
    return [control.label]


def _cell(control: Control) -> Any:
    """A cell of a row: an input grows from the basis that holds its text, a button keeps its text's width."""
    from trame.widgets import html

    basis = min_width_px(control)
    if basis is None:
        flex = "flex: 0 0 auto;" if control.kind in ("button", "code", "record") else "flex: 1 1 100%;"
        return html.Div(style=flex)
    return html.Div(style=f"flex: 1 1 {basis}px; min-width: {basis}px;")


def _disabled(control: Control) -> Any:
    """A button's ``disabled``: while it cannot act (its ``enabled`` state), and, for work that runs in a
    worker thread (an app trigger), while the app is busy."""
    conditions = (["busy"] if control.app_trigger else []) + ([f"!{control.enabled}"] if control.enabled else [])
    return (" || ".join(conditions),) if conditions else False


def _tooltip(control: Control) -> None:
    """The control's tooltip, shown over its parent element on hover."""
    from trame.widgets import vuetify3 as v

    if control.tooltip:
        v.VTooltip(text=control.tooltip, activator="parent", location="top", max_width=360, open_delay=500)


def _control(app: Any, control: Control) -> None:
    """The Vuetify widgets of one control, each in its cell of the current row."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    kind, ident = control.kind, control.dom_id
    if kind in ("choices", "ints", "floats"):  # one input per state key (an axis)
        enabled = (f"!{control.enabled}",) if control.enabled else False
        for i, (name, label) in enumerate(zip(control.state, _input_labels(control), strict=True)):
            with _cell(control):
                if kind == "choices":
                    v.VSelect(v_model=(name,), items=(f"{control.key}_items",), label=label, id=f"ffd-{name}",
                              disabled=enabled, **_FIELD)  # fmt: skip
                else:
                    extra: dict[str, Any] = {"type": "text", "inputmode": "decimal"}  # no spin buttons: more digits
                    if kind == "ints":
                        extra = {"type": "number", "step": "1", "min": 2}
                        if control.limits:
                            extra.update(min=0, max=(control.limits[i],))
                    v.VTextField(v_model=(name,), label=label, id=f"ffd-{name}", disabled=enabled, **_FIELD, **extra)
                _tooltip(control)
        return
    with _cell(control):
        if kind == "button":
            args = f"[{', '.join(control.args)}]"
            click: Any = (app.run, f"['{control.key}', {args}]")
            if control.app_trigger:
                click = f"trigger('{control.app_trigger}', {args})"
            v.VBtn(control.label, click=click, size="small", id=ident, disabled=_disabled(control),
                   classes="text-none", variant="tonal")  # fmt: skip
        elif kind == "choice":
            items = (f"{control.key}_items",)
            v.VSelect(v_model=(control.state[0],), items=items, label=control.label, id=ident, **_FIELD)
        elif kind == "switch":
            disabled = (f"!{control.enabled}",) if control.enabled else False
            v.VSwitch(
                v_model=(control.state[0],), label=control.label, disabled=disabled, id=ident, color="primary", **_FIELD
            )
        elif kind == "text":  # (a path typed longer than the field scrolls in it, as in any text field)
            v.VTextField(v_model=(control.key,), label=control.label, id=ident, classes="ffd-text", **_FIELD)
        elif kind == "slider":
            _slider(control)
        elif kind == "label":
            html.Div(re.sub(r"\{(\w+)\}", r"{{ \1 }}", control.label), classes="text-caption ffd-wrap", id=ident)
        elif kind == "messages":
            _messages(control)
        elif kind == "log":
            html.Div(control.label, classes="text-caption")
            log_style = CODE_STYLE.format(height="7.5em")
            html.Pre(f"{{{{ {control.state[0]} }}}}", classes="ffd-scroll", id=ident, style=log_style)
        elif kind == "code":
            v.VBtn(control.label, click=f"trigger('{control.app_trigger or 'ffd_show_code'}')", size="small",
                   id=ident, classes="text-none", variant="tonal")  # fmt: skip
            _code_dialog()
        elif kind == "record":
            _record(control)
        _tooltip(control)


def _code_dialog() -> None:
    """The editor's code in a dialog: to read, copy or download as a ``.py`` file."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    download = "utils.download('ffd_edits.py', trigger('ffd_download_code'), 'text/x-python')"
    with v.VDialog(v_model=("code_open",), max_width=900, scrollable=True), v.VCard():
        v.VCardTitle("Your edits as Python", classes="text-subtitle-1")
        with v.VCardText():
            code_style = CODE_STYLE.format(height="60vh")
            html.Pre("{{ code_text }}", classes="ffd-scroll", id="ffd-code-text", style=code_style)
        with v.VCardActions():
            v.VBtn("Download .py", click=download, prepend_icon="mdi-download", id="ffd-code-download",
                   classes="text-none", variant="tonal")  # fmt: skip
            copy = "navigator.clipboard && navigator.clipboard.writeText(code_text)"
            v.VBtn("Copy", click=copy, prepend_icon="mdi-content-copy", classes="text-none", variant="tonal",
                   id="ffd-code-copy")  # fmt: skip
            v.VSpacer()
            v.VBtn("Close", click="code_open = false", classes="text-none", variant="text", id="ffd-code-close")


def _record(control: Control) -> None:
    """The "Record" button (the animation downloads when written) and its progress bar."""
    from trame.widgets import vuetify3 as v

    args = f"[{', '.join(['movie_format', 'orbit'])}]"
    mime = "movie_format === 'gif' ? 'image/gif' : 'video/mp4'"
    click = f"utils.download('deformation.' + movie_format, trigger('{control.app_trigger}', {args}), {mime})"
    v.VBtn(control.label, click=click, size="small", id=control.dom_id, disabled=("recording",),
           prepend_icon="mdi-movie-open-outline", classes="text-none", variant="tonal")  # fmt: skip
    v.VProgressLinear(model_value=("record_progress",), v_show=("recording",), color="primary", height=6,
                      id="ffd-record-progress", classes="mt-1", style="min-width: 120px;")  # fmt: skip


def _slider(control: Control) -> None:
    """A slider with its label before it and its value as text after it (a bubble would cover the row above)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    low, high, step = control.bounds or (0.0, 0.95, 0.05)
    # strength: two decimals; a fraction (decimate): a percentage
    shown = f"{control.key}.toFixed(2)" if control.bounds else f"Math.round({control.key} * 100) + '%'"
    with v.VSlider(v_model=(control.key,), min=low, max=high, step=step, label=control.label, hide_details=True,
                   density="compact", id=control.dom_id):  # fmt: skip
        with v.Template(v_slot_append=True):
            html.Span(f"{{{{ {shown} }}}}", classes="text-body-2", style="min-width: 3.5em; text-align: right;",
                      id=f"{control.dom_id}-value")  # fmt: skip


def _messages(control: Control) -> None:
    """The newest messages, newest first, one compact line each (wrapped when long); errors in red."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(id=control.dom_id):
        with html.Div(v_for="(m, i) in messages", key="i", classes=("m.error ? 'text-error' : ''",),
                      style="display: flex; gap: 4px; align-items: baseline;"):  # fmt: skip
            v.VIcon(icon=("m.error ? 'mdi-alert-circle' : 'mdi-information-outline'",), size="x-small")
            html.Span("{{ m.text }}", classes="text-caption ffd-wrap")


def _rows(app: Any, rows: dict[int, list[Control]]) -> None:
    from trame.widgets import html

    for row in rows.values():
        with html.Div(classes="ffd-row"):
            for control in row:
                _control(app, control)


def _sections(app: Any, controls: list[Control]) -> None:
    """One folding section per control section, one wrapping row per (section, row)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    sections: dict[str, dict[int, list[Control]]] = {}
    for control in controls:
        sections.setdefault(control.section, {}).setdefault(control.row, []).append(control)
    with v.VExpansionPanels(v_model=(_OPEN_STATE,), multiple=True, variant="accordion", flat=True, static=True):
        for section, rows in sections.items():
            slug = section.lower().replace(" ", "-")
            with v.VExpansionPanel(value=section, id=f"ffd-section-{slug}"):
                hint = f" ({SECTION_HINTS[section]})" if section in SECTION_HINTS else ""
                v.VExpansionPanelTitle(section + hint, classes="text-subtitle-2")
                with v.VExpansionPanelText():
                    if section == "Files":
                        html.Div("in {{ root_name }} on the server", classes="text-caption mt-1 ffd-wrap",
                                 id="ffd-root")  # fmt: skip
                    _rows(app, rows)
                    if section == "Files":
                        _browser_files()


def _browser_files() -> None:
    """Upload from and download to the browser: no server path needed."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Your computer's files", classes="text-caption mt-3")
    for name, label, accept, ident in (
        ("ffd_upload", "upload a lattice (.ffd, .tfm, .h5, .mat, .prm, .nii.gz)", _LATTICE_ACCEPT, "ffd-upload"),
        ("mesh_upload", "upload a mesh, or a photo of a face", _MESH_ACCEPT, "ffd-mesh-upload"),
    ):
        with html.Div(classes="ffd-row"):
            v.VFileInput(v_model=(name,), label=label, accept=accept, id=ident, prepend_icon="", disabled=("busy",),
                         style="flex: 1 1 100%;", **_FIELD)  # fmt: skip
    with html.Div(classes="ffd-row"):
        html.Span("download", classes="text-body-2")
        download = {"size": "small", "prepend_icon": "mdi-download", "classes": "text-none", "variant": "tonal"}
        v.VBtn("lattice", click="utils.download('lattice.ffd', trigger('ffd_download_ffd'), 'text/plain')",
               id="ffd-download", **download)  # fmt: skip
        v.VBtn("mesh", click=_DOWNLOAD_MESH, id="ffd-download-mesh", **download)
        with html.Div(style="flex: 1 1 100px; min-width: 100px;"):
            v.VSelect(v_model=("mesh_format",), items=("mesh_format_items",), id="ffd-mesh-format", **_FIELD)


def build_layout(app: Any) -> tuple[Any, Any]:
    """Build the page for ``app`` (an :class:`~ffd_notebook.view.editor.app.EditorApp`); return (layout, view)."""
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import client, html
    from trame.widgets import vuetify3 as v

    from ...serving.remote_view import RemoteView

    toolbar = [c for c in app.controls if c.section == "toolbar"]
    messages = [c for c in app.controls if c.kind == "messages"]
    app.server.state[TAB_ID] = "anonymous"  # (trame-rca's default origin) until the tab sets its own
    app.server.state[_OPEN_STATE] = list(OPEN_SECTIONS)
    app.server.state.client_only(TAB_ID, _OPEN_STATE)
    with SinglePageWithDrawerLayout(app.server, width=DRAWER_WIDTH) as layout:
        client.Style(_CSS)
        layout.title.set_text("FFD editor")
        with layout.toolbar:
            v.VSpacer()
            for control in toolbar:
                v.VBtn(
                    control.label,
                    click=(app.run, f"['{control.key}', []]"),
                    disabled=_disabled(control),
                    variant="text",
                    id=control.dom_id,
                )
            v.VBtn("Fit view", click=app.reset_camera, variant="text", id="ffd-fit")
        with layout.drawer as drawer:
            drawer.classes = "ffd-panel"
            _sections(app, [c for c in app.controls if c.section != "toolbar" and c.kind != "messages"])
            # always in sight, whatever is folded: what the app is doing, what it said
            with v.Template(v_slot_append=True), html.Div(classes="px-3 pb-2 pt-1 border-t"):
                v.VProgressLinear(indeterminate=True, v_show=("busy",), classes="mb-1", id="ffd-busy", color="primary")
                html.Div("{{ busy_text }}", v_show=("busy",), classes="text-caption")
                with html.Div(style="max-height: 20vh; overflow-y: auto;"):
                    for control in messages:
                        _messages(control)
        with layout.content:
            with v.VContainer(fluid=True, classes="pa-0 fill-height"):
                with html.Div(id="ffd-view", style="width: 100%; height: 100%; position: relative;"):
                    # server-side rendering paced by the renderer (see ..remote_view)
                    # each tab tells its mouse events apart (one tab at a time holds the mouse: PointerOwner)
                    view = RemoteView(app.editor.plotter, style="width: 100%; height: 100%;", origin=(TAB_ID,))
                    client.ClientTriggers(mounted=f"{TAB_ID} = 'tab-' + Math.random().toString(36).slice(2)")
    return layout, view
