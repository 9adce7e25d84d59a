"""The standalone app (``python -m ffd_notebook``) in headless Chromium: drag a control point, save, upload.

Run: ``python -m pytest tests/browser/test_app_browser.py -m browser -s`` (``-s`` prints the latency figures,
which are also written to ``test-artifacts/browser_metrics.json`` with before/after screenshots).
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
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
    trigger,
    wait_for,
)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def save_mesh(page, path: Path):
    """Save the deformed mesh through the panel (path typed into its field, then the button) and read it."""
    import pyvista as pv

    open_panel_section(page, "Files")
    page.fill("#ffd-mesh-save-path", str(path))
    page.click("#ffd-save-mesh")
    wait_for(path.exists, 20, f"the app to write {path.name}")
    return pv.read(path)


INSTRUMENTED_APP = Path(__file__).resolve().parent / "serve_instrumented_app.py"


@pytest.fixture
def app(tmp_path: Path):
    """``python -m ffd_notebook`` on a free port, instrumented by test code (serve_instrumented_app.py) to trace
    drag events; yields (url, trace path, log path)."""
    port, trace = free_port(), tmp_path / "trace.jsonl"
    with app_server([str(INSTRUMENTED_APP), str(trace), "--port", str(port)], tmp_path) as url:
        assert url.startswith(f"http://127.0.0.1:{port}/?secret=")  # with its session token
        yield url, trace, tmp_path / "app.log"


def test_drag_save_and_upload_in_the_app(app, tmp_path: Path):
    from ffd_notebook import Lattice, load_ffd, read_obj, save_ffd

    url, trace, _ = app
    ARTIFACTS.mkdir(exist_ok=True)
    metrics: dict = {}
    t0 = time.monotonic()
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile")
        try:
            page, view, errors = open_app_page(context, url)
            metrics["first_image_s"] = round(time.monotonic() - t0, 1)
            time.sleep(1.0)
            page.screenshot(path=ARTIFACTS / "app_before_drag.png")
            state0 = trigger(page, "ffd_state")
            assert state0["n_callbacks"] == 0 and state0["offsets_abs_sum"] == 0
            save_mesh(page, tmp_path / "rest.vtp")

            # an outer sphere (issue 10: the fitted lattice hugs the mesh, so the outer spheres move it too)
            metrics.update(drag_and_measure(page, page.main_frame, view, trace, shape=(5, 5, 5), outer=True))
            page.screenshot(path=ARTIFACTS / "app_after_drag.png")

            # the server side saw it: callbacks for the dragged sphere only, and the mesh moved
            state1, records = settled_drag_state(page, trace, state0["n_callbacks"])  # (asserts the counts agree)
            assert records and {r["index"] for r in records} == {metrics["widget"]}
            assert state1["offsets_abs_sum"] > 0
            assert state1["checksum"] != state0["checksum"], "the mesh did not change"
            rest, deformed = pv.read(tmp_path / "rest.vtp"), save_mesh(page, tmp_path / "deformed.vtp")
            moved_by = np.linalg.norm(deformed.points - rest.points, axis=1)
            spacing = (np.ptp(rest.points, axis=0) / 2).min()  # a 5x5x5 B-spline lattice: two cells span the mesh
            assert moved_by.max() > 0.01 * spacing, "the deformed mesh saved by the app did not move"
            assert metrics["stepped"]["event_to_callback_ms"] is not None
            assert metrics["stepped"]["event_to_frame_ms"] is not None, "no new image after the callbacks"
            assert metrics["paced"]["callbacks"] > 0

            # save through the panel: a path typed into the field, then the button
            saved = tmp_path / "dragged.ffd"
            page.fill("#ffd-path", str(saved))
            page.click("#ffd-save")
            wait_for(saved.exists, 20, "the saved .ffd file")
            lattice = load_ffd(saved)
            ijk = tuple(records[-1]["ijk"])
            moved = np.argwhere(np.any(lattice.offsets != 0, axis=-1))
            assert [tuple(m) for m in moved] == [ijk], "only the dragged control point has an offset"
            # its offset is where the sphere was last dragged to, minus its rest position
            assert np.allclose(lattice.control_points(deformed=True)[ijk], records[-1]["center"], atol=1e-9)
            assert np.isclose(np.abs(lattice.offsets).sum(), state1["offsets_abs_sum"])
            # the file is renamed into place in a worker thread, the message follows from the event loop
            wait_for(lambda: page.locator("#ffd-messages").inner_text().count("saved the lattice") == 1, 20,
                     "the page's message about the save")  # fmt: skip

            # upload a .ffd from the browser: its offsets replace the lattice
            upload = Lattice(lattice.shape, spacing=lattice.spacing, origin=lattice.origin)
            upload.offsets[1, 2, 3] = (0.5, -0.25, 1.0)
            save_ffd(tmp_path / "upload.ffd", upload)
            page.set_input_files("#ffd-upload", str(tmp_path / "upload.ffd"))
            wait_for(lambda: trigger(page, "ffd_state")["offsets_abs_sum"] == 1.75, 20, "the uploaded lattice")
            page.screenshot(path=ARTIFACTS / "app_after_upload.png")

            # download to the browser: the lattice as a .ffd file, the deformed mesh as OBJ (no server path)
            with page.expect_download(timeout=30_000) as download:
                page.click("#ffd-download")
            download.value.save_as(tmp_path / "downloaded.ffd")
            assert np.array_equal(load_ffd(tmp_path / "downloaded.ffd").offsets, upload.offsets)
            with page.expect_download(timeout=30_000) as download:
                page.click("#ffd-download-mesh")
            assert download.value.suggested_filename == "deformed.obj"
            download.value.save_as(tmp_path / "downloaded.obj")
            assert read_obj(tmp_path / "downloaded.obj").n_points == rest.n_points

            assert not errors, errors
            # the trame client took the token out of the address bar; a reload still connects (cookie).
            # (Unloading may reject the old page's pending calls: errors from here on are not checked.)
            assert "secret=" not in page.url
            page.reload(wait_until="load")

            def reconnected() -> bool:
                try:  # window.trame appears once the client has connected
                    return trigger(page, "ffd_state")["offsets_abs_sum"] == 1.75
                except Exception:
                    return False

            wait_for(reconnected, 60, "the page to reconnect after a reload")
        finally:
            context.close()
    metrics["test_s"] = round(time.monotonic() - t0, 1)
    record_metrics("standalone_app", metrics)


def test_open_the_real_registration_lattice_and_drag(app, tmp_path: Path, shared_data: Path):
    """A user opens the real 11x12x11 registration .ffd through the panel (1452 control points: the
    "auto" display draws its hull), asks for all control points, and drags an inner one."""
    url, trace, _ = app
    shutil.copy(shared_data / "seed-lineage" / "registration_11x12x11.FFD", tmp_path / "registration.ffd")
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile")
        try:
            page, view, errors = open_app_page(context, url)
            open_panel_section(page, "Files")
            page.fill("#ffd-path", "registration.ffd")  # relative to the app's root folder
            page.click("#ffd-load")
            wait_for(lambda: len(trigger(page, "ffd_widget_px")["widgets"]) == 1452 - 9 * 10 * 9, 60,
                     "the 11x12x11 lattice, its hull drawn")  # fmt: skip
            loaded = trigger(page, "ffd_state")
            assert loaded["offsets_abs_sum"] > 0  # a registration result: its offsets came with it
            open_panel_section(page, "Display")
            page.click(".v-select:has(#ffd-points-shown) .v-field")  # open the select, pick the option
            page.get_by_role("option", name="all", exact=True).click()
            wait_for(lambda: len(trigger(page, "ffd_widget_px")["widgets"]) == 1452, 30, "every control point drawn")
            metrics = drag_and_measure(page, page.main_frame, view, trace, shape=(11, 12, 11))
            page.screenshot(path=ARTIFACTS / "app_registration_after_drag.png")
            state, records = settled_drag_state(page, trace, loaded["n_callbacks"])
            assert records and {r["index"] for r in records} == {metrics["widget"]}
            assert state["offsets_abs_sum"] != loaded["offsets_abs_sum"]
            assert state["checksum"] != loaded["checksum"], "the mesh did not change"
            assert not errors, errors
        finally:
            context.close()
