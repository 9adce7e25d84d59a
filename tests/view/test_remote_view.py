"""The remote view's frame scheduler: coalesced requests, each image pushed before the next render, a sharp
frame once requests stop (ffd_notebook.view.serving.remote_view.FrameScheduler), on a real editor's render window."""

from __future__ import annotations

import asyncio
import io
import time

import numpy as np
import pyvista as pv
from PIL import Image

from ffd_notebook.view import Editor
from ffd_notebook.view.serving.remote_view import ENCODER, FrameScheduler


async def _drive(editor: Editor, n_bursts: int, burst: int, every_s: float) -> tuple[list, list]:
    """Request ``n_bursts`` bursts of ``burst`` frames (no await inside a burst), ``every_s`` apart, moving a
    mesh point each time; returns the (render start, render end) times and the (push time, meta, image)
    records once the frames stop."""
    renders: list[list[float]] = []
    pushes: list[tuple[float, dict, bytes]] = []
    window = editor.plotter.render_window
    window.AddObserver("StartEvent", lambda *_: renders.append([time.perf_counter(), 0.0]))
    window.AddObserver("EndEvent", lambda *_: renders[-1].__setitem__(1, time.perf_counter()))
    scheduler = FrameScheduler(
        window, target_fps=60, interactive_quality=40, still_quality=95,
        push_callback=lambda image, meta: pushes.append((time.perf_counter(), meta, image)),
    )  # fmt: skip
    try:
        for k in range(n_bursts * burst):
            editor.scene.display_points[0] += 0.01 * (k + 1)
            editor.scene.display.GetPoints().Modified()
            scheduler.schedule_render()
            if k % burst == burst - 1:
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
        renders, pushes = asyncio.run(_drive(editor, n_bursts=8, burst=5, every_s=0.002))
    finally:
        editor.close()
    interactive = [p for p in pushes if p[1]["quality"] == 40]
    # 8 bursts of 5 requests: the requests of a burst make one frame at most, whatever the machine's load
    # (requests made during a frame make one more frame, not one each)
    assert 1 <= len(interactive) <= 8
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


class SlowEncoder:
    """Pillow's JPEG, taking at least ``delay_s``; ``started`` is set while an image is being encoded."""

    def __init__(self, delay_s: float) -> None:
        import threading

        from trame_rca.encoders import RcaImageEncoder

        self.inner, self.delay_s, self.started = RcaImageEncoder(ENCODER), delay_s, threading.Event()

    def encode(self, *args):
        self.started.set()
        time.sleep(self.delay_s)
        return self.inner.encode(*args)


async def _request_during_encoding(editor: Editor) -> list[dict]:
    pushes: list[dict] = []
    encoder = SlowEncoder(0.2)
    scheduler = FrameScheduler(
        editor.plotter.render_window, target_fps=60, interactive_quality=40, still_quality=95, encoder=encoder,
        push_callback=lambda image, meta: pushes.append(meta),
    )  # fmt: skip
    try:
        scheduler.schedule_render()
        while not encoder.started.is_set():  # the first frame is rendered and now being encoded
            await asyncio.sleep(0.005)
        editor.scene.display_points[0] += 0.5  # the scene changes meanwhile (a mouse event's callback)
        editor.scene.display.GetPoints().Modified()
        scheduler.schedule_render()
        deadline = time.perf_counter() + 30
        while len(pushes) < 2 and time.perf_counter() < deadline:
            await asyncio.sleep(0.01)
    finally:
        await scheduler.close()
    return pushes


def test_a_request_made_while_a_frame_is_encoded_gets_its_own_interactive_frame():
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(160, 120))
    try:
        pushes = asyncio.run(_request_during_encoding(editor))
    finally:
        editor.close()
    # not dropped until the still frame (5 periods later): the next frame is interactive
    assert [p["quality"] for p in pushes[:2]] == [40, 40]


def _mouse(kind: str, action: str) -> dict:
    """A mouse event at the centre of a 320x240 view, as trame-rca's browser side sends it (vtk.js's fields)."""
    buttons = {"buttonLeft": int(action == "down"), "buttonMiddle": 0, "buttonRight": 0}
    keys = {"shiftKey": 0, "altKey": 0, "ctrlKey": 0, "metaKey": 0}
    return {"type": kind, "action": action, "x": 160, "y": 120, "w": 320, "h": 240, **buttons, **keys}


