"""A kernel that shuts down or restarts leaves nothing behind (issue 24): after an editor, a GP explorer and a
cut viewer were shown and dragged in it, the kernel process ends by itself (nothing keeps it from exiting), the
notebook view server's port is closed, and no child process of the kernel survives."""

from __future__ import annotations

import socket
import time

import psutil
import pytest
from kernel_session import Kernel

SHOW_EVERYTHING = """
import json, os
import lifetime_probe as probe
import numpy as np
import psutil
import pyvista as pv
import ffd_notebook as fn
from ffd_notebook.view import CutViewer, GPExplorer, TexturedOrgan
from ffd_notebook.meshing.organ import tetrahedralize
from ffd_notebook.solidtex import SolidTexture
from ffd_notebook.view.serving.jupyter import jupyter_server

editor = fn.edit(pv.Sphere(radius=10), shape=(4, 4, 4), window_size=(320, 240))
probe.drag_control_point(editor)
explorer = GPExplorer(pv.Sphere(radius=10), sigma=6.0, rank=20, n_inducing=60, window_size=(320, 240))
explorer.show()
probe.drag_across(explorer.plotter)
grid = tetrahedralize(pv.Sphere(radius=10, theta_resolution=16, phi_resolution=12), method="delaunay")
texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), dtype=np.uint8), grid.bounds)
viewer = CutViewer(TexturedOrgan(grid, texture, subdivisions=0), window_size=(320, 240))
viewer.show()
probe.drag_across(viewer.plotter)
print(json.dumps({"pid": os.getpid(), "port": jupyter_server().port,
                  "children": [p.pid for p in psutil.Process().children(recursive=True)]}))
"""


def _port_open(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(1.0)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _gone(pids: list[int], port: int, deadline_s: float = 30.0) -> dict:
    """Poll until every process in ``pids`` has ended and ``port`` refuses connections (or the deadline)."""
    end = time.monotonic() + deadline_s
    while True:
        alive = [pid for pid in pids if psutil.pid_exists(pid) and psutil.Process(pid).status() != "zombie"]
        listening = _port_open(port)
        if (not alive and not listening) or time.monotonic() > end:
            return {"alive": alive, "listening": listening}
        time.sleep(0.2)


class PatientKernel(Kernel):
    """Jupyter sends SIGTERM half-way through its 5 s grace period: a kernel that has loaded VTK, Mesa and trame
    takes 2-4 s to exit on a loaded 2-core machine (1.4 s without them), so with the default grace it is
    sometimes terminated, which also leaves nothing behind. Here it gets the time to show that nothing (a
    thread, a handler, a task) keeps it from exiting by itself."""

    shutdown_wait_s = 60.0


@pytest.mark.slow
def test_a_kernel_that_shuts_down_exits_by_itself_and_leaves_nothing_behind():
    with PatientKernel() as kernel:
        shown = kernel.json(SHOW_EVERYTHING)
        assert _port_open(shown["port"])  # the view server listens while the kernel lives
        process = kernel.manager.provisioner.process
        started = time.monotonic()
        kernel.shutdown()
        took = time.monotonic() - started
        print(f"\nthe kernel exited {took:.1f} s after the shutdown request")
        assert process.poll() == 0, f"the kernel did not exit by itself (exit code {process.poll()})"
        left = _gone([shown["pid"], *shown["children"]], shown["port"])
        assert left == {"alive": [], "listening": False}, left


@pytest.mark.slow
def test_a_kernel_shut_down_with_jupyters_defaults_leaves_nothing_behind():
    with Kernel() as kernel:
        shown = kernel.json(SHOW_EVERYTHING)
        kernel.shutdown()
        left = _gone([shown["pid"], *shown["children"]], shown["port"])
        assert left == {"alive": [], "listening": False}, left


@pytest.mark.slow
def test_a_kernel_that_restarts_leaves_nothing_behind_and_serves_again():
    with Kernel() as kernel:
        shown = kernel.json(SHOW_EVERYTHING)
        kernel.shutdown(restart=True)
        left = _gone([shown["pid"], *shown["children"]], shown["port"])
        assert left == {"alive": [], "listening": False}, left
        again = kernel.json(SHOW_EVERYTHING)  # the restarted kernel shows views again
        assert again["pid"] != shown["pid"] and _port_open(again["port"])
