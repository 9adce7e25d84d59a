"""The editor's display side: mesh colouring and fields, screenshots, trame hooks (a mixin of :class:`Editor`)."""

from __future__ import annotations

import json
import os
import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...meshing import color_array_name
from . import coloring as fields

__all__ = ["EditorDisplayMixin"]


class EditorDisplayMixin:
    """Display methods of :class:`~ffd_notebook.view.editor.Editor`."""

    @property
    def field(self) -> str | None:
        """The deformation field shown on the mesh: None, ``"displacement"`` or ``"jacobian"``."""
        return self._field

    @property
    def colors_shown(self) -> bool:
        """Whether per-vertex colours are shown (when the mesh has them and no field is shown)."""
        return self._colors_on

    @property
    def has_colors(self) -> bool:
        """Whether the mesh has per-vertex colours."""
        return color_array_name(self.mesh) is not None

    def _write_trace(self, index: int, ijk: tuple[int, int, int], center: ArrayLike) -> None:
        record = {
            "t": time.time(),
            "ev": "cb",
            "index": index,
            "ijk": list(ijk),
            "center": [float(c) for c in np.asarray(center).ravel()],
            "ms": self.last_callback_ms,
            "checksum": self.checksum(),
        }
        self._trace.write(json.dumps(record) + "\n")

    def checksum(self) -> float:
        """A cheap fingerprint of the shown mesh (for tests and traces): changes when any point moves.

        The points projected on a fixed random pattern, summed in float64. ``sum |p|`` would hardly
        change when points move across their position vectors (a drag seen along the view axis).
        """
        points = np.asarray(self._display_points, dtype=np.float64).ravel()
        pattern = getattr(self, "_checksum_pattern", None)
        if pattern is None or len(pattern) != len(points):
            pattern = np.random.default_rng(0).standard_normal(len(points))
            self._checksum_pattern = pattern
        return float(points @ pattern)

    def show_colors(self, show: bool = True) -> None:
        """Show the mesh's per-vertex colours (or a plain colour)."""
        self._colors_on = bool(show)
        if show and not self.has_colors:
            self._info("this mesh has no per-vertex colours")
        self._apply_coloring()
        self._render()
        self._notify("display")

    def set_field(self, field: str | None) -> None:
        """Colour the mesh by a deformation field: None, ``"displacement"`` or ``"jacobian"`` (folding)."""
        if field not in fields.FIELDS:
            raise ValueError(f"field must be one of {fields.FIELDS}, got {field!r}")
        self._field = field
        self._update_field()
        self._apply_coloring()
        self._render()
        if field == "jacobian":
            n = int(self._display.point_data[fields.FOLDING_ARRAY].sum())
            self._info(f"folding (det J <= 0) at {n} of {self.mesh.n_points} vertices")
        self._notify("display")

    def _apply_coloring(self) -> None:
        name = color_array_name(self._display)
        if self._field is not None:
            vmax = self._display.point_data[fields.DISPLACEMENT_ARRAY].max() if self._field == "displacement" else 1
            fields.show_field(self.mesh_actor, self._field, vmax)
        elif self._colors_on and name is not None:
            fields.show_rgb(self.mesh_actor, name)
        else:
            fields.show_plain(self.mesh_actor)

    def _update_field(self, changed: list[tuple[int, int, int]] | None = None) -> None:
        """Recompute the shown field (``changed`` is accepted for symmetry with the point update)."""
        if self._field == "displacement":
            mag = fields.displacement_magnitude(self.mesh.points, self._display_points)
            self._display.point_data[fields.DISPLACEMENT_ARRAY] = mag
            fields.set_field_range(self.mesh_actor, float(mag.max()) if len(mag) else 1.0)
        elif self._field == "jacobian":
            # the deformer reuses its cached grouping of points by cell (~20 ms on 53k points)
            fold = (self._deformer.jacobian_determinant() <= 0.0).astype(np.float32)
            shown = self._display.point_data
            if fields.FOLDING_ARRAY in shown:
                shown[fields.FOLDING_ARRAY][...] = fold  # a view of the VTK array: updated in place
                shown.GetArray(fields.FOLDING_ARRAY).Modified()
            else:
                shown[fields.FOLDING_ARRAY] = fold

    def screenshot(self, path: str | os.PathLike[str] | None = None) -> NDArray[np.uint8]:
        """Render and return the image ``(h, w, 3)`` uint8; also write a PNG if ``path`` is given."""
        self.plotter.render_window.Render()
        img = self.plotter.screenshot(return_img=True)
        if path is not None:
            from PIL import Image

            Image.fromarray(img).save(os.fspath(path))
        return img

    def widget_display_positions(self) -> list[dict[str, float]]:
        """Where each sphere widget is on screen: ``{"index", "u", "v", "z"}``, normalised, origin bottom-left."""
        ren = self.plotter.renderer
        w, h = self.plotter.render_window.GetSize()
        out = []
        for i, widget in enumerate(self._lattice_actor.widgets):
            ren.SetWorldPoint(*widget.GetCenter(), 1.0)
            ren.WorldToDisplay()
            x, y, z = ren.GetDisplayPoint()
            out.append({"index": i, "u": x / w, "v": y / h, "z": z})
        return out

    # ------------------------------------------------------------------ trame
    def register_triggers(self, server: Any) -> None:
        """Register the ``ffd_widget_px`` and ``ffd_state`` triggers on a trame server (last editor wins)."""
        server.controller.trigger("ffd_widget_px")(self._trigger_widget_px)
        server.controller.trigger("ffd_state")(self._trigger_state)

    def _trigger_widget_px(self) -> dict[str, Any]:
        return {"size": list(self.plotter.render_window.GetSize()), "widgets": self.widget_display_positions()}

    def _trigger_state(self) -> dict[str, Any]:
        return {
            "checksum": self.checksum(),
            "offsets_abs_sum": float(np.abs(self.lattice.offsets).sum()),
            "n_callbacks": self.n_callbacks,
        }

    def attach_viewer(self, viewer: Any) -> None:
        """Let a trame viewer (with ``.update()``) receive a new image after programmatic changes."""
        self._viewers.append(viewer)

    def _ipython_display_(self) -> None:
        from .notebook import display_editor

        display_editor(self)
