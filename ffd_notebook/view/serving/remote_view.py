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

The scheduler is the package's own (:class:`FrameScheduler`), in trame-rca's place: an image is encoded,
pushed and written to the websocket before the next render starts. trame-rca's scheduler starts the
next render (which holds the event loop) while the previous image is still being encoded or sent, so
during a drag each image reached the browser one render late; its wait for the still frame also
forgot requests made while a frame was encoded.

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
from concurrent.futures import ThreadPoolExecutor
from time import monotonic
from typing import Any

from trame_rca.view_adapter import RcaViewAdapter

__all__ = ["ENCODER", "FrameScheduler", "InteractiveSizeAdapter", "PointerOwner", "RemoteView"]

#: trame-rca's encoder name: Pillow's JPEG (libjpeg-turbo inside Pillow's wheels; see the module docstring)
ENCODER = "jpeg"


_ENCODING: list[ThreadPoolExecutor] = []  # one small pool per process, made on first use


def _encoding_pool() -> ThreadPoolExecutor:
    if not _ENCODING:
        _ENCODING.append(ThreadPoolExecutor(max_workers=2, thread_name_prefix="ffd-view-encode"))
    return _ENCODING[0]


class FrameScheduler:
    """Renders a window when asked, one frame at a time: render, read back, encode, push, written.

    It plays trame-rca's scheduler part (what :class:`trame_rca.view_adapter.RcaViewAdapter` calls:
    ``rca``, ``schedule_render``, ``set_push_callback``, ``target_fps``, ``reset``, ``close``),
    written here rather than subclassed because the order within a frame is the point: rendering
    holds the event loop (VTK renders on the thread that handles the mouse events), so an image that
    still waits for its encoding or its websocket write when the next render starts waits a whole
    render more. Images up to ``INLINE_PIXELS`` are encoded on the loop (under 2 ms), larger ones in a
    thread pool so the loop takes mouse events (~1 ms each) meanwhile; requests made during a frame
    (and while it is encoded or sent) make one next frame with the latest state; frames are at most
    ``target_fps`` a second; once requests stop for ``still_after`` periods, the scene is sent again at
    still quality.

    Parameters
    ----------
    window : vtkRenderWindow or trame-rca window
        What to render (wrapped by :func:`trame_rca.rca.window_wrapper`).
    push_callback : callable, optional
        ``push(image_bytes, meta)``; the adapter sets it with :meth:`set_push_callback`.
    sent : callable, optional
        Called just before an image is pushed; returns an awaitable that completes once that image is
        written to the network. The next render waits for it, at most ``SEND_TIMEOUT_S``.
    target_fps : float
        At most this many frames a second.
    interactive_quality, still_quality : int
        Image quality of the frames made on request, and of the frame made once requests stop.
    encoder : str or object
        A trame-rca encoder name, or an object with ``encode(image, cols, rows, quality) -> (bytes,
        meta, ms)`` like :class:`trame_rca.encoders.RcaImageEncoder`.
    still_after : int
        Periods without a request before the still frame.

    Examples
    --------
    >>> import asyncio
    >>> import pyvista as pv
    >>> pl = pv.Plotter(off_screen=True, window_size=(64, 48))
    >>> _ = pl.add_mesh(pv.Sphere())
    >>> async def frames():
    ...     pushed = []
    ...     scheduler = FrameScheduler(pl.render_window, push_callback=lambda image, meta: pushed.append(meta))
    ...     scheduler.schedule_render()
    ...     while len(pushed) < 2:  # the requested frame, then the still one
    ...         await asyncio.sleep(0.01)
    ...     await scheduler.close()
    ...     return [(meta["w"], meta["h"], meta["quality"]) for meta in pushed]
    >>> asyncio.run(frames())
    [(64, 48, 60), (64, 48, 90)]
    >>> pl.close()
    """

    SEND_TIMEOUT_S = 1.0
    #: images up to this many pixels are encoded on the loop: Pillow's JPEG takes 0.4 ms for a 400x300 drag
    #: frame and 1.9 ms for an 800x600 still one, while a thread pool's hand-over and the loop's wake-up took
    #: several ms on a loaded 2-core machine; larger images go to the pool so mouse events keep flowing
    INLINE_PIXELS = 500_000

    def __init__(
        self,
        window: Any,
        *,
        push_callback: Callable[[bytes, dict], None] | None = None,
        sent: Callable[[], Awaitable[Any] | None] | None = None,
        target_fps: float = 60.0,
        interactive_quality: int = 60,
        still_quality: int = 90,
        encoder: Any = ENCODER,
        still_after: int = 5,
    ) -> None:
        from trame.app import asynchronous
        from trame_rca.encoders import RcaImageEncoder
        from trame_rca.rca import window_wrapper

        self.rca = window_wrapper(window)
        self.target_fps = target_fps
        self.interactive_quality, self.still_quality = interactive_quality, still_quality
        self.encoder = RcaImageEncoder(encoder) if isinstance(encoder, str) else encoder
        self.still_after = still_after
        self._push, self._sent = push_callback, sent
        #: called just before each render (the adapter handles the newest mouse move there)
        self.before_render: Callable[[], None] | None = None
        self._requested = asyncio.Event()
        self._closing = False
        self._task = asynchronous.create_task(self._run())

    def set_push_callback(self, callback: Callable[[bytes, dict], None]) -> None:
        """Where encoded images go: ``callback(image_bytes, meta)``."""
        self._push = callback

    def schedule_render(self) -> None:
        """Ask for a frame (coalesced with any request not yet served)."""
        self._requested.set()

    def reset(self) -> None:
        """Nothing to reset: images carry no state between frames."""

    async def close(self) -> None:
        """Stop the frame loop and wait until it has stopped."""
        self.stop()
        await asyncio.gather(self._task, return_exceptions=True)

    def stop(self) -> None:
        """Stop the frame loop (it ends at its event loop's next turn) and forget the window and the push
        callback: a pending task is held by its event loop, so a scheduler left running kept its render
        window, and the whole scene in it, alive for the rest of the process."""
        self._closing = True
        self._requested.set()
        self._task.cancel()
        self._push = self._sent = self.before_render = None
        self.rca = None

    @property
    def period_s(self) -> float:
        """The shortest time between two frames."""
        return 1.0 / self.target_fps

    async def _run(self) -> None:
        while not self._closing:
            await self._requested.wait()
            if self._closing:
                break
            self._requested.clear()
            started = monotonic()
            await self._frame(self.interactive_quality)
            if self.interactive_quality == self.still_quality:
                await asyncio.sleep(max(0.0, self.period_s - (monotonic() - started)))
            elif await self._quiet_since(started):
                await self._frame(self.still_quality)

    async def _quiet_since(self, started: float) -> bool:
        """True if no frame is requested for ``still_after`` periods after the frame that began at ``started``
        ended; False as soon as one is (including a request made while that frame was encoded or sent), but
        never sooner than one period after ``started``. Quiet is counted from the frame's end: with renders
        longer than the delay, counting from its start would make a still frame at once after every frame
        whose next event is a few ms away, and that event would wait a whole render more."""
        ended = monotonic()
        await asyncio.sleep(max(0.0, started + self.period_s - ended))
        if self._requested.is_set():
            return False
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(self._requested.wait(), ended + self.still_after * self.period_s - monotonic())
        return not self._requested.is_set()

    async def _frame(self, quality: int) -> None:
        if self.before_render is not None:
            self.before_render()
        image, cols, rows = self.rca.img_cols_rows  # render and read the pixels back
        if cols * rows <= self.INLINE_PIXELS:  # cheaper than the hand-over to a thread and back
            encoded, meta, _ = self.encoder.encode(image, cols, rows, quality)
        else:
            loop = asyncio.get_running_loop()
            encoded, meta, _ = await loop.run_in_executor(
                _encoding_pool(), self.encoder.encode, image, cols, rows, quality
            )
        if self._push is None:
            return
        sent = None if self._sent is None else self._sent()
        self._push(encoded, meta)
        if sent is not None:  # the websocket write needs the loop: let it finish before rendering
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(sent, self.SEND_TIMEOUT_S)


