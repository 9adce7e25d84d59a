"""Surface-drag benchmark on the 53k-vertex face (issue 10, item 4: grab the mesh itself).

Run from the repository root (needs ../shared/data):

    python tests/benchmarks/bench_surface_drag.py [--events 60] [--repeat 3]

Prints, in one run and as medians (of repeats of medians; the machine is shared):

- picking the mesh point under the cursor on a press: the editor's NumPy ray test
  (:func:`ffd_notebook.view.editor.session.surface_drag.ray_hit`, bounding spheres then Moller-Trumbore)
  against the baseline ``vtkCellPicker`` on the mesh actor, after the points moved (as after a drag);
- one surface-drag event (``session.surface.move``: the least-norm fit with two pins, the
  cached FFD update of every control point involved, undo bookkeeping) against the baseline
  sphere-drag event (``session.drag``, one control point), and the one-point ``FFD.fit_points``
  solve alone against its target (<= 5 ms).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FACE = HERE.parents[2] / "shared" / "data" / "face" / "template_colored.obj"
SOLVE_TARGET_MS = 5.0


def timed(fn, n):
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=60)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--shape", type=int, default=7)
    args = parser.parse_args()

    from vtkmodules.vtkRenderingCore import vtkCellPicker

    from ffd_notebook.view import Editor

    editor = Editor(FACE, shape=(args.shape,) * 3, window_size=(800, 600))
    session, handle = editor.session, editor.scene.surface_picking
    editor.screenshot()
    print(f"face: {editor.mesh.n_points} vertices, {editor.mesh.n_cells} triangles, lattice {editor.lattice.shape}")
    w, h = editor.plotter.window_size
    rng = np.random.default_rng(0)
    xy = [(w * u, h * v) for u, v in rng.uniform(0.35, 0.65, (args.events, 2))]
    picker = vtkCellPicker()
    picker.SetTolerance(0.0005)
    picker.PickFromListOn()
    picker.AddPickList(editor.scene.mesh_actor)

    def cell_picker():
        editor.scene.display.GetPoints().Modified()  # the points moved since the last press
        for x, y in xy[:5]:
            picker.Pick(x, y, 0.0, editor.plotter.renderer)

    def ray_test():
        for x, y in xy[:5]:
            handle.pick(x, y)

    rows = {"pick: vtkCellPicker (baseline)": [], "pick: NumPy ray test (editor)": []}
    for _ in range(args.repeat):
        rows["pick: vtkCellPicker (baseline)"].append(timed(cell_picker, 3) / 5)
        rows["pick: NumPy ray test (editor)"].append(timed(ray_test, 3) / 5)

    grab = handle.pick(w / 2, h / 2)
    session.surface.pin(int(np.argmax(editor.mesh.points[:, 1])))
    session.surface.pin(int(np.argmin(editor.mesh.points[:, 1])))
    start = session.ffd.deform(grab[None])[0]
    scale = 0.05 * float(np.ptp(editor.mesh.points, axis=0).max())
    centers = session.control_points()
    index = int(np.ravel_multi_index((args.shape // 2,) * 3, editor.lattice.shape))
    solve_rows = np.array([grab])
    for _ in range(args.repeat):
        session.surface.begin(grab)
        targets = iter(start + rng.normal(0, scale, (args.events, 3)))
        rows.setdefault("event: surface drag, 2 pins (editor)", []).append(
            timed(lambda it=targets: session.surface.move(next(it)), args.events)
        )
        session.surface.end()
        moves = iter(centers[index] + rng.normal(0, scale, (args.events, 3)))
        session.begin_drag(index)
        rows.setdefault("event: sphere drag (baseline)", []).append(
            timed(lambda it=moves: session.drag(index, next(it)), args.events)
        )
        session.end_drag()
        ffd = session.ffd
        goals = iter(start + rng.normal(0, scale, (args.events, 3)))
        rows.setdefault("FFD.fit_points, one point (alone)", []).append(
            timed(lambda it=goals, f=ffd: f.fit_points(solve_rows, next(it)[None]), args.events)
        )
    for name, values in rows.items():
        print(f"{name:42s} {statistics.median(values):8.2f} ms")
    pick_ratio = statistics.median(rows["pick: NumPy ray test (editor)"]) / statistics.median(
        rows["pick: vtkCellPicker (baseline)"]
    )
    event_ratio = statistics.median(rows["event: surface drag, 2 pins (editor)"]) / statistics.median(
        rows["event: sphere drag (baseline)"]
    )
    solve = statistics.median(rows["FFD.fit_points, one point (alone)"])
    print(f"ratio pick ray test / vtkCellPicker: {pick_ratio:.2f}")
    print(f"ratio surface-drag event / sphere-drag event: {event_ratio:.2f}")
    verdict = "ok" if solve <= SOLVE_TARGET_MS else "MISSED"
    print(f"one-point solve {solve:.2f} ms, target <= {SOLVE_TARGET_MS} ms: {verdict}")
    editor.close()


if __name__ == "__main__":
    main()
