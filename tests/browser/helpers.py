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

import contextlib
import json
import math
import os
import re
import shutil
import socket
import statistics
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
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
  if (window === window.top) {  // when each view's iframe enters the page: its data-ffd-seen attribute
    new MutationObserver((records) => {
      for (const record of records) for (const node of record.addedNodes) {
        if (node.nodeType !== 1) continue;
        const views = node.matches('iframe.pyvista') ? [node] : node.querySelectorAll('iframe.pyvista');
        for (const view of views) if (!view.dataset.ffdSeen) view.dataset.ffdSeen = String(now());
      }
    }).observe(document, {childList: true, subtree: true});
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


@contextlib.contextmanager
def app_server(args: list[str], cwd: Path, timeout: float = 90) -> Iterator[str]:
    """``python ARGS`` (``["-m", "ffd_notebook", "--port", P, ...]`` or ``serve_instrumented_app.py``) run in ``cwd``,
    its output in ``cwd/app.log``; yields the URL it prints once listening (with its token); stopped on exit."""
    log_path = Path(cwd) / "app.log"
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            [sys.executable, *args], cwd=cwd, stdout=log, stderr=subprocess.STDOUT, env=server_env()
        )
        try:

            def started() -> str | None:
                if proc.poll() is not None:
                    raise RuntimeError(f"the app exited with {proc.returncode}:\n{log_path.read_text()}")
                found = re.search(r"running at (http://\S+)", log_path.read_text())
                return found.group(1) if found else None

            yield wait_for(started, timeout, "the app to print its URL")
        finally:
            stop_process(proc)


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
def launch_browser(playwright: Any, profile_dir: str | os.PathLike[str], width: int = 1280, height: int = 900,
                   args: tuple[str, ...] = ()) -> Any:  # fmt: skip
    """A headless Chromium context (Debian's chromium, a fresh profile, more command-line ``args``); the init
    script is installed."""
    context = playwright.chromium.launch_persistent_context(
        str(profile_dir),
        executable_path=CHROMIUM,
        headless=True,
        args=[*CHROMIUM_ARGS, *args],
        viewport={"width": width, "height": height},
    )
    context.add_init_script(INIT_JS)
    return context


def trigger(frame: Any, name: str) -> Any:
    """Call a trame trigger of the page (or iframe) ``frame`` and return its result."""
    return frame.evaluate(f"window.trame.trigger({json.dumps(name)})")


def settled_drag_state(
    frame: Any, trace: str | os.PathLike[str], n_before: int, timeout: float = 60, traced_before: int = 0
) -> tuple[Any, list]:
    """``(ffd_state answer, trace records)`` once every drag event counted since ``n_before`` is also traced
    (the records after the first ``traced_before``, those of earlier drags).

    Events of a finished drag may still be arriving (the server handles them one by one): read both
    until they agree, never at one instant.
    """

    def agreed() -> tuple[Any, list] | None:
        state = trigger(frame, "ffd_state")
        records = callbacks(trace)[traced_before:]
        return (state, records) if state["n_callbacks"] - n_before == len(records) else None

    return wait_for(agreed, timeout, "the trace to record every drag event the editor counted")


def drawn_after_drag(frame: Any, trace: str | os.PathLike[str], n_before: int, quiet_s: float = 0.5,
                     timeout: float = 30) -> list[dict[str, Any]]:  # fmt: skip
    """Wait until a finished drag is drawn: it has drag records past ``n_before``, none arrived for ``quiet_s``,
    and the page received an image after the last one. Returns the drag's records (polls, never a fixed sleep)."""
    seen: dict[str, Any] = {"n": -1, "since": time.monotonic()}

    def drawn() -> list[dict[str, Any]] | None:
        records = callbacks(trace)[n_before:]
        if len(records) != seen["n"]:
            seen.update(n=len(records), since=time.monotonic())
            return None
        if not records or time.monotonic() - seen["since"] < quiet_s:
            return None
        frames = image_frames(frame)
        return records if frames and frames[-1]["t"] >= records[-1]["t"] * 1000.0 else None

    return wait_for(drawn, timeout, "the drag's last callback and the image after it", interval=0.1)