class PointerOwner:
    """One mouse for every browser tab showing a view: while a button is held in one tab (an *origin*), the
    events of the others are dropped, so two tabs dragging at once make one drag, not two interleaved ones
    (one interactor holds one pointer: interleaved moves would make the handle jump between the tabs' cursors
    and end the drag at the other tab's release).

    A tab that holds the pointer and then says nothing for ``timeout_s`` (closed in the middle of a drag)
    loses it. Tabs that share one origin (trame-rca's default, "anonymous") are one pointer, as before.

    Examples
    --------
    >>> owner = PointerOwner(timeout_s=5.0)
    >>> owner.accepts("tab-a", "StartInteractionEvent", now=0.0), owner.accepts("tab-a", "LeftButtonPress", 0.0)
    (True, True)
    >>> owner.accepts("tab-b", "LeftButtonPress", now=0.1), owner.accepts("tab-b", "MouseMove", now=0.2)
    (False, False)
    >>> owner.accepts("tab-a", "LeftButtonRelease", now=0.3), owner.accepts("tab-a", "EndInteractionEvent", 0.3)
    (True, True)
    >>> owner.accepts("tab-b", "LeftButtonPress", now=0.4)   # free again
    True
    >>> owner.accepts("tab-a", "LeftButtonPress", now=9.0)   # tab-b went silent while holding it
    True
    """

    def __init__(self, timeout_s: float = 10.0) -> None:
        self.timeout_s = timeout_s
        self.holder: Any = None
        self._last = 0.0

    def accepts(self, origin: Any, kind: str | None, now: float | None = None) -> bool:
        """Whether the event ``kind`` from ``origin`` reaches the view (and who holds the pointer after it)."""
        now = monotonic() if now is None else now
        if self.holder is not None and origin != self.holder and now - self._last <= self.timeout_s:
            return False
        if kind in _PRESSES or kind == "StartInteractionEvent":
            self.holder = origin
        elif kind in _RELEASES or kind == "EndInteractionEvent":
            self.holder = None
        elif self.holder is not None and origin != self.holder:  # the silent holder's time ran out
            self.holder = None
        self._last = now
        return True


