"""How long the editor's view takes to show its first image, and to answer a drag, by the route it takes.

Run from the repository root (needs /usr/bin/chromium, Playwright, jupyterhub and configurable-http-proxy; not
collected by pytest):

    python tests/benchmarks/bench_first_image.py [--routes direct one-port hub] [--repeats 3]

A notebook opens the editor (``fn.edit(shape=(5, 5, 5))``, the face, a 640x440 view) in its last cell and runs
``--repeats`` times; each time, the time from the view's iframe entering the page to its first image is taken
(the kernel is idle by then: nothing else runs in it). Then a control point is dragged in timed steps (mouse
event -> next image, :func:`browser.helpers.stepped_drag`; an outer one, as the quickstart test drags). The routes:

- ``direct``: JupyterLab without jupyter-server-proxy, the browser on the kernel's machine: the view opens the
  kernel's own port (the baseline: nothing in between);
- ``one-port``: JupyterLab under ``/lab-here/``, the browser allowed to reach Lab's address only: the view
  goes through Jupyter's proxy, found in the browser;
- ``hub``: a real JupyterHub (configurable-http-proxy in front, the hub's environment sets the proxy prefix),
  the browser allowed to reach the hub's address only: two proxies in between.

Figures are printed and written to ``test-artifacts/first_image_bench.json``; the ratios are against ``direct``.
The machine may be shared: repeat before drawing conclusions.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests/: browser.helpers

from browser.helpers import (  # noqa: E402
    ARTIFACTS,
    IDLE,
    Lab,
    drag_and_measure,
    launch_browser,
    reach_only,
    start_lab,
    wait_for,
)
from browser.hub import log_in, start_hub  # noqa: E402

OUT = ARTIFACTS / "first_image_bench.json"
SHAPE = (5, 5, 5)
CELLS = ["import ffd_notebook as fn", f"editor = fn.edit(shape={SHAPE}, window_size=(640, 440))"]
NOTEBOOK = "first_image.ipynb"


def write_notebook(work: Path) -> None:
    import nbformat

    work.mkdir(parents=True, exist_ok=True)
    cells = [nbformat.v4.new_code_cell(c) for c in CELLS]
    nbformat.write(nbformat.v4.new_notebook(cells=cells), work / NOTEBOOK)


def _view_mark(page: Any) -> float | None:
    """When the editor's current iframe entered the page (its ``data-ffd-seen`` mark), or None."""
    iframe = page.locator(".jp-CodeCell", has_text="editor = fn.edit(").first.locator("iframe.pyvista").first
    mark = iframe.get_attribute("data-ffd-seen") if iframe.count() else None
    return None if mark is None else float(mark)


def first_images(lab: Lab, page: Any, repeats: int) -> list[float]:
    """Run the notebook ``repeats`` times; each time, seconds from the new iframe entering the page to its image."""
    seen: list[float] = []
    times: list[float] = []
    for k in range(repeats):
        if k == 0:
            lab.run_notebook(page, NOTEBOOK, lambda: True)
        else:
            Lab.run_all(page)
        wait_for(lambda: _view_mark(page) not in [None, *seen], 120, "the new view's iframe")
        seen.append(float(_view_mark(page) or 0.0))
        iframe, frame = lab.view_iframe(page, "editor = fn.edit(")
        times.append(Lab.first_image_s(iframe, frame))
        page.wait_for_selector(IDLE, timeout=60_000)
    return times


def measure(lab: Lab, page: Any, trace: Path, repeats: int) -> dict[str, Any]:
    times = first_images(lab, page, repeats)
    _, frame = lab.view_iframe(page, "editor = fn.edit(")
    time.sleep(1.0)
    drag = drag_and_measure(page, frame, frame.locator("img").first, trace, shape=SHAPE, outer=True)
    return {
        "view_url": frame.url.split("?")[0],
        "iframe_to_first_image_s": times,
        "first_image_median_s": round(statistics.median(times), 2),
        "drag_event_to_frame_ms": drag["stepped"]["event_to_frame_ms"],
        "drag_event_to_callback_ms": drag["stepped"]["event_to_callback_ms"],
    }


def route_direct(tmp: Path) -> AbstractContextManager[Lab]:
    options = ("--ServerApp.jpserver_extensions=jupyter_server_proxy=False",)
    return start_lab(tmp, tmp / "work", tmp / "trace.jsonl", options=options)


def route_one_port(tmp: Path) -> AbstractContextManager[Lab]:
    return start_lab(tmp, tmp / "work", tmp / "trace.jsonl", base_url="/lab-here/")


class _HubLab(AbstractContextManager):  # the user's Lab through the hub, and the hub to log in to
    def __init__(self, tmp: Path) -> None:
        self._hub = start_hub(tmp, tmp / "work", tmp / "trace.jsonl")
        self.tmp = tmp

    def __enter__(self) -> Lab:
        self.hub = self._hub.__enter__()
        return self.hub.user_lab(self.tmp / "work")

    def __exit__(self, *exc: Any) -> Any:
        return self._hub.__exit__(*exc)


ROUTES: dict[str, Callable[[Path], AbstractContextManager[Lab]]] = {
    "direct": route_direct,
    "one-port": route_one_port,
    "hub": _HubLab,
}


def bench_route(pw: Any, route: str, tmp: Path, repeats: int) -> dict[str, Any]:
    write_notebook(tmp / "work")
    manager = ROUTES[route](tmp)
    with manager as lab:
        context = launch_browser(pw, tmp / "profile", width=1400, height=1000)
        try:
            if route != "direct":  # the browser reaches the notebook's address only
                reach_only(context, lab.origin)
            page = context.new_page()
            if isinstance(manager, _HubLab):
                log_in(page, manager.hub)
            return measure(lab, page, tmp / "trace.jsonl", repeats)
        except Exception:
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=ARTIFACTS / f"first_image_bench_{route}_failure.png")
            raise
        finally:
            context.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--routes", nargs="+", choices=list(ROUTES), default=list(ROUTES))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="ffd_bench_first_image_") as tmp, sync_playwright() as pw:
        for route in [r for r in ROUTES if r in args.routes]:
            results[route] = bench_route(pw, route, Path(tmp) / route, args.repeats)
            print(f"\n[{route}]\n{json.dumps(results[route], indent=1)}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=1))
    base = results.get("direct")
    print()
    for route, r in results.items():
        drag = r["drag_event_to_frame_ms"] or {}
        line = (f"{route:9s} first image {r['first_image_median_s']:5.2f} s (median of {args.repeats}: "
                f"{r['iframe_to_first_image_s']}) | drag event -> frame median {drag.get('median')} ms")  # fmt: skip
        if base is not None and route != "direct":
            ratio = r["first_image_median_s"] / base["first_image_median_s"]
            drag_ratio = (drag.get("median") or 0) / ((base["drag_event_to_frame_ms"] or {}).get("median") or 1)
            line += f" | x{ratio:.2f} first image, x{drag_ratio:.2f} drag against direct"
        print(line)
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
