"""Attacks on the real standalone app (``python -m ffd_notebook --port 0 --root ROOT``) over a real WebSocket.

Each test is one attack from issue 8, played the way the issue found it (a small wslink client, a
foreign ``Origin``, trame's public default secret) and, where the attacker could also be a holder
of the token (a shared link, a mistyped path), with the token too. On the code before issue 8
every one of them succeeded: the handshake was accepted from any Origin, ``wslink-secret``
authenticated, typed paths went anywhere, load errors quoted files, a FIFO froze the server and a
bad ``.vtk`` killed it.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from browser.helpers import server_env, stop_process, wait_for
from security.wslink_client import DEFAULT_SECRET, Refused, connect, http_status, messages, printed_url

from ffd_notebook import Lattice, save_ffd

pytestmark = pytest.mark.slow

BAD_VTK = (b"# vtk DataFile Version 3.0\nbad\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n"
           b"POLYGONS 1 4\n3 0 1 999999\n")  # fmt: skip  # 113 bytes: a face index far past the 3 points
PTH_PAYLOAD = "import os; open(os.path.expanduser('~/pwned'), 'w')"


class App:
    """A running app: its process, printed URL, token and folders."""

    def __init__(self, proc: subprocess.Popen, url: str, root: Path, outside: Path, log: Path) -> None:
        self.proc, self.url, self.root, self.outside, self.log = proc, url, root, outside, log
        self.base = url.split("?")[0].rstrip("/")
        self.port = int(self.base.rsplit(":", 1)[1])
        self.token = url.split("secret=", 1)[1]
        self.ws = f"ws://127.0.0.1:{self.port}/ws"
        self.origin = f"http://127.0.0.1:{self.port}"


def make_folders(base: Path) -> tuple[Path, Path]:
    root, outside = base / "root", base / "outside"
    (root / "site").mkdir(parents=True)
    outside.mkdir()
    save_ffd(root / "lattice.ffd", Lattice((5, 5, 5), 0.2))
    (root / "secret_first_line.ffd").write_text("TOPSECRET-7f3a is the first line\n#dimension#\n3\n")
    (root / "bad.vtk").write_bytes(BAD_VTK)
    os.mkfifo(root / "fifo.ffd")
    os.symlink(outside, root / "link_out")
    os.symlink("/dev/zero", root / "zero.obj")
    (outside / "passwd").write_text("root:x:0:0:OUTSIDE-SECRET:/root:/bin/bash\n")
    pv.Sphere().save(outside / "m.vtp")
    return root, outside


def start_app(base: Path, *extra: str) -> App:
    root, outside = make_folders(base)
    log = base / "app.log"
    env = server_env(TMPDIR=str(base / "tmp"))
    env.pop("FFD_NOTEBOOK_TEST_HOOKS", None)  # normal use: no test hooks
    (base / "tmp").mkdir()
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "ffd_notebook", "--port", "0", "--root", str(root), *extra],
                                cwd=base, stdout=out, stderr=subprocess.STDOUT, env=env)  # fmt: skip

    def started() -> str | None:
        if proc.poll() is not None:
            raise RuntimeError(f"the app exited with {proc.returncode}:\n{log.read_text()}")
        return printed_url(log)

    try:
        url = wait_for(started, 180, "the app to print its URL")
    except BaseException:
        stop_process(proc)
        raise
    return App(proc, url, root, outside, log)


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    running = start_app(tmp_path_factory.mktemp("attacks"))
    yield running
    stop_process(running.proc)


def run(coro, timeout: float = 120):
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def authenticated_action(app: App, trigger: str, *args, wait_s: float = 60):
    """With the token and the app's own Origin: call ``trigger`` and return the state once it is idle again."""
    async with connect(app.ws, origin=app.origin) as s:
        assert "result" in await s.hello(app.token)
        reply = await s.trigger(trigger, *args)  # returns once refused, or once the work runs in the background
        assert "error" not in reply, reply
        return await s.wait_for_state(lambda st: not st["busy"], wait_s)


# ---------------------------------------------------------------------- who may connect
@pytest.mark.parametrize("origin", ["http://evil.example", "null", "http://127.0.0.1:1"])
def test_foreign_origin_is_refused_at_the_handshake(app, origin):
    with pytest.raises(Refused) as refused:
        run(connect(app.ws, origin=origin).__aenter__())
    assert refused.value.status == 403
    assert http_status(f"{app.base}/index.html", {"Origin": origin}) == 403


def test_dns_rebinding_host_is_refused(app):
    host = f"evil.example:{app.port}"
    with pytest.raises(Refused):
        run(connect(app.ws, origin=f"http://{host}", host=host).__aenter__())
    assert http_status(f"{app.base}/index.html", {"Host": host}) == 403