class InteractiveSizeAdapter(RcaViewAdapter):
    """trame-rca's view adapter, rendering at ``ratio`` of the size between the browser's Start and End of
    an interaction (trame-rca scales the events' coordinates by the same factor).

    A button press is handled after a mouse move to where it is (VTK's button widgets act only on a
    press over the button the pointer hovers, and the browser sends no moves while no button is held).

    Mouse moves are coalesced: a move is kept, not handled, until the scheduler is about to render
    (``scheduler.before_render``) or another event arrives, and a newer move replaces it. Moves arrive
    every ~10-20 ms while a frame takes ~50 ms; each one handled ran the VTK interactor and the
    editor's drag callback (~3 ms) for a state no frame showed, and held up the websocket write of
    the frame just rendered. Widgets and the camera end where the last move puts them either way (a
    drag sets positions; a camera turn adds up the steps). In paired runs of
    tests/benchmarks/bench_browser.py (with the editor's 10k-triangle interactive copy, measured
    together) JupyterLab's drag went from 13.2-19.8 to 16.2-29.1 frames/s.

    Several browser tabs may show one view (the app opened twice): the events' ``origin`` tells them
    apart when the page gives each tab its own, and :class:`PointerOwner` lets one tab at a time hold the
    mouse.
    """

    def __init__(self, window: Any, name: str, *, scheduler: FrameScheduler, ratio: float = 1.0, **kwargs: Any) -> None:
        # renders are asked for here (a kept move asks without being handled), not by trame-rca on every event
        super().__init__(window, name, scheduler=scheduler, do_schedule_render_on_interaction=False, **kwargs)
        self.scheduler = scheduler
        self.ratio = ratio
        self._move: dict[str, Any] | None = None
        self.pointer = PointerOwner()
        scheduler.before_render = self.flush

    def release(self) -> None:
        """Stop the frames and drop the window: the view is closed (events for it are no longer delivered)."""
        self.scheduler.stop()
        self._rca = self._move = None

    def flush(self) -> None:
        """Handle the mouse move kept for the next frame, if any (without asking for another frame)."""
        move, self._move = self._move, None
        if move is not None:
            super().on_interaction(None, move)  # trame-rca scales it to the render size and hands it to VTK

    def on_interaction(self, origin: Any, event: dict[str, Any]) -> None:
        kind = event.get("type")
        if not self.pointer.accepts(origin, kind):
            return  # another tab holds the mouse
        if kind == "MouseMove":
            self._move = event  # the newest position wins
            self.schedule_render()
            return
        self.flush()  # events keep their order: a press or a release after the moves before it
        if kind == "StartInteractionEvent" and self.ratio != 1.0:
            self.scale = self.ratio  # before the button press that follows: the whole drag at one size
        if kind in _PRESSES:
            # the browser sends no mouse moves while no button is held (trame-rca's default, and hovering would
            # cost a render per move): bring the pointer to the press first, as it is in a desktop window, where
            # it always got there by moving. VTK's button widgets take a press only over the button they hover
            super().on_interaction(origin, {**event, "type": "MouseMove"})
        super().on_interaction(origin, event)
        if kind == "EndInteractionEvent" and self.scale != 1.0:
            self.scale = 1.0
        self.schedule_render()


