"""A face from a photo in a real browser: upload a photo in the standalone app and in JupyterLab's panel, see
the face, drag a control point (issue 20).

The photo is scikit-image's ``astronaut()`` saved as a JPEG; the kernel or the app's server says that the mesh
is the face (28,881 vertices) and that the drag moved it; the view's picture must change with the upload and
with the drag. Screenshots go to ``test-artifacts/face_*.png``.

Run: ``python -m pytest tests/browser/test_face_browser.py -m browser -s``
"""

from __future__ import annotations

import io
import time
from pathlib import Path

import nbformat
import numpy as np
import pytest
from browser.helpers import (
    ARTIFACTS,
    app_server,
    drag_and_measure,
    free_port,
    launch_browser,
    open_app_page,
    open_panel_section,
    record_metrics,
    settled_drag_state,
    start_lab,
    trigger,
    wait_for,
)
from PIL import Image
from playwright.sync_api import sync_playwright
from skimage import data

pytestmark = [pytest.mark.browser, pytest.mark.slow]

FACE_POINTS = 28881  # the face of astronaut() (face_from_photo's default subdivision)
SHAPE = (5, 5, 5)
INSTRUMENTED_APP = Path(__file__).resolve().parent / "serve_instrumented_app.py"


def astronaut_jpeg(folder: Path) -> Path:
    path = folder / "astronaut.jpg"
    Image.fromarray(data.astronaut()).save(path, quality=92)
    return path


def view_picture(view) -> np.ndarray:
    """The remote view's current picture, as the browser shows it."""
    return np.asarray(Image.open(io.BytesIO(view.screenshot())).convert("RGB"), dtype=np.int16)


def changed(before: np.ndarray, after: np.ndarray) -> float:
    """Fraction of the picture's pixels that changed visibly (by more than 20 of 255 in some channel)."""
    if before.shape != after.shape:
        return 1.0
    return float((np.abs(before - after).max(axis=2) > 20).mean())


def wait_for_face(frame, what: str) -> dict:
    def face() -> dict | None:
        state = trigger(frame, "ffd_state")
        assert not any(m.startswith("Error") for m in state["messages"][-1:]), state["messages"]
        return state if state["n_points"] == FACE_POINTS else None

    return wait_for(face, 120, what, interval=0.5)


def drag_moves_the_face(page, frame, view, trace: Path, state0: dict, metrics: dict, picture: Path) -> None:
    """Drag an inner control point of the face's lattice; the server moved that one and the mesh changed, and so
    did the picture (saved to ``picture``)."""
    before = view_picture(view)
    metrics.update(drag_and_measure(page, frame, view, trace, shape=SHAPE))
    state1, records = settled_drag_state(frame, trace, state0["n_callbacks"])
    assert records and {r["index"] for r in records} == {metrics["widget"]}
    assert state1["offsets_abs_sum"] > 0 and state1["checksum"] != state0["checksum"], "the face did not move"
    assert state1["n_points"] == FACE_POINTS
    time.sleep(0.5)
    page.screenshot(path=picture)
    metrics["changed_by_drag"] = round(changed(before, view_picture(view)), 4)
    assert metrics["changed_by_drag"] > 0.001, "the picture did not change with the drag"


def test_upload_a_photo_in_the_app_and_drag_the_face(tmp_path: Path):
    photo = astronaut_jpeg(tmp_path)
    port = free_port()
    trace = tmp_path / "trace.jsonl"
    ARTIFACTS.mkdir(exist_ok=True)
    metrics: dict = {}
    with app_server([str(INSTRUMENTED_APP), str(trace), "--port", str(port)], tmp_path) as url:
        with sync_playwright() as pw:
            context = launch_browser(pw, tmp_path / "profile")
            try:
                page, view, errors = open_app_page(context, url)
                time.sleep(1.0)
                sample = view_picture(view)
                assert trigger(page, "ffd_state")["n_points"] == 6393  # the sample face

                t0 = time.monotonic()
                open_panel_section(page, "Files")
                page.set_input_files("#ffd-mesh-upload", str(photo))  # the app's own upload takes photos
                state0 = wait_for_face(page, "the face of the uploaded photo")
                metrics["upload_to_face_s"] = round(time.monotonic() - t0, 1)
                wait_for(lambda: "made the face in astronaut.jpg (uploaded)" in page.locator("#ffd-messages")
                         .inner_text(), 30, "the page's message about the face")  # fmt: skip
                time.sleep(1.0)
                page.screenshot(path=ARTIFACTS / "face_app_after_upload.png")
                metrics["changed_by_upload"] = round(changed(sample, view_picture(view)), 3)
                assert metrics["changed_by_upload"] > 0.05, "the view does not show a new mesh"

                drag_moves_the_face(page, page.main_frame, view, trace, state0, metrics,
                                    ARTIFACTS / "face_app_after_drag.png")  # fmt: skip
                assert not errors, errors
            finally:
                context.close()
    record_metrics("face_app", metrics)


NOTEBOOK = "face_upload.ipynb"


def test_upload_a_photo_in_jupyterlab_and_drag_the_face(tmp_path: Path):
    work = tmp_path / "work"
    work.mkdir()
    photo = astronaut_jpeg(tmp_path)
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell("import ffd_notebook as fn\n\neditor = fn.edit()"),
        nbformat.v4.new_code_cell("open('ready.txt', 'w').close()"),
    ]
    nbformat.write(nb, work / NOTEBOOK)
    trace = tmp_path / "trace.jsonl"
    ARTIFACTS.mkdir(exist_ok=True)
    metrics: dict = {}
    with start_lab(tmp_path, work, trace) as lab, sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1400, height=1000)
        page = context.new_page()
        try:
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            lab.run_notebook(page, NOTEBOOK, lambda: (work / "ready.txt").exists(), metrics)
            iframe, frame = lab.view_iframe(page, "editor = fn.edit(")
            view = frame.locator("img").first
            time.sleep(1.0)
            sample = view_picture(view)
            assert trigger(frame, "ffd_state")["n_points"] == 6393

            # the panel's upload button opens the browser's file chooser
            button = page.locator("button.ffd-face-upload").first
            button.scroll_into_view_if_needed()
            t0 = time.monotonic()
            with page.expect_file_chooser() as chooser:
                button.click()
            chooser.value.set_files(str(photo))
            state0 = wait_for_face(frame, "the face of the uploaded photo")
            metrics["upload_to_face_s"] = round(time.monotonic() - t0, 1)
            wait_for(lambda: "made the face in astronaut.jpg" in page.locator(".ffd-panel").inner_text(), 30,
                     "the panel's message about the face")  # fmt: skip
            iframe.scroll_into_view_if_needed()
            time.sleep(1.0)
            page.screenshot(path=ARTIFACTS / "face_jupyter_after_upload.png")
            metrics["changed_by_upload"] = round(changed(sample, view_picture(view)), 3)
            assert metrics["changed_by_upload"] > 0.05, "the view does not show a new mesh"

            drag_moves_the_face(page, frame, view, trace, state0, metrics, ARTIFACTS / "face_jupyter_after_drag.png")
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "face_jupyter_failure.png")
            raise
        finally:
            context.close()
    record_metrics("face_jupyterlab", metrics)