def test_the_issue_attack_foreign_origin_default_secret_save(app):
    """The issue's exact client: Origin evil.example, secret wslink-secret, then save the lattice anywhere."""
    target = app.outside / "written_by_evil.ffd"

    async def attack():
        async with connect(app.ws, origin="http://evil.example") as s:
            await s.hello(DEFAULT_SECRET)
            await s.trigger("ffd_save_ffd", str(target))

    with pytest.raises(Refused):
        run(attack())
    assert not target.exists()


@pytest.mark.parametrize("secret", [DEFAULT_SECRET, "", "x" * 43])
def test_default_or_wrong_secret_is_refused(app, secret):
    target = app.root / "written_without_token.ffd"

    async def attack():
        async with connect(app.ws, origin=app.origin) as s:
            hello = await s.hello(secret)
            save = await s.trigger("ffd_save_ffd", str(target))
            state = await s.call("trame.state.get")
            return hello, save, state

    hello, save, state = run(attack())
    assert "error" in hello and "error" in save and "error" in state
    assert "Unauthorized" in save["error"]["message"]
    assert not target.exists()


def test_the_printed_url_carries_the_token_that_works(app):
    assert app.url.startswith(f"http://127.0.0.1:{app.port}/?secret=") and len(app.token) >= 40
    assert app.token not in app.log.read_text().replace(app.url, "")  # printed once, in the URL only
    state = run(authenticated_action(app, "ffd_save_ffd", "saved_with_token.ffd"))
    assert (app.root / "saved_with_token.ffd").is_file()
    assert messages(state)[0] == "saved the lattice to saved_with_token.ffd"


def test_a_reload_keeps_the_token_through_an_httponly_cookie(app):
    """The trame client strips the token from the address bar; the page's cookie brings it back on reload."""
    import http.client

    def get(path: str, cookie: str | None = None) -> http.client.HTTPResponse:
        conn = http.client.HTTPConnection("127.0.0.1", app.port, timeout=30)
        conn.request("GET", path, headers={"Cookie": cookie} if cookie else {})
        response = conn.getresponse()
        response.read()
        conn.close()
        return response

    first = get(f"/index.html?secret={app.token}")
    set_cookie = first.getheader("Set-Cookie")
    assert first.status == 200 and "HttpOnly" in set_cookie and "SameSite=Strict" in set_cookie
    cookie = set_cookie.split(";", 1)[0]
    reload = get("/index.html?ui=main", cookie)
    assert reload.status == 302 and reload.getheader("Location") == f"/index.html?ui=main&secret={app.token}"
    assert get("/index.html", cookie.split("=")[0] + "=forged").status == 200  # no redirect, no token
    assert get("/index.html?secret=wrong").getheader("Set-Cookie") is None


def test_test_hooks_are_off_in_normal_use(app):
    async def probe():
        async with connect(app.ws, origin=app.origin) as s:
            await s.hello(app.token)
            return [await s.trigger(name) for name in ("ffd_state", "ffd_widget_px")]

    for reply in run(probe()):
        assert reply.get("result") is None  # no such trigger: no internal state handed out


# ---------------------------------------------------------------------- paths (even with the token)
@pytest.mark.parametrize("typed", ["../outside/x.ffd", "{outside}/x.ffd", "link_out/x.ffd", "site/../../outside/x.ffd"])
def test_save_outside_the_root_is_refused(app, typed):
    typed = typed.format(outside=app.outside)
    state = run(authenticated_action(app, "ffd_save_ffd", typed))
    assert "outside the app's folder" in messages(state)[0]
    mesh_typed = typed.replace(".ffd", ".obj")
    state = run(authenticated_action(app, "ffd_save_mesh", mesh_typed))
    assert "outside the app's folder" in messages(state)[0]
    assert not list(app.outside.glob("x.*"))


def test_pth_file_cannot_be_written(app):
    """The issue's code execution: upload a .ffd whose unknown section carries Python, save it as a .pth."""
    lattice_text = (app.root / "lattice.ffd").read_text() + f"\n#unknown#\n{PTH_PAYLOAD}\n"

    async def attack():
        async with connect(app.ws, origin=app.origin) as s:
            await s.hello(app.token)
            await s.set_state(ffd_upload={"name": "payload.ffd", "content": lattice_text.encode()})
            await s.wait_for_state(lambda st: not st["busy"] and st["ffd_upload"] is None, 60)
            for trigger in ("ffd_save_ffd", "ffd_save_mesh"):
                for typed in ("site/evil.pth", "site/evil.pth/../evil.pth", f"{app.outside}/evil.pth"):
                    await s.trigger(trigger, typed)
            return await s.wait_for_state(lambda st: not st["busy"], 60)

    state = run(attack())
    assert not list(app.root.rglob("*.pth")) and not list(app.outside.rglob("*.pth"))
    assert any("must end with .ffd" in m for m in messages(state))
    assert any("must end with .obj" in m for m in messages(state))


