"""One loopback rule for the whole package (``web_security.is_loopback``): the Host check of the servers and
the app's warning about its listening address use it, and agree.

The rule: ``localhost``, any name under ``.localhost`` (RFC 6761 section 6.3: browsers resolve those to
loopback themselves, so a page cannot rebind them), and loopback addresses, IPv4-mapped ones included.
"""

from __future__ import annotations

import pytest

from ffd_notebook.__main__ import main
from ffd_notebook.view.serving.web_security import AccessPolicy, is_loopback

LOOPBACK = ["localhost", "LocalHost", "localhost.", "app.localhost", "a.b.localhost", "127.0.0.1", "127.255.0.9",
            "::1", "[::1]", "::ffff:127.0.0.1"]  # fmt: skip
NOT_LOOPBACK = ["localhost.example", "localhost.evil.example", "notlocalhost", "mylocalhost", "10.0.0.1",
                "0.0.0.0", "::", "192.168.1.2", "::ffff:10.0.0.1", "evil.example", ""]  # fmt: skip


@pytest.mark.parametrize("host", LOOPBACK)
def test_loopback_names_and_addresses(host):
    assert is_loopback(host)


@pytest.mark.parametrize("host", NOT_LOOPBACK)
def test_other_names_and_addresses(host):
    assert not is_loopback(host)


@pytest.mark.parametrize("host", ["app.localhost", "127.0.0.2", "[::1]"])
def test_the_servers_host_check_admits_every_loopback_name(host):
    """A server listening on 127.0.0.1 admits a request to any loopback name and no other name (DNS rebinding)."""
    policy = AccessPolicy("token")
    assert policy.allows({"Host": f"{host}:8080", "Origin": f"http://{host}:8080"})
    assert not policy.allows({"Host": "localhost.evil.example:8080", "Origin": "http://localhost.evil.example:8080"})


def _warning(capsys, monkeypatch, tmp_path, host: str) -> str:
    """What ``python -m ffd_notebook --host HOST`` prints about its address before it starts (the start is
    stopped at the editor's first step, which the warning precedes)."""

    class Stop(Exception):
        pass

    def stop(*_args, **_kwargs):
        raise Stop

    import ffd_notebook.view.editor.app as app_module

    monkeypatch.setattr(app_module, "run_app", stop)
    monkeypatch.setenv("TRAME_ARGS", "")  # main sets it for trame
    with pytest.raises(Stop):
        main(["--host", host, "--root", str(tmp_path)])
    return capsys.readouterr().err


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost", "app.localhost", "::1"])
def test_the_app_does_not_warn_on_a_loopback_address(capsys, monkeypatch, tmp_path, host):
    assert "warning: listening" not in _warning(capsys, monkeypatch, tmp_path, host)


@pytest.mark.parametrize("host", ["0.0.0.0", "localhost.example"])
def test_the_app_warns_on_any_other_address(capsys, monkeypatch, tmp_path, host):
    assert f"warning: listening on {host}" in _warning(capsys, monkeypatch, tmp_path, host)
