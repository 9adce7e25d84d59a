"""Files inside the app's folder that name files outside it, driven through the app's own commands (issue 36).

The standalone app confines every typed path to its folder; the files it reads may name others: a displacement
field's MetaImage or NRRD data files (one name, a LIST, a pattern), an ITK ``.h5`` transform's external storage, an
elastix chain's initial transform, an image header's data files. Each case below is a crafted file in the folder
(and, for the lattice box, the same file uploaded) against sentinel files outside it whose values are recognisable:
a field read from them moves every voxel by 1234.5, an image shows 0xEE everywhere. Before this change every case
but the FIFO loaded the secret (the FIFO froze the worker, the app stayed busy); after it each is refused with its
reason, the lattice, its undo history and the image stay as they were, and nothing shows a sentinel value.

The app runs in-process without an event loop, so its file commands run synchronously (what its worker thread does).
"""

from __future__ import annotations

import gzip
import os
import subprocess
import sys
import time
import uuid

import h5py
import numpy as np
import pytest
import pyvista as pv
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice
from ffd_notebook.io import save_displacement_field, save_elastix, save_transform
from ffd_notebook.view import Editor
from ffd_notebook.view.editor.app import EditorApp

SECRET_SHIFT = 1234.5  # every component of every vector in the sentinel field data
SECRET_BYTE = 0xEE  # every byte of the sentinel image data
FIELD = (6, 6, 6)  # voxels of the crafted fields (x, y, z)


def _field_header(kind: str, source: str, *, tail: str = "", comments: int = 0) -> bytes:
    """A displacement-field header (3-vectors of float64 on FIELD) whose data is ``source``."""
    nx, ny, nz = FIELD
    if kind == "mha":
        lines = ["ObjectType = Image", "NDims = 3", f"DimSize = {nx} {ny} {nz}", "ElementNumberOfChannels = 3",
                 "ElementSpacing = 0.8 0.8 0.8", "Offset = -2 -2 -2", "ElementType = MET_DOUBLE"]  # fmt: skip
        lines += ["Comment = padding padding padding padding"] * comments
        return ("\n".join([*lines, f"ElementDataFile = {source}"]) + "\n" + tail).encode()
    lines = ["NRRD0004", "type: double", "dimension: 4", f"sizes: 3 {nx} {ny} {nz}",
             "kinds: vector domain domain domain", "space dimension: 3",
             "space directions: none (0.8,0,0) (0,0.8,0) (0,0,0.8)", "space origin: (-2,-2,-2)", "encoding: raw",
             "endian: little"]  # fmt: skip
    lines += ["# padding padding padding padding padding padding"] * comments
    return ("\n".join([*lines, f"data file: {source}"]) + "\n" + tail).encode()


