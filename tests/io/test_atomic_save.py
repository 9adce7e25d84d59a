"""Saving (issue 8): errors name the target, no orphan temporary file, symlinks followed, modes kept, fsync."""

from __future__ import annotations

import os
import stat

import pytest
import pyvista as pv

from ffd_notebook import Lattice
from ffd_notebook.io import _atomic, save_ffd, write_mesh


def _no_temporary_files(folder) -> None:
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]


def test_error_names_the_target_not_the_temporary_file(tmp_path):
    target = tmp_path / "no-such-folder" / "lattice.ffd"
    with pytest.raises(FileNotFoundError) as info:
        save_ffd(target, Lattice((2, 2, 2), 1.0))
    assert info.value.filename == str(target) and ".tmp" not in str(info.value)


def test_replacing_a_folder_names_the_target_and_leaves_nothing(tmp_path):
    target = tmp_path / "lattice.ffd"
    target.mkdir()
    with pytest.raises(OSError) as info:
        save_ffd(target, Lattice((2, 2, 2), 1.0))
    assert str(target) in str(info.value) and ".tmp" not in str(info.value)
    assert target.is_dir()
    assert [p.name for p in tmp_path.iterdir()] == ["lattice.ffd"]


def test_failure_inside_a_writer_leaves_no_orphan(tmp_path, monkeypatch):
    def failing_fsync(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", failing_fsync)
    with pytest.raises(OSError, match="No space"):
        save_ffd(tmp_path / "a.ffd", Lattice((2, 2, 2), 1.0))
    assert list(tmp_path.iterdir()) == []


def test_writer_error_messages_name_the_target(tmp_path):
    with pytest.raises(ValueError) as info:  # PyVista has no writer for .xyz
        write_mesh(tmp_path / "mesh.xyz", pv.Cube())
    assert ".tmp" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_saving_to_a_symlink_writes_the_file_it_points_to(tmp_path):
    real = tmp_path / "data" / "lattice.ffd"
    real.parent.mkdir()
    real.write_text("old")
    real.chmod(0o640)
    link = tmp_path / "link.ffd"
    link.symlink_to(real)
    save_ffd(link, Lattice((2, 2, 2), 1.0))
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_text().startswith("#dimension#")
    assert stat.S_IMODE(real.stat().st_mode) == 0o640
    _no_temporary_files(tmp_path)
    _no_temporary_files(real.parent)


@pytest.mark.parametrize("mode", [0o600, 0o644, 0o755])
def test_existing_mode_is_kept(tmp_path, mode):
    target = tmp_path / "mesh.vtp"
    target.write_text("old")
    target.chmod(mode)
    write_mesh(target, pv.Cube())
    assert stat.S_IMODE(target.stat().st_mode) == mode
    assert pv.read(target).n_cells == 6


def test_folder_is_fsynced_after_the_rename(tmp_path, monkeypatch):
    events = []
    real_replace, real_fsync = os.replace, os.fsync

    def replace(src, dst):
        events.append(("replace", str(dst)))
        real_replace(src, dst)

    def fsync(fd):
        info = os.fstat(fd)
        events.append(("fsync-dir" if stat.S_ISDIR(info.st_mode) else "fsync-file", info.st_ino))
        real_fsync(fd)

    monkeypatch.setattr(_atomic.os, "replace", replace)
    monkeypatch.setattr(_atomic.os, "fsync", fsync)
    save_ffd(tmp_path / "a.ffd", Lattice((2, 2, 2), 1.0))
    kinds = [e[0] for e in events]
    assert "replace" in kinds and kinds[-1] == "fsync-dir"
    assert events[-1][1] == tmp_path.stat().st_ino
    assert "fsync-file" in kinds[: kinds.index("replace")]
