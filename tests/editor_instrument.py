"""Test instrumentation of an Editor: it subscribes to the editor's session; the package never imports it.

What the browser and kernel tests read about an editor they drive from outside:

- :func:`fingerprint` of the shown mesh (changes when any point moves);
- a trace file, one JSON line per drag event (``{"t", "ev": "cb", "index", "ijk", "center", "ms",
  "checksum"}``), ``ms`` being the time from the widget callback's start to the end of the scene's update;
- trame triggers, ``ffd_widget_px`` (where each control point is on screen), ``ffd_state``
  (fingerprint, sum of |offsets|, number of drag events) and ``ffd_surface`` (surface mode: what is
  under a screen point, the pins, the last grabbed point), registered by :meth:`Instrument.register_triggers`.

Nothing here is reachable in normal use: test code installs it (in-process, through
``tests/browser/serve_instrumented_app.py`` for the app, or an IPython startup file for JupyterLab).
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

import numpy as np
from scipy import sparse

__all__ = ["Instrument", "fingerprint", "instrument_notebook_editors"]

_patterns: dict[int, np.ndarray] = {}


def fingerprint(points: Any) -> float:
    """A cheap fingerprint of a point set: the points projected on a fixed random pattern, summed in float64.

    ``sum |p|`` would hardly change when points move across their position vectors (a drag seen
    along the view axis); a projection on a random pattern changes with any move.
    """
    flat = np.asarray(points, dtype=np.float64).ravel()
    pattern = _patterns.get(len(flat))
    if pattern is None:
        pattern = _patterns[len(flat)] = np.random.default_rng(0).standard_normal(len(flat))
    return float(flat @ pattern)


class Instrument:
    """Counts and traces one editor's drag events; answers the tests' trame triggers.

    Parameters
    ----------
    editor : Editor
        The editor to follow (through ``editor.session.subscribe``).
    trace : path-like, optional
        A JSON-lines file to append one record per drag event to.
    """

    def __init__(self, editor: Any, *, trace: str | os.PathLike[str] | None = None) -> None:
        self.editor = editor
        self.n_drags = 0
        self.last_grab: list[float] | None = None  # rest position of the last surface-dragged point
        self._trace = open(trace, "a", buffering=1) if trace else None
        self._unsubscribe = editor.session.subscribe(self._follow)

    def _follow(self, change: Any) -> None:
        if change.kind != "drag":
            return
        if change.label == "surface drag" and self.editor.session.surface.grabbed is not None:
            self.last_grab = self.editor.session.surface.grabbed.tolist()
        self.n_drags += 1
        if self._trace is None:
            return
        session = self.editor.session
        index = int(change.points[0])
        record = {
            "t": time.time(),
            "ev": "cb",
            "index": index,
            "ijk": [int(v) for v in np.unravel_index(index, session.lattice.shape)],
            "center": [float(c) for c in session.control_points()[index]],
            "ms": (time.perf_counter() - change.started) * 1000.0,
            "checksum": self.fingerprint(),
        }
        self._trace.write(json.dumps(record) + "\n")

    def fingerprint(self) -> float:
        """:func:`fingerprint` of the points the renderer draws."""
        return fingerprint(self.editor.scene.shown_points())

    def widget_display_positions(self) -> list[dict[str, float]]:
        """Where each drawn control point is on screen: ``{"index", "u", "v", "z"}``, normalised, origin
        bottom-left (the points the display setting hides are left out: nobody can grab them), whether it
        moves some vertex (``"moves_mesh"``) and its largest pull on a vertex (``"pull"``: the fraction of
        its own move that vertex makes), and whether a press on it grabs it (``"visible"``: its sphere is in
        front of the mesh there; a hidden one takes Alt, issue 24)."""
        plotter = self.editor.plotter
        ren = plotter.renderer
        w, h = plotter.render_window.GetSize()
        shown = set(self.editor.scene.lattice_actor.shown.tolist())
        from ffd_notebook.ffd.fit import control_weights

        index, weight = control_weights(self.editor.session.ffd, self.editor.session.rest_points)
        rows = np.repeat(np.arange(len(index)), index.shape[1])
        # a control point's pull on each vertex (repeated indices of the clamp border add up), its largest
        n_points = int(np.prod(self.editor.lattice.shape))
        pulls = sparse.coo_matrix((weight.ravel(), (rows, index.ravel())), shape=(len(index), n_points)).tocsr()
        pull = np.asarray(pulls.max(axis=0).todense()).ravel()
        out = []
        actor = self.editor.scene.lattice_actor
        for i, center in enumerate(self.editor.session.control_points()):
            if i not in shown:
                continue
            ren.SetWorldPoint(*center, 1.0)
            ren.WorldToDisplay()
            x, y, z = ren.GetDisplayPoint()
            visible = bool(actor.in_front([i], x, y)[0])
            out.append({"index": i, "u": x / w, "v": y / h, "z": z, "moves_mesh": bool(pull[i] > 0),
                        "pull": float(pull[i]), "visible": visible})  # fmt: skip
        return out

    def surface(self, probe: list[list[float]] | None = None) -> dict[str, Any]:
        """What the ``ffd_surface`` trigger answers: the mode, the pins (rest and on screen), the last
        grabbed point (rest and on screen), and for each ``probe`` ``(u, v)`` the rest point under it (or None)."""
        session, handle = self.editor.session, self.editor.scene.surface_picking
        w, h = self.editor.plotter.render_window.GetSize()

        def on_screen(rest: Any) -> list[list[float]]:
            rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
            shown = handle.world_to_display(session.ffd.deform(rest)) if len(rest) else np.empty((0, 3))
            return [[float(x) / w, float(y) / h] for x, y, _ in shown]

        hits = [handle.pick(u * w, v * h) for u, v in probe or []]
        return {
            "mode": session.surface.mode,
            "pins": session.surface.pins.tolist(),
            "pins_uv": on_screen(session.surface.pins),
            "pins_world": session.surface.pinned_points().tolist(),
            "grab": self.last_grab,
            "grab_uv": on_screen(self.last_grab)[0] if self.last_grab is not None else None,
            "dragging": session.surface.grabbed is not None,
            "history": len(session.history),
            "probe": [None if hit is None else hit.tolist() for hit in hits],
        }

    def image(self) -> dict[str, Any]:
        """What the ``ffd_image`` trigger answers: per slice, the texels the scene draws, whether they are the
        session's current slice values, and which of them the selected (inner) control point reaches (its
        cubic B-spline support: two cells each way)."""
        from ffd_notebook.view.editor.scene.image_slices import to_texels

        shown_slices, session = self.editor.scene.image_slices, self.editor.session
        if shown_slices is None:
            return {"loaded": False}
        selected = session.selected
        answer: dict[str, Any] = {"loaded": True, "selected": None if selected is None else list(selected), "axes": {}}
        for axis in shown_slices.planes:
            texels = shown_slices.shown_values(axis)
            current = to_texels(session.image.slices.values[axis], session.image.window)
            u = session.lattice.to_lattice(session.image.slices.slice_points(axis))
            reach = None if selected is None else np.all(np.abs(u - np.array(selected)) < 2.0, axis=1).tolist()
            same = bool(np.array_equal(texels, current))
            answer["axes"][str(axis)] = {"texels": texels.ravel().tolist(), "current": same, "reach": reach}
        return answer

    def state(self) -> dict[str, Any]:
        """What the ``ffd_state`` trigger answers."""
        return {
            "checksum": self.fingerprint(),
            "offsets_abs_sum": float(np.abs(self.editor.lattice.offsets).sum()),
            "n_callbacks": self.n_drags,
            "selected": None if self.editor.session.selected is None else list(self.editor.session.selected),
            "n_points": int(self.editor.mesh.n_points),
            "messages": list(self.editor.messages)[-3:],
        }

    def register_triggers(self, server: Any) -> None:
        """Register ``ffd_widget_px`` and ``ffd_state`` on a trame server (the last instrument wins)."""
        size = lambda: list(self.editor.plotter.render_window.GetSize())  # noqa: E731
        server.controller.trigger("ffd_widget_px")(lambda: {"size": size(), "widgets": self.widget_display_positions()})
        server.controller.trigger("ffd_state")(self.state)
        server.controller.trigger("ffd_surface")(self.surface)
        server.controller.trigger("ffd_image")(self.image)

    def close(self) -> None:
        """Stop following the editor; close the trace file."""
        self._unsubscribe()
        if self._trace is not None:
            self._trace.close()
            self._trace = None


def instrument_notebook_editors(
    trace: str | os.PathLike[str] | None = None, frames: str | os.PathLike[str] | None = None
) -> None:
    """In an IPython kernel: instrument every Editor a cell leaves in the user's namespace.

    After each cell, new editors get an :class:`Instrument` (tracing to ``trace``) whose triggers are
    registered on the trame server that serves the package's notebook views; with ``frames``, also a
    :class:`frame_timing.FrameTimer` logging there (its protocol patches are installed right away,
    before any trame server starts).
    """
    import sys

    from IPython import get_ipython

    shell = get_ipython()
    seen: dict[int, Instrument] = {}
    if frames is not None:
        import frame_timing

        frame_timing.install(frames)

    def after_cell(_result: Any = None) -> None:
        if "ffd_notebook.view.editor" not in sys.modules:  # no editor yet: import nothing
            return
        from ffd_notebook.view.editor import Editor

        for value in list(shell.user_ns.values()):
            if isinstance(value, Editor) and id(value) not in seen:
                from trame_pyvista.widgets import get_server

                from ffd_notebook.view.serving.jupyter import SERVER_NAME

                seen[id(value)] = inst = Instrument(value, trace=trace)
                inst.register_triggers(get_server(SERVER_NAME))
                if frames is not None:
                    frame_timing.FrameTimer(value, frames).register_triggers(get_server(SERVER_NAME))

    shell.events.register("post_run_cell", after_cell)
