"""Imported inside a test kernel: counts what the runs of a cell leave alive, and drags like a user.

Nothing here holds what it tracks: owners and plotters through weak references, render windows by a
VTK ``DeleteEvent`` observer (it fires when the C++ object is destroyed, whoever held it: a weak
reference to the Python wrapper would only say that the wrapper went).
"""

from __future__ import annotations

import asyncio
import ctypes
import gc
import os
import weakref
from collections import Counter
from typing import Any

_owners: list[weakref.ref] = []
_plotters: list[weakref.ref] = []
_windows_made = 0
_windows_deleted: set[int] = set()


def rss_mb() -> float:
    """The kernel's resident set size, MB (it sees VTK's C++ allocations too), after glibc's ``malloc_trim``
    has handed freed heap pages back (on other C libraries the size as it is)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def track(owner: Any, plotter: Any) -> None:
    """Watch ``owner`` (an editor, explorer, viewer), its plotter and its render window."""
    global _windows_made
    _owners.append(weakref.ref(owner))
    _plotters.append(weakref.ref(plotter))
    number = _windows_made
    _windows_made += 1
    deleted = _windows_deleted  # the observer refers to the set and the number only
    plotter.render_window.AddObserver("DeleteEvent", lambda *_: deleted.add(number))


def alive() -> dict[str, int]:
    """How many tracked owners, plotters and render windows are still alive, and PyVista's open plotters."""
    from pyvista.plotting.plotter import _ALL_PLOTTERS

    return {
        "owners": sum(r() is not None for r in _owners),
        "plotters": sum(r() is not None for r in _plotters),
        "render_windows": _windows_made - len(_windows_deleted),
        "open_plotters": len(_ALL_PLOTTERS),
    }


def live_types(*names: str) -> dict[str, int]:
    """Live objects (seen by the garbage collector) of the classes named."""
    counts = Counter(type(o).__name__ for o in gc.get_objects())
    return {name: counts[name] for name in names}


async def settle(expected: int = 1, deadline_s: float = 20.0) -> dict[str, int]:
    """Collect and let the event loop turn (releases run there) until at most ``expected`` of each tracked
    kind is alive, or the deadline passes; returns :func:`alive`'s counts."""
    loop = asyncio.get_running_loop()
    end = loop.time() + deadline_s
    while True:
        gc.collect()
        await asyncio.sleep(0.05)
        counts = alive()
        if max(counts["owners"], counts["plotters"], counts["render_windows"]) <= expected or loop.time() > end:
            return counts


def mouse_drag(plotter: Any, start: tuple[float, float], delta: tuple[float, float], steps: int = 5) -> None:
    """Left-button press at display ``start`` (pixels, origin bottom-left), ``steps`` moves by ``delta`` in
    all, release: through the VTK interactor, as the browser view's events arrive."""
    iren = plotter.iren.interactor
    x, y = (round(v) for v in start)
    iren.SetEventInformation(x, y, 0, 0, "\0", 0, None)
    iren.LeftButtonPressEvent()
    for k in range(1, steps + 1):
        iren.SetEventInformation(x + round(delta[0] * k / steps), y + round(delta[1] * k / steps), 0, 0, "\0", 0, None)
        iren.MouseMoveEvent()
    iren.LeftButtonReleaseEvent()


def drag_control_point(editor: Any) -> None:
    """Drag a control point of ``editor`` with the mouse (press on its sphere, move, release): the first one a
    press grabs (not hidden behind the mesh)."""
    editor.screenshot()
    actor = editor.scene.lattice_actor
    screen = actor.display_positions()
    index = next(i for i in actor.shown if actor.index_at(*screen[i, :2]) == i)
    x, y = screen[index, :2]
    before = editor.lattice.offsets.copy()
    mouse_drag(editor.plotter, (x, y), (15, 10))
    assert not (editor.lattice.offsets == before).all(), "the drag moved no control point"


def drag_across(plotter: Any) -> None:
    """A drag from the middle of the view (widgets there take it, or the camera turns)."""
    plotter.render()
    width, height = plotter.window_size
    mouse_drag(plotter, (width / 2, height / 2), (20, 12))