def test_load_errors_neither_quote_files_nor_tell_what_exists_outside(app):
    outside_exists, outside_missing = app.outside / "passwd", app.outside / "no_such_file"
    texts = []
    for trigger in ("ffd_load_ffd", "ffd_load_mesh"):
        for path in (outside_exists, outside_missing, "/etc/passwd", "/etc/no_such_file"):
            texts.append(messages(run(authenticated_action(app, trigger, str(path))))[0].replace(str(path), "P"))
    assert len(set(texts)) == 1, texts  # one answer whether the file exists or not
    assert texts[0] == "Error: could not load: 'P' is outside the app's folder"
    inside = messages(run(authenticated_action(app, "ffd_load_ffd", "secret_first_line.ffd")))[0]
    assert inside.startswith("Error: could not load: secret_first_line.ffd, line 1:")
    all_text = " ".join(texts) + inside
    assert "TOPSECRET" not in all_text and "OUTSIDE-SECRET" not in all_text and "root:x" not in all_text


# ---------------------------------------------------------------------- files that froze or killed the server
def test_fifo_does_not_freeze_the_server(app):
    for trigger in ("ffd_load_ffd", "ffd_load_mesh"):
        state = run(authenticated_action(app, trigger, "fifo.ffd"), timeout=60)
        assert messages(state)[0] == "Error: could not load: fifo.ffd is not a regular file"
    assert http_status(f"{app.base}/index.html") == 200


def test_dev_zero_is_never_read(app):
    for typed in ("/dev/zero", "zero.obj"):  # absolute, and a symlink in the root pointing at it
        state = run(authenticated_action(app, "ffd_load_mesh", typed), timeout=60)
        assert "outside the app's folder" in messages(state)[0]
    assert app.proc.poll() is None


def test_crashing_vtk_does_not_kill_the_server(app):
    state = run(authenticated_action(app, "ffd_load_mesh", "bad.vtk"))
    assert messages(state)[0].startswith("Error: could not load: bad.vtk: ")

    async def upload():
        async with connect(app.ws, origin=app.origin) as s:
            await s.hello(app.token)
            await s.set_state(mesh_upload={"name": "bad.vtk", "content": BAD_VTK})
            return await s.wait_for_state(lambda st: not st["busy"] and "bad.vtk (uploaded)" in messages(st)[0], 60)

    assert messages(run(upload()))[0].startswith("Error: could not load: bad.vtk (uploaded)")
    assert app.proc.poll() is None and http_status(f"{app.base}/index.html") == 200
    state = run(authenticated_action(app, "ffd_load_mesh", "link_out/../lattice.ffd"))  # still serving actions
    assert app.proc.poll() is None and messages(state)[0].startswith("Error:")


# ---------------------------------------------------------------------- a slow load, uploads, exit
def test_http_answers_during_a_slow_load_and_uploads_go_at_exit(tmp_path):
    app = start_app(tmp_path)
    try:
        big = pv.Sphere(theta_resolution=500, phi_resolution=500)  # ~20 MB of OBJ text: seconds to parse
        big.point_data["RGB"] = np.zeros((big.n_points, 3), dtype=np.uint8)
        from ffd_notebook.io import write_obj

        write_obj(app.root / "big.obj", big)

        async def scenario():
            async with connect(app.ws, origin=app.origin) as s:
                await s.hello(app.token)
                await s.set_state(ffd_upload={"name": "up.ffd", "content": (app.root / "lattice.ffd").read_bytes()})
                await s.wait_for_state(lambda st: not st["busy"] and "up.ffd (uploaded)" in messages(st)[0], 60)
                uploads = list((tmp_path / "tmp").glob("ffd_notebook_upload_*/upload_*/up.ffd"))  # one folder each
                reply = await s.trigger("ffd_load_mesh", "big.obj")
                t_reply = time.monotonic()
                busy = (await s.state())["busy"]
                status = await asyncio.to_thread(http_status, f"{app.base}/index.html")
                t_http = time.monotonic()
                still_busy = (await s.state())["busy"]
                done = await s.wait_for_state(lambda st: not st["busy"], 180)
                return reply, busy, status, still_busy, t_http - t_reply, done, uploads

        reply, busy, status, still_busy, http_s, done, uploads = run(scenario(), timeout=300)
        assert "error" not in reply and busy, "the load must run in the background, shown as busy"
        assert status == 200 and still_busy, f"HTTP must answer while the load runs (took {http_s:.2f} s)"
        assert messages(done)[0].startswith("loaded big.obj: 249002 vertices")
        assert len(uploads) == 1
    finally:
        stop_process(app.proc)
    assert app.proc.returncode is not None
    assert not list((tmp_path / "tmp").glob("ffd_notebook_upload_*")), "the uploads folder outlived the app"


def test_no_setting_installs_state_triggers():
    """The triggers that hand out internal state exist only in tests/editor_instrument.py, installed by code."""
    package = Path(__file__).resolve().parents[2] / "ffd_notebook"
    for path in package.rglob("*.py"):
        text = path.read_text()
        assert "ffd_state" not in text and "ffd_widget_px" not in text, path
        assert "TEST_HOOKS" not in text and "FFD_NOTEBOOK_TRACE" not in text, path