async def _interaction_sizes(editor: Editor) -> list[tuple[int, int]]:
    from trame_rca.rca import window_wrapper

    from ffd_notebook.view.serving.remote_view import InteractiveSizeAdapter

    window = window_wrapper(editor.plotter.render_window)
    scheduler = FrameScheduler(window)
    adapter = InteractiveSizeAdapter(window, "test_area", scheduler=scheduler, ratio=0.5)
    sizes = []
    try:
        adapter.update_size("browser", {"w": 320, "h": 240, "p": 1})  # the element's size, as the browser says
        sizes.append(tuple(editor.plotter.render_window.GetSize()))
        adapter.on_interaction("browser", {"type": "StartInteractionEvent"})
        sizes.append(tuple(editor.plotter.render_window.GetSize()))
        # a press at the view's centre, in the browser's pixels: VTK gets it at the reduced size
        adapter.on_interaction("browser", _mouse("LeftButtonPress", "down"))
        sizes.append(tuple(editor.plotter.iren.interactor.GetEventPosition()))
        adapter.on_interaction("browser", _mouse("LeftButtonRelease", "up"))
        adapter.on_interaction("browser", {"type": "EndInteractionEvent"})
        sizes.append(tuple(editor.plotter.render_window.GetSize()))
    finally:
        await scheduler.close()
    return sizes


def test_the_window_renders_at_the_interactive_ratio_while_a_button_is_held():
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(320, 240))
    try:
        before, during, press_at, after = asyncio.run(_interaction_sizes(editor))
    finally:
        editor.close()
    assert before == (320, 240) and during == (160, 120) and after == (320, 240)
    assert press_at == (80, 60)


async def _request_soon_after_a_slow_frame(editor: Editor) -> list[int]:
    pushes: list[dict] = []
    scheduler = FrameScheduler(
        editor.plotter.render_window, target_fps=60, interactive_quality=40, still_quality=95,
        encoder=SlowEncoder(0.15), push_callback=lambda image, meta: pushes.append(meta),
    )  # fmt: skip
    try:
        scheduler.schedule_render()
        deadline = time.perf_counter() + 30
        while not pushes and time.perf_counter() < deadline:
            await asyncio.sleep(0.002)
        await asyncio.sleep(0.02)  # the next mouse event, well within the still frame's delay (5 x 16.7 ms)
        editor.scene.display_points[0] += 0.5
        editor.scene.display.GetPoints().Modified()
        scheduler.schedule_render()
        while len(pushes) < 3 and time.perf_counter() < deadline:
            await asyncio.sleep(0.01)
    finally:
        await scheduler.close()
    return [p["quality"] for p in pushes]


def test_frames_slower_than_the_still_delay_do_not_make_a_still_frame_before_the_next_event():
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(160, 120))
    try:
        qualities = asyncio.run(_request_soon_after_a_slow_frame(editor))
    finally:
        editor.close()
    assert qualities == [40, 40, 95]


def test_small_images_are_encoded_on_the_loop_and_large_ones_in_the_pool_with_the_same_bytes():
    pl = pv.Plotter(off_screen=True, window_size=(96, 72))
    pl.add_mesh(pv.Sphere(), color="tan")
    threads: list[str] = []

    class Recording:
        def __init__(self):
            from trame_rca.encoders import RcaImageEncoder

            self.inner = RcaImageEncoder(ENCODER)

        def encode(self, *args):
            import threading

            threads.append(threading.current_thread().name)
            return self.inner.encode(*args)

    async def one_frame(inline_pixels: int) -> bytes:
        pushed: list[bytes] = []
        scheduler = FrameScheduler(
            pl.render_window,
            push_callback=lambda image, meta: pushed.append(image),
            encoder=Recording(),
            still_after=1000,
        )
        scheduler.INLINE_PIXELS = inline_pixels
        scheduler.schedule_render()
        deadline = time.monotonic() + 10
        while not pushed and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        await scheduler.close()
        return pushed[0]

    try:
        inline = asyncio.run(one_frame(96 * 72))
        pooled = asyncio.run(one_frame(96 * 72 - 1))
    finally:
        pl.close()
    assert threads[0] == "MainThread" and threads[1].startswith("ffd-view-encode")
    assert inline == pooled and Image.open(io.BytesIO(inline)).size == (96, 72)


class RecordingArea:
    """A remote-controlled area (trame-rca's protocol) that records the events it handles and the frames it makes."""

    def __init__(self):
        self.handled: list[tuple[str, int]] = []
        self.frames: list[list[tuple[str, int]]] = []  # what had been handled when each frame was rendered

    @property
    def img_cols_rows(self):
        self.frames.append(list(self.handled))
        return np.zeros((24, 32, 3), np.uint8), 32, 24

    def process_resize_event(self, width, height):
        pass

    def process_interaction_event(self, event):
        self.handled.append((event["type"], event.get("x", -1)))

    def rendered(self) -> list[list[tuple[str, int]]]:
        return [f for f in self.frames if f]  # (isinstance on trame-rca's protocol reads img_cols_rows once)


