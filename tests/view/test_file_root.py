"""The app's root folder, special/oversize files, safe messages, and the Host/Origin policy, without a server."""

from __future__ import annotations

import os

import pytest

from ffd_notebook.errors import FileFormatError
from ffd_notebook.io.mesh import MESH_SUFFIXES
from ffd_notebook.view.serving.file_root import (
    FFD_SUFFIXES,
    FileRoot,
    PathRefused,
    client_message,
    refuse_special_or_oversize,
)
from ffd_notebook.view.serving.web_security import AccessPolicy, url_with_token


@pytest.fixture
def root(tmp_path):
    (tmp_path / "root" / "sub").mkdir(parents=True)
    (tmp_path / "outside").mkdir()
    (tmp_path / "root" / "a.ffd").write_text("x" * 100)
    (tmp_path / "outside" / "o.ffd").write_text("secret")
    os.symlink(tmp_path / "root" / "a.ffd", tmp_path / "root" / "sub" / "to_a.ffd")
    os.symlink(tmp_path / "outside" / "o.ffd", tmp_path / "root" / "to_o.ffd")
    os.symlink("loop2", tmp_path / "root" / "loop1.ffd")
    os.symlink("loop1.ffd", tmp_path / "root" / "loop2")
    return FileRoot(tmp_path / "root", max_bytes=1000)


def test_paths_inside_the_root_resolve_and_symlinks_are_followed(root):
    assert root.for_reading("a.ffd") == root.path / "a.ffd"
    assert root.for_reading(str(root.path / "sub" / ".." / "a.ffd")) == root.path / "a.ffd"
    assert root.for_reading("sub/to_a.ffd") == root.path / "a.ffd"  # a link inside the root: its target
    assert root.for_writing("sub/to_a.ffd", FFD_SUFFIXES) == root.path / "a.ffd"  # saving writes the target
    assert root.for_writing("sub/new.ply", MESH_SUFFIXES) == root.path / "sub" / "new.ply"


@pytest.mark.parametrize("typed", ["../outside/o.ffd", "to_o.ffd", "/etc/passwd", "sub/../../outside/o.ffd",
                                   "loop1.ffd", "", "a\x00.ffd"])  # fmt: skip
def test_escapes_are_refused_alike(root, typed):
    with pytest.raises(PathRefused) as refused:
        root.for_reading(typed)
    assert "secret" not in str(refused.value)
    with pytest.raises(PathRefused):
        root.for_writing(typed, FFD_SUFFIXES)


def test_special_oversize_and_wrong_kind(root, tmp_path):
    os.mkfifo(root.path / "fifo.ffd")
    with pytest.raises(PathRefused, match=r"fifo\.ffd is not a regular file"):
        root.for_reading("fifo.ffd")  # must not block
    with pytest.raises(PathRefused, match="sub is not a regular file"):
        root.for_reading("sub")
    (root.path / "big.ffd").write_bytes(b"0" * 1001)
    with pytest.raises(PathRefused, match="bigger than the limit"):
        root.for_reading("big.ffd")
    with pytest.raises(FileNotFoundError):
        root.for_reading("missing.ffd")
    with pytest.raises(PathRefused, match=r"must end with \.ffd"):
        root.for_writing("x.pth", FFD_SUFFIXES)
    with pytest.raises(PathRefused, match="not a regular file"):
        root.for_writing("fifo.ffd", FFD_SUFFIXES)
    with pytest.raises(FileNotFoundError):
        root.for_writing("nofolder/x.ffd", FFD_SUFFIXES)
    with pytest.raises(PathRefused):
        refuse_special_or_oversize("/dev/null", 10)


def test_client_messages_do_not_quote_the_file():
    err = FileFormatError("/abs/x.ffd", 3, "expected 'dx dy dz' for control point 4, got 'PRIVATE KEY'")
    assert client_message(err, "x.ffd") == "x.ffd, line 3: expected"
    err = FileFormatError("/abs/m.ply", None, "not a mesh file PyVista can read (ValueError: PRIVATE)")
    assert client_message(err, "m.ply") == "m.ply: not a mesh file PyVista can read"
    assert "PRIVATE" not in client_message(ValueError("bad value: PRIVATE"), "m.ply")


def test_access_policy_for_a_server_on_all_interfaces():
    policy = AccessPolicy("t", bind_host="0.0.0.0")
    assert policy.allows({"Host": "192.168.1.20:8080", "Origin": "http://192.168.1.20:8080"})
    assert policy.allows({"Host": "[::1]:8080", "Origin": "http://[::1]:8080"})
    assert not policy.allows({"Host": "192.168.1.20:8080", "Origin": "http://192.168.1.20:9999"})
    assert not policy.allows({"Host": "rebound.example:8080", "Origin": "http://rebound.example:8080"})
    assert not policy.allows({"Origin": "http://127.0.0.1:8080"})  # no Host at all
    assert AccessPolicy("t", behind_proxy=lambda: True).allows({"Host": "hub.example", "Origin": "https://hub.example"})


def test_url_with_token_replaces_an_old_token():
    assert url_with_token("http://h:1/?secret=old&ui=a", "new") == "http://h:1/?ui=a&secret=new"