def image_frames(frame: Any, t_from: float | None = None, t_to: float | None = None) -> list[dict[str, Any]]:
    """Image frames (big websocket messages) received by ``frame``, optionally within [t_from, t_to) ms."""
    frames = [m for m in frame.evaluate("window.__ws || []") if m["size"] >= FRAME_MIN_BYTES]
    return [m for m in frames if (t_from is None or m["t"] >= t_from) and (t_to is None or m["t"] < t_to)]


def open_app_page(context: Any, url: str) -> tuple[Any, Any, list[str]]:
    """Open the app at ``url`` in a new page of ``context`` and wait for its first image; returns
    ``(page, view, errors)``: the view's ``<img>`` locator and the page's JavaScript errors (filled as they come)."""
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url, wait_until="load")
    view = page.locator("#ffd-view img").first
    view.wait_for(state="visible", timeout=60_000)
    wait_for(lambda: image_frames(page.main_frame), 60, "the first image")
    return page, view, errors


def widget_xy(info: dict[str, Any], box: dict[str, float], index: int) -> tuple[float, float]:
    """Page coordinates of widget ``index`` from an ``ffd_widget_px`` answer and the view's bounding box."""
    w = next(w for w in info["widgets"] if w["index"] == index)
    return box["x"] + w["u"] * box["width"], box["y"] + (1.0 - w["v"]) * box["height"]


#: an outer control point dragged by the tests moves some vertex by at least this fraction of its own move
#: (issue 10: the fitted lattice hugs the mesh, so its outer spheres visibly move it)
OUTER_PULL = 0.25


def pick_widget(
    info: dict[str, Any], box: dict[str, float], shape: tuple[int, int, int], distance: float = 90.0,
    outer: bool = False,
) -> tuple[int, float, float]:  # fmt: skip
    """A widget to drag and a drag vector.

    The widget is a visible one (a sphere in front of the mesh: a press on a hidden one turns the camera), the
    inner control point of the ``shape`` lattice that moves some vertex of the mesh
    (``moves_mesh`` in the answer; outer ones, or those of a big lattice far from the mesh, may move none)
    in the view's middle that is farthest on screen from every other sphere; with ``outer``, the outer
    control point (on the lattice's hull) that pulls some vertex by at least :data:`OUTER_PULL` of its own move.
    The direction (of ``distance`` px) keeps farthest from the other widgets and inside the view.
    """
    positions = [(w["index"], *widget_xy(info, box, w["index"]), w["z"]) for w in info["widgets"]]
    moves_mesh = {w["index"]: w.get("moves_mesh", True) for w in info["widgets"]}

    def inner(index: int) -> bool:
        ijk = np.unravel_index(index, shape)
        return all(1 <= v <= n - 2 for v, n in zip(ijk, shape, strict=True))

    def room(p: tuple[int, float, float, float]) -> float:
        # a press takes the sphere nearest the camera; one clear of the others is also clear to drag
        return min(math.hypot(p[1] - q[1], p[2] - q[2]) for q in positions if q[0] != p[0])

    pull = {w["index"]: w.get("pull", 1.0) for w in info["widgets"]}

    visible = {w["index"]: w.get("visible", True) for w in info["widgets"]}

    def wanted(index: int) -> bool:
        if not visible[index]:  # hidden behind the mesh: a press there turns the camera (issue 24)
            return False
        return pull[index] >= OUTER_PULL and not inner(index) if outer else inner(index) and moves_mesh[index]

    candidates = [
        p for p in positions
        if wanted(p[0]) and 0.15 < (p[1] - box["x"]) / box["width"] < 0.85
        and 0.15 < (p[2] - box["y"]) / box["height"] < 0.85
    ]  # fmt: skip
    assert candidates, f"no {'outer' if outer else 'inner'} control point to drag in the view"
    index, x0, y0, _ = max(candidates, key=room)
    assert room((index, x0, y0, 0.0)) > 12, "every candidate control point overlaps another sphere on screen"
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
    drawn_after_drag(frame, trace, n_before)
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
    drawn_after_drag(frame, trace, n_before)
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


