"""The editor with an image in headless Chromium, in the app (``python -m ffd_notebook --image IMG``) and in
JupyterLab (``fn.edit(image=...)``): a drag changes the slices.

No mesh is given, so the lattice is fitted to the image's box. The drawn slice textures are read back from the
scene (the ``ffd_image`` trigger of tests/editor_instrument.py): after a drag of an inner control-point sphere
they show the session's warped slices, and the pixels that changed all lie within the dragged control point's
reach.

Run: ``python -m pytest tests/browser/test_image_browser.py -m browser -s``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk
from browser.helpers import (
    ARTIFACTS,
    app_server,
    drag_and_measure,
    free_port,
    launch_browser,
    open_app_page,
    settled_drag_state,
    start_lab,
    trigger,
    wait_for,
)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

INSTRUMENTED_APP = Path(__file__).resolve().parent / "serve_instrumented_app.py"


def image_over_the_sample_face(path: Path) -> Path:
    """A CT-like 48^3 volume over the bundled face's box."""
    from ffd_notebook.datasets import sample_mesh
    from ffd_notebook.images import ImageGrid, write_image

    points = np.asarray(sample_mesh().points, dtype=np.float64)
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.05 * (hi - lo)
    grid = ImageGrid((48, 48, 48), spacing=(hi - lo + 2 * pad) / 47, origin=lo - pad)
    k, j, i = np.meshgrid(*[np.linspace(-1, 1, 48)] * 3, indexing="ij")
    volume = (100.0 * np.sin(6 * i) * np.cos(5 * j) + 50.0 * k).astype(np.float32)
    write_image(path, grid.to_sitk(sitk.GetImageFromArray(volume)))
    return path


def check_the_drag(page, frame, view, trace: Path, screenshot: str) -> None:
    """Drag an inner sphere; the drawn slices become the session's, changed only within the control point's reach."""
    before = trigger(frame, "ffd_image")
    assert before["loaded"] and set(before["axes"]) == {"0", "1", "2"}
    assert all(a["current"] for a in before["axes"].values())
    metrics = drag_and_measure(page, frame, view, trace, shape=(5, 5, 5))
    settled_drag_state(frame, trace, 0)

    def drawn() -> dict | None:  # the frame after the last drag event shows the current slices
        answer = trigger(frame, "ffd_image")
        return answer if all(a["current"] for a in answer["axes"].values()) else None

    after = wait_for(drawn, 30, "the slices drawn after the drag")
    page.screenshot(path=ARTIFACTS / screenshot)
    assert after["selected"] is not None, "the dragged control point is selected"
    changed_somewhere = False
    for axis, shown in after["axes"].items():
        changed = np.array(shown["texels"]) != np.array(before["axes"][axis]["texels"])
        reach = np.array(shown["reach"])
        assert not changed[~reach].any(), f"slice {axis}: pixels changed outside the reach"
        assert reach.mean() < 0.9
        changed_somewhere |= bool(changed.any())
    assert changed_somewhere, f"no slice pixel changed (dragged widget {metrics['widget']})"


def test_a_drag_changes_the_slices_only_where_the_control_point_reaches(tmp_path: Path):
    image = image_over_the_sample_face(tmp_path / "ct.nrrd")
    trace = tmp_path / "trace.jsonl"
    command = [str(INSTRUMENTED_APP), str(trace), "--port", str(free_port()), "--image", str(image)]
    with app_server(command, tmp_path) as url:
        with sync_playwright() as pw:
            context = launch_browser(pw, tmp_path / "profile")
            try:
                page, view, errors = open_app_page(context, url)
                check_the_drag(page, page.main_frame, view, trace, "app_image_after_drag.png")
                assert not errors, errors
            finally:
                context.close()


def test_the_same_in_jupyterlab(tmp_path: Path):
    """``fn.edit(image=...)`` in a notebook cell, dragged in JupyterLab's trame view."""
    import nbformat

    work = tmp_path / "work"
    work.mkdir()
    image_over_the_sample_face(work / "ct.nrrd")
    cells = ["import ffd_notebook as fn",
             "editor = fn.edit(image='ct.nrrd', shape=(5, 5, 5), window_size=(640, 480))",
             "open('ready.txt', 'w').write('ok')"]  # fmt: skip
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells]), work / "image.ipynb")
    trace = tmp_path / "trace.jsonl"
    with start_lab(tmp_path, work, trace) as lab, sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1400, height=1000)
        try:
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            lab.run_notebook(page, "image.ipynb", lambda: (work / "ready.txt").exists(), {})
            frame = lab.editor_frame(page, "editor = fn.edit(")
            check_the_drag(page, frame, frame.locator("img").first, trace, "jupyter_image_after_drag.png")
            assert not errors, errors
        finally:
            context.close()
