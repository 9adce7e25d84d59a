"""Editor drag-path and lattice-size benchmark on the 53k-vertex face (issue: the notebook editor; issue 10 item 2).

Run from the repository root (needs ../shared/data):

    python tests/benchmarks/bench_editor.py [--events 400] [--repeat 5]

Prints, in one run and as medians: the time of one sphere-widget callback
(``editor.on_widget_moved``: offsets, cached FFD update of the points one control point reaches,
in-place copy into the plotted mesh, lattice lines, undo bookkeeping) and its parts, the bare
render time of the same scene (``render_window.Render()``, 800x600, 125 sphere widgets), and the
ratio callback / render with its target (<= 10 %). Each is the median over several repeats of
the median over many events (the machine is shared).

Then the lattice-size figures (the same 53k-vertex face, 800x600), each opening in a fresh
subprocess so its memory is its own: opening the editor (construction + first frame) with the real
11x12x11 registration ``.ffd`` (target <= 0.3 s), with a fitted 20^3 lattice (<= 1 s and <= 100 MB
resident memory above a 5^3 one), and the frame cost with a 20^3 lattice against a 5^3 one in the
same process (target <= 1.2x), for each control-point display mode.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FACE = HERE.parents[2] / "shared" / "data" / "face" / "template_colored.obj"
REGISTRATION = HERE.parents[2] / "shared" / "data" / "seed-lineage" / "registration_11x12x11.FFD"
TARGET_RATIO = 0.10
TARGET_OPEN_FILE_S, TARGET_OPEN_20_S, TARGET_OPEN_20_MB, TARGET_FRAME_RATIO = 0.3, 1.0, 100.0, 1.2


def median_ms(samples):
    return 1000.0 * statistics.median(samples)


def drag_samples(editor, events, rng):
    """Time ``events`` widget callbacks of drags of inner control points; returns seconds per event."""
    shape = editor.lattice.shape
    inner = [(i, j, k) for i in range(1, shape[0] - 1) for j in range(1, shape[1] - 1) for k in range(1, shape[2] - 1)]
    step = 0.02 * float(editor.lattice.spacing.min())
    actor = editor.scene.lattice_actor
    out = []
    per_drag = 20
    for _ in range(0, events, per_drag):
        index = int(np.ravel_multi_index(inner[rng.integers(len(inner))], shape))
        actor.place_handle(index)
        center = np.array(actor.handle.GetCenter())
        for _ in range(per_drag):
            center = center + rng.normal(0, step, 3)
            actor.handle.SetCenter(*center)
            t0 = time.perf_counter()
            editor.on_widget_moved(center, index)
            out.append(time.perf_counter() - t0)
        actor.handle.InvokeEvent("EndInteractionEvent")
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


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def open_once(what: str) -> dict:
    """In this (fresh) process: open the editor on the 53k face with ``what`` (``"file"``: the
    registration .ffd, or ``"N"``: a fitted N^3 lattice), render the first frame; seconds and MB."""
    import pyvista as pv

    from ffd_notebook.io import load_ffd, read_mesh
    from ffd_notebook.view.editor import Editor

    mesh = read_mesh(FACE)
    lattice = load_ffd(REGISTRATION) if what == "file" else None
    shape = (5, 5, 5) if what == "file" else (int(what),) * 3
    t0 = time.perf_counter()
    pv.Plotter(off_screen=True).close()  # a process's first plotter: PyVista's one-off OpenGL probe
    first_plotter = time.perf_counter() - t0
    rss0, t0 = rss_bytes(), time.perf_counter()
    editor = Editor(mesh, lattice=lattice, shape=shape, window_size=(800, 600))
    editor.plotter.render_window.Render()
    seconds, mb = time.perf_counter() - t0, (rss_bytes() - rss0) / 2**20
    editor.close()
    return {"s": seconds, "mb": mb, "first_plotter_s": first_plotter}


def open_in_subprocess(what: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--open-once", what], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def lattice_size_figures(repeat: int, frames: int) -> None:
    """Opening times and memory (fresh processes), then frame cost 20^3 vs 5^3 (one process)."""
    from ffd_notebook.view.editor import Editor

    print("\nlattice size (53k face, 800x600; opening = Editor(...) + first frame, median of runs):")
    opened = {what: [open_in_subprocess(what) for _ in range(repeat)] for what in ("5", "file", "20")}
    keys = ("s", "mb", "first_plotter_s")
    med = {w: {k: statistics.median(r[k] for r in runs) for k in keys} for w, runs in opened.items()}
    for what, label, target in (
        ("file", "real 11x12x11 .ffd", TARGET_OPEN_FILE_S),
        ("20", "20^3 fitted", TARGET_OPEN_20_S),
    ):
        verdict = "ok" if med[what]["s"] <= target else "MISSED"
        print(f"  open, {label:<20} {med[what]['s']:8.3f} s    (target <= {target} s)  {verdict}")
    print(f"  open, {'5^3 fitted':<20} {med['5']['s']:8.3f} s    (baseline)")
    print(f"  (not counted: a process's first plotter, PyVista's OpenGL probe: {med['5']['first_plotter_s']:.3f} s)")
    extra = med["20"]["mb"] - med["5"]["mb"]
    verdict = "ok" if extra <= TARGET_OPEN_20_MB else "MISSED"
    print(f"  memory, 20^3 above 5^3    {extra:8.1f} MB   (resident; 5^3 itself {med['5']['mb']:.0f} MB; "
          f"target <= {TARGET_OPEN_20_MB:.0f} MB)  {verdict}")  # fmt: skip
    editor = Editor(FACE, shape=(5, 5, 5), window_size=(800, 600))
    try:
        for mode in ("auto", "all", "near", "hull"):
            editor.show_points(mode)
            cost = {}
            for n in (5, 20):
                editor.session.set_shape((n, n, n))
                editor.session.select((n // 2, n // 2, n - 1))
                editor.screenshot()
                cost[n] = statistics.median(median_ms(render_samples(editor, frames)) for _ in range(repeat))
            ratio = cost[20] / cost[5]
            verdict = "ok" if ratio <= TARGET_FRAME_RATIO else "MISSED"
            print(f"  frame, points shown {mode!r:<7} 5^3 {cost[5]:6.2f} ms  20^3 {cost[20]:6.2f} ms  "
                  f"ratio {ratio:5.2f}  (target <= {TARGET_FRAME_RATIO})  {verdict}")  # fmt: skip
    finally:
        editor.close()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=400, help="widget callbacks per repeat")
    parser.add_argument("--frames", type=int, default=30, help="renders per repeat")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--shape", type=int, nargs=3, default=(5, 5, 5))
    parser.add_argument("--open-once", help=argparse.SUPPRESS)  # one opening, in a subprocess
    parser.add_argument("--sizes-only", action="store_true", help="only the lattice-size figures")
    args = parser.parse_args(argv)
    if args.open_once:
        print(json.dumps(open_once(args.open_once)))
        return
    if args.sizes_only:
        lattice_size_figures(args.repeat, args.frames)
        return

    from ffd_notebook.view.editor import Editor

    editor = Editor(FACE, shape=tuple(args.shape), window_size=(800, 600))
    rng = np.random.default_rng(0)
    try:
        editor.screenshot()  # first render: OpenGL set-up
        n = editor.mesh.n_points
        glyphs = editor.scene.lattice_actor.glyphs.n_points
        print(f"face: {n} vertices, {editor.mesh.n_cells} triangles, lattice {editor.lattice.shape} ({glyphs} spheres)")
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
    lattice_size_figures(args.repeat, args.frames)


if __name__ == "__main__":
    main()