@pytest.fixture()
def world(tmp_path):
    """The app's folder ``root`` with good files and crafted ones, ``outside`` with the sentinels, and the app."""
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    nx, ny, nz = FIELD
    secret_vectors = np.full(nx * ny * nz * 3, SECRET_SHIFT)
    (outside / "secret.raw").write_bytes(secret_vectors.tobytes())
    for k in range(nz):
        (outside / f"slice{k}.raw").write_bytes(secret_vectors[: nx * ny * 3].tobytes())
    (outside / "image.raw").write_bytes(bytes([SECRET_BYTE]) * 4096)
    lat = Lattice((5, 5, 5), 1.0, origin=(-2.0, -2.0, -2.0))
    save_elastix(outside / "TransformParameters.0.txt", FFD(lat))  # an initial transform that exists, outside

    slices = "".join(f"../outside/slice{k}.raw\n" for k in range(nz))
    crafted = {
        "field_list.mha": _field_header("mha", "LIST 2D", tail=slices),
        "field_pattern.mha": _field_header("mha", "../outside/slice%d.raw 0 5 1"),
        "field_absolute.mha": _field_header("mha", str(outside / "secret.raw")),
        "field_colon.nrrd": _field_header("nrrd", "../outside/secret.raw"),
        "field_list.nrrd": _field_header("nrrd", "LIST 3", tail=slices),
        "field_comments.nrrd": _field_header("nrrd", "../outside/secret.raw", comments=2000),  # 90 KB of comments
        "field_fifo.mha": _field_header("mha", "pipe.raw"),
        "field_zero.mha": _field_header("mha", "/dev/zero"),
    }  # fmt: skip
    for name, content in crafted.items():
        (root / name).write_bytes(content)
    os.mkfifo(root / "pipe.raw")

    save_transform(root / "external.h5", FFD(lat))  # its parameters kept in the secret file (HDF5 external storage)
    with h5py.File(root / "external.h5", "a") as f:
        group = f["TransformGroup/0"]
        n = group["TransformParameters"].shape[0]
        (outside / "params.bin").write_bytes(np.full(n, SECRET_SHIFT).tobytes())
        del group["TransformParameters"]
        group.create_dataset("TransformParameters", shape=(n,), dtype="f8",
                             external=[(str(outside / "params.bin"), 0, 8 * n)])  # fmt: skip

    save_elastix(root / "TransformParameters.1.txt", FFD(lat))
    for name, initial in (("chain_exists.txt", outside / "TransformParameters.0.txt"),
                          ("chain_missing.txt", outside / "nothing_here.txt")):  # fmt: skip
        text = (root / "TransformParameters.1.txt").read_text()
        (root / name).write_text(text.replace('"NoInitialTransform"', f'"{initial}"'))

    image_tail = "ObjectType = Image\nNDims = 3\nDimSize = 16 16 16\nElementType = MET_UCHAR\n"
    (root / "image_list.mhd").write_text(image_tail + "ElementDataFile = LIST\n" + "../outside/image.raw\n" * 16)
    (root / "image_pattern.mhd").write_text(image_tail + "ElementDataFile = ../outside/image%d.raw 0 15 1\n")
    for k in range(16):
        (outside / f"image{k}.raw").write_bytes(bytes([SECRET_BYTE]) * 256)
    (root / "image_comments.nrrd").write_bytes(
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 16 16 16\nencoding: raw\n"
        + b"# padding padding padding padding padding padding\n" * 2000
        + b"data file: ../outside/image.raw\n\n"
    )
    (root / "image_fifo.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 16 16 16\nencoding: raw\n"
                                          "data file: pipe.raw\n")  # fmt: skip
    (root / "image_gzip_list.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 16 16 16\nencoding: "
                                               "gzip\ndata file: LIST\n" + "../outside/image.gz\n" * 16)  # fmt: skip
    (outside / "image.gz").write_bytes(gzip.compress(bytes([SECRET_BYTE]) * 256))

    mesh = pv.Sphere(radius=2.0, theta_resolution=12, phi_resolution=12)
    app = EditorApp(Editor(mesh, shape=(4, 4, 4), window_size=(120, 90)), name=f"test_{uuid.uuid4().hex}", root=root)
    yield root, outside, app
    app.close()


LATTICE_CASES = {  # file in the folder -> what the refusal says
    "field_list.mha": "outside the folder",
    "field_pattern.mha": "outside the folder",
    "field_absolute.mha": "outside the folder",
    "field_colon.nrrd": "outside the folder",
    "field_list.nrrd": "outside the folder",
    "field_comments.nrrd": "outside the folder",
    "field_fifo.mha": "FIFO",
    "field_zero.mha": "outside the folder",
    "external.h5": "HDF5 dataset",
    "chain_exists.txt": "not in the folder",
    "chain_missing.txt": "not in the folder",
}
IMAGE_CASES = {
    "image_list.mhd": "outside the folder",
    "image_pattern.mhd": "outside the folder",
    "image_comments.nrrd": "outside the folder",
    "image_fifo.nhdr": "FIFO",
    "image_gzip_list.nhdr": "outside the folder",
}


def _last(app) -> dict:
    return app.state.messages[0]


def _lattice_state(app):
    session = app.editor.session
    return session.lattice.offsets.copy(), session.lattice.shape, len(session.history)


def _unchanged(app, before) -> None:
    offsets, shape, history = _lattice_state(app)
    assert shape == before[1] and history == before[2]
    np.testing.assert_array_equal(offsets, before[0])
    assert np.abs(app.editor.deformed_mesh.points).max() < 100  # no sentinel displacement anywhere


@pytest.mark.parametrize("name", sorted(LATTICE_CASES))
def test_the_lattice_box_reads_nothing_outside_the_folder(world, name):
    root, _, app = world
    before = _lattice_state(app)
    start = time.perf_counter()
    app.run("load_ffd", [name])
    assert time.perf_counter() - start < 10 and not app.state.busy
    message = _last(app)
    assert message["error"] and LATTICE_CASES[name] in message["text"], message["text"]
    assert str(root) not in message["text"]  # the page is told the root-relative name only
    _unchanged(app, before)


@pytest.mark.parametrize("name", sorted(n for n in LATTICE_CASES if n != "field_fifo.mha"))
def test_the_same_files_uploaded_name_nothing(world, name):
    root, _, app = world
    before = _lattice_state(app)
    app.files.receive_ffd_upload({"name": name, "content": (root / name).read_bytes()})
    message = _last(app)
    assert message["error"], message["text"]
    assert any(reason in message["text"] for reason in ("outside the folder", "not in the folder", "HDF5 dataset"))
    _unchanged(app, before)


