"""Statismo/Scalismo HDF5 files: the real Scalismo model loads, its instances match the raw formula, it saves back
unchanged; bad files raise FileFormatError naming the dataset; saving is atomic."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook.errors import FileFormatError
from ffd_notebook.gp import GaussianKernel, GaussianProcess, LowRankGP, load_model, save_model

SCALISMO = Path(__file__).resolve().parents[3] / "shared" / "data" / "statismo" / "scalismo_asm_model.h5"


def _contents(path):
    """Every dataset (value, dtype) and group of a file, and every attribute of each, by path."""
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            value = obj[()] if isinstance(obj, h5py.Dataset) else None
            out[name] = (value, None if value is None else np.asarray(value).dtype, dict(obj.attrs))

        f.visititems(visit)
    return out


def _assert_same_contents(a, b):
    ca, cb = _contents(a), _contents(b)
    assert set(ca) == set(cb)
    for name, (va, ta, attrs_a) in ca.items():
        vb, tb, attrs_b = cb[name]
        assert ta == tb, name
        if va is not None:
            assert np.shape(va) == np.shape(vb), name
            assert np.array_equal(va, vb), name
        assert set(attrs_a) == set(attrs_b), name
        for key in attrs_a:
            assert attrs_a[key].dtype == attrs_b[key].dtype and np.array_equal(attrs_a[key], attrs_b[key]), (name, key)


@pytest.fixture(scope="module")
def raw():
    with h5py.File(SCALISMO, "r") as f:
        return {k: f[k][()].astype(np.float64) for k in ("model/mean", "model/pcaBasis", "model/pcaVariance")} | {
            "points": f["representer/points"][()].astype(np.float64),
            "cells": f["representer/cells"][()],
        }


def test_scalismo_model_loads_and_its_instances_follow_the_raw_datasets(raw):
    model = load_model(SCALISMO)
    assert model.points.shape == (1400, 3) and model.rank == 50
    np.testing.assert_array_equal(model.points, raw["points"].T)
    np.testing.assert_array_equal(model.cells, raw["cells"].T)
    basis = raw["model/pcaBasis"]
    gram = basis.T @ basis
    assert np.abs(gram - np.eye(50)).max() > 1.0  # the file's basis is not orthonormal
    np.testing.assert_array_equal(model.eigenvalues, raw["model/pcaVariance"])
    rng = np.random.default_rng(0)
    for c in [np.zeros(50), *rng.normal(size=(3, 50))]:
        expected = raw["model/mean"] + basis @ (np.sqrt(raw["model/pcaVariance"]) * c)
        np.testing.assert_allclose((model.points + model.instance(c)).ravel(), expected, rtol=0, atol=1e-10)
    np.testing.assert_allclose(model.basis_matrix(), basis, atol=1e-12)
    # the model works like any other: a posterior with per-landmark covariances
    post = model.posterior(model.points[:3], model.mean()[:3] + 1.0, noise=np.broadcast_to(np.eye(3), (3, 3, 3)))
    assert post.mean().shape == (1400, 3)


def test_scalismo_model_saves_back_with_the_same_datasets_and_attributes(tmp_path):
    out = tmp_path / "again.h5"
    save_model(out, load_model(SCALISMO))
    _assert_same_contents(SCALISMO, out)
    save_model(out, load_model(out))  # and again
    _assert_same_contents(SCALISMO, out)


def test_models_built_here_round_trip_and_overwrite_atomically(tmp_path):
    rng = np.random.default_rng(1)
    ref = rng.uniform(-1, 1, (80, 3))

    class Mesh:  # anything with .points and PyVista-style triangle faces
        points = ref
        faces = np.column_stack([np.full(20, 3), rng.integers(0, 80, (20, 3))]).ravel()

    model = LowRankGP.from_examples(Mesh(), ref + rng.normal(scale=0.1, size=(6, 80, 3)))
    path = tmp_path / "model.h5"
    save_model(path, model)
    back = load_model(path)
    np.testing.assert_array_equal(back.cells, Mesh.faces.reshape(-1, 4)[:, 1:])
    c = rng.normal(size=model.rank)
    np.testing.assert_allclose(back.instance(c), model.instance(c), atol=1e-5)  # float32 in the file
    np.testing.assert_allclose(back.eigenvalues, model.eigenvalues, rtol=1e-6)
    with h5py.File(path) as f:
        assert f["representer"].attrs["datasetType"][0] == b"POLYGON_MESH"
        assert int(f["version/majorVersion"][()]) == 0 and int(f["version/minorVersion"][()]) == 9
        assert "modelinfo/build-time" in f
    # a kernel model (no cells) is a point-set model; a failing save leaves the old file whole
    kernel_model = LowRankGP.nystrom(GaussianProcess(GaussianKernel(1.0)), ref, n_inducing=30, rank=10, rng=0)
    before = path.read_bytes()

    class Broken(LowRankGP):
        def basis_matrix(self):
            raise RuntimeError("disk full")

    broken = Broken(kernel_model._space, kernel_model._factor, variances=kernel_model.eigenvalues)
    with pytest.raises(RuntimeError, match="disk full"):
        save_model(path, broken)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.h5"]
    save_model(path, kernel_model)
    with h5py.File(path) as f:
        assert f["representer"].attrs["datasetType"][0] == b"POINT_SET" and "cells" not in f["representer"]
    np.testing.assert_allclose(load_model(path).covariance(ref[:5]), kernel_model.covariance(ref[:5]), atol=1e-5)


def _corrupt(tmp_path, edit):
    path = tmp_path / "bad.h5"
    shutil.copy(SCALISMO, path)
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _replace(name, value):
    def edit(f):
        del f[name]
        f[name] = value

    return edit


BAD = {
    "/model/mean": lambda f: f.__delitem__("model/mean"),
    "/model/pcaBasis": lambda f: f.__delitem__("model/pcaBasis"),
    "/model/pcaVariance": _replace("model/pcaVariance", np.ones(49, np.float32)),
    "/representer/points": _replace("representer/points", np.zeros((1400, 3), np.float32)),
    "/representer/cells": _replace("representer/cells", np.full((3, 5), 5000, np.int32)),
    "/version": _replace("version/minorVersion", np.int32(3)),
    "/representer": lambda f: f.__delitem__("representer"),
}


@pytest.mark.parametrize("dataset", BAD)
def test_bad_files_name_the_dataset(tmp_path, dataset):
    with pytest.raises(FileFormatError, match=dataset):
        load_model(_corrupt(tmp_path, BAD[dataset]))


def test_nan_wrong_shapes_and_non_hdf5_files(tmp_path):
    def nan_basis(f):
        f["model/pcaBasis"][5, 3] = np.nan

    with pytest.raises(FileFormatError, match="/model/pcaBasis contains NaN"):
        load_model(_corrupt(tmp_path, nan_basis))
    with pytest.raises(FileFormatError, match=r"/model/mean: expected shape \(4200,\)"):
        load_model(_corrupt(tmp_path, _replace("model/mean", np.zeros(4199, np.float32))))
    with pytest.raises(FileFormatError, match="/model/pcaBasis: expected 2 dimensions"):
        load_model(_corrupt(tmp_path, _replace("model/pcaBasis", np.zeros(4200, np.float32))))
    with pytest.raises(FileFormatError, match="/model/pcaVariance has negative"):
        load_model(_corrupt(tmp_path, _replace("model/pcaVariance", -np.ones(50, np.float32))))
    text = tmp_path / "model.h5"
    text.write_text("not hdf5")
    with pytest.raises(FileFormatError, match="not a readable HDF5 file"):
        load_model(text)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    name=st.sampled_from(
        [
            "model/mean",
            "model/pcaBasis",
            "model/pcaVariance",
            "model/noiseVariance",
            "representer/points",
            "representer/cells",
            "version/majorVersion",
        ]
    ),
    shape=st.lists(st.integers(0, 5), min_size=0, max_size=3),
    kind=st.sampled_from(["f4", "i4", "S3"]),
)
def test_any_replaced_dataset_loads_or_raises_a_file_format_error(tmp_path, name, shape, kind):
    value = np.ones(shape, dtype=kind) if kind != "S3" else np.full(shape, b"abc", dtype="S3")
    try:
        model = load_model(_corrupt(tmp_path, _replace(name, value)))
    except FileFormatError as err:
        assert str(tmp_path) in str(err)
    else:
        assert model.rank >= 0
