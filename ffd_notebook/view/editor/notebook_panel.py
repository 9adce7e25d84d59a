"""The editor's control panel for Jupyter (ipywidgets).

Every control calls one :class:`~ffd_notebook.view.editor.Editor` method; the panel has no
logic of its own. It follows the editor through :meth:`Editor.observe`: dragging a sphere selects
that control point here and shows its displacement in the X/Y/Z fields, undo/redo buttons are
enabled when there is something to undo/redo, and the last message (errors in red) is shown at
the bottom.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import ipywidgets as widgets

if TYPE_CHECKING:
    from .editor import Editor

__all__ = ["ControlPanel"]

# ipywidgets shows a ``None`` value as an empty dropdown: the panel uses "none" for "no field"
FIELD_OPTIONS = [("mesh colours", "none"), ("|displacement|", "displacement"), ("folding (det J <= 0)", "jacobian")]
PANEL_WIDTH = "410px"


def _narrow() -> widgets.Layout:
    return widgets.Layout(width="58px")


def _number() -> widgets.Layout:
    return widgets.Layout(width="84px")


def _stretch() -> widgets.Layout:
    """A text field that takes the room its row leaves."""
    return widgets.Layout(flex="1 1 auto", width="auto", min_width="90px")


def _button(
    description: str, tooltip: str, on_click: Callable[[], Any], icon: str = "", css: str = ""
) -> widgets.Button:
    # buttons never shrink below their label (flex-shrink 0); css classes let tests and users style them
    button = widgets.Button(
        description=description,
        tooltip=tooltip or description,
        icon=icon,
        layout=widgets.Layout(width="auto", flex="0 0 auto"),
    )
    if css:
        button.add_class(css)
    button.on_click(lambda _b: on_click())
    return button


class ControlPanel(widgets.VBox):
    """ipywidgets panel bound to an :class:`Editor`.

    Parameters
    ----------
    editor : Editor
        The editor the controls act on.

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

    def __init__(self, editor: Editor) -> None:
        self.editor = editor
        self._syncing = False
        nx, ny, nz = editor.lattice.shape
        # lattice
        self.shape = [widgets.BoundedIntText(value=n, min=2, max=40, layout=_narrow()) for n in (nx, ny, nz)]
        self.rebuild_button = _button(
            "Rebuild", "Fit a new lattice of this size around the mesh", self._rebuild, css="ffd-rebuild"
        )
        self.basis = widgets.Dropdown(options=["bspline", "bernstein"], value=editor.basis, layout=_number())
        self.basis.observe(lambda ch: self._call(editor.set_basis, ch["new"]), names="value")
        # control point
        self.ijk = [widgets.BoundedIntText(value=0, min=0, max=n - 1, layout=_narrow()) for n in (nx, ny, nz)]
        for w in self.ijk:
            w.observe(self._on_ijk, names="value")
        self.xyz = [widgets.FloatText(value=0.0, layout=_number()) for _ in range(3)]
        self.apply_button = _button(
            "Apply", "Set the displacement of control point (i, j, k)", self._apply, css="ffd-apply"
        )
        self.reset_point_button = _button(
            "Reset point", "Zero this control point's displacement", self._reset_point, css="ffd-reset-point"
        )
        self.reset_all_button = _button(
            "Reset all", "Zero every displacement", lambda: self._call(editor.reset), css="ffd-reset-all"
        )
        self.undo_button = _button("Undo", "Undo the last change", lambda: self._call(editor.undo), "undo", "ffd-undo")
        self.redo_button = _button("Redo", "Redo", lambda: self._call(editor.redo), "repeat", "ffd-redo")
        # files
        self.ffd_path = widgets.Text(value="lattice.ffd", placeholder="path/to/lattice.ffd", layout=_stretch())
        self.ffd_path.add_class("ffd-ffd-path")
        self.load_ffd_button = _button(
            "Load .ffd",
            "Load a lattice file",
            lambda: self._call(editor.load_ffd, self.ffd_path.value),
            css="ffd-load-ffd",
        )
        self.save_ffd_button = _button(
            "Save .ffd",
            "Save the lattice",
            lambda: self._call(editor.save_ffd, self.ffd_path.value),
            css="ffd-save-ffd",
        )
        self.mesh_path = widgets.Text(
            value="deformed.obj", placeholder="mesh.obj / .ply / .vtp / ...", layout=_stretch()
        )
        self.mesh_path.add_class("ffd-mesh-path")
        self.load_mesh_button = _button(
            "Load",
            "Load a mesh (OBJ with colours, PLY, VTP, STL, anything PyVista reads)",
            lambda: self._call(editor.load_mesh, self.mesh_path.value),
            css="ffd-load-mesh",
        )
        self.save_mesh_button = _button(
            "Save deformed",
            "Save the deformed mesh: OBJ keeps colours; PLY, VTP, STL...",
            lambda: self._call(editor.save_mesh, self.mesh_path.value),
            css="ffd-save-mesh",
        )
        # display
        self.colors = widgets.Checkbox(value=editor.colors_shown, description="colours", indent=False)
        self.colors.observe(lambda ch: self._call(editor.show_colors, ch["new"]), names="value")
        self.field = widgets.Dropdown(
            options=FIELD_OPTIONS, value=editor.field or "none", layout=widgets.Layout(width="170px")
        )
        self.field.observe(
            lambda ch: self._call(editor.set_field, None if ch["new"] == "none" else ch["new"]), names="value"
        )
        self.reduction = widgets.FloatSlider(
            value=0.0, min=0.0, max=0.95, step=0.05, readout_format=".0%", layout=_stretch()
        )
        self.decimate_button = _button(
            "Decimate",
            "Remove this fraction of the faces, keeping colours (0 restores the mesh)",
            self._decimate,
            css="ffd-decimate",
        )
        self.message = widgets.HTML(value="")

        def row(*children: widgets.Widget) -> widgets.HBox:
            return widgets.HBox(list(children))

        def label(text: str) -> widgets.Label:
            return widgets.Label(text, layout=widgets.Layout(width="104px", flex="0 0 auto"))

        super().__init__(
            [
                widgets.HTML("<b>Lattice</b>"),
                row(label("points per axis"), *self.shape, self.rebuild_button),
                row(label("basis"), self.basis),
                widgets.HTML("<b>Control point</b> <small>(drag a sphere, or pick one and type)</small>"),
                row(label("i, j, k"), *self.ijk),
                row(label("displacement"), *self.xyz),
                row(self.apply_button, self.reset_point_button, self.reset_all_button),
                row(self.undo_button, self.redo_button),
                widgets.HTML("<b>Files</b>"),
                row(self.ffd_path, self.load_ffd_button, self.save_ffd_button),
                row(self.mesh_path, self.load_mesh_button, self.save_mesh_button),
                widgets.HTML("<b>Display</b>"),
                row(self.colors, label("colour by"), self.field),
                row(label("decimate"), self.reduction, self.decimate_button),
                self.message,
            ],
            layout=widgets.Layout(padding="0 0 0 12px", width=PANEL_WIDTH, flex="0 0 auto"),
        )
        self.add_class("ffd-panel")
        editor.observe(self._follow)
        self._sync_all()

    # ------------------------------------------------------------------ actions (one editor call each)
    def _call(self, method: Callable[..., Any], *args: Any) -> None:
        if self._syncing:
            return
        self.editor.attempt(method, *args)  # a failure becomes the editor's last message, shown below
        self._sync_all()

    def _rebuild(self) -> None:
        self._call(self.editor.set_shape, tuple(w.value for w in self.shape))

    def _apply(self) -> None:
        self._call(self.editor.move_control_point, self._ijk(), tuple(w.value for w in self.xyz))

    def _reset_point(self) -> None:
        self._call(self.editor.reset, self._ijk())

    def _decimate(self) -> None:
        self._call(self.editor.decimate, self.reduction.value)

    def _on_ijk(self, _change: dict[str, Any]) -> None:
        self._call(self.editor.select, self._ijk())

    def _ijk(self) -> tuple[int, int, int]:
        return tuple(int(w.value) for w in self.ijk)  # type: ignore[return-value]

    # ------------------------------------------------------------------ following the editor
    def _follow(self, event: str) -> None:
        if event in ("drag", "select", "offsets"):
            self._sync_point()
            self._sync_history()
        elif event == "message":
            self._sync_message()
        else:
            self._sync_all()

    def _sync_all(self) -> None:
        self._syncing = True
        try:
            ed = self.editor
            for w, n in zip(self.shape, ed.lattice.shape, strict=True):
                w.value = n
            for w, n in zip(self.ijk, ed.lattice.shape, strict=True):
                w.max = n - 1
            self.basis.value = ed.basis
            self.colors.value = ed.colors_shown
            self.field.value = ed.field or "none"
        finally:
            self._syncing = False
        self._sync_point()
        self._sync_history()
        self._sync_message()

    def _sync_point(self) -> None:
        ijk = self.editor.selected
        if ijk is None:
            ijk = self._ijk()
        self._syncing = True
        try:
            for w, v in zip(self.ijk, ijk, strict=True):
                w.value = v
            for w, v in zip(self.xyz, self.editor.lattice.offsets[ijk], strict=True):
                w.value = round(float(v), 9)
        finally:
            self._syncing = False

    def _sync_history(self) -> None:
        self.undo_button.disabled = not self.editor.can_undo
        self.redo_button.disabled = not self.editor.can_redo

    def _sync_message(self) -> None:
        if self.editor.messages:
            self._show(self.editor.messages[-1])

    def _show(self, text: str) -> None:
        color = "#c62828" if text.startswith("Error") else "#2e7d32"
        self.message.value = f'<span style="color: {color}">{html.escape(text)}</span>'
