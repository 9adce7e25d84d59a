"""Teaching in the standalone app (issue 33): the running log, the code dialog and its .py download, Record's
progress bar and its GIF download, in headless Chromium.

Run: ``python -m pytest tests/browser/test_app_teaching_browser.py -m browser -s``
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import imageio.v3 as iio
import pytest
from browser.helpers import (
    ARTIFACTS,
    app_server,
    free_port,
    launch_browser,
    open_app_page,
    open_panel_section,
    wait_for,
)
from playwright.sync_api import sync_playwright

from ffd_notebook.view.editor.session.controls import RECORD_FRAMES

pytestmark = [pytest.mark.browser, pytest.mark.slow]

TYPED = "lattice.offsets[1, 2, 1] = (0.0, 0.25, 0.0)"


def state(page, key: str):
    return page.evaluate("(k) => window.trame.state.get(k)", key)


def test_code_dialog_and_record_in_the_app(tmp_path: Path):
    folder = tmp_path / "root"
    folder.mkdir()
    screens = Path(os.environ.get("FFD_TEACHING_SCREENS", ARTIFACTS))
    screens.mkdir(parents=True, exist_ok=True)
    args = ["-m", "ffd_notebook", "--port", str(free_port()), "--shape", "4", "4", "4"]
    with app_server(args, folder, timeout=120) as url, sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1440, height=900)
        try:
            page, _, errors = open_app_page(context, url)
            # a displacement typed into the panel: the running log shows it as code
            for axis, value in zip("ijk", (1, 2, 1), strict=True):
                page.fill(f"#ffd-sel_{axis}", str(value))
                page.press(f"#ffd-sel_{axis}", "Enter")
            wait_for(lambda: [state(page, f"sel_{a}") for a in "ijk"] == [1, 2, 1], 20, "point (1, 2, 1) selected")
            page.fill("#ffd-dy", "0.25")
            page.click("#ffd-apply")
            open_panel_section(page, "Teaching")
            log = page.locator("#ffd-code-log")
            log.scroll_into_view_if_needed()
            wait_for(lambda: TYPED in log.inner_text(), 30, "the running log to show the typed displacement")

            # "Code": the dialog shows the code; its button downloads it as a .py file
            page.click("#ffd-code")
            text = page.locator("#ffd-code-text")
            text.wait_for(state="visible", timeout=20_000)
            assert TYPED in text.inner_text() and "fn.Lattice.around(" in text.inner_text()
            time.sleep(0.6)  # (the dialog fades in)
            page.screenshot(path=screens / "app_code_dialog.png")
            with page.expect_download(timeout=30_000) as download:
                page.click("#ffd-code-download")
            assert download.value.suggested_filename == "ffd_edits.py"
            download.value.save_as(tmp_path / "ffd_edits.py")
            code = (tmp_path / "ffd_edits.py").read_text()
            assert TYPED in code and code.strip() == text.inner_text().strip()
            page.click("#ffd-code-close")
            text.wait_for(state="hidden", timeout=20_000)

            # "Record": a progress bar while it renders, then the GIF downloads
            page.locator("#ffd-record").scroll_into_view_if_needed()
            with page.expect_download(timeout=180_000) as download:
                page.click("#ffd-record")
                bar = page.locator("#ffd-record-progress")
                bar.wait_for(state="visible", timeout=30_000)
                page.mouse.move(900, 100)  # (the button's tooltip away)
                bar.scroll_into_view_if_needed()
                page.screenshot(path=screens / "app_recording.png")
            assert download.value.suggested_filename == "deformation.gif"
            download.value.save_as(tmp_path / "deformation.gif")
            frames = iio.imread(tmp_path / "deformation.gif")
            assert frames.shape[0] == RECORD_FRAMES and frames.shape[-1] == 3
            bar.wait_for(state="hidden", timeout=30_000)
            wait_for(lambda: "recorded the deformation" in page.locator("#ffd-messages").inner_text(), 20,
                     "the message about the recording")  # fmt: skip
            shutil.copy(tmp_path / "deformation.gif", ARTIFACTS / "app_recording.gif") if ARTIFACTS.is_dir() else None
            assert not errors, errors
        except Exception:
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=ARTIFACTS / "app_teaching_failure.png")
            raise
        finally:
            context.close()
