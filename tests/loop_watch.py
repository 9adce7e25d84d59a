"""How long the standalone app's event loop stops answering while it works (tests and benchmarks).

A heartbeat coroutine wakes every 2 ms on the loop; the longest gap between two beats is how long
the loop was blocked (a browser's message, an HTTP request or a trame ping waits at least that long).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any

__all__ = ["big_sphere", "longest_stall"]


def big_sphere(path: Any, resolution: int = 710) -> Any:
    """Write a sphere of ``resolution``^2 points (710: 502,682 points, 1M triangles) as binary PLY."""
    import pyvista as pv

    mesh = pv.Sphere(theta_resolution=resolution, phi_resolution=resolution)
    mesh.save(path)
    return mesh


async def longest_stall(
    action: Callable[[], Any], done: Callable[[], bool], timeout: float = 300.0
) -> tuple[float, float]:
    """Run ``action()`` on the running loop and poll ``done()`` until it is true (or ``timeout`` s):
    ``(seconds until done, longest loop stall in seconds)``."""
    gaps: list[float] = []
    stop = asyncio.Event()

    async def beat() -> None:
        last = time.perf_counter()
        while not stop.is_set():
            await asyncio.sleep(0.002)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now

    heart = asyncio.create_task(beat())
    await asyncio.sleep(0.05)
    t0 = time.perf_counter()
    action()
    while not done():
        if time.perf_counter() - t0 > timeout:
            raise TimeoutError(f"not done after {timeout} s")
        await asyncio.sleep(0.01)
    total = time.perf_counter() - t0
    await asyncio.sleep(0.05)  # renders scheduled right after the work count too
    stop.set()
    await heart
    return total, max(gaps)