#: trame-rca's button-press events
_PRESSES = ("LeftButtonPress", "MiddleButtonPress", "RightButtonPress")
_RELEASES = ("LeftButtonRelease", "MiddleButtonRelease", "RightButtonRelease")


def _area_class() -> type:
    from trame.widgets import rca

    return rca.RemoteControlledArea


class RemoteView:
    """A trame-rca remote view of ``plotter``'s render window, made inside a trame layout.

    The view's element fills its parent; the render window follows its size. ``update()`` asks for a
    new frame (coalesced with any pending one): :class:`~ffd_notebook.view.serving.jupyter.BrowserViews` calls it
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
        from trame_rca.rca import window_wrapper

        self.area = _area_class()(display="image", event_throttle_ms=event_throttle_ms, **kwargs)
        window = window_wrapper(plotter.render_window)
        scheduler = FrameScheduler(
            window,
            sent=self._image_sent,
            target_fps=target_fps,
            interactive_quality=interactive_quality,
            still_quality=still_quality,
        )
        self.handler: InteractiveSizeAdapter | None = InteractiveSizeAdapter(
            window, self.area.name, scheduler=scheduler, ratio=interactive_ratio
        )
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
            # wslink sets ``monitor.event`` when a write completes and lowers ``pending`` in the write task's
            # done-callback just after: wake on the event (not on a timer: under load each timer wake-up costs
            # ms), then let the callbacks run
            while monitor.pending > before:
                monitor.event.clear()
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(monitor.event.wait(), 0.005)
                await asyncio.sleep(0)

        return written()

    def update(self) -> None:
        """Ask for a new frame (rendered and pushed by the scheduler, once per period at most)."""
        if self.handler is not None:
            self.handler.update()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self.handler is None

    def close(self) -> None:
        """Stop serving the plotter: the area's handler leaves the server (trame-rca keeps every registered
        handler, and with it the render window, for as long as the server runs), the frame loop stops, and
        the view keeps no VTK object. Safe to call twice."""
        handler, self.handler = self.handler, None
        if handler is None:
            return
        # (a view made before the server started waits in its area, which goes with this view)
        unregister = getattr(self.server.root_server.controller, "rc_area_unregister", None)
        if unregister is not None:
            with contextlib.suppress(KeyError):
                unregister(self.area.name)
        handler.release()
