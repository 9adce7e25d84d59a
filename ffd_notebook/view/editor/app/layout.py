"""The standalone app's page: a Vuetify 3 side panel built from :data:`..session.controls.CONTROLS`, beside the view.

Every button passes the values it needs as arguments (``click=(app.run, "['apply', [sel_i, ...]]")``),
so an action never runs with a text field's previous value; file buttons call the app's named
triggers (root folder, worker thread). Element ids (``ffd-save``, ``ffd-path``, ``ffd-view``, ...) are
stable: the browser tests use them. The uploads, downloads and the progress bar are the app's own
(a notebook reads files from the kernel's folder).
"""

from __future__ import annotations

import re
from typing import Any

from ....face.photo import PHOTO_SUFFIXES
from ....io import MESH_SUFFIXES
from ...serving.file_root import FFD_SUFFIXES
from ..session.controls import Control

__all__ = ["build_layout"]

_FIELD = {"density": "compact", "hide_details": True, "variant": "outlined"}
_COLS = {"button": 4, "choice": 6, "switch": 6, "slider": 8, "text": 12, "label": 12, "messages": 12}
#: the upload's file filter: every lattice file suffix the app reads, in both cases
_LATTICE_ACCEPT = ",".join(s for suffix in FFD_SUFFIXES for s in (suffix, suffix.upper()))
#: the mesh upload's filter: meshes, and photos (the face in a photo becomes the mesh)
_MESH_ACCEPT = ",".join(s for suffix in (*MESH_SUFFIXES, *PHOTO_SUFFIXES) for s in (suffix, suffix.upper()))
_DOWNLOAD_MESH = "utils.download('deformed.' + mesh_format, trigger('ffd_download_mesh', [mesh_format]))"
_HINTS = {"Control point": "Control point (drag a sphere or type)"}


#: a client-only state variable: each browser tab's own id (the origin of its view's mouse events)
TAB_ID = "ffd_tab"


def _disabled(control: Control) -> Any:
    """A button's ``disabled``: while it cannot act (its ``enabled`` state), and, for work that runs in a
    worker thread (an app trigger), while the app is busy."""
    conditions = (["busy"] if control.app_trigger else []) + ([f"!{control.enabled}"] if control.enabled else [])
    return (" || ".join(conditions),) if conditions else False


def _section(title: str, first: bool = False) -> None:
    from trame.widgets import vuetify3 as v

    if not first:
        v.VDivider(classes="my-2")
    v.VListSubheader(title, classes="px-0")


def _control(app: Any, control: Control) -> None:
    """The Vuetify widgets of one control (inside a VRow)."""
    from trame.widgets import vuetify3 as v

    kind, ident = control.kind, control.dom_id
    if kind == "choices":  # one select per state key (axis), the same items
        disabled = (f"!{control.enabled}",) if control.enabled else False
        for name in control.state:
            with v.VCol(cols=4):
                v.VSelect(
                    v_model=(name,),
                    items=(f"{control.key}_items",),
                    label=f"{control.key[:6]}. {name[-1]}",  # e.g. "interp. x"
                    id=f"ffd-{name}",
                    disabled=disabled,
                    **_FIELD,
                )
        return
    if kind in ("ints", "floats"):
        labels = [k[-1] if control.limits else k for k in control.state]
        for i, (name, label) in enumerate(zip(control.state, labels, strict=True)):
            extra: dict[str, Any] = {"min": 2} if kind == "ints" else {}
            if control.limits:
                extra = {"min": 0, "max": (control.limits[i],)}
            with v.VCol(cols=4):
                v.VTextField(
                    v_model=(name,),
                    label=label,
                    type="number",
                    step="1" if kind == "ints" else "any",
                    id=f"ffd-{name}",
                    **_FIELD,
                    **extra,
                )
        return
    with v.VCol(cols=_COLS.get(kind, 12)):
        if kind == "button":
            args = f"[{', '.join(control.args)}]"
            click: Any = (app.run, f"['{control.key}', {args}]")
            if control.app_trigger:
                click = f"trigger('{control.app_trigger}', {args})"
            disabled = _disabled(control)
            v.VBtn(control.label, click=click, block=True, size="small", id=ident, disabled=disabled)
        elif kind == "choice":
            items = (f"{control.key}_items",)
            v.VSelect(v_model=(control.state[0],), items=items, label=control.label, id=ident, **_FIELD)
        elif kind == "switch":
            disabled = (f"!{control.enabled}",) if control.enabled else False
            v.VSwitch(
                v_model=(control.state[0],), label=control.label, disabled=disabled, id=ident, color="primary", **_FIELD
            )
        elif kind == "text":
            v.VTextField(v_model=(control.key,), label=control.label, id=ident, classes="mt-1", **_FIELD)
        elif kind == "slider":
            low, high, step = control.bounds or (0.0, 0.95, 0.05)
            v.VSlider(
                v_model=(control.key,),
                min=low,
                max=high,
                step=step,
                label=control.label,
                thumb_label="always" if control.bounds else True,  # a value of its own (strength) stays visible
                hide_details=True,
                density="compact",
                id=ident,
            )
        elif kind == "label":
            v.VLabel(re.sub(r"\{(\w+)\}", r"{{ \1 }}", control.label), classes="text-caption", id=ident)
        elif kind == "messages":
            with v.VContainer(classes="pa-0", id=ident):
                v.VAlert(
                    v_for="(m, i) in messages",
                    key="i",
                    text=("m.text",),
                    type=("m.error ? 'error' : 'info'",),
                    density="compact",
                    variant="tonal",
                    classes="mb-1 text-caption",
                )


