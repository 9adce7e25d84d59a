"""The quickstart notebook in a real JupyterLab, driven by headless Chromium.

JupyterLab runs on 127.0.0.1 with a token and private settings; the test opens a copy of
``notebooks/01_quickstart.ipynb``, runs all cells, drags an outer control-point sphere inside the editor's
trame iframe, checks from the kernel side (trace file, ``ffd_state`` trigger of tests/editor_instrument.py) that
the callbacks ran and the lattice moved, saves the .ffd through the notebook's panel and checks the
file. Latency and frame rate go to ``test-artifacts/browser_metrics.json``; screenshots to
``test-artifacts/``.

Run: ``python -m pytest tests/browser/test_jupyter_browser.py -m browser -s``
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from browser.helpers import (
    ARTIFACTS,
    launch_browser,
    quickstart_drag,
    quickstart_folder,
    record_metrics,
    start_lab,
    wait_for,
)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def lab(tmp_path: Path):
    """JupyterLab serving a copy of the quickstart notebook (outputs cleared); yields (Lab, trace path)."""
    work, trace = quickstart_folder(tmp_path)
    with start_lab(tmp_path, work, trace) as running:
        yield running, trace


def test_quickstart_notebook_drag_and_save(lab, tmp_path: Path):
    from ffd_notebook import load_ffd

    lab_, trace = lab
    ARTIFACTS.mkdir(exist_ok=True)
    for stale in ARTIFACTS.glob("jupyter_failure.*"):
        stale.unlink()
    metrics: dict = {}
    t0 = time.monotonic()
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1400, height=1000)
        try:
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            # an outer sphere dragged, its effect checked from the kernel's side
            _, _, records = quickstart_drag(lab_, page, trace, metrics)
            page.screenshot(path=ARTIFACTS / "jupyter_after_drag.png")

            # save through the notebook's panel: type a path into its .ffd field, click its save button
            saved = tmp_path / "dragged.ffd"
            path_field = page.locator('input[placeholder="path/to/lattice.ffd"]').first
            path_field.scroll_into_view_if_needed()
            path_field.fill(str(saved))
            page.locator("button.jupyter-button", has_text="Save lattice").first.click()
            wait_for(saved.exists, 30, "the .ffd file saved from the panel")
            lattice = load_ffd(saved)
            ijk = tuple(records[-1]["ijk"])
            # the file records the drag: control point ijk sits where the sphere was dragged to
            assert np.linalg.norm(lattice.offsets[ijk]) > 0
            assert np.allclose(lattice.control_points(deformed=True)[ijk], records[-1]["center"], atol=1e-9)
            assert np.isclose(np.abs(lattice.offsets).sum(), metrics["offsets_abs_sum"])
            page.screenshot(path=ARTIFACTS / "jupyter_after_save.png")
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyter_failure.png")
            (ARTIFACTS / "jupyter_failure.html").write_text(page.content())
            raise
        finally:
            context.close()
    metrics["test_s"] = round(time.monotonic() - t0, 1)
    record_metrics("jupyterlab", metrics)
