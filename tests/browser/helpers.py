"""Shared pieces of the browser tests: headless Chromium, server processes, paced drags, metrics.

Facts these helpers rely on (measured on this kind of machine, see the project's docs):

* Playwright drives Debian's ``/usr/bin/chromium`` (``playwright install`` would download a browser).
* vtk.js forwards a drag move to the server only if the previous move was 33-200 ms earlier, so
  every drag moves the mouse in steps 40-150 ms apart, never in one jump.
* A sphere widget moves ~1.26x the cursor distance under perspective: re-read its screen position
  between drags (``ffd_widget_px`` trigger, display y is bottom-up).
* Effects are checked from the server side: the tests' instrumentation (``tests/editor_instrument.py``,
  installed by test code: ``serve_instrumented_app.py`` for the app, an IPython startup file for
  JupyterLab) appends one JSON line per drag event to a trace file and answers the ``ffd_state`` trigger.
"""

from __future__ import annotations

import json
import math
import os
import socket
import statistics
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "test-artifacts"
METRICS_FILE = ARTIFACTS / "browser_metrics.json"
CHROMIUM = os.environ.get("FFD_TEST_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
# websocket messages at least this big are image frames (JPEG attachments); state messages are smaller
FRAME_MIN_BYTES = 8000

# Runs in every frame (the trame iframe too) before the page's scripts: timestamps (epoch ms, the same clock
# as Python's time.time()) of every websocket message received and of every pointer event.
INIT_JS = r"""
(() => {
  if (window.__ffdProbe) return;
  window.__ffdProbe = true;
  const now = () => performance.timeOrigin + performance.now();
  window.__ws = [];
  window.__ptr = [];
  const Native = window.WebSocket;
  function Recording(...args) {
    const socket = new Native(...args);
    socket.addEventListener('message', (event) => {
      const d = event.data;
      const size = typeof d === 'string' ? d.length : (d.byteLength ?? d.size ?? -1);
      window.__ws.push({t: now(), size});
    });
    return socket;
  }
  Recording.prototype = Native.prototype;
  for (const k of ['CONNECTING', 'OPEN', 'CLOSING', 'CLOSED']) Recording[k] = Native[k];
  window.WebSocket = Recording;
  for (const type of ['pointerdown', 'pointermove', 'pointerup']) {
    window.addEventListener(type, (e) => window.__ptr.push({t: now(), type, x: e.clientX, y: e.clientY}), true);
  }
})();
"""


# ---------------------------------------------------------------------- processes and files
def free_port() -> int:
    """A TCP port that is free on 127.0.0.1 right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def server_env(**extra: str) -> dict[str, str]:
    """The environment for a server under test: the repository importable, EGL rendering, ``extra`` on top."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    env["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    env.pop("TRAME_ARGS", None)
    env.update(extra)
    return env


def stop_process(proc: subprocess.Popen, grace_s: float = 15.0) -> None:
    """Terminate a process we started (by its handle), killing it if it does not exit in time."""
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(grace_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)


def read_jsonl(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Records of a JSON-lines file (a missing file or a half-written last line is skipped)."""
    out = []
    try:
        with open(path) as f:
            for line in f:
                try:
                    out.append(json.loads(line))
                except json.JSONDecodeError:
                    pass
    except FileNotFoundError:
        pass
    return out


def callbacks(trace: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The editor's widget-callback records (``"ev": "cb"``) so far."""
    return [r for r in read_jsonl(trace) if r.get("ev") == "cb"]


def wait_for(predicate: Callable[[], Any], timeout: float, what: str, interval: float = 0.2) -> Any:
    """Poll ``predicate`` until it returns something truthy (returned) or raise TimeoutError."""
    end = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > end:
            raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(interval)


# ---------------------------------------------------------------------- browser
def launch_browser(playwright: Any, profile_dir: str | os.PathLike[str], width: int = 1280, height: int = 900) -> Any:
    """A headless Chromium context (Debian's chromium, a fresh profile); the init script is installed."""
    context = playwright.chromium.launch_persistent_context(
        str(profile_dir),
        executable_path=CHROMIUM,
        headless=True,
        args=CHROMIUM_ARGS,
        viewport={"width": width, "height": height},
    )
    context.add_init_script(INIT_JS)
    return context


def trigger(frame: Any, name: str) -> Any:
    """Call a trame trigger of the page (or iframe) ``frame`` and return its result."""
    return frame.evaluate(f"window.trame.trigger({json.dumps(name)})")


def settled_drag_state(
    frame: Any, trace: str | os.PathLike[str], n_before: int, timeout: float = 60
) -> tuple[Any, list]:
    """``(ffd_state answer, trace records)`` once every drag event counted since ``n_before`` is also traced.

    Events of a finished drag may still be arriving (the server handles them one by one): read both
    until they agree, never at one instant.
    """

    def agreed() -> tuple[Any, list] | None:
        state = trigger(frame, "ffd_state")
        records = callbacks(trace)
        return (state, records) if state["n_callbacks"] - n_before == len(records) else None

    return wait_for(agreed, timeout, "the trace to record every drag event the editor counted")


def image_frames(frame: Any, t_from: float | None = None, t_to: float | None = None) -> list[dict[str, Any]]:
    """Image frames (big websocket messages) received by ``frame``, optionally within [t_from, t_to) ms."""
    frames = [m for m in frame.evaluate("window.__ws || []") if m["size"] >= FRAME_MIN_BYTES]
    return [m for m in frames if (t_from is None or m["t"] >= t_from) and (t_to is None or m["t"] < t_to)]


def widget_xy(info: dict[str, Any], box: dict[str, float], index: int) -> tuple[float, float]:
    """Page coordinates of widget ``index`` from an ``ffd_widget_px`` answer and the view's bounding box."""
    w = next(w for w in info["widgets"] if w["index"] == index)
    return box["x"] + w["u"] * box["width"], box["y"] + (1.0 - w["v"]) * box["height"]


def pick_widget(
    info: dict[str, Any], box: dict[str, float], shape: tuple[int, int, int], distance: float = 90.0
) -> tuple[int, float, float]:
    """A widget to drag and a drag vector.

    The widget is the inner control point of the ``shape`` lattice (outer ones may influence no vertex of
    the mesh) in the view's middle that is farthest on screen from every other sphere.
    The direction (of ``distance`` px) keeps farthest from the other widgets and inside the view.
    """
    positions = [(w["index"], *widget_xy(info, box, w["index"]), w["z"]) for w in info["widgets"]]

    def inner(index: int) -> bool:
        ijk = np.unravel_index(index, shape)
        return all(1 <= v <= n - 2 for v, n in zip(ijk, shape, strict=True))

    def room(p: tuple[int, float, float, float]) -> float:
        # a press takes the sphere nearest the camera; one clear of the others is also clear to drag
        return min(math.hypot(p[1] - q[1], p[2] - q[2]) for q in positions if q[0] != p[0])

    candidates = [
        p for p in positions
        if inner(p[0]) and 0.15 < (p[1] - box["x"]) / box["width"] < 0.85
        and 0.15 < (p[2] - box["y"]) / box["height"] < 0.85
    ]  # fmt: skip
    assert candidates, "no inner control point in the view"
    index, x0, y0, _ = max(candidates, key=room)
    assert room((index, x0, y0, 0.0)) > 12, "every inner control point overlaps another sphere on screen"
    best = None
    for degrees in range(0, 360, 15):
        dx, dy = distance * math.cos(math.radians(degrees)), distance * math.sin(math.radians(degrees))
        if not (box["x"] + 40 < x0 + dx < box["x"] + box["width"] - 40):
            continue
        if not (box["y"] + 40 < y0 + dy < box["y"] + box["height"] - 40):
            continue
        clearance = min(
            math.hypot(x0 + dx * f - x, y0 + dy * f - y)
            for i, x, y, _ in positions
            if i != index
            for f in (0.25, 0.5, 0.75, 1.0, 1.3)  # the widget overshoots the cursor by ~1.26x
        )
        if best is None or clearance > best[0]:
            best = (clearance, dx, dy)
    assert best is not None, "no room to drag inside the view"
    return index, best[1], best[2]


# ---------------------------------------------------------------------- drags and measurements
def _summary(values: list[float]) -> dict[str, float] | None:
    if not values:
        return None
    return {
        "n": len(values),
        "median": round(statistics.median(values), 1),
        "min": round(min(values), 1),
        "max": round(max(values), 1),
    }


def stepped_drag(page: Any, frame: Any, start: tuple[float, float], delta: tuple[float, float], trace: Path,
                 n_steps: int = 6, settle_s: float = 0.6) -> dict[str, Any]:  # fmt: skip
    """Drag in ``n_steps`` isolated steps and time each one: pointer event -> Python callback -> next image.

    Each step is a 1-px primer move then, 60 ms later, the measured move (vtk.js sends a move only if
    the previous one was 33-200 ms earlier); then the drag rests ``settle_s`` so steps do not overlap.
    """
    n_before = len(callbacks(trace))
    x0, y0 = start
    page.mouse.move(x0, y0)
    time.sleep(0.3)
    page.mouse.down()
    time.sleep(0.4)
    sent = []
    for k in range(1, n_steps + 1):
        x, y = x0 + delta[0] * k / n_steps, y0 + delta[1] * k / n_steps
        page.mouse.move(x - 1, y)
        time.sleep(0.06)
        sent.append(time.time() * 1000.0)
        page.mouse.move(x, y)
        time.sleep(settle_s)
    page.mouse.up()
    time.sleep(0.8)
    # when each measured move really reached the page (first pointermove at or after sending it)
    pointer = [p["t"] for p in frame.evaluate("window.__ptr") if p["type"] == "pointermove"]
    events = [min((t for t in pointer if t >= s - 1.0), default=s) for s in sent]
    cb_times = sorted(c["t"] * 1000.0 for c in callbacks(trace)[n_before:])
    frame_times = sorted(m["t"] for m in image_frames(frame))
    rows = []
    for k, t_event in enumerate(events):
        t_next = events[k + 1] if k + 1 < len(events) else float("inf")
        cbs = [t for t in cb_times if t_event <= t < t_next]
        frames = [t for t in frame_times if cbs and cbs[0] <= t < t_next]
        rows.append({
            "step": k,
            "callbacks": len(cbs),
            "event_to_callback_ms": round(cbs[0] - t_event, 1) if cbs else None,
            "event_to_frame_ms": round(frames[0] - t_event, 1) if frames else None,
        })  # fmt: skip
    return {
        "steps": rows,
        "callbacks": len(cb_times),
        "event_to_callback_ms": _summary([r["event_to_callback_ms"] for r in rows if r["event_to_callback_ms"]]),
        "event_to_frame_ms": _summary([r["event_to_frame_ms"] for r in rows if r["event_to_frame_ms"]]),
    }


def paced_drag(page: Any, frame: Any, start: tuple[float, float], delta: tuple[float, float], trace: Path,
               n_moves: int = 30, step_s: float = 0.05) -> dict[str, Any]:  # fmt: skip
    """A continuous drag, one mouse move every ``step_s`` (40-150 ms), like a hand; frames per second."""
    assert 0.04 <= step_s <= 0.15, "vtk.js drops moves closer than 33 ms and restarts after 200 ms"
    n_before = len(callbacks(trace))
    page.mouse.move(*start)
    time.sleep(0.3)
    page.mouse.down()
    time.sleep(0.3)
    t_start = time.time() * 1000.0
    for k in range(1, n_moves + 1):
        page.mouse.move(start[0] + delta[0] * k / n_moves, start[1] + delta[1] * k / n_moves)
        time.sleep(step_s)
    t_end = time.time() * 1000.0
    page.mouse.up()
    time.sleep(1.0)
    frames = image_frames(frame, t_start, t_end)
    seconds = (t_end - t_start) / 1000.0
    return {
        "mouse_moves": n_moves,
        "step_ms": round(step_s * 1000),
        "duration_ms": round(t_end - t_start, 1),
        "callbacks": len(callbacks(trace)) - n_before,
        "frames": len(frames),
        "fps": round(len(frames) / seconds, 1),
        "frame_kb_median": round(statistics.median([f["size"] for f in frames]) / 1024, 1) if frames else None,
    }


def drag_and_measure(page: Any, frame: Any, view: Any, trace: Path, shape: tuple[int, int, int]) -> dict[str, Any]:
    """Pick a control-point sphere of the ``shape`` lattice inside ``view`` (a locator of the remote view's
    ``<img>``), drag it out in timed steps, then back half-way in a paced drag. Returns the metrics and
    which widget moved."""
    view.scroll_into_view_if_needed()
    box = view.bounding_box()
    info = trigger(frame, "ffd_widget_px")
    index, dx, dy = pick_widget(info, box, shape)
    start = widget_xy(info, box, index)
    result: dict[str, Any] = {"widget": index, "view_px": [round(box["width"]), round(box["height"])]}
    result["stepped"] = stepped_drag(page, frame, start, (dx, dy), trace)
    # the widget does not follow the cursor 1:1: grab it where it is now
    here = widget_xy(trigger(frame, "ffd_widget_px"), box, index)
    result["paced"] = paced_drag(page, frame, here, (-dx / 2, -dy / 2), trace)
    return result


def record_metrics(name: str, metrics: dict[str, Any]) -> None:
    """Merge ``metrics`` under ``name`` into test-artifacts/browser_metrics.json and print them."""
    ARTIFACTS.mkdir(exist_ok=True)
    try:
        everything = json.loads(METRICS_FILE.read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        everything = {}
    everything[name] = metrics
    METRICS_FILE.write_text(json.dumps(everything, indent=1))
    print(f"\n[{name}] browser metrics:\n{json.dumps(metrics, indent=1)}")
