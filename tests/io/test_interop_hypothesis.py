"""Fuzzing the ITK and PyGeM readers with mutated real files: a model or a FileFormatError, nothing else."""

from __future__ import annotations

import os

import numpy as np
import pytest
import SimpleITK as sitk
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, load_prm, load_transform
from ffd_notebook.errors import FileFormatError

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@st.composite
def edits(draw, text: str):
    """A few random edits of ``text``: replace, delete or insert a short run of characters, or a whole line."""
    for _ in range(draw(st.integers(1, 4))):
        where = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["replace", "delete", "insert", "drop line", "copy line"]))
        junk = draw(st.text(alphabet=st.sampled_from(list("0123456789 .-e+#:\t\nabcxyzT[]=nan")), max_size=6))
        if kind == "replace":
            text = text[:where] + junk + text[where + len(junk) :]
        elif kind == "delete":
            text = text[:where] + text[where + draw(st.integers(1, 8)) :]
        elif kind == "insert":
            text = text[:where] + junk + text[where:]
        else:
            lines = text.split("\n")
            i = min(where * len(lines) // max(len(text), 1), len(lines) - 1)
            lines[i : i + 1] = [] if kind == "drop line" else [lines[i], lines[i]]
            text = "\n".join(lines)
    return text


def sitk_composite_text(tmp_path_factory) -> str:
    rng = np.random.default_rng(0)
    image = sitk.Image([6, 6, 6], sitk.sitkFloat32)
    bspline = sitk.BSplineTransformInitializer(image, [1, 2, 1], 3)
    bspline.SetParameters(rng.normal(size=len(bspline.GetParameters())).tolist())
    composite = sitk.CompositeTransform(3)
    composite.AddTransform(sitk.AffineTransform(3))
    composite.AddTransform(bspline)
    path = tmp_path_factory.mktemp("fuzz") / "real.tfm"
    sitk.WriteTransform(composite, os.fspath(path))
    return path.read_text()


@pytest.fixture(scope="module")
def tfm_text(tmp_path_factory):
    return sitk_composite_text(tmp_path_factory)


@pytest.fixture(scope="module")
def prm_text(shared_data):
    return (shared_data / "pygem" / "parameters_test_ffd_sphere.prm").read_text()


def check(load, path):
    try:
        result = load(path)
    except FileFormatError as exc:
        assert exc.path == os.fspath(path)
        assert (exc.line is not None and exc.line >= 1) or "HDF5" in exc.problem
        return None
    return result


@SETTINGS
@given(data=st.data())
def test_mutated_tfm(tmp_path, tfm_text, data):
    path = tmp_path / "mutated.tfm"
    path.write_text(data.draw(edits(tfm_text)))
    ffd = check(load_transform, path)
    if ffd is not None:  # what loads must be a working deformation
        assert isinstance(ffd, FFD)
        assert np.all(np.isfinite(ffd.deform(ffd.lattice.control_points().reshape(-1, 3))))


@SETTINGS
@given(data=st.data())
def test_mutated_prm(tmp_path, prm_text, data):
    path = tmp_path / "mutated.prm"
    path.write_text(data.draw(edits(prm_text)))
    lattice = check(load_prm, path)
    if lattice is not None:
        assert np.all(np.isfinite(lattice.offsets)) and min(lattice.shape) >= 2


@SETTINGS
@given(data=st.data())
def test_random_bytes(tmp_path, data):
    """Binary junk (not UTF-8, NUL bytes) is a FileFormatError too."""
    blob = data.draw(st.binary(max_size=200))
    for name, load in (("junk.tfm", load_transform), ("junk.prm", load_prm)):
        path = tmp_path / name
        path.write_bytes(blob)
        check(load, path)


@pytest.fixture(scope="module")
def h5_bytes(tmp_path_factory):
    text_path = tmp_path_factory.mktemp("fuzz-h5") / "real.tfm"
    text_path.write_text(sitk_composite_text(tmp_path_factory))
    path = text_path.with_suffix(".h5")
    sitk.WriteTransform(sitk.ReadTransform(os.fspath(text_path)), os.fspath(path))
    return path.read_bytes()


@SETTINGS
@given(data=st.data())
def test_mutated_h5(tmp_path, h5_bytes, data):
    blob = bytearray(h5_bytes)
    for _ in range(data.draw(st.integers(1, 5))):
        blob[data.draw(st.integers(0, len(blob) - 1))] = data.draw(st.integers(0, 255))
    path = tmp_path / "mutated.h5"
    path.write_bytes(bytes(blob))
    ffd = check(load_transform, path)
    if ffd is not None:
        assert np.all(np.isfinite(ffd.deform(ffd.lattice.control_points().reshape(-1, 3))))


def test_damaged_global_heap_is_refused_not_read(tmp_path, h5_bytes):
    """The HDF5 library loops forever on a global-heap object too long by a few bytes (found by fuzzing)."""
    blob = bytearray(h5_bytes)
    heap = blob.index(b"GCOL\x01\x00\x00\x00")
    at, last = heap + 16, None
    while int.from_bytes(blob[at : at + 2], "little"):  # walk to the free space, remembering the last object
        last = at
        at += 16 + -(-int.from_bytes(blob[at + 8 : at + 16], "little") // 8) * 8
    blob[last + 8] += 64  # the last string now runs 64 bytes into the free space
    path = tmp_path / "heap.h5"
    path.write_bytes(bytes(blob))
    with pytest.raises(FileFormatError, match=rf"heap.h5: damaged HDF5 global heap at byte {heap}"):
        load_transform(path)