def drag_and_measure(page: Any, frame: Any, view: Any, trace: Path, shape: tuple[int, int, int],
                     outer: bool = False) -> dict[str, Any]:  # fmt: skip
    """Pick a control-point sphere of the ``shape`` lattice inside ``view`` (a locator of the remote view's
    ``<img>``; an outer one with ``outer``, see :func:`pick_widget`), drag it out in timed steps, then back
    half-way in a paced drag. Returns the metrics and which widget moved."""
    view.scroll_into_view_if_needed()
    box = view.bounding_box()
    info = trigger(frame, "ffd_widget_px")
    index, dx, dy = pick_widget(info, box, shape, outer=outer)
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


# ---------------------------------------------------------------------- a panel that fits
# Every visible piece of text in ``root`` (a CSS selector): its width must lie within every element that holds it,
# up to ``root`` itself (a select's value cut to "bsp…", a button's text wider than the button, a label past the
# panel's edge); an input's value must fit its box; no two texts may cover each other (a slider's value bubble
# over the select above it). Returns one record per problem.
PANEL_FIT_JS = r"""
(root) => {
  const panel = document.querySelector(root);
  if (!panel) return [{problem: 'no element ' + root}];
  const problems = [];
  const shown = (el) => {
    for (let e = el; e; e = e.parentElement) {
      const s = getComputedStyle(e);
      if (s.display === 'none' || s.visibility === 'hidden' || s.opacity === '0') return false;
      if (e === panel) break;
    }
    const r = el.getBoundingClientRect();
    return r.width > 0 && r.height > 0;
  };
  const name = (el) => {
    const holder = el.closest('[id]');
    return (holder ? '#' + holder.id + ' ' : '') + el.tagName.toLowerCase() +
      [...el.classList].slice(0, 3).map((c) => '.' + c).join('');
  };
  const px = (r) => [Math.round(r.left), Math.round(r.right), Math.round(r.top), Math.round(r.bottom)];
  const texts = [];
  const walker = document.createTreeWalker(panel, NodeFilter.SHOW_TEXT);
  while (walker.nextNode()) {
    const node = walker.currentNode;
    const text = node.textContent.trim();
    const el = node.parentElement;
    // (a box the user scrolls on purpose, e.g. lines of code, is marked .ffd-scroll: its lines may be wider)
    if (!text || !shown(el) || el.closest('.ffd-scroll')) continue;
    const range = document.createRange();
    range.selectNodeContents(node);
    const r = range.getBoundingClientRect();
    if (r.width === 0) continue;
    for (let box = el; box; box = box.parentElement) {
      const b = box.getBoundingClientRect();
      if (r.left < b.left - 1 || r.right > b.right + 1) {
        problems.push({problem: 'text wider than its box', text, box: name(box), text_px: px(r), box_px: px(b)});
        break;
      }
      if (box === panel) break;
    }
    // the part of it in sight: inside every ancestor that clips (a scrolled-away text covers nothing)
    let seen = {left: r.left, right: r.right, top: r.top, bottom: r.bottom};
    for (let box = el.parentElement; box; box = box.parentElement) {
      if (getComputedStyle(box).overflow !== 'visible') {
        const b = box.getBoundingClientRect();
        seen = {left: Math.max(seen.left, b.left), right: Math.min(seen.right, b.right),
                top: Math.max(seen.top, b.top), bottom: Math.min(seen.bottom, b.bottom)};
      }
      if (box === panel) break;
    }
    if (seen.right - seen.left > 1 && seen.bottom - seen.top > 1) texts.push({text, r: seen, el});
  }
  // (a path the user types longer than its field scrolls in it, as in any text field: the app's are .ffd-text)
  for (const input of panel.querySelectorAll('input')) {
    if (!shown(input) || input.readOnly || input.closest('.ffd-text')) continue;
    if (['checkbox', 'radio', 'file', 'hidden', 'range'].includes(input.type)) continue;
    if (input.scrollWidth > input.clientWidth + 1) {
      problems.push({problem: 'value wider than its field', text: input.value, box: name(input),
                     value_px: input.scrollWidth, box_px: input.clientWidth});
    }
  }
  // a native select (the notebook's dropdowns) shows its option's text in its content box
  const canvas = document.createElement('canvas').getContext('2d');
  for (const select of panel.querySelectorAll('select')) {
    const option = select.options[select.selectedIndex];
    if (!shown(select) || !option) continue;
    const style = getComputedStyle(select);
    canvas.font = `${style.fontWeight} ${style.fontSize} ${style.fontFamily}`;
    const room = select.clientWidth - parseFloat(style.paddingLeft) - parseFloat(style.paddingRight);
    if (canvas.measureText(option.text).width > room + 1) {
      problems.push({problem: 'choice wider than its field', text: option.text, box: name(select),
                     value_px: canvas.measureText(option.text).width, box_px: room});
    }
  }
  for (let i = 0; i < texts.length; i++) {
    for (let j = i + 1; j < texts.length; j++) {
      const a = texts[i].r, b = texts[j].r;
      const w = Math.min(a.right, b.right) - Math.max(a.left, b.left);
      const h = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
      if (w > 1 && h > 1) {
        problems.push({problem: 'texts cover each other', text: texts[i].text + ' / ' + texts[j].text,
                       box: name(texts[i].el) + ' / ' + name(texts[j].el), px: [px(a), px(b)]});
      }
    }
  }
  return problems;
}
"""


