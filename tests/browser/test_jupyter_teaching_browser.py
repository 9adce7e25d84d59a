"""Teaching in a real JupyterLab (issue 33): drag, type a displacement, show the code, and the code runs.

A notebook opens the editor on the bundled face (4x4x4); headless Chromium drags a sphere in the editor's trame
iframe and types a displacement into the panel; the panel's "Code" button shows the code, which names both steps;
a cell ``editor.code_cell()`` puts the code in a new cell below it (IPython's ``set_next_input``, which JupyterLab
honours for a cell it runs; a click in a widget cannot add a cell), and running that cell in the same kernel
rebuilds the editor's lattice exactly: a last cell writes the comparison to a file the test reads.

Run: ``python -m pytest tests/browser/test_jupyter_teaching_browser.py -m browser -s``
"""

from __future__ import annotations

import time
from pathlib import Path

import nbformat
import pytest
from browser.helpers import ARTIFACTS, drag_and_measure, launch_browser, start_lab, trigger, wait_for
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

CELLS = ["import ffd_notebook as fn", "editor = fn.edit(shape=(4, 4, 4))", "open('ready.txt', 'w').write('ok')"]
CHECK = (
    "import numpy as np; open('check.txt', 'w').write(repr((lattice is not editor.lattice, "
    "bool(np.array_equal(lattice.offsets, editor.lattice.offsets)), "
    "bool(np.allclose(deformed.points, editor.deformed_mesh.points, atol=1e-4)))))"
)


def new_cell_below_last(page, text: str) -> None:
    """Select the last cell, add a cell below it (command mode "b"), type ``text`` and run it (Shift+Enter)."""
    last = page.locator(".jp-Notebook .jp-Cell").last
    last.scroll_into_view_if_needed()
    last.locator(".jp-InputPrompt").first.click()
    page.keyboard.press("Escape")
    page.keyboard.press("b")
    page.keyboard.press("Enter")
    page.keyboard.type(text, delay=5)
    page.keyboard.press("Shift+Enter")


def test_the_code_of_a_lesson_runs_in_the_notebook(tmp_path: Path):
    work = tmp_path / "work"
    work.mkdir()
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in CELLS]), work / "teach.ipynb")
    trace = tmp_path / "trace.jsonl"
    ARTIFACTS.mkdir(exist_ok=True)
    with start_lab(tmp_path, work, trace) as lab, sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1440, height=900)
        page = context.new_page()
        try:
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            lab.run_notebook(page, "teach.ipynb", lambda: (work / "ready.txt").exists())
            frame = lab.editor_frame(page, "editor = fn.edit(")
            view = frame.locator("img").first
            time.sleep(0.5)
            drag_and_measure(page, frame, view, trace, shape=(4, 4, 4), outer=True)  # a drag out, half-way back

            # a displacement typed into the panel
            page.locator(".ffd-panel").first.scroll_into_view_if_needed()
            for field, value in zip(page.locator(".ffd-ijk input").all(), (1, 2, 1), strict=True):
                field.fill(str(value))
                field.press("Enter")
            # the kernel selects it and shows its displacement in the fields: type the new one after that
            wait_for(lambda: trigger(frame, "ffd_state")["selected"] == [1, 2, 1], 30, "point (1, 2, 1) selected")
            time.sleep(0.5)
            for field, value in zip(page.locator(".ffd-xyz input").all(), ("0", "0.25", "0"), strict=True):
                field.fill(value)
            page.locator("button.ffd-apply").first.click()
            log = page.locator(".ffd-code-log pre").first
            wait_for(lambda: "lattice.offsets[1, 2, 1] = (0.0, 0.25, 0.0)" in log.inner_text(), 30,
                     "the running log to show the typed displacement")  # fmt: skip

            # "Code": the whole code in the panel, to copy
            page.locator("button.ffd-code").first.click()
            text = page.locator(".ffd-code-text textarea").first
            wait_for(lambda: "lattice.offsets[1, 2, 1] = (0.0, 0.25, 0.0)" in text.input_value(), 30, "the code")
            code = text.input_value()
            assert code.count("# drag a control point") == 2 and "mesh = sample_mesh()" in code
            page.locator(".ffd-panel").first.screenshot(path=ARTIFACTS / "jupyter_teaching_panel.png")

            # the code in a new cell below, run in the kernel: the same lattice
            new_cell_below_last(page, "editor.code_cell()")
            made = page.locator(".jp-CodeCell", has_text="What the editor did, as code")
            wait_for(lambda: made.count() == 1, 60, "the cell editor.code_cell() makes")
            made.first.locator(".jp-InputPrompt").first.click()
            page.keyboard.press("Shift+Enter")
            wait_for(lambda: made.first.locator(".jp-InputPrompt").first.inner_text().strip() not in ("[ ]:", "[*]:"),
                     120, "the code cell to run")  # fmt: skip
            new_cell_below_last(page, CHECK)
            wait_for(lambda: (work / "check.txt").exists(), 120, "the check cell")
            page.screenshot(path=ARTIFACTS / "jupyter_teaching_after.png", full_page=True)
            assert (work / "check.txt").read_text() == "(True, True, True)"
            stderr = page.locator(".jp-OutputArea-output[data-mime-type='application/vnd.jupyter.stderr']")
            assert not [t for t in stderr.all_inner_texts() if "Error" in t or "Traceback" in t]
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyter_teaching_failure.png", full_page=True)
            raise
        finally:
            context.close()
