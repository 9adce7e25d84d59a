"""Re-running a notebook cell frees what the previous run made (issue 24): a real kernel, cells as JupyterLab
sends them (the same cell id for a re-run), the default (trame) backend, a drag in every run.

Measured in the kernel: its resident set size (it sees VTK's C++ memory) over 50 re-runs, and what is still
alive of the earlier runs: the owner (editor, explorer, viewer), its plotter and its render window (the C++
object's DeleteEvent), PyVista's open plotters, and the live objects of the view classes. Only the current
run's may remain. As in the drag soak test (tests/view/editor/test_soak.py), memory is measured after a
warm-up (the first run and :data:`WARMUP` re-runs), so that one-off allocations (the view server's first
pages, OpenGL and shader caches, malloc arenas) are not counted: without it the first few re-runs add 15-30 MB
once, after which the size stays flat. The size is read after glibc's ``malloc_trim`` (:func:`lifetime_probe.rss_mb`):
without it freed heap pages that glibc keeps made 20-23 MB of the editor's growth over 50 re-runs (30.4 MB once in
CI, over its 30 MB bound), with it 4-6 MB, so a leak (an editor kept per run is megabytes) stands out.
"""

from __future__ import annotations

import pytest
from kernel_session import Kernel

RERUNS = 50
WARMUP = 5

SETUP = """
import json
import lifetime_probe as probe
import numpy as np
import pyvista as pv
import ffd_notebook as fn
"""

MEASURE = """
counts = await probe.settle()
print(json.dumps({"rss": probe.rss_mb(), **counts,
                  **probe.live_types("Editor", "EditorScene", "GPExplorer", "CutViewer", "Plotter", "RemoteView",
                                     "FrameScheduler", "InteractiveSizeAdapter", "ControlPanel")}))
"""

EDITOR = "editor = fn.edit()\nprobe.track(editor, editor.plotter)"
EDITOR_CLOSING = "if 'editor' in globals():\n    editor.close()\n" + EDITOR
EDITOR_DRAG = "probe.drag_control_point(editor)"

EXPLORER_SETUP = """
from ffd_notebook.view import GPExplorer
sphere = pv.Sphere(radius=10, theta_resolution=60, phi_resolution=60)
"""
EXPLORER = """
explorer = GPExplorer(sphere, sigma=6.0, rank=40, n_inducing=120, window_size=(500, 400))
probe.track(explorer, explorer.plotter)
explorer.show()
"""
EXPLORER_DRAG = """
probe.drag_across(explorer.plotter)
explorer.sample()
explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 1.0))
"""

VIEWER_SETUP = """
from ffd_notebook.meshing.organ import tetrahedralize
from ffd_notebook.solidtex import SolidTexture
from ffd_notebook.view import CutViewer, TexturedOrgan
grid = tetrahedralize(pv.Sphere(radius=10, theta_resolution=24, phi_resolution=20), method="delaunay")
texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8), grid.bounds)
"""
VIEWER = """
viewer = CutViewer(TexturedOrgan(grid, texture, subdivisions=1), window_size=(500, 400))
probe.track(viewer, viewer.plotter)
viewer.show()
"""
VIEWER_DRAG = """
probe.drag_across(viewer.plotter)
viewer.update(origin=viewer.origin + (1.0, 0.0, 0.0))
"""


def rerun(setup: str, make: str, drag: str, *, reruns: int = RERUNS) -> tuple[dict, dict, list[dict]]:
    """Run ``make`` (one cell, re-run) then ``drag`` (another cell) ``1 + WARMUP + reruns`` times in one kernel;
    the counts after the warm-up, after the last run, and every tenth run's."""
    with Kernel() as kernel:
        kernel.run(SETUP + setup)
        for _ in range(1 + WARMUP):
            kernel.run(make, cell_id="make")
            kernel.run(drag, cell_id="drag")
        first = kernel.json(MEASURE)
        checks = []
        for run in range(1, reruns + 1):
            kernel.run(make, cell_id="make")
            kernel.run(drag, cell_id="drag")
            if run % 10 == 0:
                checks.append(kernel.json(MEASURE))
        return first, checks[-1], checks


def assert_only_the_last_run_alive(counts: dict) -> None:
    assert counts["owners"] == 1, f"owners of earlier runs still alive: {counts}"
    assert counts["plotters"] == 1, f"plotters of earlier runs still alive: {counts}"
    assert counts["render_windows"] == 1, f"render windows of earlier runs still alive: {counts}"
    assert counts["open_plotters"] == 1, f"PyVista keeps plotters of earlier runs open: {counts}"
    assert counts["Plotter"] <= 1 and counts["RemoteView"] <= 1 and counts["FrameScheduler"] <= 1, counts


def report(name: str, first: dict, last: dict) -> float:
    growth = last["rss"] - first["rss"]
    print(f"\n{name}: {first['rss']:.0f} MB after the warm-up, {last['rss']:.0f} MB after {RERUNS} more re-runs "
          f"(+{growth:.1f} MB); alive at the end: {last}")  # fmt: skip
    return growth


@pytest.mark.slow
def test_rerunning_the_editor_cell_frees_the_old_editors():
    first, last, checks = rerun("", EDITOR, EDITOR_DRAG)
    growth = report("editor = fn.edit()", first, last)
    for counts in [first, *checks]:
        assert_only_the_last_run_alive(counts)
        assert counts["Editor"] == 1 and counts["ControlPanel"] <= 1, counts
    assert growth <= 60.0


@pytest.mark.slow
def test_rerunning_the_editor_cell_after_close_frees_the_old_editors():
    first, last, checks = rerun("", EDITOR_CLOSING, EDITOR_DRAG)
    growth = report("editor.close(); editor = fn.edit()", first, last)
    for counts in [first, *checks]:
        assert_only_the_last_run_alive(counts)
    assert growth <= 30.0


@pytest.mark.slow
def test_rerunning_the_gp_explorer_cell_frees_the_old_explorers():
    first, last, checks = rerun(EXPLORER_SETUP, EXPLORER, EXPLORER_DRAG)
    growth = report("GPExplorer(...).show()", first, last)
    for counts in [first, *checks]:
        assert_only_the_last_run_alive(counts)
        assert counts["GPExplorer"] == 1, counts
    assert growth <= 60.0


@pytest.mark.slow
def test_rerunning_the_cut_viewer_cell_frees_the_old_viewers():
    first, last, checks = rerun(VIEWER_SETUP, VIEWER, VIEWER_DRAG)
    growth = report("CutViewer(...).show()", first, last)
    for counts in [first, *checks]:
        assert_only_the_last_run_alive(counts)
        assert counts["CutViewer"] == 1, counts
    assert growth <= 60.0