async def _coalesced(area: RecordingArea) -> list[tuple[str, int]]:
    from ffd_notebook.view.serving.remote_view import InteractiveSizeAdapter

    scheduler = FrameScheduler(area, still_after=1000)
    adapter = InteractiveSizeAdapter(area, "test_area", scheduler=scheduler)
    scheduler.set_push_callback(lambda image, meta: None)  # (the adapter's needs a browser)

    async def frames(n: int) -> None:
        deadline = time.monotonic() + 10
        while len(area.rendered()) < n and time.monotonic() < deadline:
            await asyncio.sleep(0.005)
        await asyncio.sleep(0.05)  # and no other frame is asked for

    try:
        adapter.on_interaction("browser", _mouse("LeftButtonPress", "down"))
        for x in (170, 180, 190, 200):  # four moves before the loop runs a frame
            adapter.on_interaction("browser", {**_mouse("MouseMove", "move"), "x": x})
        handled_before_frame = list(area.handled)
        await frames(1)
        adapter.on_interaction("browser", {**_mouse("MouseMove", "move"), "x": 210})
        adapter.on_interaction("browser", {**_mouse("LeftButtonRelease", "up"), "x": 210})
        await frames(2)
    finally:
        await scheduler.close()
    return handled_before_frame


def test_mouse_moves_are_coalesced_into_the_newest_before_each_frame_in_order():
    area = RecordingArea()
    before = asyncio.run(_coalesced(area))
    # a press comes after a move to where it is (hover); the moves that follow wait for the frame
    assert before == [("MouseMove", 160), ("LeftButtonPress", 160)]
    rendered = area.rendered()
    # the first frame saw the press and the newest move only; a release handles the move before it first
    assert rendered[0] == [("MouseMove", 160), ("LeftButtonPress", 160), ("MouseMove", 200)]
    assert area.handled == [
        ("MouseMove", 160),
        ("LeftButtonPress", 160),
        ("MouseMove", 200),
        ("MouseMove", 210),
        ("LeftButtonRelease", 210),
    ]
    assert len(rendered) == 2  # one frame for the moves, one for the release: a handled move asks for none


async def _two_tabs(area: RecordingArea) -> None:
    from ffd_notebook.view.serving.remote_view import InteractiveSizeAdapter

    scheduler = FrameScheduler(area, still_after=1000)
    adapter = InteractiveSizeAdapter(area, "test_area", scheduler=scheduler)
    scheduler.set_push_callback(lambda image, meta: None)
    try:
        adapter.on_interaction("tab-a", {"type": "StartInteractionEvent"})
        adapter.on_interaction("tab-a", _mouse("LeftButtonPress", "down"))
        # the other tab presses and drags meanwhile: one mouse, held by tab-a
        adapter.on_interaction("tab-b", {"type": "StartInteractionEvent"})
        adapter.on_interaction("tab-b", {**_mouse("LeftButtonPress", "down"), "x": 20})
        adapter.on_interaction("tab-b", {**_mouse("MouseMove", "move"), "x": 30})
        adapter.on_interaction("tab-a", {**_mouse("MouseMove", "move"), "x": 170})
        adapter.on_interaction("tab-b", {**_mouse("LeftButtonRelease", "up"), "x": 30})
        adapter.on_interaction("tab-a", {**_mouse("LeftButtonRelease", "up"), "x": 170})
        adapter.on_interaction("tab-a", {"type": "EndInteractionEvent"})
        # then tab-b has it
        adapter.on_interaction("tab-b", {**_mouse("LeftButtonPress", "down"), "x": 40})
        adapter.on_interaction("tab-b", {**_mouse("LeftButtonRelease", "up"), "x": 40})
    finally:
        await scheduler.close()


def test_one_tab_at_a_time_holds_the_mouse():
    area = RecordingArea()
    asyncio.run(_two_tabs(area))
    assert area.handled == [
        ("StartInteractionEvent", -1),
        ("MouseMove", 160),  # (the hover before a press)
        ("LeftButtonPress", 160),
        ("MouseMove", 170),
        ("LeftButtonRelease", 170),
        ("EndInteractionEvent", -1),
        ("MouseMove", 40),
        ("LeftButtonPress", 40),
        ("LeftButtonRelease", 40),
    ]