def cut_texts(frame: Any, root: str) -> list[dict[str, Any]]:
    """What ``PANEL_FIT_JS`` finds wrong in the element ``root`` of ``frame`` (a page or an iframe): [] if all fits."""
    return frame.evaluate(PANEL_FIT_JS, root)


def open_panel_section(page: Any, section: str) -> None:
    """Unfold the app panel's ``section`` ("Files", "Display"...) if it is folded."""
    title = page.locator(f"#ffd-section-{section.lower().replace(' ', '-')} .v-expansion-panel-title")
    if title.get_attribute("aria-expanded") != "true":
        title.click()
    wait_for(lambda: title.get_attribute("aria-expanded") == "true", 20, f"the {section} section to open")


# ---------------------------------------------------------------------- JupyterLab
LAB_TOKEN = "ffd-notebook-test-token"
IDLE = ".jp-Notebook-ExecutionIndicator[data-status='idle']"


def lab_api(port: int, path: str, method: str = "GET", *, base_url: str = "/", token: str = LAB_TOKEN) -> object:
    """Call JupyterLab's REST API (``path`` relative to its ``base_url``, with ``token``); the decoded JSON answer."""
    url = f"http://127.0.0.1:{port}{base_url.rstrip('/')}{path}"
    request = urllib.request.Request(url, method=method, headers={"Authorization": f"token {token}"})
    with urllib.request.urlopen(request, timeout=10) as response:
        body = response.read()
    return json.loads(body) if body else None


def _lab_settings(root: Path) -> Path:
    """Private JupyterLab settings: no news/update toasts over the output, start the kernel without asking."""
    settings = root / ".lab-settings" / "@jupyterlab"
    for folder, name, values in (
        ("apputils-extension", "notification", {"fetchNews": "false", "checkForUpdates": False}),
        # every cell stays in the page: with windowing, the editor's iframe leaves the DOM when scrolled away
        ("notebook-extension", "tracker", {"autoStartDefaultKernel": True, "windowingMode": "none"}),
    ):
        (settings / folder).mkdir(parents=True, exist_ok=True)
        (settings / folder / f"{name}.jupyterlab-settings").write_text(json.dumps(values))
    return root / ".lab-settings"


def _instrumenting_ipython_dir(tmp_path: Path, trace: Path, frames_trace: Path | None) -> Path:
    """An IPython folder whose startup file instruments the notebook's editors (tests/editor_instrument.py and,
    with ``frames_trace``, tests/frame_timing.py): notebooks run unmodified, and the product has no setting
    that installs test hooks."""
    ipython = tmp_path / "ipython"
    startup = ipython / "profile_default" / "startup"
    startup.mkdir(parents=True)
    tests = Path(__file__).resolve().parents[1]
    frames = "" if frames_trace is None else f", frames={str(frames_trace)!r}"
    (startup / "00-instrument.py").write_text(
        f"import sys\nsys.path.insert(0, {str(tests)!r})\n"
        f"from editor_instrument import instrument_notebook_editors\n"
        f"instrument_notebook_editors({str(trace)!r}{frames})\n"
    )
    return ipython


def shut_kernels_down(lab: Lab) -> None:
    """Shut ``lab``'s kernels down cleanly (they run the trame servers), before the server is stopped."""
    try:
        for kernel in lab.api("/api/kernels") or []:  # type: ignore[union-attr]
            lab.api(f"/api/kernels/{kernel['id']}", method="DELETE")
    except Exception:
        pass