def _controls(app: Any, controls: list[Control]) -> None:
    """The drawer: one section per control section, one VRow per (section, row)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    sections: dict[str, dict[int, list[Control]]] = {}
    for control in controls:
        sections.setdefault(control.section, {}).setdefault(control.row, []).append(control)
    for n, (section, rows) in enumerate(sections.items()):
        _section(_HINTS.get(section, section), first=n == 0)
        if section == "Files":
            html.Div("in {{ root_name }} on the server", classes="text-caption", id="ffd-root")
        for row in rows.values():
            with v.VRow(dense=True, classes="mt-1", align="center"):
                for control in row:
                    _control(app, control)
        if section == "Files":
            _browser_files()


def _browser_files() -> None:
    """Upload from and download to the browser: no server path needed."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    _section("Your computer's files")
    v.VFileInput(
        v_model=("ffd_upload",),
        label="upload a lattice (.ffd, .tfm, .h5, .mat, .prm, .nii.gz)",
        accept=_LATTICE_ACCEPT,
        id="ffd-upload",
        prepend_icon="",
        classes="mt-2",
        disabled=("busy",),
        **_FIELD,
    )
    v.VFileInput(
        v_model=("mesh_upload",),
        label="upload a mesh, or a photo of a face",
        accept=_MESH_ACCEPT,
        id="ffd-mesh-upload",
        prepend_icon="",
        classes="mt-2",
        disabled=("busy",),
        **_FIELD,
    )
    with v.VRow(dense=True, classes="mt-1", align="center"):
        with v.VCol(cols=4):
            v.VBtn(
                "lattice",
                click="utils.download('lattice.ffd', trigger('ffd_download_ffd'), 'text/plain')",
                block=True,
                size="small",
                id="ffd-download",
                prepend_icon="mdi-download",
            )
        with v.VCol(cols=4):
            v.VBtn(
                "mesh",
                block=True,
                size="small",
                id="ffd-download-mesh",
                prepend_icon="mdi-download",
                click=_DOWNLOAD_MESH,
            )
        with v.VCol(cols=4):
            v.VSelect(v_model=("mesh_format",), items=("mesh_format_items",), id="ffd-mesh-format", **_FIELD)
    v.VProgressLinear(indeterminate=True, v_show=("busy",), classes="mt-2", id="ffd-busy", color="primary")
    html.Div("{{ busy_text }}", v_show=("busy",), classes="text-caption")


def build_layout(app: Any) -> tuple[Any, Any]:
    """Build the page for ``app`` (an :class:`~ffd_notebook.view.editor.app.EditorApp`); return (layout, view)."""
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import client, html
    from trame.widgets import vuetify3 as v

    from ...serving.remote_view import RemoteView

    toolbar = [c for c in app.controls if c.section == "toolbar"]
    app.server.state[TAB_ID] = "anonymous"  # (trame-rca's default origin) until the tab sets its own
    app.server.state.client_only(TAB_ID)
    with SinglePageWithDrawerLayout(app.server, width=340) as layout:
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
        with layout.drawer:
            with v.VContainer(classes="pa-3"):
                _controls(app, [c for c in app.controls if c.section != "toolbar"])
        with layout.content:
            with v.VContainer(fluid=True, classes="pa-0 fill-height"):
                with html.Div(id="ffd-view", style="width: 100%; height: 100%; position: relative;"):
                    # server-side rendering paced by the renderer (see ..remote_view)
                    # each tab tells its mouse events apart (one tab at a time holds the mouse: PointerOwner)
                    view = RemoteView(app.editor.plotter, style="width: 100%; height: 100%;", origin=(TAB_ID,))
                    client.ClientTriggers(mounted=f"{TAB_ID} = 'tab-' + Math.random().toString(36).slice(2)")
    return layout, view
