"""What the view layer's objects leave behind, in-process (issue 24): an editor, a GP explorer or a cut viewer that
nobody refers to is collected and releases its plotter (PyVista keeps every plotter until it is closed), its render
window (VTK's DeleteEvent) and its notebook widgets; a release that happens while an asyncio loop runs waits for
the loop's next turn. The kernel-level tests (50 re-runs of a cell) are tests/view/test_notebook_lifetime.py."""

from __future__ import annotations

import asyncio
import gc
import weakref

import ipywidgets
import numpy as np
import pyvista as pv
from pyvista.plotting.plotter import _ALL_PLOTTERS

from ffd_notebook.view.serving.lifetime import Lifetime, weak_call, weak_method


def _watch(owner, plotter) -> tuple[weakref.ref, weakref.ref, list[str]]:
    deleted: list[str] = []
    plotter.render_window.AddObserver("DeleteEvent", lambda *_: deleted.append("render window"))
    return weakref.ref(owner), weakref.ref(plotter), deleted


def _assert_released(owner_ref, plotter_ref, deleted, open_before: int) -> None:
    gc.collect()
    assert owner_ref() is None, gc.get_referrers(owner_ref())
    assert plotter_ref() is None
    assert deleted == ["render window"]
    assert len(_ALL_PLOTTERS) == open_before


def test_an_editor_nobody_refers_to_is_freed_with_its_plotter_and_widgets(monkeypatch):
    from ffd_notebook.view import Editor

    # the static view (a picture that follows the session): a served trame view is the kernel tests' business
    # (tests/view/test_notebook_lifetime.py); starting the view server outside a kernel is not what users do
    monkeypatch.setattr(pv.global_theme, "_jupyter_backend", "static", raising=False)

    open_before = len(_ALL_PLOTTERS)
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(160, 120))
    box = editor.widget  # the notebook widget: a view and a panel (in ipywidgets' registry until closed)
    panel = box.children[1]
    panel_widgets = [panel, *panel.children]
    editor.session.begin_drag(0)  # the drag path's callbacks exist
    editor.on_widget_moved(editor.session.control_points()[0] + 0.1, 0)
    editor.session.end_drag()
    refs = _watch(editor, editor.plotter)
    del editor
    _assert_released(*refs, open_before)
    assert all(w.comm is None for w in panel_widgets), "the panel's widgets are still open"
    assert len(box.children) == 1 and isinstance(box.children[0], ipywidgets.Image)  # the view stays, the panel went


def test_editor_close_releases_at_once_and_twice_is_harmless():
    from ffd_notebook.view import Editor

    open_before = len(_ALL_PLOTTERS)
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(160, 120))
    editor.close()
    assert len(_ALL_PLOTTERS) == open_before and not editor.lifetime.alive
    editor.close()


def test_a_gp_explorer_and_a_cut_viewer_nobody_refers_to_are_freed():
    from ffd_notebook.meshing.organ import tetrahedralize
    from ffd_notebook.solidtex import SolidTexture
    from ffd_notebook.view import CutViewer, GPExplorer, TexturedOrgan

    open_before = len(_ALL_PLOTTERS)
    explorer = GPExplorer(pv.Sphere(radius=10), sigma=6.0, rank=10, n_inducing=40, window_size=(160, 120))
    explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 1.0))  # a sphere widget with a callback
    refs = _watch(explorer, explorer.plotter)
    del explorer
    _assert_released(*refs, open_before)

    grid = tetrahedralize(pv.Sphere(radius=10, theta_resolution=12, phi_resolution=10), method="delaunay")
    texture = SolidTexture.fit(np.zeros((4, 4, 4, 3), dtype=np.uint8), grid.bounds)
    viewer = CutViewer(TexturedOrgan(grid, texture, subdivisions=0), window_size=(160, 120))
    refs = _watch(viewer, viewer.plotter)
    del viewer
    _assert_released(*refs, open_before)


def test_a_plotter_given_to_an_explorer_stays_open():
    from ffd_notebook.view import GPExplorer

    plotter = pv.Plotter(off_screen=True, window_size=(160, 120))
    explorer = GPExplorer(pv.Sphere(radius=10), sigma=6.0, rank=10, n_inducing=40, plotter=plotter)
    explorer.close()
    assert plotter.render_window is not None  # its maker closes it
    plotter.close()


def test_a_release_while_a_loop_runs_waits_for_its_next_turn():
    log: list[str] = []

    class Owner:
        pass

    async def scenario():
        owner = Owner()
        Lifetime(owner, lambda: log.append("released"))
        del owner
        gc.collect()
        log.append("collected")
        await asyncio.sleep(0)
        return list(log)

    assert asyncio.run(scenario()) == ["collected", "released"]


def test_weak_callbacks_keep_nothing_alive():
    class Owner:
        def method(self, x):
            return x + 1

    owner = Owner()
    by_method, by_call = weak_method(owner.method), weak_call(owner, lambda self, x: self.method(x))
    assert by_method(1) == by_call(1) == 2
    ref = weakref.ref(owner)
    del owner
    gc.collect()
    assert ref() is None and by_method(1) is None and by_call(1) is None