class KernelReplaced(RuntimeError):
    """JupyterLab swapped the notebook's kernel while it ran (seen right after opening a notebook)."""


class Lab:
    """A private JupyterLab started by :func:`start_lab` (or a hub user's server): its port, folder, base URL
    and API token, and ways to run a notebook in it. With ``token_in_url`` the pages it opens carry the token
    (a hub's browser logs in instead)."""

    def __init__(self, port: int, work: Path, *, base_url: str = "/", token: str = LAB_TOKEN,
                 token_in_url: bool = True, host: str = "127.0.0.1") -> None:  # fmt: skip
        self.port, self.work, self.base_url, self.token, self.token_in_url = port, work, base_url, token, token_in_url
        self.host = host

    @property
    def origin(self) -> str:
        """The address the browser reaches the server at (scheme, host and port; the test's API calls use
        127.0.0.1)."""
        return f"http://{self.host}:{self.port}"

    def api(self, path: str, method: str = "GET") -> object:
        """Call the server's REST API (``path`` under its base URL)."""
        return lab_api(self.port, path, method, base_url=self.base_url, token=self.token)

    def page_url(self, path: str, query: str = "") -> str:
        """The address of page ``path`` (under the base URL) with ``query``, and the token when it goes in URLs."""
        query = "&".join(filter(None, [f"token={self.token}" if self.token_in_url else "", query]))
        return f"{self.origin}{self.base_url}{path}" + (f"?{query}" if query else "")

    def kernels(self) -> list[dict] | None:
        """The running kernels, or None when the server could not answer this time (it answered 500 once
        while starting a kernel on a loaded machine): callers poll again."""
        try:
            return list(self.api("/api/kernels") or [])  # type: ignore[arg-type]
        except urllib.error.HTTPError as exc:
            if exc.code >= 500:
                return None
            raise

    def settled_kernel(self, page: Any) -> str:
        """The notebook's kernel once Lab has stopped changing it: one kernel, the same for 2 s, idle."""
        seen: dict = {"ids": None, "since": time.monotonic()}

        def settled() -> bool:
            kernels = self.kernels()
            if kernels is None:
                return False
            ids = [k["id"] for k in kernels]
            if ids != seen["ids"]:
                seen.update(ids=ids, since=time.monotonic())
                return False
            return len(ids) == 1 and time.monotonic() - seen["since"] > 2.0 and page.locator(IDLE).count() > 0

        wait_for(settled, 90, "JupyterLab to settle on one kernel", interval=0.5)
        return seen["ids"][0]

    @staticmethod
    def run_all(page: Any) -> int:
        """Run > Run All Cells until the first cell starts; accept a "Select Kernel" dialog. Returns the attempts."""
        for attempt in range(1, 6):
            dialog = page.locator(".jp-Dialog .jp-mod-accept")
            if dialog.count():
                dialog.first.click()
                page.wait_for_selector(IDLE, timeout=90_000)
            page.locator(".lm-MenuBar-itemLabel", has_text="Run").first.click()
            item = page.locator(".lm-Menu-itemLabel", has_text="Run All Cells").first
            item.wait_for(state="visible", timeout=10_000)
            item.click()
            try:  # the click can land before Lab is wired up: check that the first cell started
                page.wait_for_function(
                    r"""() => { const p = document.querySelector('.jp-CodeCell .jp-InputPrompt');
                                 return p && /\[(\*|\d+)\]/.test(p.textContent); }""",
                    timeout=10_000,
                )
                return attempt
            except Exception:
                page.keyboard.press("Escape")
        raise AssertionError("Run All Cells did not start the notebook")

    def done(self, page: Any, kernel: str, finished: Callable[[], bool]) -> bool:
        """True once ``finished()`` and the kernel is idle; fails on a cell's error or a replaced kernel."""
        errors = page.locator(".jp-OutputArea-output[data-mime-type='application/vnd.jupyter.stderr']")
        tracebacks = [t for t in errors.all_inner_texts() if "Traceback" in t or "Error" in t]
        assert not tracebacks, f"a notebook cell failed:\n{tracebacks[0][-2000:]}"
        kernels = self.kernels()
        if kernels is None:
            return False
        if [k["id"] for k in kernels] != [kernel]:
            raise KernelReplaced(f"kernel {kernel} was replaced by {[k['id'] for k in kernels]}")
        return finished() and kernels[0]["execution_state"] == "idle"

    def run_notebook(self, page: Any, name: str, finished: Callable[[], bool], metrics: dict | None = None) -> None:
        """Open notebook ``name``, run all its cells and wait until ``finished()`` (retried once if Lab swaps
        the kernel meanwhile); ``metrics`` receives the timings."""
        metrics = {} if metrics is None else metrics
        t0 = time.monotonic()
        page.goto(self.page_url(f"lab/tree/{name}", "reset"), wait_until="load")
        page.wait_for_selector(IDLE, timeout=90_000)
        metrics["lab_and_kernel_ready_s"] = round(time.monotonic() - t0, 1)
        for attempt in (1, 2):
            kernel = self.settled_kernel(page)
            metrics["run_all_attempts"] = self.run_all(page)
            try:
                wait_for(lambda k=kernel: self.done(page, k, finished), 120, "the last cell", interval=0.5)
                break
            except KernelReplaced:
                if attempt == 2:
                    raise
                metrics["kernel_replaced_during_run_all"] = True
        page.wait_for_selector(IDLE, timeout=60_000)

    @staticmethod
    def first_image_s(iframe: Any, frame: Any) -> float:
        """Seconds from the view's iframe entering the page to its first image (the ``data-ffd-seen`` mark)."""
        return round((image_frames(frame)[0]["t"] - float(iframe.get_attribute("data-ffd-seen"))) / 1000.0, 2)

    @staticmethod
    def view_iframe(page: Any, cell_text: str) -> tuple[Any, Any]:
        """The trame iframe (a locator) in the cell containing ``cell_text`` and its content frame, once it
        shows an image."""
        cell = page.locator(".jp-CodeCell", has_text=cell_text).first
        cell.scroll_into_view_if_needed()
        iframe = cell.locator("iframe.pyvista").first
        iframe.wait_for(state="attached", timeout=60_000)
        iframe.scroll_into_view_if_needed()
        frame = iframe.element_handle().content_frame()
        frame.wait_for_load_state("load")
        wait_for(lambda: image_frames(frame), 60, f"the first image in the view of {cell_text!r}")
        return iframe, frame

    @staticmethod
    def editor_frame(page: Any, cell_text: str) -> Any:
        """The content frame of the editor's trame iframe in the cell containing ``cell_text``, once it shows
        an image."""
        return Lab.view_iframe(page, cell_text)[1]


