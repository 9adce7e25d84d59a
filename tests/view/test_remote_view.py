"""The remote view's frame scheduler: coalesced requests, each image pushed before the next render, a sharp
frame once requests stop (ffd_notebook.view.remote_view.FrameScheduler), on a real editor's render window."""

from __future__ import annotations

import asyncio
import io
import time

import numpy as np
import pyvista as pv
from PIL import Image

from ffd_notebook.view import Editor
from ffd_notebook.view.remote_view import ENCODER, FrameScheduler


async def _drive(editor: Editor, n_requests: int, every_s: float) -> tuple[list, list]:
    """Request ``n_requests`` frames ``every_s`` apart, moving a mesh point each time; returns the
    (render start, render end) times and the (push time, meta, image) records once the frames stop."""
    renders: list[list[float]] = []
    pushes: list[tuple[float, dict, bytes]] = []
    window = editor.plotter.render_window
    window.AddObserver("StartEvent", lambda *_: renders.append([time.perf_counter(), 0.0]))
    window.AddObserver("EndEvent", lambda *_: renders[-1].__setitem__(1, time.perf_counter()))
    scheduler = FrameScheduler(
        window, target_fps=60, interactive_quality=40, still_quality=95, rca_encoder=ENCODER,
        push_callback=lambda image, meta: pushes.append((time.perf_counter(), meta, image)),
    )  # fmt: skip
    try:
        for k in range(n_requests):
            editor.scene.display_points[0] += 0.01 * (k + 1)
            editor.scene.display.GetPoints().Modified()
            scheduler.schedule_render()
            await asyncio.sleep(every_s)
        deadline = time.perf_counter() + 30
        while time.perf_counter() < deadline:  # until the still frame has been pushed
            if pushes and pushes[-1][1]["quality"] == 95 and time.perf_counter() - pushes[-1][0] > 0.3:
                break
            await asyncio.sleep(0.02)
    finally:
        await scheduler.close()
    return renders, pushes


def test_frames_are_coalesced_pushed_in_order_and_end_sharp():
    editor = Editor(pv.Sphere(theta_resolution=60, phi_resolution=60), shape=(4, 4, 4), window_size=(320, 240))
    try:
        renders, pushes = asyncio.run(_drive(editor, n_requests=40, every_s=0.002))
    finally:
        editor.close()
    interactive = [p for p in pushes if p[1]["quality"] == 40]
    # 40 requests 2 ms apart, each frame longer than that: requests made during a frame make one more frame
    assert 1 <= len(interactive) < 40
    assert len(renders) == len(pushes)
    # every image is pushed before the next render starts (it never waits for a render to free the loop)
    for (t_push, _, _), (t_next, _) in zip(pushes, renders[1:], strict=False):
        assert t_push <= t_next
    # the last frame repeats the scene at still quality: same size, a real JPEG, more bytes than interactive
    last_meta, last_image = pushes[-1][1], pushes[-1][2]
    assert last_meta["quality"] == 95 and (last_meta["w"], last_meta["h"]) == (320, 240)
    picture = np.asarray(Image.open(io.BytesIO(last_image)))
    assert picture.shape == (240, 320, 3) and picture.std() > 0
    assert len(last_image) > len(interactive[-1][2])
