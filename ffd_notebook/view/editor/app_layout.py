"""The standalone app's page: a Vuetify 3 side panel next to the plotter's remote view.

Every button passes the values it needs as arguments (``click=(method, "[ffd_path]")``), so an
action never runs with a text field's previous value. Element ids (``ffd-save``, ``ffd-path``,
``ffd-view``, ...) are stable: the browser tests use them.
"""

from __future__ import annotations

from typing import Any

__all__ = ["build_layout"]

_FIELD = {"density": "compact", "hide_details": True, "variant": "outlined"}


def _section(title: str, first: bool = False) -> None:
    from trame.widgets import vuetify3 as v

    if not first:
        v.VDivider(classes="my-2")
    v.VListSubheader(title, classes="px-0")


def _numbers(names: tuple[str, ...], labels: tuple[str, ...], step: str, ids: str, **kw: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VRow(dense=True):
        for name, label in zip(names, labels, strict=True):
            with v.VCol(cols=4):
                v.VTextField(v_model=(name,), label=label, type="number", step=step, id=f"{ids}-{name}", **_FIELD, **kw)


def _lattice_section(app: Any) -> None:
    from trame.widgets import vuetify3 as v

    _section("Lattice", first=True)
    _numbers(("nx", "ny", "nz"), ("nx", "ny", "nz"), "1", "ffd", min=2)
    with v.VRow(dense=True, classes="mt-1"):
        with v.VCol(cols=6):
            v.VBtn("Rebuild", click=(app.rebuild, "[nx, ny, nz]"), block=True, id="ffd-rebuild", size="small")
        with v.VCol(cols=6):
            v.VSelect(v_model=("basis",), items=("basis_items",), label="basis", id="ffd-basis", **_FIELD)


def _point_section(app: Any) -> None:
    from trame.widgets import vuetify3 as v

    _section("Control point (drag a sphere or type)")
    with v.VRow(dense=True):
        for name, top in (("sel_i", "max_i"), ("sel_j", "max_j"), ("sel_k", "max_k")):
            with v.VCol(cols=4):
                v.VTextField(
                    v_model=(name,), label=name[-1], type="number", min=0, max=(top,), id=f"ffd-{name}", **_FIELD
                )
    _numbers(("dx", "dy", "dz"), ("X", "Y", "Z"), "any", "ffd")
    with v.VRow(dense=True, classes="mt-1"):
        with v.VCol(cols=4):
            v.VBtn("Apply", click=(app.apply_offset, "[sel_i, sel_j, sel_k, dx, dy, dz]"), block=True, size="small",
                   color="primary", id="ffd-apply")  # fmt: skip
        with v.VCol(cols=4):
            v.VBtn("Reset", click=(app.reset_point, "[sel_i, sel_j, sel_k]"), block=True, size="small",
                   id="ffd-reset-point")  # fmt: skip
        with v.VCol(cols=4):
            v.VBtn("Reset all", click=app.reset_all, block=True, size="small", id="ffd-reset-all")
    v.VLabel("{{ moved_points }} control point(s) moved", classes="text-caption mt-1")


def _file_row(label: str, model: str, buttons: list[tuple[str, str, str]], field_id: str) -> None:
    """A path field and buttons calling the named triggers (``ffd_load_ffd``, ...) with the field's value."""
    from trame.widgets import vuetify3 as v

    v.VTextField(v_model=(model,), label=label, id=field_id, classes="mt-1", **_FIELD)
    with v.VRow(dense=True, classes="mt-1"):
        for text, trigger, button_id in buttons:
            with v.VCol():
                v.VBtn(text, click=f"trigger('{trigger}', [{model}])", block=True, size="small", id=button_id,
                       disabled=("busy",))  # fmt: skip


def _browser_files() -> None:
    """Upload from and download to the browser: no server path needed."""
    from trame.widgets import vuetify3 as v

    v.VFileInput(v_model=("ffd_upload",), label="upload a .ffd", accept=".ffd,.FFD", id="ffd-upload",
                 prepend_icon="", classes="mt-2", disabled=("busy",), **_FIELD)  # fmt: skip
    v.VFileInput(v_model=("mesh_upload",), label="upload a mesh", accept=".obj,.ply,.stl,.vtp,.vtk,.vtu",
                 id="ffd-mesh-upload", prepend_icon="", classes="mt-2", disabled=("busy",), **_FIELD)  # fmt: skip
    with v.VRow(dense=True, classes="mt-1", align="center"):
        with v.VCol(cols=4):
            v.VBtn("lattice", click="utils.download('lattice.ffd', trigger('ffd_download_ffd'), 'text/plain')",
                   block=True, size="small", id="ffd-download", prepend_icon="mdi-download")  # fmt: skip
        with v.VCol(cols=4):
            v.VBtn(
                "mesh",
                block=True,
                size="small",
                id="ffd-download-mesh",
                prepend_icon="mdi-download",
                click="utils.download('deformed.' + mesh_format, trigger('ffd_download_mesh', [mesh_format]))",
            )
        with v.VCol(cols=4):
            v.VSelect(v_model=("mesh_format",), items=("mesh_format_items",), id="ffd-mesh-format", **_FIELD)


def _files_section(app: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    _section("Files")
    html.Div("in {{ root_name }} on the server", classes="text-caption", id="ffd-root")
    _file_row(".ffd file", "ffd_path", [("Load .ffd", "ffd_load_ffd", "ffd-load"), ("Save .ffd", "ffd_save_ffd",
              "ffd-save")], "ffd-path")  # fmt: skip
    _file_row("mesh to load", "mesh_path", [("Load mesh", "ffd_load_mesh", "ffd-load-mesh")], "ffd-mesh-path")
    _file_row("save deformed mesh as", "mesh_save_path", [("Save mesh", "ffd_save_mesh", "ffd-save-mesh")],
              "ffd-mesh-save-path")  # fmt: skip
    _section("Your computer's files")
    _browser_files()
    v.VProgressLinear(indeterminate=True, v_show=("busy",), classes="mt-2", id="ffd-busy", color="primary")
    html.Div("{{ busy_text }}", v_show=("busy",), classes="text-caption")


def _display_section(app: Any) -> None:
    from trame.widgets import vuetify3 as v

    _section("Display")
    v.VSwitch(v_model=("colors",), label="vertex colours", disabled=("!has_colors",), id="ffd-colors",
              color="primary", **_FIELD)  # fmt: skip
    v.VSelect(v_model=("field",), items=("field_items",), label="field on the mesh", id="ffd-field", **_FIELD)
    with v.VRow(dense=True, classes="mt-2", align="center"):
        with v.VCol(cols=8):
            v.VSlider(v_model=("reduction",), min=0, max=0.95, step=0.05, label="decimate", thumb_label=True,
                      hide_details=True, density="compact", id="ffd-reduction")  # fmt: skip
        with v.VCol(cols=4):
            v.VBtn("Apply", click=(app.decimate, "[reduction]"), block=True, size="small", id="ffd-decimate")
    v.VLabel("{{ mesh_info }}", classes="text-caption")


def _messages_section() -> None:
    from trame.widgets import vuetify3 as v

    _section("Messages")
    with v.VContainer(classes="pa-0", id="ffd-messages"):
        v.VAlert(v_for="(m, i) in messages", key="i", text=("m.text",), type=("m.error ? 'error' : 'info'",),
                 density="compact", variant="tonal", classes="mb-1 text-caption")  # fmt: skip


def build_layout(app: Any) -> tuple[Any, Any]:
    """Build the page for ``app`` (an :class:`~ffd_notebook.view.editor.app.EditorApp`); return (layout, view)."""
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import html
    from trame.widgets import vuetify3 as v
    from trame_pyvista import PyVistaRemoteView

    with SinglePageWithDrawerLayout(app.server, width=340) as layout:
        layout.title.set_text("FFD editor")
        with layout.toolbar:
            v.VSpacer()
            v.VBtn("Undo", click=app.undo, disabled=("!can_undo",), variant="text", id="ffd-undo")
            v.VBtn("Redo", click=app.redo, disabled=("!can_redo",), variant="text", id="ffd-redo")
            v.VBtn("Fit view", click=app.reset_camera, variant="text", id="ffd-fit")
        with layout.drawer:
            with v.VContainer(classes="pa-3"):
                _lattice_section(app)
                _point_section(app)
                _files_section(app)
                _display_section(app)
                _messages_section()
        with layout.content:
            with v.VContainer(fluid=True, classes="pa-0 fill-height"):
                with html.Div(id="ffd-view", style="width: 100%; height: 100%; position: relative;"):
                    # same ratio still and moving: the image is never re-scaled mid-drag
                    view = PyVistaRemoteView(app.editor.plotter, interactive_ratio=1, still_ratio=1)
    return layout, view
