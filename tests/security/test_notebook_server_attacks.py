"""Attacks on the trame server the notebook views start (Editor, GPExplorer, CutViewer), direct and proxied.

The server is started the way a kernel starts it (:func:`ffd_notebook.view.serving.jupyter.serve_plotter`
inside a running event loop) in a child process, which prints the iframe's ``src`` and can switch
PyVista's ``server_proxy_enabled`` on request. The proxied case goes through a real Jupyter server
with jupyter-server-proxy, like ``/proxy/<port>/`` in JupyterLab.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from pathlib import Path

import pytest
from browser.helpers import free_port, server_env, stop_process, wait_for
from security.wslink_client import DEFAULT_SECRET, Refused, connect, http_status

pytestmark = pytest.mark.slow

VIEW_SERVER = r"""
import asyncio, json, sys
import pyvista as pv
from ffd_notebook.view import Editor
from ffd_notebook.view.serving.jupyter import serve_plotter

async def main():
    editor = Editor(pv.Sphere(), shape=(4, 4, 4), window_size=(200, 150))
    widget = serve_plotter(editor.plotter)
    print(json.dumps({"src": widget.src, "port": widget.viewer.server.port}), flush=True)
    loop = asyncio.get_running_loop()
    while True:  # "proxy on" / "proxy off" from the test: PyVista's server_proxy_enabled, as a user sets it
        line = (await loop.run_in_executor(None, sys.stdin.readline)).strip()
        if not line:
            return
        pv.global_theme.trame.server_proxy_enabled = line == "proxy on"
        print(json.dumps({"proxy": pv.global_theme.trame.server_proxy_enabled}), flush=True)

