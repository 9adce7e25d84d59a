"""Editing in a real JupyterLab through the notebook panel: drag the mesh itself, open the real registration
lattice and drag one of its control points.

A notebook opens the editor on the bundled face (``fn.edit()``); headless Chromium picks "the mesh
surface" in the panel's "mouse drags" select, pins a point of the face and drags another in the editor's
trame iframe, then types the real 11x12x11 registration .ffd's path into the panel, loads it, types an
inner control point's indices, shows the control points near it and drags one of them. The effects are
read in the kernel through the tests' instrumentation (tests/editor_instrument.py triggers, the drag trace).

Run: ``python -m pytest tests/browser/test_jupyter_editing_browser.py -m browser -s``
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import nbformat
import pytest
from browser.helpers import (
    ARTIFACTS,
    callbacks,
    cut_texts,
    drag_and_measure,
    launch_browser,
    settled_drag_state,
    start_lab,
    trigger,
    wait_for,
)
from browser.test_surface_drag_browser import pin_then_drag_the_surface, surface
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

CELLS = ["import ffd_notebook as fn", "editor = fn.edit()", "open('ready.txt', 'w').write('ok')"]
REGISTRATION_SHAPE = (11, 12, 11)
HULL = 11 * 12 * 11 - 9 * 10 * 9  # control points "auto" draws for a lattice over 1000 points


# every control of the panel inside the cell's output and showing all of its text
PANEL_CUT_OFF = r"""() => {
  const panel = document.querySelector('.ffd-panel');
  const out = panel.closest('.jp-OutputArea-output').getBoundingClientRect();
  const cut = [];
  for (const el of panel.querySelectorAll('input, select, button, .widget-label, .widget-html-content')) {
    const r = el.getBoundingClientRect();
    if (r.width && (r.left < out.left - 0.5 || r.right > out.right + 0.5 || el.scrollWidth > el.clientWidth + 1))
      cut.push(`${el.tagName} "${(el.innerText || el.value || '').slice(0, 40)}" ${r.left}-${r.right}`);
  }
  const view = document.querySelector('iframe.pyvista').getBoundingClientRect();
  return {cut, view: [view.left, view.right, view.width, view.height], panel: panel.getBoundingClientRect().left};
}"""


def spread(info: dict) -> float:
    """How far apart the drawn control points are on screen (the larger side of their box, in view widths)."""
    u, v = [w["u"] for w in info["widgets"]], [w["v"] for w in info["widgets"]]
    return max(max(u) - min(u), max(v) - min(v))


def choose(page, control: str, label: str) -> None:
    """Pick ``label`` in the notebook panel's select of ``control`` (its css class ``ffd-<control>``)."""
    select = page.locator(f".ffd-{control} select").first
    select.scroll_into_view_if_needed()
    select.select_option(label=label)


