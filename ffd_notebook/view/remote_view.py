"""The server-rendered browser view of a plotter, paced by the renderer (trame-rca).

Sphere widgets need server-side rendering: every mouse event must reach the VTK interactor in
Python. This view is trame-rca's ``RemoteControlledArea`` with its image render scheduler, chosen
over trame-vtk's ``VtkRemoteView`` (PyVista's default) because of what was measured on the editor's
drag (tests/benchmarks/bench_browser.py; the figures are in the project's closing notes):

- trame-vtk encodes JPEG in a background thread and sends whatever image is ready when it renders:
  during a drag almost every image it sends is the *previous* render (one frame late), and the last
  one arrives only when its 0.5 s stale timer fires; its animation loop renders at most 30 times a
  second whether or not anything changed; vtk.js drops a mouse move closer than 33 ms to the last
  one sent (the latest position may never be sent);
- trame-rca renders only when an event asked for it, and at most once per period of ``target_fps``:
  events that arrive during a render are coalesced into one frame showing the latest state, never
  queued; the browser compresses queued mouse moves into the latest one and waits for the server
  to take each before sending the next; each frame is captured right after its render and encoded
  in a thread pool.

One change to trame-rca's scheduler (:class:`FrameScheduler`): an image is encoded, pushed and written
to the websocket before the next render starts. trame-rca's own scheduler starts the next render
(which holds the event loop) while the previous image is still being encoded or sent, so during a
drag each image reached the browser one render late.

While a mouse button is held (a drag, a camera turn) the window renders at ``interactive_ratio`` of its
size and frames use ``interactive_quality``; the browser stretches them to the view. On release the
full size comes back, and once events stop for a few periods the scene is sent again at
``still_quality`` (the sharp frame). With the 53k-vertex face and Mesa's software renderer, half the
size (a quarter of the pixels) took a render + read-back from ~190-240 ms to ~110-180 ms on a loaded
2-core machine, and makes encoding and the browser's decoding 4x cheaper. The encoder is Pillow's
JPEG: Pillow ships libjpeg-turbo, which encodes an 800x600 frame in ~1-2 ms, as fast as PyTurboJPEG +
the system libturbojpeg (so no extra dependency); WebP took 30-60 ms and PNG ~70 ms.

The view's token and Origin checks are the server's (:mod:`.web_security`): the area's events and
images travel over the same protected websocket as the rest of the page.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from time import monotonic
from typing import Any

from trame_rca.schedulers import RcaImageRenderScheduler
from trame_rca.view_adapter import RcaViewAdapter

__all__ = ["ENCODER", "FrameScheduler", "RemoteView"]

#: trame-rca's encoder name: Pillow's JPEG (libjpeg-turbo inside Pillow's wheels; see the module docstring)
ENCODER = "jpeg"


class FrameScheduler(RcaImageRenderScheduler):
    """trame-rca's image scheduler, with each frame rendered, encoded and pushed before the next render.

    Rendering holds the event loop (VTK renders on the thread that handles the mouse events), so a
    frame waiting for the loop after its encoding waits for a whole render. Encoding stays in the
    thread pool: the loop takes mouse events (~1 ms each) meanwhile. Requests that arrive during a
    frame are coalesced into the next one; frames are at most ``target_fps`` a second; once requests
    stop for a few periods, the scene is sent again at still quality.

    Parameters
    ----------
    window : vtkRenderWindow or trame-rca window
        What to render.
    sent : callable, optional
        Called just before an image is pushed; returns an awaitable that completes once that image is
        written to the network. The next render waits for it, at most ``SEND_TIMEOUT_S``.
    **kwargs
        trame-rca's ``RcaImageRenderScheduler`` arguments (``push_callback``, ``target_fps``,
        ``interactive_quality``, ``still_quality``, ``rca_encoder``).
    """

    SEND_TIMEOUT_S = 1.0

    def __init__(self, window: Any, sent: Callable[[], Awaitable[Any]] | None = None, **kwargs: Any) -> None:
        super().__init__(window, **kwargs)
        self._sent = sent

    async def _render(self) -> None:
        while not self._is_closing:
            await self._request_event.wait()
            if self._is_closing:
                break
            self._request_event.clear()
            started = monotonic()
            await self._frame(self._interactive_quality)
            if self._interactive_quality == self._still_quality:
                await asyncio.sleep(max(0.0, self._target_period_s - (monotonic() - started)))
            elif await self._wait_for_still(started):
                await self._frame(self._still_quality)

    async def _wait_for_still(self, started: float) -> bool:
        """Wait up to the still-frame delay; False as soon as a frame is requested. Unlike trame-rca's, it
        keeps requests made while the previous frame was being encoded (the loop took events meanwhile)."""
        for i in range(1, self._n_period_until_still_render + 1):
            await asyncio.sleep(max(0.0, started + i * self._target_period_s - monotonic()))
            if self._request_event.is_set():
                return False
        return True

    async def _frame(self, quality: int) -> None:
        image, cols, rows = self._rca.img_cols_rows  # render and read the pixels back
        loop = asyncio.get_running_loop()
        encoded, meta, _ = await loop.run_in_executor(
            self._encode_pool, self._rca_encoder.encode, image, cols, rows, quality
        )
        if self._push_callback is not None:
            sent = None if self._sent is None else self._sent()
            self._push_callback(encoded, meta)
            if sent is not None:  # the websocket write needs the loop: let it finish before rendering
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(sent, self.SEND_TIMEOUT_S)


class _InteractiveSizeAdapter(RcaViewAdapter):
    """trame-rca's view adapter, rendering at ``ratio`` of the size between the browser's Start and End of
    an interaction (trame-rca scales the events' coordinates by the same factor)."""

    def __init__(self, *args: Any, ratio: float = 1.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.ratio = ratio

    def on_interaction(self, origin: Any, event: dict[str, Any]) -> None:
        kind = event.get("type")
        if kind == "StartInteractionEvent" and self.ratio != 1.0:
            self.scale = self.ratio  # before the button press that follows: the whole drag at one size
        super().on_interaction(origin, event)
        if kind == "EndInteractionEvent" and self.scale != 1.0:
            self.scale = 1.0


def _area_class() -> type:
    from trame.widgets import rca

    return rca.RemoteControlledArea


class RemoteView:
    """A trame-rca remote view of ``plotter``'s render window, made inside a trame layout.

    The view's element fills its parent; the render window follows its size. ``update()`` asks for a
    new frame (coalesced with any pending one): :class:`~ffd_notebook.view.jupyter.BrowserViews` calls it
    after changes made from code.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Its render window is shown (and its interactor receives the mouse events).
    target_fps : float
        At most this many frames a second (a render that takes longer simply paces the frames).
    interactive_ratio : float
        Size of the frames, relative to the view, while a mouse button is held.
    interactive_quality, still_quality : int
        JPEG quality while events arrive, and of the frame sent once they stop.
    event_throttle_ms : int
        The browser sends at most one (the latest) mouse move per this period.
    **kwargs
        Passed to ``RemoteControlledArea`` (``style``, ``id``, ...).
    """

    def __init__(
        self,
        plotter: Any,
        *,
        target_fps: float = 60.0,
        interactive_ratio: float = 0.5,
        interactive_quality: int = 60,
        still_quality: int = 90,
        event_throttle_ms: int = 10,
        **kwargs: Any,
    ) -> None:
        self.plotter = plotter
        from trame_rca.rca import window_wrapper

        self.area = _area_class()(display="image", event_throttle_ms=event_throttle_ms, **kwargs)
        window = window_wrapper(plotter.render_window)
        scheduler = FrameScheduler(
            window,
            sent=self._image_sent,
            target_fps=target_fps,
            interactive_quality=interactive_quality,
            still_quality=still_quality,
            rca_encoder=ENCODER,
        )
        self.handler = _InteractiveSizeAdapter(window, self.area.name, scheduler=scheduler, ratio=interactive_ratio)
        self.area.add_view_handler(self.handler)
        self.server = self.area.server

    def _image_sent(self) -> Awaitable[None] | None:
        """An awaitable completing once the image about to be pushed has been written to the websocket.

        wslink counts pending network writes (``network_monitor.pending``); publishing the image adds
        one. This waits until the count is back to what it was before the push, ignoring later writes
        (``server.network_completion`` would also wait for every other message, e.g. a stream of event replies).
        """
        monitor = getattr(getattr(self.area.server, "context", None), "network_monitor", None)
        if monitor is None:  # no client has connected yet
            return None
        before = monitor.pending

        async def written() -> None:
            while monitor.pending > before:
                await asyncio.sleep(0.001)

        return written()

    def update(self) -> None:
        """Ask for a new frame (rendered and pushed by the scheduler, once per period at most)."""
        self.handler.update()
