"""The quickstart through a real JupyterHub, the browser reaching the hub's address only.

JupyterHub (PyPI) with configurable-http-proxy (npm), the dummy authenticator and the local-process spawner,
all on 127.0.0.1 (:mod:`browser.hub`). Headless Chromium logs in as a user would, opens the quickstart in the
user's JupyterLab (``/user/<name>/lab``), runs it and drags a control point of the editor; every request and
WebSocket to another address than the hub's is refused. The view's iframe goes through
``/user/<name>/proxy/<port>/`` (the hub's environment sets PyVista's proxy prefix); the drag is checked from the
kernel's side. The time from the iframe entering the page to its first image goes to
``test-artifacts/browser_metrics.json``.

Run: ``python -m pytest tests/browser/test_jupyterhub_browser.py -m browser -s``
"""

from __future__ import annotations

from pathlib import Path

import pytest
from browser.helpers import Lab, quickstart_folder, quickstart_through_one_address
from browser.hub import USER, Hub, log_in, start_hub
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture(scope="module")
def hub(tmp_path_factory: pytest.TempPathFactory):
    """A hub whose user's server serves a copy of the quickstart notebook; yields (Hub, the user's Lab, trace)."""
    tmp = tmp_path_factory.mktemp("hub")
    work, trace = quickstart_folder(tmp)
    with start_hub(tmp, work, trace) as running:
        yield running, running.user_lab(work), trace


def test_quickstart_drag_through_jupyterhub(hub: tuple[Hub, Lab, Path], tmp_path: Path):
    hub_, lab, trace = hub
    assert lab.base_url == f"/user/{USER}/"  # the view must come through /user/<name>/proxy/<port>/
    with sync_playwright() as pw:
        quickstart_through_one_address(pw, lab, trace, tmp_path, "jupyterhub", before=lambda page: log_in(page, hub_))
