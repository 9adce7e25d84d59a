"""Editor drag-path benchmark on the 53k-vertex face (issue: the notebook editor).

Run from the repository root (needs ../shared/data):

    python tests/benchmarks/bench_editor.py [--events 400] [--repeat 5]

Prints, in one run and as medians: the time of one sphere-widget callback
(``editor.on_widget_moved``: offsets, cached FFD update of the points one control point reaches,
in-place copy into the plotted mesh, lattice lines, undo bookkeeping) and its parts, the bare
render time of the same scene (``render_window.Render()``, 800x600, 125 sphere widgets), and the
ratio callback / render with its target (<= 10 %). Each is the median over several repeats of
the median over many events (the machine is shared).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FACE = HERE.parents[2] / "shared" / "data" / "face" / "template_colored.obj"
TARGET_RATIO = 0.10


def median_ms(samples):
    return 1000.0 * statistics.median(samples)


def drag_samples(editor, events, rng):
    """Time ``events`` widget callbacks of drags of inner control points; returns seconds per event."""
    shape = editor.lattice.shape
    inner = [(i, j, k) for i in range(1, shape[0] - 1) for j in range(1, shape[1] - 1) for k in range(1, shape[2] - 1)]
    step = 0.02 * float(editor.lattice.spacing.min())
    widgets = editor.plotter.widgets.sphere_widgets
    out = []
    per_drag = 20
    for _ in range(0, events, per_drag):
        index = int(np.ravel_multi_index(inner[rng.integers(len(inner))], shape))
        center = np.array(widgets[index].GetCenter())
        for _ in range(per_drag):
            center = center + rng.normal(0, step, 3)
            widgets[index].SetCenter(*center)
            t0 = time.perf_counter()
            editor.on_widget_moved(center, index)
            out.append(time.perf_counter() - t0)
        widgets[index].InvokeEvent("EndInteractionEvent")
    return out


def part_samples(editor, events, rng):
    """The callback's parts alone: FFD update, copy into the plotted points, lattice lines."""
    deformer, actor = editor.session.deformer, editor.scene.lattice_actor
    shape = editor.lattice.shape
    parts = {"FFD update (deformer.update(changed))": [], "mesh points in place (+Modified)": [], "lattice lines": []}
    for _ in range(events):
        ijk = tuple(int(v) for v in rng.integers(1, np.array(shape) - 1))
        editor.lattice.offsets[ijk] += rng.normal(0, 0.01 * editor.lattice.spacing.min(), 3)
        t0 = time.perf_counter()
        out = deformer.update([ijk])
        t1 = time.perf_counter()
        editor.scene.display_points[:] = out
        editor.scene.display.GetPoints().Modified()
        t2 = time.perf_counter()
        actor.set_line_points(editor.session.control_points())
        t3 = time.perf_counter()
        for name, dt in zip(parts, (t1 - t0, t2 - t1, t3 - t2), strict=True):
            parts[name].append(dt)
    return parts


def render_samples(editor, frames):
    rw = editor.plotter.render_window
    out = []
    for _ in range(frames):
        editor.plotter.camera.Azimuth(0.5)  # a real new frame each time (no cached image)
        t0 = time.perf_counter()
        rw.Render()
        out.append(time.perf_counter() - t0)
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=400, help="widget callbacks per repeat")
    parser.add_argument("--frames", type=int, default=30, help="renders per repeat")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--shape", type=int, nargs=3, default=(5, 5, 5))
    args = parser.parse_args(argv)

    from ffd_notebook.view.editor import Editor

    editor = Editor(FACE, shape=tuple(args.shape), window_size=(800, 600))
    rng = np.random.default_rng(0)
    try:
        editor.screenshot()  # first render: OpenGL set-up
        n = editor.mesh.n_points
        widgets = len(editor.plotter.widgets.sphere_widgets)
        print(
            f"face: {n} vertices, {editor.mesh.n_cells} triangles, lattice {editor.lattice.shape} ({widgets} widgets)"
        )
        print("window 800x600, multi_samples 0, machine: 2 shared cores; medians of per-repeat medians\n")
        callback, render = [], []
        parts = {}
        for _ in range(args.repeat):
            callback.append(median_ms(drag_samples(editor, args.events, rng)))
            render.append(median_ms(render_samples(editor, args.frames)))
            for name, samples in part_samples(editor, args.events, rng).items():
                parts.setdefault(name, []).append(median_ms(samples))
        cb, rd = statistics.median(callback), statistics.median(render)
        last_ms = editor.last_callback_ms
        views = {}
        for field in ("displacement", "jacobian"):
            editor.set_field(field)
            views[field] = statistics.median(median_ms(drag_samples(editor, args.events // 2, rng)) for _ in range(3))
        editor.set_field(None)
        print(f"{'widget callback (editor.on_widget_moved)':<46} {cb:8.3f} ms   per drag event")
        for name, values in parts.items():
            print(f"  {name:<44} {statistics.median(values):8.3f} ms")
        for field, ms in views.items():
            print(f"  {'with the ' + field + ' view on':<44} {ms:8.3f} ms   (no target; shown for scale)")
        print(f"{'bare render of the same scene (baseline)':<46} {rd:8.3f} ms   per frame")
        ratio = cb / rd
        verdict = "ok" if ratio <= TARGET_RATIO else "MISSED"
        print(f"{'callback / render':<46} {100 * ratio:8.2f} %    (target <= {100 * TARGET_RATIO:.0f} %)  {verdict}")
        print(f"\nlast callback as the editor reports it: editor.last_callback_ms = {last_ms:.3f} ms")
    finally:
        editor.close()


if __name__ == "__main__":
    main()