def test_a_chain_tells_nothing_about_paths_outside(world):
    """One answer for an initial transform outside the folder, whether it exists or not."""
    _, _, app = world
    answers = []
    for name in ("chain_exists.txt", "chain_missing.txt"):
        app.run("load_ffd", [name])
        answers.append(_last(app)["text"].replace(name, "<file>"))
    assert answers[0] == answers[1], answers


@pytest.mark.parametrize("name", sorted(IMAGE_CASES))
def test_the_image_box_reads_nothing_outside_the_folder(world, name):
    _, _, app = world
    start = time.perf_counter()
    app.run("load_image", [name])
    assert time.perf_counter() - start < 10 and not app.state.busy
    message = _last(app)
    assert message["error"] and IMAGE_CASES[name] in message["text"], message["text"]
    assert not app.state.has_image and not app.editor.session.image.loaded


def test_inside_the_folder_the_same_kinds_of_files_load(world):
    """The rule confines, it does not forbid: a field whose data files are in the folder, a chain whose initial
    transform is beside it, an image whose LIST is in the folder all load through the same commands."""
    root, _, app = world
    truth = FFD(Lattice((4, 4, 4), 1.5, origin=(-2.3, -2.3, -2.3)))
    truth.lattice.offsets[1, 2, 1] = (0.2, -0.1, 0.1)
    save_displacement_field(root / "whole.mha", truth, {"size": FIELD, "spacing": 0.8, "origin": (-2.0, -2.0, -2.0)})
    app.run("load_ffd", ["whole.mha"])
    assert not _last(app)["error"], _last(app)["text"]
    sitk.WriteImage(sitk.ReadImage(str(root / "whole.mha")), str(root / "detached.mhd"))  # header + .raw data file
    raw = (root / "detached.raw").read_bytes()
    (root / "slices").mkdir()
    per = len(raw) // FIELD[2]
    for k in range(FIELD[2]):
        (root / "slices" / f"s{k}.raw").write_bytes(raw[k * per : (k + 1) * per])
    listed = "".join(f"slices/s{k}.raw\n" for k in range(FIELD[2]))
    header = (root / "detached.mhd").read_text().replace("ElementDataFile = detached.raw", "ElementDataFile = LIST 2D")
    (root / "listed.mha").write_text(header + listed)  # a field's data listed slice by slice, in the folder
    app.run("load_ffd", ["listed.mha"])
    assert not _last(app)["error"], _last(app)["text"]
    (root / "TransformParameters.0.txt").write_text(
        '(Transform "TranslationTransform")\n(TransformParameters 0.1 0 0)'
        '\n(InitialTransformParameterFileName "NoInitialTransform")\n'
    )
    text = (
        (root / "TransformParameters.1.txt").read_text().replace('"NoInitialTransform"', '"TransformParameters.0.txt"')
    )
    (root / "chain_inside.txt").write_text(text)
    app.run("load_ffd", ["chain_inside.txt"])
    assert not _last(app)["error"], _last(app)["text"]
    slices = np.arange(16 * 16 * 16, dtype=np.uint8).reshape(16, 16, 16) % 200
    for k in range(16):
        (root / f"im{k}.raw").write_bytes(slices[k].tobytes())
    (root / "image_inside.mhd").write_text("ObjectType = Image\nNDims = 3\nDimSize = 16 16 16\nElementType = MET_UCHAR"
                                           "\nElementDataFile = im%d.raw 0 15 1\n")  # fmt: skip
    app.run("load_image", ["image_inside.mhd"])
    assert not _last(app)["error"] and app.state.has_image, _last(app)["text"]


def test_without_the_fix_itk_reads_the_secrets(world):
    """The sentinels are what ITK alone reads from the crafted headers (in a child process): the refusals above are
    refusals of real leaks, not of files that could not have been read anyway."""
    root, _, _ = world
    names = ["field_list.mha", "field_pattern.mha", "field_absolute.mha", "field_colon.nrrd", "field_list.nrrd",
             "field_comments.nrrd", "image_list.mhd", "image_pattern.mhd", "image_comments.nrrd",
             "image_gzip_list.nhdr"]  # fmt: skip
    code = ("import sys, numpy as np, SimpleITK as sitk\nfor p in sys.argv[1:]:\n"
            "    a = sitk.GetArrayFromImage(sitk.ReadImage(p))\n"
            f"    print(int(np.isin(a, ({SECRET_SHIFT}, {SECRET_BYTE})).sum()))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code, *[str(root / n) for n in names]], capture_output=True,
                         text=True, timeout=120)  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    counts = dict(zip(names, map(int, out.stdout.split()), strict=True))
    assert all(count > 0 for count in counts.values()), counts