def test_surface_drag_then_the_registration_lattice_in_jupyterlab(tmp_path: Path, shared_data: Path):
    work = tmp_path / "work"
    work.mkdir()
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in CELLS]), work / "edit.ipynb")
    shutil.copy(shared_data / "seed-lineage" / "registration_11x12x11.FFD", work / "registration.ffd")
    trace = tmp_path / "trace.jsonl"
    ARTIFACTS.mkdir(exist_ok=True)
    with start_lab(tmp_path, work, trace) as lab, sync_playwright() as pw:
        # a laptop screen, JupyterLab as it opens: its file browser takes a quarter of the width
        context = launch_browser(pw, tmp_path / "profile", width=1280, height=800)
        try:
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            lab.run_notebook(page, "edit.ipynb", lambda: (work / "ready.txt").exists())
            frame = lab.editor_frame(page, "editor = fn.edit(")
            view = frame.locator("img").first

            # the panel fits beside the view: nothing cut off, the view narrower than its 800 px but usable
            page.locator(".ffd-panel").first.scroll_into_view_if_needed()
            layout = page.evaluate(PANEL_CUT_OFF)
            assert not layout["cut"], layout
            assert not cut_texts(page, ".ffd-panel")  # no text wider than its box, no choice cut (issue 32)
            assert 320 <= layout["view"][2] <= 802 and layout["view"][1] <= layout["panel"] + 1, layout
            assert abs((layout["view"][2] - 2) / (layout["view"][3] - 2) - 4 / 3) < 0.02, layout  # the window's
            # the server renders at the view's size (not the 800x600 of the window it was made with)
            width = layout["view"][2] - 2  # (the border)
            resized = lambda: abs(trigger(frame, "ffd_widget_px")["size"][0] - width) <= 2  # noqa: E731
            wait_for(resized, 20, "the render window to take the view's size")

            # the mesh itself: the panel's mode select, then a pin and a drag in the view
            choose(page, "mode", "the mesh surface")
            wait_for(lambda: surface(frame)["mode"] == "surface", 20, "surface mode in the kernel")
            time.sleep(0.5)
            pin_then_drag_the_surface(page, frame, view)
            page.screenshot(path=ARTIFACTS / "jupyter_after_surface_drag.png")
            choose(page, "mode", "control points")
            wait_for(lambda: surface(frame)["mode"] != "surface", 20, "control-point mode in the kernel")

            # the real registration lattice, by typing its path into the panel (relative to the kernel's folder)
            path_field = page.locator(".ffd-ffd-path input").first
            path_field.scroll_into_view_if_needed()
            path_field.fill("registration.ffd")
            page.locator("button.ffd-load-ffd").first.click()
            wait_for(lambda: len(trigger(frame, "ffd_widget_px")["widgets"]) == HULL, 60, "the lattice, its hull drawn")
            # the surface drag's events are all counted and traced by now (its end was awaited)
            loaded = settled_drag_state(frame, trace, 0)[0]
            traced = len(callbacks(trace))
            assert loaded["offsets_abs_sum"] > 0  # a registration result: its offsets came with it
            # 1452 spheres crowd a 436x328 view: select an inner point by its indices and show those near it
            for field, value in zip(page.locator(".ffd-ijk input").all(), (5, 6, 5), strict=True):
                field.fill(str(value))
                field.press("Enter")
            wait_for(lambda: trigger(frame, "ffd_state")["selected"] == [5, 6, 5], 20, "point (5, 6, 5) selected")
            choose(page, "points-shown", "near the selected")
            wait_for(lambda: len(trigger(frame, "ffd_widget_px")["widgets"]) < HULL, 30, "the points near (5, 6, 5)")
            # they are a small block in the middle of the view: zoom in with the mouse wheel, as a user would.
            # The panel is taller than the view, so typing into it scrolled the view out of the page: scroll its
            # iframe back from the page (an iframe out of sight gets no animation frames, which Playwright's
            # own scrolling of an element inside it waits for)
            page.locator("iframe.pyvista").first.scroll_into_view_if_needed()
            view.scroll_into_view_if_needed()
            box = view.bounding_box()
            before = spread(trigger(frame, "ffd_widget_px"))
            page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            for _ in range(4):
                page.mouse.wheel(0, -120)
                time.sleep(0.15)
            wait_for(lambda: spread(trigger(frame, "ffd_widget_px")) > 2 * before, 20, "the view to zoom in")
            time.sleep(0.5)
            metrics = drag_and_measure(page, frame, view, trace, shape=REGISTRATION_SHAPE)
            page.screenshot(path=ARTIFACTS / "jupyter_registration_after_drag.png")
            state, records = settled_drag_state(frame, trace, loaded["n_callbacks"], traced_before=traced)
            assert records and {r["index"] for r in records} == {metrics["widget"]}
            assert state["offsets_abs_sum"] != loaded["offsets_abs_sum"]
            assert state["checksum"] != loaded["checksum"], "the mesh did not change"
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyter_editing_failure.png")
            raise
        finally:
            context.close()
