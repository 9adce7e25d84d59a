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
from browser.helpers import (
    ARTIFACTS,
    QUICKSTART,
    Lab,
    copy_notebook,
    launch_browser,
    quickstart_drag,
    reach_only,
    record_metrics,
)
from browser.hub import USER, Hub, start_hub
from playwright.sync_api import sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture(scope="module")
def hub(tmp_path_factory: pytest.TempPathFactory):
    """A hub whose user's server serves a copy of the quickstart notebook; yields (Hub, the user's Lab, trace)."""
    tmp = tmp_path_factory.mktemp("hub")
    work = tmp / "work"
    work.mkdir()
    copy_notebook(QUICKSTART, work)
    trace = tmp / "trace.jsonl"
    with start_hub(tmp, work, trace) as running:
        yield running, running.user_lab(work), trace


def log_in(page, hub: Hub) -> None:
    """The hub's login form, as a user fills it (the dummy authenticator takes any password)."""
    page.goto(f"{hub.origin}/hub/login", wait_until="load")
    page.locator("input[name=username]").fill(USER)
    page.locator("input[name=password]").fill("any")
    page.locator("form [type=submit]").first.click()
    page.wait_for_url(lambda url: "/hub/login" not in url, timeout=60_000)


def test_quickstart_drag_through_jupyterhub(hub: tuple[Hub, Lab, Path], tmp_path: Path):
    hub_, lab, trace = hub
    ARTIFACTS.mkdir(exist_ok=True)
    metrics: dict = {}
    with sync_playwright() as pw:
        context = launch_browser(pw, tmp_path / "profile", width=1400, height=1000)
        refused = reach_only(context, hub_.origin)
        page = context.new_page()
        try:
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            log_in(page, hub_)
            iframe, frame, _ = quickstart_drag(lab, page, trace, metrics)
            assert frame.url.startswith(f"{hub_.origin}/user/{USER}/proxy/"), frame.url
            metrics["iframe_to_first_image_s"] = Lab.first_image_s(iframe, frame)
            port = frame.url.split("/proxy/")[1].split("/")[0]
            assert not [u for u in refused if f":{port}/" in u], refused
            page.screenshot(path=ARTIFACTS / "jupyterhub_after_drag.png")
            assert not errors, errors
        except Exception:
            page.screenshot(path=ARTIFACTS / "jupyterhub_failure.png")
            raise
        finally:
            context.close()
    record_metrics("jupyterhub", metrics)
