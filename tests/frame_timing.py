"""Test instrumentation of a served view's frames: when each mouse event, render and image push happens.

Installed by test code only (``tests/browser/serve_instrumented_app.py`` when ``FFD_FRAME_TRACE`` is set, the
benchmark's IPython startup file for JupyterLab); the package never imports it. It appends JSON lines
(``time.time()`` seconds, the clock of the browser's ``Date.now()`` on the same machine) to a file:

- ``{"ev": "mouse", "t", "action"}``: the server received a mouse event for the view (trame-vtk's
  ``viewport.mouse.interaction`` or trame-rca's ``trame.rca.event``), ``t`` when its handling started;
- ``{"ev": "render", "t0", "t1"}``: a render of the editor's render window (its Start/End events);
- ``{"ev": "pub", "t", "bytes", "stale"}``: an image handed to the websocket (``stale``: trame-vtk sent an
  image encoded before its latest render because the encoder thread had not finished).

It also registers the trame trigger ``ffd_bare_render`` (median ms of rendering the editor's window with
its points marked modified, nothing else: the "bare render" the benchmark compares against).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import statistics
import time
from typing import Any

__all__ = ["FrameTimer", "install"]

_sink: list[Any] = []  # the open trace file of this process (class-level patches write to it)


def _log(record: dict[str, Any]) -> None:
    if _sink:
        _sink[0].write(json.dumps(record) + "\n")


def _patch_trame_vtk() -> None:
    from trame_vtk.modules.vtk.protocols import mouse_handler, publish_image_delivery

    handler = mouse_handler.vtkWebMouseHandler
    if getattr(handler, "_ffd_timed", False):
        return
    original_mouse = handler.mouse_interaction

    @functools.wraps(original_mouse)  # keeps wslink's RPC registration (the function's __dict__)
    def mouse_interaction(self: Any, event: dict[str, Any]) -> Any:
        _log({"ev": "mouse", "t": time.time(), "action": event.get("action")})
        return original_mouse(self, event)

    handler.mouse_interaction = mouse_interaction
    handler._ffd_timed = True
    delivery = publish_image_delivery.vtkWebPublishImageDelivery
    original_push_render = delivery.push_render

    def push_render(self: Any, *args: Any, **kwargs: Any) -> Any:
        if not getattr(self, "_ffd_publish_timed", False):  # wslink sets ``publish`` per instance
            original_publish = self.publish

            def publish(topic: str, reply: Any) -> Any:
                if topic == "viewport.image.push.subscription":
                    _log({"ev": "pub", "t": time.time(), "stale": bool(reply.get("stale")),
                          "bytes": reply.get("memsize")})  # fmt: skip
                return original_publish(topic, reply)

            self.publish, self._ffd_publish_timed = publish, True
        return original_push_render(self, *args, **kwargs)

    delivery.push_render = push_render


def _patch_trame_rca() -> None:
    try:
        from trame_rca import protocol
    except ImportError:
        return
    manager = protocol.StreamManager
    if getattr(manager, "_ffd_timed", False):
        return
    original_event, original_push = manager.on_interaction, manager.push_content

    @functools.wraps(original_event)
    def on_interaction(self: Any, area_name: str, origin: Any, event: dict[str, Any]) -> Any:
        _log({"ev": "mouse", "t": time.time(), "action": event.get("type")})
        return original_event(self, area_name, origin, event)

    @functools.wraps(original_push)
    def push_content(self: Any, area_name: str, metadata: Any, content: bytes) -> Any:
        _log({"ev": "pub", "t": time.time(), "stale": False, "bytes": len(content)})
        return original_push(self, area_name, metadata, content)

    manager.on_interaction, manager.push_content = on_interaction, push_content
    manager._ffd_timed = True


def _patch_remote_view() -> None:
    """``{"ev": "sent", "t", "waited_ms"}`` when the package's RemoteView has seen its image written."""
    from ffd_notebook.view import remote_view

    view = remote_view.RemoteView
    if getattr(view, "_ffd_timed", False):
        return
    original = view._image_sent

    def _image_sent(self: Any) -> Any:
        waiter = original(self)
        if waiter is None:
            return None

        async def timed() -> None:
            t0 = time.time()
            await waiter
            _log({"ev": "sent", "t": time.time(), "waited_ms": (time.time() - t0) * 1000.0})

        return timed()

    view._image_sent, view._ffd_timed = _image_sent, True


def install(path: str | os.PathLike[str]) -> None:
    """Open the trace file and patch trame-vtk's and trame-rca's protocols (before any server starts)."""
    if not _sink:
        _sink.append(open(path, "a", buffering=1))
    _patch_trame_vtk()
    _patch_trame_rca()
    with contextlib.suppress(ImportError, AttributeError):  # a product without it (e.g. a checkout before it)
        _patch_remote_view()


class FrameTimer:
    """Logs mouse events, renders and image pushes of one editor's view to ``path`` (see the module docstring)."""

    def __init__(self, editor: Any, path: str | os.PathLike[str]) -> None:
        self.editor = editor
        install(path)
        window = editor.plotter.render_window
        started: list[float] = [0.0]
        window.AddObserver("StartEvent", lambda *_: started.__setitem__(0, time.time()))
        window.AddObserver("EndEvent", lambda *_: _log({"ev": "render", "t0": started[0], "t1": time.time()}))

    def bare_render_ms(self, n: int = 30) -> dict[str, Any]:
        """``n`` renders of the editor's window after marking its mesh modified (``samples``, ``median``),
        and as many renders followed by reading the pixels back (``readback``: Mesa's software renderer
        finishes drawing only when the pixels are read)."""
        from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter

        window = self.editor.plotter.render_window
        points = self.editor.scene.display.GetPoints()
        grab = vtkWindowToImageFilter()
        grab.SetInput(window)
        grab.ShouldRerenderOff()
        grab.ReadFrontBufferOff()
        times, readback = [], []
        for _ in range(int(n)):
            points.Modified()
            t0 = time.perf_counter()
            window.Render()
            times.append((time.perf_counter() - t0) * 1000.0)
            points.Modified()
            t0 = time.perf_counter()
            window.Render()
            grab.Modified()
            grab.Update()
            readback.append((time.perf_counter() - t0) * 1000.0)
        return {
            "samples": times,
            "median": statistics.median(times),
            "readback": readback,
            "size": list(window.GetSize()),
        }

    def register_triggers(self, server: Any) -> None:
        """Register the ``ffd_bare_render`` trigger on a trame server."""
        server.controller.trigger("ffd_bare_render")(self.bare_render_ms)
