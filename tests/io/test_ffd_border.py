"""The .ffd file records a "clamp" lattice in a #border# section; files without it mean "zero"."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_ffd, save_ffd

TINY = (
    "#dimension#\n3\n#one to one#\n1\n#control grid size#\n2\n2\n2\n#control grid spacing#\n1\n1\n1\n"
    "#offsets of the control points#\n0 0 0\t0 0 0.5\t\n0 0 0\t0 0 0\t\n\n1.5 0 0\t0 0 0\t\n0 0 0\t0 -2 0\t\n\n"
)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31), st.sampled_from(["zero", "clamp"]))
def test_border_round_trips_and_the_loaded_ffd_deforms_the_same(tmp_path_factory, seed, border):
    rng = np.random.default_rng(seed)
    lat = Lattice(tuple(rng.integers(4, 7, 3)), rng.uniform(0.5, 2, 3), rng.normal(size=3), border=border)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape)
    path = tmp_path_factory.mktemp("border") / "lattice.ffd"
    save_ffd(path, lat)
    text = path.read_text()
    assert ("#border#\nclamp\n" in text) == (border == "clamp")
    loaded = load_ffd(path)
    assert loaded == lat and loaded.border == border
    pts = lat.to_world(rng.uniform(-2, np.array(lat.shape) + 1, size=(50, 3)))
    np.testing.assert_array_equal(FFD(loaded).deform(pts), FFD(lat).deform(pts))


def test_files_without_the_section_mean_zero_and_zero_lattices_are_written_as_before(tmp_path):
    path = tmp_path / "tiny.ffd"
    path.write_text(TINY)
    lat = load_ffd(path)
    assert lat.border == "zero"
    save_ffd(path, lat)
    headers = [line for line in path.read_text().splitlines() if line.startswith("#")]
    assert headers == [line for line in TINY.splitlines() if line.startswith("#")]  # nothing added for "zero"


def test_border_section_is_read_loosely_and_kept_with_unknown_sections(tmp_path):
    path = tmp_path / "clamp.ffd"
    path.write_text(TINY + "# Border #\r\n  CLAMP \r\n#notes#\nkept\n")
    lat = load_ffd(path)
    assert lat.border == "clamp"
    assert [s["header"] for s in lat.metadata["ffd_extra_sections"]] == ["notes"]
    save_ffd(path, lat)
    assert path.read_text().endswith("#border#\nclamp\n#notes#\nkept\n")
    assert load_ffd(path) == lat


@pytest.mark.parametrize("body, line", [("mirror\n", 21), ("\n", 20), ("zero clamp\n", 21)])
def test_bad_border_section_names_the_file_and_line(tmp_path, body, line):
    path = tmp_path / "bad.ffd"
    path.write_text(TINY + "#border#\n" + body)
    with pytest.raises(FileFormatError, match=rf"bad\.ffd.*line {line}.*'zero' or 'clamp'"):
        load_ffd(path)
