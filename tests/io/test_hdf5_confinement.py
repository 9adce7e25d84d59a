"""HDF5 files read only what they hold (issue 36): ITK ``.h5`` transforms and Statismo models.

Before: an ITK ``.h5`` transform whose ``TransformParameters`` used HDF5 external storage naming a
file outside the app's folder loaded that file's bytes as the lattice's offsets; a virtual dataset
or an external link did the same; a FIFO named ``.h5`` blocked ``load_transform`` and
``gp.load_model`` for ever; and a 8 KB model file declaring a ``(3e5, 2e4)`` basis made
``load_model`` allocate what it said. Each is refused now, before a value is read, naming the
file and the dataset or link.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.gp import LowRankGP, load_model, save_model
from ffd_notebook.io import load_deformation, load_transform, save_transform

SENTINEL = np.full(3993, 123456.789)  # a secret outside the folder (3993: the test transform's parameters)


def _secret(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.bin").write_bytes(SENTINEL.tobytes())
    with h5py.File(outside / "other.h5", "w") as f:
        f["TransformParameters"] = SENTINEL
        f["model"] = SENTINEL[:60]
        f["points"] = SENTINEL[:60].reshape(3, 20)
    return outside


def _transform(tmp_path):
    folder = tmp_path / "folder"
    folder.mkdir()
    lat = Lattice((5, 5, 5), 1.0)
    lat.offsets[2, 2, 2] = (0.1, 0.2, 0.3)
    save_transform(folder / "good.h5", FFD(lat))
    return folder


def _rewrite_parameters(path, make):
    """Replace ``/TransformGroup/0/TransformParameters`` of an ITK file by what ``make(group, n)`` creates."""
    with h5py.File(path, "a") as f:
        group = f["TransformGroup/0"]
        n = group["TransformParameters"].shape[0]
        del group["TransformParameters"]
        make(group, n)


def _external_storage(outside):
    def make(group, n):
        group.create_dataset("TransformParameters", shape=(n,), dtype="f8",
                             external=[(str(outside / "secret.bin"), 0, 8 * n)])  # fmt: skip

    return make


def _virtual(outside):
    def make(group, n):
        layout = h5py.VirtualLayout(shape=(n,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(outside / "other.h5"), "TransformParameters", shape=SENTINEL.shape)[:n]
        group.create_virtual_dataset("TransformParameters", layout)

    return make


def _external_link(outside):
    def make(group, n):
        group["TransformParameters"] = h5py.ExternalLink(str(outside / "other.h5"), "/TransformParameters")

    return make


def _soft_link(outside):
    def make(group, n):
        group["elsewhere"] = np.zeros(n)
        group["TransformParameters"] = h5py.SoftLink(group.name + "/elsewhere")

    return make


@pytest.mark.parametrize(
    ("make", "reason"),
    [(_external_storage, "external storage"), (_virtual, "virtual dataset"), (_external_link, "external link"),
     (_soft_link, "soft link")],
)  # fmt: skip
def test_an_itk_transform_reads_nothing_outside_its_file(tmp_path, make, reason):
    outside = _secret(tmp_path)
    folder = _transform(tmp_path)
    path = folder / "hostile.h5"
    path.write_bytes((folder / "good.h5").read_bytes())
    _rewrite_parameters(path, make(outside))
    with h5py.File(path, "r") as f:  # the file really reaches outside (or the test would prove nothing)
        if reason != "soft link":
            assert np.all(f["TransformGroup/0/TransformParameters"][()] == SENTINEL[0])
    for reader in (load_transform, load_deformation):
        with pytest.raises(FileFormatError, match=reason) as info:
            reader(path)
        assert str(path) in str(info.value) and "TransformParameters" in str(info.value)
    assert load_transform(folder / "good.h5").lattice.offsets[2, 2, 2].tolist() == pytest.approx([0.1, 0.2, 0.3])


def _model(tmp_path):
    ref = np.random.default_rng(0).random((20, 3))
    path = tmp_path / "model.h5"
    save_model(path, LowRankGP.from_examples(ref, [ref, ref + 0.1, ref * 1.1]))
    return path


@pytest.mark.parametrize(
    ("dataset", "make", "reason"),
    [("model/mean", "external", "external storage"), ("model/pcaVariance", "virtual", "virtual dataset"),
     ("representer/points", "link", "external link"), ("modelinfo/notes", "external", "external storage")],
)  # fmt: skip
def test_a_statismo_model_reads_nothing_outside_its_file(tmp_path, dataset, make, reason):
    outside = _secret(tmp_path)
    path = _model(tmp_path)
    with h5py.File(path, "a") as f:
        shape = f[dataset].shape if dataset in f else (4,)
        if dataset in f:
            del f[dataset]
        n = int(np.prod(shape))
        if make == "external":
            f.create_dataset(dataset, shape=shape, dtype="f8", external=[(str(outside / "secret.bin"), 0, 8 * n)])
        elif make == "virtual":
            layout = h5py.VirtualLayout(shape=shape, dtype="f8")
            layout[:] = h5py.VirtualSource(str(outside / "other.h5"), "model", shape=(60,))[:n]
            f.create_virtual_dataset(dataset, layout)
        else:
            f[dataset] = h5py.ExternalLink(str(outside / "other.h5"), "/points")
    with pytest.raises(FileFormatError, match=reason) as info:
        load_model(path)
    assert str(path) in str(info.value)


def test_declared_shapes_are_checked_before_anything_is_read(tmp_path):
    """A few KB of chunked, compressed datasets declaring gigabytes: refused from the shapes alone."""
    path = tmp_path / "huge.h5"
    save_model(path, LowRankGP.from_examples(np.zeros((4, 3)), [np.zeros((4, 3)), np.ones((4, 3))]))
    n, rank = 300_000, 20_000  # a 6e9-value basis: 48 GB of float64
    with h5py.File(path, "a") as f:
        for name, shape in (("representer/points", (3, n)), ("model/mean", (3 * n,)),
                            ("model/pcaBasis", (3 * n, rank)), ("model/pcaVariance", (rank,))):  # fmt: skip
            del f[name]
            f.create_dataset(name, shape=shape, dtype="f4", chunks=(1,) * len(shape), compression="gzip")
    assert path.stat().st_size < 64 * 1024
    start = time.perf_counter()
    with pytest.raises(FileFormatError, match="pcaBasis: declares 18000000000 values"):
        load_model(path)
    assert time.perf_counter() - start < 5
    with h5py.File(path, "a") as f:  # shapes that disagree are refused before any read too
        del f["model/pcaBasis"]
        f.create_dataset("model/pcaBasis", shape=(12, 3), dtype="f4")
    with pytest.raises(FileFormatError, match=r"pcaBasis: expected shape \(900000, r\), got \(12, 3\)"):
        load_model(path)


_UNBLOCKER = """
import os, sys, time
time.sleep(5)
while True:  # every open of the reader gets a writer that closes at once (EOF)
    try:
        os.close(os.open(sys.argv[1], os.O_WRONLY | os.O_NONBLOCK))
    except OSError:  # no reader waiting
        pass
    time.sleep(0.05)
"""


def _never_blocks(call, fifo):
    """Run ``call()``; if it opens the FIFO (and blocks, maybe holding the GIL: the HDF5 library does), another
    process keeps unblocking it from 5 s on, and the test fails on the time it took."""
    unblocker = subprocess.Popen([sys.executable, "-c", _UNBLOCKER, str(fifo)])
    start = time.perf_counter()
    try:
        with pytest.raises(FileFormatError, match="FIFO"):
            call()
    finally:
        unblocker.kill()
        unblocker.wait()
    assert time.perf_counter() - start < 4, "the reader opened the FIFO and blocked"


@pytest.mark.parametrize("reader", [load_transform, load_model, load_deformation])
def test_a_fifo_named_h5_is_refused_without_blocking(tmp_path, reader):
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    _never_blocks(lambda: reader(fifo), fifo)