def lab_options(tmp_path: Path) -> list[str]:
    """JupyterLab's options for a test: private settings and workspaces, no news or update checks."""
    return [
        f"--LabApp.user_settings_dir={_lab_settings(tmp_path)}",
        f"--LabApp.workspaces_dir={tmp_path / '.lab-workspaces'}",
        "--LabApp.news_url=None", "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
    ]  # fmt: skip


def kernel_env(tmp_path: Path, trace: Path, frames_trace: Path | None = None,
               pythonpath: Path = REPO) -> dict[str, str]:  # fmt: skip
    """The environment of a Jupyter server whose kernels are instrumented (:func:`_instrumenting_ipython_dir`),
    import ffd_notebook from ``pythonpath`` and use the users' default backend (trame)."""
    env = server_env(
        IPYTHONDIR=str(_instrumenting_ipython_dir(tmp_path, trace, frames_trace)),
        JUPYTER_RUNTIME_DIR=str(tmp_path / "runtime"),
        PYTHONPATH=str(pythonpath),
    )
    env.pop("PYVISTA_JUPYTER_BACKEND", None)  # users' default: the trame backend
    return env


@contextlib.contextmanager
def start_lab(tmp_path: Path, work: Path, trace: Path, frames_trace: Path | None = None,
              pythonpath: Path = REPO, base_url: str = "/", options: tuple[str, ...] = (),
              host: str = "127.0.0.1") -> Iterator[Lab]:  # fmt: skip
    """JupyterLab on a free port of 127.0.0.1 serving ``work`` under ``base_url``, kernels instrumented (see
    :func:`_instrumenting_ipython_dir`) and importing ffd_notebook from ``pythonpath``, with more command-line
    ``options``; the browser reaches it as ``host`` (another name needs Chromium's
    :func:`host_resolver_args` and Jupyter's ``--ServerApp.allow_remote_access=True``). Its kernels and the
    server are stopped on exit."""
    port = free_port()
    env = kernel_env(tmp_path, trace, frames_trace, pythonpath)
    cmd = [
        sys.executable, "-m", "jupyter", "lab", "--no-browser", "--ip=127.0.0.1", f"--port={port}",
        f"--IdentityProvider.token={LAB_TOKEN}", f"--ServerApp.root_dir={work}",
        f"--ServerApp.base_url={base_url}", *lab_options(tmp_path), *options,
    ]  # fmt: skip
    if sys.platform.startswith("linux") and os.geteuid() == 0:
        cmd.append("--allow-root")
    log_path = tmp_path / "jupyter.log"
    lab = Lab(port, work, base_url=base_url, host=host)
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, cwd=work, stdout=log, stderr=subprocess.STDOUT, env=env)
        try:

            def up() -> object:
                if proc.poll() is not None:
                    raise RuntimeError(f"jupyter lab exited:\n{log_path.read_text()[-3000:]}")
                try:
                    return lab.api("/api/status")
                except OSError:
                    return None

            wait_for(up, 90, "JupyterLab to answer")
            yield lab
        finally:
            shut_kernels_down(lab)
            stop_process(proc)
            shutil.copy(log_path, ARTIFACTS / "jupyter.log") if ARTIFACTS.is_dir() else None


