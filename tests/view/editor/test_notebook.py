"""edit() in Jupyter: the static fallback in-process, and the trame view inside a real kernel (nbclient)."""

from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from editor_testing import colored_sphere


@pytest.fixture
def static_backend(monkeypatch):
    monkeypatch.setattr(pv.global_theme, "_jupyter_backend", "static", raising=False)
    assert pv.global_theme.jupyter_backend == "static"


def test_static_view_follows_the_panel(static_backend):
    from PIL import Image

    from ffd_notebook.view.editor import edit
    from ffd_notebook.view.editor.notebook.output import EditorOutput

    editor = edit(colored_sphere(), shape=(4, 4, 4), window_size=(200, 150))
    try:
        bundle = EditorOutput(editor)._repr_mimebundle_()
        assert "application/vnd.jupyter.widget-view+json" in bundle and bundle["text/plain"] == repr(editor)
        png = Image.open(io.BytesIO(base64.b64decode(bundle["image/png"])))
        assert png.size == (200, 150)
        box = editor.widget
        assert editor.widget is box  # one widget per editor
        view, panel = box.children
        before = bytes(view.value)
        for w, v in zip(panel.ijk, (1, 1, 3), strict=True):
            w.value = v  # a control point next to the sphere's top (the corners are far from it)
        panel.xyz[2].value = 0.5
        panel.apply_button.click()
        assert bytes(view.value) != before  # the picture follows the edit
    finally:
        editor.close()


NOTEBOOK_CODE = r"""
import json
import pyvista as pv
from ffd_notebook.view import edit
from editor_testing import colored_sphere
editor = edit(colored_sphere(), shape=(4, 4, 4), window_size=(320, 240))
from editor_instrument import Instrument
view, panel = editor.widget.children
server = view.viewer.server
Instrument(editor).register_triggers(server)  # the tests' own triggers, installed by test code
state0 = server.controller.trigger_fn("ffd_state")()
index = 21
center = [c + 0.3 for c in editor.session.control_points()[index]]
editor.on_widget_moved(center, index)
state1 = server.controller.trigger_fn("ffd_state")()
pv.global_theme.trame.server_proxy_enabled = True
pv.global_theme.trame.server_proxy_prefix = "/proxy/"
second = edit(colored_sphere(12), shape=(4, 4, 4), window_size=(320, 240))
proxied = second.widget.children[0].src
print(json.dumps({
    "iframe_class_pyvista": 'class="pyvista"' in view.value,
    "src": view.src, "port": server.port, "proxied": proxied,
    "state0": state0, "state1": state1,
    "n_px": len(server.controller.trigger_fn("ffd_widget_px")()["widgets"]),
    "panel": type(panel).__name__, "selected": list(editor.session.selected),
}))
"""


@pytest.mark.slow
def test_trame_view_in_a_kernel(tmp_path, monkeypatch):
    """A real kernel: edit() serves the plotter through trame, registers the triggers, honours the proxy."""
    import json
    import urllib.request

    import nbformat
    from nbclient import NotebookClient

    monkeypatch.delenv("PYVISTA_JUPYTER_BACKEND", raising=False)  # the kernel inherits it: use the default
    tests_dir = str(Path(__file__).resolve().parents[2])
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(f"import sys; sys.path.insert(0, {tests_dir!r})"),
        nbformat.v4.new_code_cell(NOTEBOOK_CODE),
    ]
    client = NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    with client.setup_kernel():
        for i, cell in enumerate(nb.cells):
            client.execute_cell(cell, i)
        outputs = nb.cells[1].outputs
        streams = "".join(o.get("text", "") for o in outputs if o["output_type"] == "stream")
        result = json.loads(streams.strip().splitlines()[-1])
        # the kernel is idle now: its trame server answers the iframe's address
        with urllib.request.urlopen(result["src"], timeout=30) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
    displays = [o for o in outputs if o["output_type"] == "display_data"]
    assert len(displays) == 2  # one per edit(), not doubled
    assert {"application/vnd.jupyter.widget-view+json", "image/png"} <= set(displays[0]["data"])
    assert result["iframe_class_pyvista"]
    assert result["src"].startswith(f"http://localhost:{result['port']}/index.html?ui=")
    assert result["proxied"].startswith(f"/proxy/{result['port']}/index.html?ui=")
    token = result["src"].split("&secret=")[1]  # the server's session token, for the trame client in the iframe
    assert len(token) >= 40 and result["proxied"].endswith(f"&secret={token}")
    assert result["state0"]["n_callbacks"] == 0 and result["state1"]["n_callbacks"] == 1
    assert result["state1"]["offsets_abs_sum"] == pytest.approx(0.9)
    assert result["state1"]["checksum"] != result["state0"]["checksum"]
    assert result["n_px"] == 64 and result["panel"] == "ControlPanel"
    assert result["selected"] == [int(v) for v in np.unravel_index(21, (4, 4, 4))]


VIEWERS_CODE = r"""
import json
import numpy as np
import pyvista as pv
from ffd_notebook.solidtex import SolidTexture
from ffd_notebook.view import CutViewer, GPExplorer, TexturedOrgan
from ffd_notebook.view.serving.jupyter import views_of
from ffd_notebook.meshing.organ import tetrahedralize

explorer = GPExplorer(pv.Sphere(radius=10, theta_resolution=16, phi_resolution=12), sigma=8.0, rank=20,
                      n_inducing=60, window_size=(320, 240))
gp_widget = explorer.show()
pushed = []
original_update = gp_widget.viewer.update
gp_widget.viewer.update = lambda *a, **k: (pushed.append(1), original_update(*a, **k))
explorer.sample(3)                      # a change made from code reaches the browser view

grid = tetrahedralize(pv.Sphere(radius=10, theta_resolution=16, phi_resolution=12), method="delaunay")
rng = np.random.default_rng(0)
texture = SolidTexture.fit(rng.integers(0, 255, (8, 8, 8, 3), dtype=np.uint8), grid.bounds)
cut_widget = CutViewer(TexturedOrgan(grid, texture, subdivisions=0), window_size=(320, 240)).show()
print(json.dumps({
    "gp_src": gp_widget.src, "cut_src": cut_widget.src,
    "gp_server_side": gp_widget.viewer in views_of(explorer.plotter).viewers,
    "pushed": len(pushed),
    "gp_iframe": 'class="pyvista"' in gp_widget.value,
}))
"""


@pytest.mark.slow
def test_gp_explorer_and_cut_viewer_show_server_rendered_views_in_a_kernel(tmp_path, monkeypatch):
    """Their VTK widgets need server-side rendering: show() gives the editor's trame view, served for real."""
    import json
    import urllib.request

    import nbformat
    from nbclient import NotebookClient

    monkeypatch.delenv("PYVISTA_JUPYTER_BACKEND", raising=False)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(VIEWERS_CODE)]
    client = NotebookClient(nb, timeout=180, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    with client.setup_kernel():
        client.execute_cell(nb.cells[0], 0)
        outputs = nb.cells[0].outputs
        errors = [o for o in outputs if o["output_type"] == "error"]
        assert not errors, errors[0].get("traceback") if errors else None
        streams = "".join(o.get("text", "") for o in outputs if o["output_type"] == "stream")
        result = json.loads(streams.strip().splitlines()[-1])
        for src in (result["gp_src"], result["cut_src"]):
            with urllib.request.urlopen(src, timeout=30) as page:
                assert page.status == 200 and b"<html" in page.read().lower()
    assert result["gp_server_side"] and result["gp_iframe"]
    assert result["pushed"] >= 1
