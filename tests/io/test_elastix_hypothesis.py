"""Property tests of elastix parameter files: any parameters and any B-spline FFD survive a write and a read."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import load_deformation, load_elastix, save_elastix
from ffd_notebook.io.elastix_text import read_parameter_file, write_parameter_file

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,20}", fullmatch=True)
words = st.text(st.characters(codec="ascii", exclude_characters='"\r\n/'), min_size=1, max_size=30).filter(
    lambda w: w.strip(" \t") != ""
)
values = st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.integers(-(2**60), 2**60), words, st.booleans())


@SETTINGS
@given(st.dictionaries(names, st.lists(values, min_size=1, max_size=6), min_size=1, max_size=8))
def test_parameters_read_back_as_written(entries):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "p.txt"
        write_parameter_file(path, list(entries.items()))
        params = read_parameter_file(path)
    assert list(params.entries) == list(entries)
    for name, written in entries.items():
        read = params.values(name)
        expected = []
        for v in written:
            if isinstance(v, bool):
                expected.append("true" if v else "false")
            elif isinstance(v, str):  # elastix splits quoted strings only on quotes; blanks around stay inside
                expected.append(v.replace("\t", " "))
            else:
                expected.append(v)
        assert len(read) == len(expected)
        for got, want in zip(read, expected, strict=True):
            if isinstance(want, str):
                assert got == want
            else:
                assert float(got) == float(want)


@st.composite
def ffds(draw):
    shape = tuple(draw(st.lists(st.integers(4, 6), min_size=3, max_size=3)))
    spacing = draw(st.lists(st.floats(1e-2, 1e2), min_size=3, max_size=3))
    origin = draw(st.lists(finite, min_size=3, max_size=3))
    rotation = Rotation.random(random_state=draw(st.integers(0, 2**32 - 1))).as_matrix()
    if draw(st.booleans()):
        rotation = rotation @ np.diag([1.0, 1.0, -1.0])
    offsets = draw(arrays(np.float64, shape + (3,), elements=st.floats(-1e3, 1e3)))
    affine = np.eye(4)
    if draw(st.booleans()):
        affine[:3] = draw(arrays(np.float64, (3, 4), elements=st.floats(-10, 10)))
    lattice = Lattice(shape, spacing, origin, rotation, offsets)
    return FFD(lattice, affine=affine, only_inside=draw(st.booleans()))


@SETTINGS
@given(ffds())
def test_any_bspline_ffd_survives_elastix_files(ffd):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "TransformParameters.0.txt"
        save_elastix(path, ffd)
        back = load_deformation(path)
        chain = load_elastix(path)
    lat = ffd.lattice
    assert back.only_inside == ("half-open" if ffd.only_inside else False)
    assert np.array_equal(back.affine, ffd.affine)
    assert np.array_equal(back.lattice.offsets, lat.offsets)
    assert np.array_equal(back.lattice.spacing, lat.spacing) and np.array_equal(back.lattice.rotation, lat.rotation)
    scale = np.abs(lat.origin).max() + 10 * lat.spacing.max()
    assert np.abs(back.lattice.origin - lat.origin).max() <= 1e-13 * scale
    inside = lat.to_world(np.random.default_rng(0).random((20, 3)) * (np.array(lat.shape) - 3) + 1)
    size = np.abs(ffd.deform(inside)).max() + 1.0
    # the two compute lattice coordinates differently: rounding of |x| / spacing, times the offsets
    rounding = 1e-13 * np.abs(inside).max() / lat.spacing.min() * (np.abs(lat.offsets).max() + 1.0)
    assert np.abs(chain.deform(inside) - ffd.deform(inside)).max() <= 1e-9 * size + rounding


@SETTINGS
@given(st.binary(max_size=400), st.sampled_from([b"", b"(Transform ", b'(Transform "BSplineTransform")\n(']))
def test_garbage_is_a_file_format_error(data, prefix):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "p.txt"
        path.write_bytes(prefix + data)
        try:
            load_elastix(path)
        except FileFormatError:
            pass
