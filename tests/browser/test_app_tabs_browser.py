"""The standalone app open in two browser tabs (issue 24): one session that every tab follows.

A drag in one tab shows in the other with the same frame (the server broadcasts each image to every tab), its
panel follows (moved control points, undo enabled), the other tab undoes it, and two tabs dragging at the same
time make one drag (one undo step): one tab at a time holds the mouse.

Run: ``python -m pytest tests/browser/test_app_tabs_browser.py -m browser -s``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from browser.helpers import (
    ARTIFACTS,
    app_server,
    free_port,
    image_frames,
    launch_browser,
    open_app_page,
    pick_widget,
    trigger,
    wait_for,
    widget_xy,
)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

INSTRUMENTED_APP = Path(__file__).resolve().parent / "serve_instrumented_app.py"


@pytest.fixture
def app_url(tmp_path: Path):
    with app_server(
        [str(INSTRUMENTED_APP), str(tmp_path / "trace.jsonl"), "--port", str(free_port())], tmp_path
    ) as url:
        yield url


def _drag(page, start, delta, n_steps: int = 6) -> None:
    """Press at ``start``, move by ``delta`` in steps 80 ms apart (vtk.js sends a move only if the previous one
    was at least 33 ms earlier), release."""
    x0, y0 = start
    page.mouse.move(x0, y0)
    time.sleep(0.2)
    page.mouse.down()
    time.sleep(0.3)
    for k in range(1, n_steps + 1):
        page.mouse.move(x0 + delta[0] * k / n_steps, y0 + delta[1] * k / n_steps)
        time.sleep(0.08)


def _moved_label(page) -> str:
    return page.locator("body").inner_text()


def _view_pixels(view) -> np.ndarray:
    from io import BytesIO

    from PIL import Image

    return np.asarray(Image.open(BytesIO(view.screenshot())).convert("RGB"), dtype=np.int16)


def _history(page) -> int:
    return trigger(page, "ffd_surface")["history"]


def test_two_tabs_follow_one_session_and_undo_each_other(app_url, tmp_path: Path):
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile")
        try:
            a, view_a, errors_a = open_app_page(context, app_url)
            b, view_b, errors_b = open_app_page(context, app_url)
            time.sleep(1.0)
            state0 = trigger(a, "ffd_state")
            assert state0["offsets_abs_sum"] == 0 and _history(a) == 0
            before_b = _view_pixels(view_b)

            # a drag in tab A
            box = view_a.bounding_box()
            info = trigger(a, "ffd_widget_px")
            index, dx, dy = pick_widget(info, box, (5, 5, 5), outer=True)
            _drag(a, widget_xy(info, box, index), (dx, dy))
            frames_a, frames_b = len(image_frames(a.main_frame)), len(image_frames(b.main_frame))
            released = time.time() * 1000.0
            a.mouse.up()
            wait_for(lambda: _history(a) == 1, 20, "the drag's undo step")
            assert trigger(a, "ffd_state")["offsets_abs_sum"] > 0

            # tab B shows it: the frame after the release reaches B when it reaches A (the same broadcast)
            def after_release(page) -> list[float]:
                return [m["t"] for m in image_frames(page.main_frame) if m["t"] >= released]

            wait_for(lambda: after_release(a) and after_release(b), 20, "a frame after the release in both tabs")
            first_a, first_b = after_release(a)[0], after_release(b)[0]
            assert abs(first_b - first_a) < 250, f"tab B got the release's frame {first_b - first_a:.0f} ms later"
            assert len(image_frames(b.main_frame)) > frames_b and len(image_frames(a.main_frame)) > frames_a
            time.sleep(1.0)  # the sharp still frame
            moved_b = np.abs(_view_pixels(view_b) - before_b).max(axis=-1) > 40
            assert moved_b.mean() > 0.002, "tab B's picture did not change"
            # tab B's panel follows: its undo button is enabled and it counts the moved control point
            wait_for(lambda: b.locator("#ffd-undo").is_enabled(), 10, "tab B's undo button enabled")
            wait_for(lambda: "1 control point(s) moved" in _moved_label(b), 10, "tab B's moved-points label")

            # undo from tab B: both tabs go back
            b.click("#ffd-undo")
            wait_for(lambda: trigger(a, "ffd_state")["offsets_abs_sum"] == 0, 20, "the undo, seen from tab A")
            wait_for(lambda: "0 control point(s) moved" in _moved_label(a), 10, "tab A's label after the undo")
            wait_for(lambda: not a.locator("#ffd-undo").is_enabled(), 10, "tab A's undo button disabled")
            time.sleep(1.0)
            back_a = np.abs(_view_pixels(view_a) - before_b).max(axis=-1) > 40
            assert back_a.mean() < 0.002, "tab A does not show the undone state"

            # both tabs drag at once: one mouse, one drag, one undo step
            info = trigger(a, "ffd_widget_px")
            start = widget_xy(info, box, index)
            _drag(a, start, (dx, dy), n_steps=3)
            _drag(b, start, (-dx, -dy), n_steps=3)  # tab B presses while tab A holds the mouse
            a.mouse.up()
            b.mouse.up()
            wait_for(lambda: trigger(a, "ffd_state")["offsets_abs_sum"] > 0, 20, "the drag")
            time.sleep(1.0)  # (a second drag's step would have been recorded by now)
            assert _history(a) == 1, "two tabs dragging at once made more than one undo step"
            b.click("#ffd-undo")
            wait_for(lambda: trigger(a, "ffd_state")["offsets_abs_sum"] == 0, 20, "one undo undoes both tabs' drag")
            assert not errors_a and not errors_b, errors_a + errors_b
            ARTIFACTS.mkdir(exist_ok=True)
            b.screenshot(path=ARTIFACTS / "app_second_tab.png")
        finally:
            context.close()
