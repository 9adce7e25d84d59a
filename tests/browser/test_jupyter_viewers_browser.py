"""The GP explorer and the organ cut viewer in a real JupyterLab: their VTK widgets work through the browser view.

A notebook shows a :class:`~ffd_notebook.view.gp.GPExplorer` on the frog liver and a
:class:`~ffd_notebook.view.solidtex.CutViewer` on a textured liver, each in the server-rendered trame
view they need. Headless Chromium clicks the explorer's "sample" button (a VTK button drawn in the
picture, bottom left) and drags the cut viewer's plane widget, as a user would. What the kernel sees is
read by running the notebook's last cell again (it writes ``state.json``); the pictures must change too.

Run: ``python -m pytest tests/browser/test_jupyter_viewers_browser.py -m browser -s``
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import nbformat
import numpy as np
import pytest
from browser.helpers import ARTIFACTS, launch_browser, start_lab, view_box, wait_for
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

SIZE = (480, 320)
CELLS = [
    "import json\nimport numpy as np\nimport skimage.data\nfrom ffd_notebook.datasets import frog_liver",
    "from ffd_notebook.view.gp import GPExplorer\n"
    f"explorer = GPExplorer(frog_liver(1500), window_size={SIZE}, n_inducing=150, rank=80, rng=0)\n"
    "explorer.show()",
    "from ffd_notebook.meshing.organ import tetrahedralize\n"
    "from ffd_notebook.solidtex import SolidTexture, sliding_crops, volume_from_slices\n"
    "from ffd_notebook.view.solidtex import CutViewer, TexturedOrgan\n"
    "liver = frog_liver(1200)\n"
    "stack = sliding_crops(skimage.data.immunohistochemistry(), 32, 48, step=(1, 1), start=(90, 90))\n"
    "texture = SolidTexture.fit(volume_from_slices(stack), liver.bounds)\n"
    "organ = TexturedOrgan(tetrahedralize(liver, method='delaunay'), texture, subdivisions=1)\n"
    f"viewer = CutViewer(organ, normal=(1, 0, 0), window_size={SIZE})\n"
    "viewer.look_at_cut()\n"
    "viewer.show()",
    "state = {'gp_max': float(np.abs(explorer.displacement).max()), 'origin': viewer.origin.tolist(),\n"
    "         'normal': viewer.normal.tolist(), 'face_points': int(viewer.face.n_points)}\n"
    "json.dump(state, open('state.json', 'w'))",
]


def picture(page, view) -> np.ndarray:
    """What ``view`` (the ``<img>`` in an iframe) shows now, as an RGB array, from a screenshot of the page."""
    import io

    from PIL import Image

    box = view_box(view)  # in the page's viewport (the iframe was scrolled into view)
    png = page.screenshot(clip={k: box[k] for k in ("x", "y", "width", "height")})
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def settled_picture(page, iframe, view, quiet_s: float = 1.0, timeout: float = 30.0) -> np.ndarray:
    """The view's picture once it has stopped changing for ``quiet_s`` (the sharp frame after an interaction)."""
    iframe.scroll_into_view_if_needed()
    seen = {"img": picture(page, view), "since": time.monotonic()}

    def quiet() -> bool:
        now = picture(page, view)
        if now.shape != seen["img"].shape or np.abs(now - seen["img"]).mean() > 0.05:
            seen.update(img=now, since=time.monotonic())
            return False
        return time.monotonic() - seen["since"] >= quiet_s

    wait_for(quiet, timeout, "the view to settle", interval=0.25)
    return seen["img"]


def kernel_state(page, work: Path) -> dict:
    """Run the notebook's last cell again and read the new ``state.json`` it writes."""
    target = work / "state.json"
    stamp = target.stat().st_mtime_ns if target.exists() else 0
    cell = page.locator(".jp-CodeCell", has_text="json.dump(state").first
    cell.scroll_into_view_if_needed()
    cell.locator(".jp-InputArea-editor").first.click()
    page.keyboard.press("Shift+Enter")
    wait_for(lambda: target.exists() and target.stat().st_mtime_ns != stamp, 60, "the probe cell's state.json")
    return wait_for(lambda: _read(target), 10, "a complete state.json")


def _read(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except ValueError:  # still being written
        return None


def test_gp_explorer_button_and_cut_viewer_plane_in_jupyterlab(tmp_path: Path):
    work = tmp_path / "work"
    work.mkdir()
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in CELLS]), work / "views.ipynb")
    ARTIFACTS.mkdir(exist_ok=True)
    with start_lab(tmp_path, work, tmp_path / "trace.jsonl") as lab, sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1280, height=900)
        try:
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            lab.run_notebook(page, "views.ipynb", lambda: (work / "state.json").exists())
            start = json.loads((work / "state.json").read_text())
            assert start["gp_max"] == 0.0  # the prior mean: nothing moved yet

            # the explorer's "sample" button: a VTK button 30 px wide, 10 px from the picture's bottom-left corner
            iframe, frame = lab.view_iframe(page, "explorer = GPExplorer(")
            view = frame.locator("img").first
            before = settled_picture(page, iframe, view)
            box = view_box(view)
            assert abs(box["width"] - SIZE[0]) <= 2 and abs(box["height"] - SIZE[1]) <= 2, box
            page.mouse.click(box["x"] + 25, box["y"] + box["height"] - 25)
            sampled = wait_for(lambda: (s := kernel_state(page, work))["gp_max"] > 0 and s, 60, "a sample")
            after = settled_picture(page, iframe, view)
            assert np.abs(after - before).mean() > 1.0, "the explorer's picture did not change"
            page.screenshot(path=ARTIFACTS / "jupyter_gp_after_sample.png")

            # the cut viewer's plane: press on it beside the middle of the picture (the origin handle and
            # the normal arrow are in the middle) and drag; the organ is cut again where the plane went
            iframe, frame = lab.view_iframe(page, "viewer = CutViewer(")
            view = frame.locator("img").first
            before = settled_picture(page, iframe, view)
            box = view_box(view)
            x, y = box["x"] + 0.5 * box["width"], box["y"] + 0.7 * box["height"]
            page.mouse.move(x, y)
            page.mouse.down()
            for step in range(1, 9):
                page.mouse.move(x + 12 * step, y - 4 * step)
                time.sleep(0.08)
            page.mouse.up()

            def plane_moved() -> dict | None:
                now = kernel_state(page, work)
                same = np.allclose(now["origin"], start["origin"]) and np.allclose(now["normal"], start["normal"])
                return None if same else now

            cut = wait_for(plane_moved, 60, "the cut plane to move in the kernel")
            assert cut["face_points"] > 0 and cut["gp_max"] == sampled["gp_max"]
            after = settled_picture(page, iframe, view)
            assert np.abs(after - before).mean() > 1.0, "the cut viewer's picture did not change"
            page.screenshot(path=ARTIFACTS / "jupyter_cut_after_drag.png")
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyter_viewers_failure.png")
            raise
        finally:
            context.close()
