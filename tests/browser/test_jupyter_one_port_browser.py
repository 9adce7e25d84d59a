"""JupyterLab reached through one port: the editor's view goes through Jupyter's proxy with no setting.

JupyterLab runs under a base URL (``/lab-here/``) on 127.0.0.1, and headless Chromium may reach Lab's address
only (every other request and WebSocket is refused, as for a browser that reaches a lab machine through an SSH
tunnel, Docker's ``-p 8888:8888`` or VS Code's port forwarding): the kernel's trame server listens on a port
the browser cannot reach. The browser knows Lab by a name, ``lab-machine.test`` (resolved to 127.0.0.1 by
Chromium itself), as a remote Jupyter: the Host the view's server gets through Jupyter's proxy is then not a
loopback one, which only the forwarded-Host rule admits (:mod:`ffd_notebook.view.serving.web_security`); a
tunnel's ``localhost`` passes more easily.

The quickstart notebook runs unmodified; its editor's iframe must find the page through
``/lab-here/proxy/<port>/`` (jupyter-server-proxy) by itself, and a drag of a control point must reach the
kernel (checked from the kernel's side, as in test_jupyter_browser.py). The time from the iframe entering the
page to its first image goes to ``test-artifacts/browser_metrics.json``.

Without jupyter-server-proxy in the Jupyter server the view falls back to the kernel's own port, which a
browser on the kernel's machine reaches (as before this route existed).

Run: ``python -m pytest tests/browser/test_jupyter_one_port_browser.py -m browser -s``
"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from browser.helpers import (
    ARTIFACTS,
    Lab,
    launch_browser,
    quickstart_folder,
    quickstart_through_one_address,
    record_metrics,
    start_lab,
    trigger,
)
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]

BASE_URL = "/lab-here/"
NAME = "lab-machine.test"  # the name the browser reaches Lab by


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory):
    """JupyterLab under :data:`BASE_URL` serving a copy of the quickstart notebook; yields (Lab, trace path)."""
    tmp = tmp_path_factory.mktemp("one_port_lab")
    work, trace = quickstart_folder(tmp)
    # Jupyter itself refuses a Host that is not its own unless it may be reached remotely
    options = ("--ServerApp.allow_remote_access=True",)
    with start_lab(tmp, work, trace, base_url=BASE_URL, options=options, host=NAME) as running:
        yield running, trace


def test_quickstart_drag_through_labs_one_port(lab: tuple[Lab, Path], tmp_path: Path):
    with sync_playwright() as pw:
        quickstart_through_one_address(pw, *lab, tmp_path, "jupyter_one_port")


EDIT_CELLS = ["import ffd_notebook as fn", "editor = fn.edit(window_size=(400, 300))", "open('ready.txt', 'w')"]


@pytest.fixture(scope="module")
def lab_without_proxy(tmp_path_factory: pytest.TempPathFactory):
    """JupyterLab with jupyter-server-proxy turned off, serving a notebook that opens the editor."""
    tmp = tmp_path_factory.mktemp("lab_without_proxy")
    work = tmp / "work"
    work.mkdir()
    cells = [nbformat.v4.new_code_cell(c) for c in EDIT_CELLS]
    nbformat.write(nbformat.v4.new_notebook(cells=cells), work / "edit.ipynb")
    options = ("--ServerApp.jpserver_extensions=jupyter_server_proxy=False",)
    with start_lab(tmp, work, tmp / "trace.jsonl", base_url=BASE_URL, options=options) as running:
        yield running


def test_without_jupyter_server_proxy_the_view_opens_the_kernels_port(lab_without_proxy: Lab, tmp_path: Path):
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile")
        page = context.new_page()
        try:
            lab_without_proxy.run_notebook(page, "edit.ipynb", (lab_without_proxy.work / "ready.txt").exists)
            iframe, frame = lab_without_proxy.view_iframe(page, "editor = fn.edit(")
            assert frame.url.startswith("http://localhost:"), frame.url  # Jupyter answered 404: the direct address
            assert trigger(frame, "ffd_state")["n_callbacks"] == 0  # its websocket answers
            record_metrics("jupyterlab_direct", {"iframe_to_first_image_s": Lab.first_image_s(iframe, frame)})
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyter_without_proxy_failure.png")
            raise
        finally:
            context.close()
