"""A real JupyterHub for the browser tests: PyPI's ``jupyterhub``, npm's ``configurable-http-proxy``.

Everything on 127.0.0.1 with free ports: the proxy's public port (the only address the browser needs), the
hub's own API port and the proxy's API port. The dummy authenticator lets any name in; the local-process
spawner runs each user's JupyterLab (``jupyterhub.singleuser``) as a process of the hub's own account
(:class:`jupyterhub.spawner.SimpleLocalProcessSpawner`, the testing form of the local-process spawner:
the real one switches to the user's system account, which a test machine does not have). The user's
kernels are instrumented as JupyterLab's in :func:`browser.helpers.start_lab`. A service token (admin of
users and servers) lets the test start the user's server and call its REST API.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import subprocess
import sys
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from browser.helpers import (
    ARTIFACTS,
    Lab,
    free_port,
    kernel_env,
    lab_options,
    shut_kernels_down,
    stop_process,
    wait_for,
)

USER = "tester"
SERVICE_TOKEN = "ffd-notebook-hub-test-service-token"


def proxy_command() -> str:
    """The configurable-http-proxy executable (``npm install -g configurable-http-proxy``)."""
    found = shutil.which("configurable-http-proxy")
    if found is None:
        raise RuntimeError("configurable-http-proxy is not on PATH: npm install -g configurable-http-proxy")
    return found


def log_in(page: Any, hub: Hub) -> None:
    """The hub's login form, as a user fills it (the dummy authenticator takes any password)."""
    page.goto(f"{hub.origin}/hub/login", wait_until="load")
    page.locator("input[name=username]").fill(USER)
    page.locator("input[name=password]").fill("any")
    page.locator("form [type=submit]").first.click()
    page.wait_for_url(lambda url: "/hub/login" not in url, timeout=60_000)


class Hub:
    """A running hub: its public port, and its REST API with the service token."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.origin = f"http://127.0.0.1:{port}"

    def api(self, path: str, method: str = "GET", body: Any = None) -> Any:
        """Call the hub's REST API (``/hub/api`` + ``path``); the decoded JSON answer."""
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(f"{self.origin}/hub/api{path}", data=data, method=method,
                                         headers={"Authorization": f"token {SERVICE_TOKEN}"})  # fmt: skip
        with urllib.request.urlopen(request, timeout=30) as answer:
            text = answer.read()
        return json.loads(text) if text else None

    def server_ready(self) -> bool:
        """Whether the user's server runs and answers (its spawn finished)."""
        server = (self.api(f"/users/{USER}").get("servers") or {}).get("")
        return bool(server and server.get("ready"))

    def user_lab(self, work: Path) -> Lab:
        """The user's JupyterLab, reached through the hub's address (the browser logs in: no token in pages)."""
        return Lab(self.port, work, base_url=f"/user/{USER}/", token=SERVICE_TOKEN, token_in_url=False)


def _config(tmp: Path, work: Path, ports: dict[str, int], env: dict[str, str]) -> str:
    args = ["--allow-root"] if sys.platform.startswith("linux") and os.geteuid() == 0 else []
    environment = {k: v for k, v in env.items() if not k.startswith(("JUPYTERHUB_", "CONFIGPROXY_"))}
    return "\n".join([
        "c = get_config()  # noqa",
        "c.JupyterHub.ip = '127.0.0.1'",
        f"c.JupyterHub.port = {ports['public']}",
        "c.JupyterHub.hub_ip = '127.0.0.1'",
        f"c.JupyterHub.hub_port = {ports['hub']}",
        f"c.ConfigurableHTTPProxy.api_url = 'http://127.0.0.1:{ports['proxy_api']}'",
        f"c.ConfigurableHTTPProxy.command = [{proxy_command()!r}]",
        f"c.JupyterHub.db_url = 'sqlite:///{tmp / 'jupyterhub.sqlite'}'",
        f"c.JupyterHub.cookie_secret_file = {str(tmp / 'cookie_secret')!r}",
        f"c.JupyterHub.pid_file = {str(tmp / 'jupyterhub.pid')!r}",
        "c.JupyterHub.authenticator_class = 'dummy'",
        "c.Authenticator.allow_all = True",
        "c.JupyterHub.spawner_class = 'simple'",
        f"c.SimpleLocalProcessSpawner.home_dir_template = {str(tmp / 'home' / '{username}')!r}",
        f"c.Spawner.cmd = [{sys.executable!r}, '-m', 'jupyterhub.singleuser']",
        f"c.Spawner.args = {[*args, *lab_options(tmp)]!r}",
        f"c.Spawner.notebook_dir = {str(work)!r}",
        "c.Spawner.default_url = '/lab'",
        f"c.Spawner.environment = {environment!r}",
        "c.Spawner.start_timeout = 120",
        "c.Spawner.http_timeout = 120",
        f"c.JupyterHub.services = [{{'name': 'ffd-test', 'api_token': {SERVICE_TOKEN!r}}}]",
        "c.JupyterHub.load_roles = [{'name': 'ffd-test', 'services': ['ffd-test'],",
        "    'scopes': ['admin:users', 'admin:servers', 'access:servers', 'read:users']}]",
    ])  # fmt: skip


@contextlib.contextmanager
def start_hub(tmp: Path, work: Path, trace: Path) -> Iterator[Hub]:
    """A hub on free 127.0.0.1 ports whose user :data:`USER` has a running server serving ``work``; the user's
    kernels, server, the hub and its proxy are stopped on exit."""
    ports = {"public": free_port(), "hub": free_port(), "proxy_api": free_port()}
    config = tmp / "jupyterhub_config.py"
    config.write_text(_config(tmp, work, ports, kernel_env(tmp, trace)))
    log_path = tmp / "jupyterhub.log"
    hub = Hub(ports["public"])
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "jupyterhub", "-f", str(config)], cwd=tmp, stdout=log,
                                stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"})  # fmt: skip
        try:

            def up() -> bool:
                if proc.poll() is not None:
                    raise RuntimeError(f"jupyterhub exited:\n{log_path.read_text()[-3000:]}")
                try:
                    return hub.api("/") is not None
                except (OSError, urllib.error.HTTPError):
                    return False

            wait_for(up, 120, "JupyterHub to answer", interval=0.5)
            hub.api(f"/users/{USER}", method="POST")
            hub.api(f"/users/{USER}/server", method="POST")
            wait_for(hub.server_ready, 180, "the user's server to start", interval=0.5)
            yield hub
        finally:
            with contextlib.suppress(Exception):
                shut_kernels_down(hub.user_lab(work))
                hub.api(f"/users/{USER}/server", method="DELETE")
                wait_for(lambda: not hub.server_ready(), 60, "the user's server to stop", interval=0.5)
            stop_process(proc)
            if ARTIFACTS.is_dir():
                shutil.copy(log_path, ARTIFACTS / "jupyterhub.log")