asyncio.run(main())
"""


class ViewServer:
    def __init__(self, proc: subprocess.Popen, info: dict) -> None:
        self.proc, self.src, self.port = proc, info["src"], info["port"]
        self.token = self.src.split("secret=", 1)[1]
        self.ws = f"ws://127.0.0.1:{self.port}/ws"

    def proxy(self, on: bool) -> None:
        self.proc.stdin.write("proxy on\n" if on else "proxy off\n")
        self.proc.stdin.flush()
        assert json.loads(self.proc.stdout.readline()) == {"proxy": on}


@pytest.fixture(scope="module")
def view_server():
    env = server_env()
    env.pop("FFD_NOTEBOOK_TEST_HOOKS", None)
    proc = subprocess.Popen([sys.executable, "-c", VIEW_SERVER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=env)  # fmt: skip
    try:
        line = proc.stdout.readline()  # blocks until the server listens (or the child dies: "")
        assert line, "the view server did not start"
        server = ViewServer(proc, json.loads(line))
        yield server
    finally:
        proc.stdin.close()
        stop_process(proc)


def run(coro, timeout: float = 60):
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def hello(ws_url: str, origin: str | None, secret: str, host: str | None = None) -> dict:
    async with connect(ws_url, origin=origin, host=host) as s:
        reply = await s.hello(secret)
        if "result" in reply:
            reply["state"] = await s.call("trame.state.get")
        return reply


def test_the_iframe_src_carries_a_fresh_token(view_server):
    assert view_server.src.startswith(f"http://localhost:{view_server.port}/index.html?ui=")
    assert len(view_server.token) >= 40 and view_server.token != DEFAULT_SECRET
    assert http_status(view_server.src) == 200


def test_direct_mode_own_origin_and_token_only(view_server):
    own_host = f"localhost:{view_server.port}"  # the iframe's address
    ok = run(hello(view_server.ws, f"http://{own_host}", view_server.token, host=own_host))
    assert "result" in ok and "result" in ok["state"]
    assert "error" in run(hello(view_server.ws, f"http://{own_host}", DEFAULT_SECRET, host=own_host))  # public default
    for origin in ("http://evil.example", "http://localhost:8888", "null"):  # any other page, even Jupyter's
        with pytest.raises(Refused):
            run(hello(view_server.ws, origin, view_server.token))
    rebound = f"evil.example:{view_server.port}"
    with pytest.raises(Refused):
        run(hello(view_server.ws, f"http://{rebound}", view_server.token, host=rebound))
    assert http_status(view_server.src, {"Origin": "http://evil.example"}) == 403


def test_proxy_mode_accepts_jupyters_host_but_still_needs_same_origin_and_token(view_server):
    jupyter = "jupyter.example.org"  # what jupyter-server-proxy forwards: Jupyter's Host and Origin
    rebound = f"{jupyter}:{view_server.port}"  # a page that reached this port itself names it: DNS rebinding
    with pytest.raises(Refused):
        run(hello(view_server.ws, f"http://{rebound}", view_server.token, host=rebound))
    view_server.proxy(True)
    try:
        ok = run(hello(view_server.ws, f"http://{rebound}", view_server.token, host=rebound))
        assert "result" in ok  # PyVista's setting accepts any Host, as asked; the Origin and token still count
        ok = run(hello(view_server.ws, f"https://{jupyter}", view_server.token, host=jupyter))
        assert "result" in ok and "result" in ok["state"]
        assert "error" in run(hello(view_server.ws, f"https://{jupyter}", DEFAULT_SECRET, host=jupyter))
        with pytest.raises(Refused):
            run(hello(view_server.ws, "https://evil.example", view_server.token, host=jupyter))
    finally:
        view_server.proxy(False)


@pytest.fixture(scope="module")
def jupyter_proxy(tmp_path_factory):
    """A real Jupyter server with jupyter-server-proxy (token T); yields its port."""
    tmp = tmp_path_factory.mktemp("jupyter")
    port = free_port()
    cmd = [sys.executable, "-m", "jupyter", "server", "--no-browser", "--ip=127.0.0.1", f"--port={port}",
           "--IdentityProvider.token=T", f"--ServerApp.root_dir={tmp}",
           "--ServerApp.allow_remote_access=True"]  # fmt: skip
    if sys.platform.startswith("linux") and __import__("os").geteuid() == 0:
        cmd.append("--allow-root")
    log = Path(tmp) / "jupyter.log"
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT,
                                env=server_env(JUPYTER_RUNTIME_DIR=str(tmp / "runtime")))  # fmt: skip
    try:
        wait_for(lambda: http_status(f"http://127.0.0.1:{port}/api/status?token=T", timeout=5) == 200, 90,
                 "Jupyter to answer")  # fmt: skip
        yield port
    finally:
        stop_process(proc)


def test_through_jupyter_server_proxy(view_server, jupyter_proxy):
    """The iframe's proxied address: Jupyter checks its token and Origin, the view server its own token."""
    jp = jupyter_proxy
    page = f"http://127.0.0.1:{jp}/proxy/{view_server.port}/index.html?token=T"
    assert http_status(page) == 200
    ws = f"ws://127.0.0.1:{jp}/proxy/{view_server.port}/ws?token=T"
    jupyter_origin = f"http://127.0.0.1:{jp}"
    ok = run(hello(ws, jupyter_origin, view_server.token))
    assert "result" in ok and "result" in ok["state"]
    assert "error" in run(hello(ws, jupyter_origin, DEFAULT_SECRET))
    # Jupyter skips its own Origin check for token-authenticated requests (a ?token= URL cannot be forged
    # by a page); the view server still refuses the foreign Origin, and Jupyter then closes the socket
    with pytest.raises((Refused, ConnectionError)):
        run(hello(ws, "http://evil.example", view_server.token))
    # a Jupyter reached by a name (a remote host through one port): its Host names Jupyter's port, not the
    # view server's, so it came through a forwarder; accepted with no setting, still same-origin and with the token
    named = f"jupyter.example.org:{jp}"
    ok = run(hello(ws, f"http://{named}", view_server.token, host=named))
    assert "result" in ok and "result" in ok["state"]
    assert "error" in run(hello(ws, f"http://{named}", DEFAULT_SECRET, host=named))
    for origin in ("http://evil.example", f"http://jupyter.example.org:{view_server.port}", "null"):
        with pytest.raises((Refused, ConnectionError)):  # a foreign page, through the proxied route
            run(hello(ws, origin, view_server.token, host=named))
    # the same name naming the view server's own port came straight to it: a DNS-rebinding page
    rebound = f"jupyter.example.org:{view_server.port}"
    with pytest.raises(Refused):
        run(hello(view_server.ws, f"http://{rebound}", view_server.token, host=rebound))
    view_server.proxy(True)  # PyVista's setting (a hub's environment): any Host, the rest unchanged
    try:
        ok = run(hello(ws, f"http://{named}", view_server.token, host=named))
        assert "result" in ok and "result" in ok["state"]
        with pytest.raises((Refused, ConnectionError)):
            run(hello(ws, "http://evil.example", view_server.token, host=named))
    finally:
        view_server.proxy(False)


def test_the_proxied_page_names_its_server_and_scopes_its_cookie(view_server, jupyter_proxy):
    """What the iframe's first page checks before it sends the token through Jupyter (the server's public id),
    and the reload cookie: no Path, so the browser keeps it to ``<base_url>proxy/<port>/``, away from Jupyter's
    other pages (a hub's other users' servers)."""
    import urllib.request

    from ffd_notebook.view.serving.web_security import SERVER_ID_HEADER

    def get(url: str) -> tuple[str, list[str]]:  # the server id, and the cookies the view server set
        request = urllib.request.Request(url, headers={"Authorization": "token T"})  # (Jupyter's token)
        with urllib.request.urlopen(request) as answer:
            cookies = [c for c in answer.headers.get_all("Set-Cookie") or [] if c.startswith("ffd_notebook_")]
            return answer.headers[SERVER_ID_HEADER], cookies

    page = f"http://127.0.0.1:{jupyter_proxy}/proxy/{view_server.port}/index.html?ui=x"
    server_id, cookies = get(page)
    assert not cookies  # no token, no cookie
    assert server_id and len(server_id) == 16 and server_id not in view_server.token
    again, cookies = get(f"{page}&secret={view_server.token}")
    assert again == server_id and len(cookies) == 1
    assert view_server.token in cookies[0] and "path" not in cookies[0].lower() and "HttpOnly" in cookies[0]
