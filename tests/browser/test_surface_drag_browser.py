"""The standalone app in headless Chromium: switch to surface mode, pin a point of the face, drag another.

Run: ``python -m pytest tests/browser/test_surface_drag_browser.py -m browser -s``. The effects are read
from the server through the tests' instrumentation (``ffd_surface`` trigger of tests/editor_instrument.py).
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
from browser.helpers import ARTIFACTS, image_frames, launch_browser, open_app_page, view_box, wait_for
from browser.test_app_browser import app  # noqa: F401  (the instrumented app fixture)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def surface(page, probe=None) -> dict:
    """The ``ffd_surface`` trigger's answer (what is under each ``probe`` (u, v), pins, last grab)."""
    return page.evaluate(f"window.trame.trigger('ffd_surface', [{json.dumps(probe)}])")


def page_xy(box: dict, uv) -> tuple[float, float]:
    """Page coordinates of normalised display coordinates (origin bottom-left) in the view's box."""
    return box["x"] + uv[0] * box["width"], box["y"] + (1.0 - uv[1]) * box["height"]


def choose_points(page) -> tuple[list[float], list[float]]:
    """Two points of the face on screen, (u, v): one to grab near the middle, one to pin far from it."""
    grid = [[u, v] for u in np.linspace(0.2, 0.8, 13) for v in np.linspace(0.2, 0.8, 13)]
    hits = [uv for uv, rest in zip(grid, surface(page, grid)["probe"], strict=True) if rest is not None]
    assert len(hits) > 20, "the face is not in the middle of the view"
    middle = np.mean(hits, axis=0)
    grab = min(hits, key=lambda uv: math.dist(uv, middle))
    pin = max(hits, key=lambda uv: math.dist(uv, grab))
    return grab, pin


def pin_then_drag_the_surface(page, frame, view) -> dict:
    """Click a point of the face in ``view`` (in ``frame``) to pin it, then drag another point upwards;
    check on the server that the grabbed point followed the mouse, the pin held and the drag is one undo
    step. Returns the ``ffd_surface`` answer after the drag."""
    view.scroll_into_view_if_needed()
    box = view_box(view)
    grab_uv, pin_uv = choose_points(frame)

    # a click without movement pins the point under it
    x, y = page_xy(box, pin_uv)
    page.mouse.move(x, y)
    time.sleep(0.3)
    page.mouse.down()
    time.sleep(0.1)
    page.mouse.up()
    pinned = wait_for(lambda: surface(frame)["pins"] or None, 20, "the click to pin a point")
    assert len(pinned) == 1
    pins_before = np.array(surface(frame)["pins_world"])
    history_before = surface(frame)["history"]

    # a paced drag of the face: mouse moves 60 ms apart
    x0, y0 = page_xy(box, grab_uv)
    dx, dy = 0.0, -0.12 * box["height"]  # up
    n_frames = len(image_frames(frame))
    page.mouse.move(x0, y0)
    time.sleep(0.3)
    page.mouse.down()
    time.sleep(0.2)
    for k in range(1, 13):
        page.mouse.move(x0 + dx * k / 12, y0 + dy * k / 12)
        time.sleep(0.06)
    time.sleep(0.2)
    page.mouse.up()

    def released() -> dict | None:
        state = surface(frame)
        return state if state["grab"] is not None and not state["dragging"] else None

    state = wait_for(released, 30, "the surface drag to end on the server")
    # the grabbed point is where the mouse was released (the browser may merge the last move or two)
    moved_uv = np.subtract(state["grab_uv"], grab_uv)
    wanted_uv = np.array([dx / box["width"], -dy / box["height"]])
    assert np.linalg.norm(moved_uv - wanted_uv) < 0.25 * np.linalg.norm(wanted_uv), (moved_uv, wanted_uv)
    # the pinned point did not move, and the drag is one undo step
    np.testing.assert_allclose(state["pins_world"], pins_before, atol=1e-6)
    assert state["history"] == history_before + 1
    wait_for(lambda: len(image_frames(frame)) > n_frames, 20, "a new image after the drag")
    return state


def test_drag_the_face_itself_in_the_app(app, tmp_path):  # noqa: F811
    url, _trace, _ = app
    ARTIFACTS.mkdir(exist_ok=True)
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile")
        try:
            page, view, errors = open_app_page(context, url)

            # the mode control, as a user would: open the select, pick the option
            page.click(".v-select:has(#ffd-mode) .v-field")
            page.get_by_role("option", name="the mesh surface").click()
            wait_for(lambda: surface(page)["mode"] == "surface", 20, "surface mode on the server")

            pin_then_drag_the_surface(page, page.main_frame, view)
            page.screenshot(path=ARTIFACTS / "app_after_surface_drag.png")
            assert not errors, errors
        finally:
            context.close()
