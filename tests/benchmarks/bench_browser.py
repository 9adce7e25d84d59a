"""Drag a control point in a real browser and find where the time between a mouse event and the next frame goes.

Run from the repository root (needs /usr/bin/chromium and Playwright; not collected by pytest):

    python tests/benchmarks/bench_browser.py [--surface app jupyter] [--seconds 3] [--image]

For the standalone app (``python -m ffd_notebook``) and for the editor in a private JupyterLab, with the
53k-vertex face (``../shared/data/face/template.ply``), a 7x7x7 lattice and an 800x600 view: headless Chromium
grabs an inner
control point and moves the mouse every 16 ms for 3 s. Timestamps on one clock (``time.time()`` in the
server, ``performance.timeOrigin + performance.now()`` in the page) come from

- the page: every pointer event, every websocket message, every change of the view's ``<img>`` source
  (the new frame on screen);
- the server (tests/frame_timing.py): every mouse event received, every render of the editor's window
  (its Start/End events), every image handed to the websocket; the editor's drag callbacks
  (tests/editor_instrument.py).

For each pointer move of the drag, the frame that shows it is the first one displayed whose render started
after the server received that move (or a later one). The chain pointer move -> server receipt -> render
start -> render end -> image sent -> image displayed gives the split: client throttling and transport in,
waiting for the render (callback included), render, capture+encode, transport+browser decode. The bare render
(``ffd_bare_render``: the same window re-rendering the same scene) is measured in the same run; targets:
drag fps >= 0.6 x 1000 / bare render ms, event -> frame median <= 2 x bare render + 25 ms.
Figures are printed and written to ``test-artifacts/browser_bench.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests/: browser.helpers

from browser.helpers import (  # noqa: E402
    ARTIFACTS,
    REPO,
    callbacks,
    free_port,
    image_frames,
    launch_browser,
    pick_widget,
    read_jsonl,
    server_env,
    start_lab,
    stop_process,
    trigger,
    wait_for,
    widget_xy,
)

FACE = REPO.parent / "shared" / "data" / "face" / "template.ply"  # 53,349 vertices, 106k triangles (menpo3d)
SHAPE = (7, 7, 7)
VIEW = (800, 600)
IMAGE_SIZE = 192  # --image: a CT-like 192^3 float32 volume over the face's box (27 MiB), shown as three warped slices


def face_image(folder: Path) -> Path:
    """A CT-like volume over the face's bounding box (smooth noise plus a bright shell), written as NRRD."""
    import numpy as np
    import SimpleITK as sitk
    from scipy import ndimage

    from ffd_notebook.images import ImageGrid, write_image
    from ffd_notebook.io import read_mesh

    points = np.asarray(read_mesh(FACE).points, dtype=np.float64)
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.05 * (hi - lo)
    spacing = (hi - lo + 2 * pad) / (IMAGE_SIZE - 1)
    grid = ImageGrid((IMAGE_SIZE,) * 3, spacing=spacing, origin=lo - pad)
    rng = np.random.default_rng(0)
    volume = ndimage.zoom(rng.random((IMAGE_SIZE // 8,) * 3), 8, order=1).astype(np.float32) * 200.0
    k, j, i = np.meshgrid(*[np.linspace(-1, 1, IMAGE_SIZE)] * 3, indexing="ij")
    volume += (800.0 * (np.abs(np.sqrt(i**2 + j**2 + k**2) - 0.7) < 0.05)).astype(np.float32)
    path = folder / "face_ct.nrrd"
    write_image(path, grid.to_sitk(sitk.GetImageFromArray(volume)))
    return path


MOVE_MS = 16.0
OUT = ARTIFACTS / "browser_bench.json"

# Records when the view's image changes (the new frame is in the page) and the next animation frame (painted).
DISPLAY_JS = r"""
(() => {
  if (window.__ffdDisplay) return;
  window.__ffdDisplay = [];
  const now = () => performance.timeOrigin + performance.now();
  const seen = (img) => {
    const t = now();
    const rec = {t, paint: null};
    window.__ffdDisplay.push(rec);
    requestAnimationFrame(() => { rec.paint = now(); });
  };
  new MutationObserver((changes) => {
    for (const c of changes) {
      if (c.type === 'attributes' && c.target.tagName === 'IMG') seen(c.target);
      for (const n of c.addedNodes || []) if (n.tagName === 'IMG') seen(n);
    }
  }).observe(document, {subtree: true, childList: true, attributes: true, attributeFilter: ['src']});
})();
"""


# ---------------------------------------------------------------------- the drag
def circle_drag(page: Any, start: tuple[float, float], radius: float, seconds: float) -> dict[str, float]:
    """Press at ``start`` and move the mouse every 16 ms along a circle through ``start`` for ``seconds``."""
    page.mouse.move(*start)
    time.sleep(0.3)
    page.mouse.down()
    time.sleep(0.3)
    cx, cy = start[0] - radius, start[1]
    t_start = time.time()
    n, due = 0, t_start
    while due - t_start < seconds:
        # the next move is due 16 ms after the previous one was due; a late move (the browser or the machine
        # is busy) is sent at once, towards where the hand is by then: the mouse never falls behind the clock
        due = max(due + MOVE_MS / 1000.0, time.time())
        time.sleep(max(0.0, due - time.time()))
        angle = 2 * math.pi * (time.time() - t_start) / 1.5  # one turn in 1.5 s
        page.mouse.move(cx + radius * math.cos(angle), cy + radius * math.sin(angle))
        n += 1
    t_end = time.time()
    page.mouse.up()
    return {"t_start": t_start * 1000.0, "t_end": t_end * 1000.0, "moves": n}


# ---------------------------------------------------------------------- analysis
def _first(values: list[float], at_least: float) -> float | None:
    return next((v for v in values if v >= at_least), None)


def _published(pubs: list[tuple], render: tuple[float, float]) -> tuple | None:
    """The image push that carries ``render``'s picture: the first push after it, or, if that push was stale
    (trame-vtk's encoder thread had not finished, so it sent the previous picture), the push after that."""
    after = [p for p in pubs if p[0] >= render[1]]
    if not after:
        return None
    return after[0] if not after[0][1] else (after[1] if len(after) > 1 else None)


def _median(values: list[float]) -> float | None:
    values = [v for v in values if v is not None]
    return round(statistics.median(values), 1) if values else None


def analyse(window: dict[str, float], pointer: list[dict], displays: list[dict], ws: list[dict],
            server: list[dict], cbs: list[dict], bare_ms: float) -> dict[str, Any]:  # fmt: skip
    """The drag's figures (see the module docstring); every time in ms on the epoch clock."""
    t_start, t_end = window["t_start"], window["t_end"]
    moves = [p["t"] for p in pointer if p["type"] == "pointermove" and t_start <= p["t"] <= t_end]
    mouse = sorted(r["t"] * 1000.0 for r in server if r["ev"] == "mouse")
    renders = sorted((r["t0"] * 1000.0, r["t1"] * 1000.0) for r in server if r["ev"] == "render")
    pubs = sorted((r["t"] * 1000.0, r["stale"], r.get("bytes")) for r in server if r["ev"] == "pub")
    shown = sorted(d["t"] for d in displays)
    arrived = sorted(m["t"] for m in ws)
    chains = []
    for t_ev in moves:
        t_rx = _first(mouse, t_ev)
        if t_rx is None:
            continue
        render = next((r for r in renders if r[0] >= t_rx), None)
        if render is None:
            continue
        pub = _published(pubs, render)
        if pub is None:
            continue
        t_ws = _first(arrived, pub[0])
        t_show = _first(shown, pub[0])
        if t_show is None or t_show > t_end + 1000:
            continue
        chains.append({
            "event_to_frame": t_show - t_ev,
            "throttle_and_transport_in": t_rx - t_ev,
            "wait_for_render": render[0] - t_rx,
            "render": render[1] - render[0],
            "capture_and_encode": pub[0] - render[1],
            "transport": (t_ws - pub[0]) if t_ws is not None and t_ws <= t_show else None,
            "browser_decode": (t_show - t_ws) if t_ws is not None and t_ws <= t_show else None,
        })  # fmt: skip
    in_drag = [t for t in shown if t_start <= t <= t_end]
    drag_renders = [r for r in renders if t_start <= r[0] <= t_end]
    drag_pubs = [p for p in pubs if t_start <= p[0] <= t_end]
    seconds = (t_end - t_start) / 1000.0
    forwarded = [t for t in mouse if t_start <= t <= t_end]
    drag_cbs = [c for c in cbs if t_start <= c["t"] * 1000.0 <= t_end + 200]
    split = {k: _median([c[k] for c in chains]) for k in chains[0] if k != "event_to_frame"} if chains else {}
    return {
        "bare_render_ms": round(bare_ms, 1),
        "drag_fps": round(len(in_drag) / seconds, 1),
        "event_to_frame_ms": _median([c["event_to_frame"] for c in chains]),
        "callback_ms": _median([c["ms"] for c in drag_cbs]),
        "split_ms": split,
        "counts": {
            "pointer_moves": len(moves),
            "moves_forwarded": len(forwarded),
            "callbacks": len(drag_cbs),
            "renders": len(drag_renders),
            "images_sent": len(drag_pubs),
            "stale_images_sent": sum(1 for p in drag_pubs if p[1]),
            "frames_shown": len(in_drag),
            "chains": len(chains),
        },
        "render_in_drag_ms": _median([r[1] - r[0] for r in drag_renders]),
        "image_write_wait_ms": _median(
            [r["waited_ms"] for r in server if r["ev"] == "sent" and t_start <= r["t"] * 1000.0 <= t_end]
        ),
        "image_kb": _median([p[2] / 1024 for p in drag_pubs if p[2]]),
        "seconds": round(seconds, 2),
    }


def verdict(result: dict[str, Any]) -> dict[str, Any]:
    bare = result["bare_render_ms"]
    fps_target, latency_target = 0.6 * 1000.0 / bare, 2 * bare + 25.0
    latency = result["event_to_frame_ms"]
    return {
        "drag_fps_target": round(fps_target, 1),
        "event_to_frame_target_ms": round(latency_target, 1),
        "fps_pass": result["drag_fps"] >= fps_target,
        "latency_pass": latency is not None and latency <= latency_target,
    }


def measure(page: Any, frame: Any, view: Any, trace: Path, frames_trace: Path, seconds: float) -> dict[str, Any]:
    """Bare render, then the drag; returns the analysed figures."""
    view.scroll_into_view_if_needed()
    box = view.bounding_box()
    size = (round(box["width"]), round(box["height"]))
    if abs(size[0] - VIEW[0]) > 4 or abs(size[1] - VIEW[1]) > 4:  # the view shrinks in a narrow page
        raise RuntimeError(f"the view is {size[0]}x{size[1]} pixels, not {VIEW[0]}x{VIEW[1]}: widen the browser")
    before = trigger_args(frame, "ffd_bare_render", 30)
    info = trigger(frame, "ffd_widget_px")
    index, _, _ = pick_widget(info, box, SHAPE, distance=60.0)
    start = widget_xy(info, box, index)
    time.sleep(0.5)
    window = circle_drag(page, start, radius=30.0, seconds=seconds)
    time.sleep(1.5)  # the last frames arrive
    after = trigger_args(frame, "ffd_bare_render", 30)
    # the machine is shared: the bare render is the median of the samples taken just before and after the drag
    bare_ms = statistics.median(before["samples"] + after["samples"])
    result = analyse(
        window,
        frame.evaluate("window.__ptr"),
        frame.evaluate("window.__ffdDisplay"),
        image_frames(frame),
        read_jsonl(frames_trace),
        callbacks(trace),
        bare_ms,
    )
    if not result["counts"]["callbacks"]:
        raise RuntimeError("the drag moved no control point (no callback ran): the figures would be of something else")
    result["move_interval_ms"] = round((window["t_end"] - window["t_start"]) / max(1, window["moves"]), 1)
    result["view_px"] = [round(box["width"]), round(box["height"])]
    result["render_window_px"] = before["size"]
    result["bare_render_before_after_ms"] = [round(before["median"], 1), round(after["median"], 1)]
    result["render_and_readback_ms"] = round(statistics.median(before["readback"] + after["readback"]), 1)
    result.update(verdict(result))
    return result


def trigger_args(frame: Any, name: str, *args: Any) -> Any:
    """Call a trame trigger with arguments."""
    return frame.evaluate(f"window.trame.trigger({json.dumps(name)}, {json.dumps(list(args))})")


# ---------------------------------------------------------------------- surfaces
def bench_app(pw: Any, tmp: Path, seconds: float, product: Path, image: Path | None = None) -> dict[str, Any]:
    port = free_port()
    trace, frames_trace, log_path = tmp / "app_trace.jsonl", tmp / "app_frames.jsonl", tmp / "app.log"
    script = REPO / "tests" / "browser" / "serve_instrumented_app.py"
    cmd = [sys.executable, str(script), str(trace), str(FACE), "--port", str(port), "--shape", *map(str, SHAPE)]
    if image is not None:
        cmd += ["--image", str(image)]
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, cwd=tmp, stdout=log, stderr=subprocess.STDOUT,
                                env=server_env(FFD_FRAME_TRACE=str(frames_trace), PYTHONPATH=str(product)))  # fmt: skip
        try:

            def started() -> str | None:
                if proc.poll() is not None:
                    raise RuntimeError(f"the app exited:\n{log_path.read_text()}")
                found = re.search(r"running at (http://\S+)", log_path.read_text())
                return found.group(1) if found else None

            url = wait_for(started, 90, "the app's URL")
            context = launch_browser(pw, tmp / "app_profile", width=1200, height=800)
            try:
                context.add_init_script(DISPLAY_JS)
                page = context.new_page()
                page.goto(url, wait_until="load")
                view = page.locator("#ffd-view img").first
                view.wait_for(state="visible", timeout=60_000)
                wait_for(lambda: image_frames(page.main_frame), 60, "the first image")
                # size the window so that the view is 800x600 (the drawer and toolbar take the rest)
                for _ in range(3):
                    box = view.bounding_box()
                    size = page.viewport_size
                    width = size["width"] + VIEW[0] - round(box["width"])
                    height = size["height"] + VIEW[1] - round(box["height"])
                    page.set_viewport_size({"width": width, "height": height})
                    time.sleep(1.0)
                wait_for(lambda: trigger(page, "ffd_widget_px")["size"] == list(VIEW), 20, "an 800x600 render window")
                time.sleep(1.0)
                return measure(page, page.main_frame, view, trace, frames_trace, seconds)
            finally:
                context.close()
        finally:
            stop_process(proc)


NOTEBOOK_CELLS = [
    "import ffd_notebook as fn",
    f"editor = fn.edit({str(FACE)!r}, shape={SHAPE}, window_size={VIEW})",
    "open('ready.txt', 'w').write('ok')",
]


def bench_jupyter(pw: Any, tmp: Path, seconds: float, product: Path, image: Path | None = None) -> dict[str, Any]:
    import nbformat

    work = tmp / "lab"
    work.mkdir()
    cells = list(NOTEBOOK_CELLS)
    if image is not None:
        cells[1] = cells[1].replace(")", f", image={str(image)!r})")
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    nbformat.write(nb, work / "bench.ipynb")
    trace, frames_trace = tmp / "lab_trace.jsonl", tmp / "lab_frames.jsonl"
    with start_lab(tmp, work, trace, frames_trace=frames_trace, pythonpath=product) as lab:
        # wide enough for the 800x600 view beside the panel with Lab's file browser open
        context = launch_browser(pw, tmp / "lab_profile", width=1800, height=1000)
        try:
            context.add_init_script(DISPLAY_JS)
            page = context.new_page()
            lab.run_notebook(page, "bench.ipynb", lambda: (work / "ready.txt").exists())
            frame = lab.editor_frame(page, "editor = fn.edit(")
            view = frame.locator("img").first
            time.sleep(1.0)
            return measure(page, frame, view, trace, frames_trace, seconds)
        finally:
            context.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--surface", nargs="+", choices=["app", "jupyter"], default=["app", "jupyter"])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument(
        "--product",
        type=Path,
        default=REPO,
        help="the checkout whose ffd_notebook the servers run (e.g. another branch, for before/after)",
    )
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--image", action="store_true",
                        help=f"show a {IMAGE_SIZE}^3 CT-like image with the face (three warped slices): the drag's "
                             "frame rate with an image, to compare with a run without")  # fmt: skip
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="ffd_bench_browser_") as tmp, sync_playwright() as pw:
        for surface in args.surface:
            run = bench_app if surface == "app" else bench_jupyter
            image = face_image(Path(tmp)) if args.image else None
            results[surface] = run(pw, Path(tmp), args.seconds, args.product.resolve(), image)
            results[surface]["image"] = None if image is None else f"{IMAGE_SIZE}^3"
            results[surface]["product"] = str(args.product.resolve())
            print(f"\n[{surface}]\n{json.dumps(results[surface], indent=1)}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=1))
    print()
    ok = True
    for surface, r in results.items():
        passed = r["fps_pass"] and r["latency_pass"]
        ok &= passed
        print(f"{surface:8s} bare render {r['bare_render_ms']:6.1f} ms | drag {r['drag_fps']:5.1f} fps "
              f"(target >= {r['drag_fps_target']:.1f}: {'pass' if r['fps_pass'] else 'FAIL'}) | "
              f"event->frame median {r['event_to_frame_ms']} ms (target <= {r['event_to_frame_target_ms']:.0f}: "
              f"{'pass' if r['latency_pass'] else 'FAIL'}) | callback {r['callback_ms']} ms")  # fmt: skip
    print(f"written {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