# ---------------------------------------------------------------------- the quickstart; a browser reaching one address
QUICKSTART = "01_quickstart.ipynb"
QUICKSTART_SHAPE = (5, 5, 5)  # the editor's lattice at the end of the quickstart notebook
QUICKSTART_LAST_FILE = "face_deformed.obj"  # what the notebook's last cell writes


def quickstart_folder(tmp: Path) -> tuple[Path, Path]:
    """``(work, trace)``: a folder ``tmp/work`` holding a fresh copy of the quickstart notebook, and the drag
    trace's path beside it."""
    work = tmp / "work"
    work.mkdir()
    copy_notebook(QUICKSTART, work)
    return work, tmp / "trace.jsonl"


def copy_notebook(name: str, work: Path) -> None:
    """Copy ``notebooks/<name>`` into ``work`` with its outputs cleared, as a user would open it first."""
    import nbformat

    nb = nbformat.read(REPO / "notebooks" / name, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    nbformat.write(nb, work / name)


def quickstart_drag(lab: Lab, page: Any, trace: Path, metrics: dict[str, Any]) -> tuple[Any, Any, list[dict[str, Any]]]:
    """Run the quickstart notebook in ``lab`` (any kernel left by an earlier test is shut down first), drag an
    outer control point of its editor and check from the kernel's side that the callbacks ran for that sphere
    only and the lattice and the mesh moved. Returns ``(iframe, frame, records)``: the editor's iframe
    locator and content frame, and the drag's trace records; ``metrics`` receives the timings."""
    shut_kernels_down(lab)
    wait_for(lambda: lab.kernels() == [], 60, "the earlier kernels to go")
    (lab.work / QUICKSTART_LAST_FILE).unlink(missing_ok=True)
    t0 = time.monotonic()
    # the whole notebook (programmatic edits, saving, loading) must finish before the drag: its last cell
    # writes face_deformed.obj
    lab.run_notebook(page, QUICKSTART, (lab.work / QUICKSTART_LAST_FILE).exists, metrics)
    metrics["notebook_done_s"] = round(time.monotonic() - t0, 1)
    iframe, frame = lab.view_iframe(page, "editor = fn.edit(")
    metrics["first_image_s"] = round(time.monotonic() - t0, 1)
    traced = len(callbacks(trace))  # an earlier run's records (another kernel) come first
    state0 = trigger(frame, "ffd_state")
    metrics.update(drag_and_measure(page, frame, frame.locator("img").first, trace, shape=QUICKSTART_SHAPE, outer=True))
    # the kernel saw the drag: callbacks for that sphere only, and its offset changed
    state1, records = settled_drag_state(frame, trace, state0["n_callbacks"], traced_before=traced)
    assert records and {r["index"] for r in records} == {metrics["widget"]}
    assert state1["offsets_abs_sum"] != state0["offsets_abs_sum"]
    assert state1["checksum"] != state0["checksum"], "the mesh did not change"
    ijk = np.unravel_index(metrics["widget"], QUICKSTART_SHAPE)
    assert any(v in (0, n - 1) for v, n in zip(ijk, QUICKSTART_SHAPE, strict=True)), "the sphere dragged is outer"
    assert metrics["stepped"]["event_to_frame_ms"] is not None, "no new image after the callbacks"
    assert metrics["paced"]["callbacks"] > 0
    metrics["offsets_abs_sum"] = state1["offsets_abs_sum"]
    return iframe, frame, records


def reach_only(context: Any, origin: str) -> list[str]:
    """Let the pages of ``context`` reach ``origin`` (``http://host:port``) only, like a browser that reaches a
    notebook through one forwarded port: every other request and WebSocket is refused. Returns the list of the
    refused addresses (filled as they come, while Playwright is called).

    The routes match a regular expression (every address but ``origin``'s), which the browser evaluates
    itself: with a Python predicate every request would wait for the test's Python side, which serves the
    routes of the sync API only while it is inside a Playwright call (JupyterLab then never started its kernel).
    """
    import re

    host = re.escape(origin.split("://", 1)[1])
    refused: list[str] = []

    def request(route: Any) -> None:
        refused.append(route.request.url)
        route.abort("addressunreachable")

    def socket(ws: Any) -> None:
        refused.append(ws.url)
        ws.close()

    context.route(re.compile(rf"^(?!https?://{host}/)"), request)
    context.route_web_socket(re.compile(rf"^(?!wss?://{host}/)"), socket)
    return refused


def host_resolver_args(name: str) -> tuple[str, ...]:
    """Chromium's arguments that make host ``name`` resolve to 127.0.0.1 (a remote machine's name, played here)."""
    return (f"--host-resolver-rules=MAP {name} 127.0.0.1",)


def quickstart_through_one_address(pw: Any, lab: Lab, trace: Path, tmp_path: Path, name: str,
                                   before: Callable[[Any], None] | None = None) -> dict[str, Any]:  # fmt: skip
    """The quickstart's drag (:func:`quickstart_drag`) in a browser that reaches ``lab.origin`` only
    (:func:`reach_only`; ``before(page)`` runs first, e.g. a hub's login). The view must come through Jupyter's
    proxy under ``lab.base_url`` and never try the kernel's own port, which must be out of the browser's reach
    indeed; the page's reload cookie must stay in the proxied view's folder. Screenshots go to
    ``test-artifacts/<name>_after_drag.png`` (``<name>_failure.png``), the metrics under ``name``."""
    metrics: dict[str, Any] = {}
    ARTIFACTS.mkdir(exist_ok=True)
    names = host_resolver_args(lab.host) if lab.host != "127.0.0.1" else ()
    context = launch_browser(pw, tmp_path / "profile", width=1400, height=1000, args=names)
    refused = reach_only(context, lab.origin)
    page = context.new_page()
    try:
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        if before is not None:
            before(page)
        iframe, frame, _ = quickstart_drag(lab, page, trace, metrics)
        proxied = f"{lab.origin}{lab.base_url}proxy/"
        assert frame.url.startswith(proxied), frame.url
        metrics["iframe_to_first_image_s"] = Lab.first_image_s(iframe, frame)
        # the token reached the page, and the reload cookie stays in the proxied view's folder
        cookies = [c for c in context.cookies() if c["name"].startswith("ffd_notebook_")]
        assert cookies and all(c["path"].startswith(f"{lab.base_url}proxy/") for c in cookies), cookies
        page.screenshot(path=ARTIFACTS / f"{name}_after_drag.png")
        # nothing tried the kernel's own port, which is out of this browser's reach indeed
        port = frame.url.removeprefix(proxied).split("/")[0]
        assert not [u for u in refused if f":{port}/" in u], refused
        direct = f"http://localhost:{port}/index.html"
        fetched = page.evaluate(f"fetch('{direct}', {{mode: 'no-cors'}}).then(() => 'ok', () => 'refused')")
        assert fetched == "refused" and direct in refused, (fetched, refused)
        assert not errors, errors
    except Exception:
        page.screenshot(path=ARTIFACTS / f"{name}_failure.png")
        raise
    finally:
        context.close()
    record_metrics(name, metrics)
    return metrics
