"""Image headers that name other files read nothing outside the folder they are confined to (issues 32, 36).

A MetaImage or NRRD header names its pixel files: one name, a ``LIST`` of names (one a line after
the header), or a ``%d`` pattern. Before, the app checked only the first form (and only in the
header's first 64 KiB): ``ElementDataFile = LIST`` then ``../outside/secret.raw`` loaded the secret's
bytes as pixels, so did a pattern, key spellings MetaIO or teem accept (``ElementDataFile:``,
``DATA FILE:``, ``datafile:``), CR or CRLF line ends, and a NRRD ``data file:`` line after 90 KB of
comments. Now every name is resolved and checked (:func:`ffd_notebook._util.file_access.named_file`)
and what is not understood exactly is refused.

The property test builds headers from those forms, spellings and names, reads each through
:func:`~ffd_notebook.images.read_image` confined to a folder — ITK does the reading, after the
checks — and asserts that whatever loads holds no byte of the sentinel files outside the folder
(every byte of theirs is 0xEE; every byte of the data inside is below 0x20).
"""

from __future__ import annotations

import gzip
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook.errors import FileFormatError
from ffd_notebook.images import image_data_files, open_image, read_image, read_image_information

SECRET = 0xEE
SIZES = (8, 2, 4)  # x, y, z: 64 bytes of uint8, four 16-byte slices


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    """``folder`` (inside data) and ``outside`` (sentinels), a symlink from one to the other, and a FIFO inside."""
    base = tmp_path_factory.mktemp("confinement")
    folder, outside = base / "folder", base / "outside"
    (folder / "sub").mkdir(parents=True)
    outside.mkdir()
    secret = bytes([SECRET]) * 4096
    for name in ("secret.raw", "s0.raw", "s1.raw", "s2.raw", "s3.raw", "in.raw"):
        (outside / name).write_bytes(secret)
    (outside / "secret.raw.gz").write_bytes(gzip.compress(secret))
    (folder / "in.raw").write_bytes(bytes(i % 16 + 1 for i in range(64)))
    for i in range(4):
        (folder / f"in{i}.raw").write_bytes(bytes([i + 1]) * 16)
    (folder / "in.raw.gz").write_bytes(gzip.compress(bytes([3]) * 64))
    os.symlink(outside, folder / "link_out")
    os.symlink(outside / "secret.raw", folder / "looks_inside.raw")
    os.mkfifo(folder / "pipe.raw")
    return folder, outside


NAMES = [
    "in.raw", "sub/../in.raw", "./in.raw", "in.raw.gz",
    "../outside/secret.raw", "link_out/secret.raw", "looks_inside.raw", "sub/../../outside/secret.raw",
    "{outside}/secret.raw", "{outside}/../outside/secret.raw", "../outside/secret.raw.gz", "/dev/zero", "pipe.raw",
    "~/secret.raw", "-", " in.raw", "in.raw ", "../outside/in.raw",
]  # fmt: skip
MET_KEYS = ["ElementDataFile"] * 4 + ["elementdatafile", "ELEMENTDATAFILE", "Element DataFile", "ElementDataFile "]
MET_SEPARATORS = [" = ", " = ", "=", " : ", ":", " == ", "\t=\t", " =: "]
NRRD_KEYS = ["data file"] * 4 + ["datafile", "DATA FILE", "Data File", "data  file", " data file", "data_file"]
NRRD_SEPARATORS = [": "] * 4 + [":  ", ":\t", ":", " : ", ":="]
ENDINGS = ["\n", "\n", "\r\n", "\r"]


@st.composite
def headers(draw):
    """``(file name, bytes)`` of a MetaImage or NRRD header with a drawn data source, spelling and line ends."""
    fmt = draw(st.sampled_from([".mha", ".mhd", ".nrrd", ".nhdr", "gzip.nrrd"]))
    source = draw(st.sampled_from(["inline", "name", "list", "pattern"]))
    names = st.sampled_from(NAMES)
    ending = draw(st.sampled_from(ENDINGS))
    comments = draw(st.sampled_from([0, 0, 1, 3000]))  # 3000 lines of 33 bytes: the data line after 90 KB
    if fmt in (".mha", ".mhd"):
        key, sep = draw(st.sampled_from(MET_KEYS)), draw(st.sampled_from(MET_SEPARATORS))
        lines = ["ObjectType = Image", "NDims = 3", "DimSize = 8 2 4", "ElementType = MET_UCHAR"]
        lines += ["Comment = padding padding padding"] * comments
        if source == "inline":
            value, tail = "LOCAL", [bytes(i % 16 + 1 for i in range(64)).decode("latin-1")]
        elif source == "name":
            value, tail = draw(names), []
        elif source == "list":
            value = draw(st.sampled_from(["LIST", "LIST 2D", "LIST [2D]", "LIST 2", "LIST2D", "LIST 1D"]))
            tail = [draw(names) for _ in range(4 if value != "LIST 1D" else 8)]
        else:
            value = draw(st.sampled_from(["in%d.raw 0 3 1", "../outside/s%d.raw 0 3 1", "in%d.raw 0 3",
                                          "in%s.raw 0 3 1", "link_out/s%d.raw 0 3 1", "in%d.raw 0 6 2"]))  # fmt: skip
            tail = []
        text = ending.join([*lines, f"{key}{sep}{value}", *tail]) + ending
    else:
        key, sep = draw(st.sampled_from(NRRD_KEYS)), draw(st.sampled_from(NRRD_SEPARATORS))
        encoding = "gzip" if fmt == "gzip.nrrd" else "raw"
        lines = ["NRRD0004", "type: uint8", "dimension: 3", "sizes: 8 2 4", f"encoding: {encoding}"]
        lines += ["# padding padding padding padding"] * comments
        if source == "inline":
            data = bytes(i % 16 + 1 for i in range(64))
            body = gzip.compress(data) if encoding == "gzip" else data
            return "a.nrrd", (ending.join(lines) + ending + ending).encode("latin-1") + body
        if source == "name":
            value, tail = draw(names), []
        elif source == "list":
            value = draw(st.sampled_from(["LIST", "LIST 2", "LIST 3", "LIST [2]", "LIST 1"]))
            tail = [draw(names) for _ in range({"LIST 3": 1, "LIST 1": 8}.get(value, 4))]
        else:
            value = draw(st.sampled_from(["in%d.raw 0 3 1", "../outside/s%d.raw 0 3 1", "in%d.raw 3 0 -1",
                                          "in%d.raw 0 3 1 2", "in%s.raw 0 3 1", "link_out/s%d.raw 0 3 1"]))  # fmt: skip
            tail = []
        text = ending.join([*lines, f"{key}{sep}{value}", *tail]) + ending
        if fmt == ".nrrd":
            text += ending
        fmt = ".nhdr" if fmt != ".nrrd" else ".nrrd"
    return f"a{fmt}", text.encode("latin-1")


def _holds_no_secret(image) -> bool:
    return bool((sitk.GetArrayViewFromImage(image) != SECRET).all())


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(header=headers())
def test_whatever_loads_read_nothing_outside_the_folder(tree, header):
    folder, outside = tree
    name, content = header
    path = folder / name
    path.write_bytes(content.replace(b"{outside}", os.fsencode(outside)))
    try:
        image = read_image(path, within=folder)
    except (FileFormatError, OSError):
        return  # refused (with a reason): nothing read
    assert image.GetSize() == SIZES
    assert _holds_no_secret(image), content[-200:]


CASES = {  # header tail after the common lines -> (what ITK alone did, what the confined reader says)
    "list.mhd": ("ElementDataFile = LIST 2D\n../outside/secret.raw\nin1.raw\nin2.raw\nin3.raw\n", "outside the folder"),
    "list_bracket.mha": ("ElementDataFile = LIST [2D]\n../outside/secret.raw\nin1.raw\nin2.raw\nin3.raw\n",
                         "outside the folder"),
    "pattern.mhd": ("ElementDataFile = ../outside/s%d.raw 0 3 1\n", "outside the folder"),
    "colon.mhd": ("ElementDataFile : ../outside/secret.raw\n", "outside the folder"),
    "crlf.mhd": ("ElementDataFile = ../outside/secret.raw\n", "outside the folder"),
    "absolute.mha": ("ElementDataFile = {outside}/secret.raw\n", "outside the folder"),
    "symlink.mhd": ("ElementDataFile = looks_inside.raw\n", "outside the folder"),
    "lowercase.mhd": ("elementdatafile = ../outside/secret.raw\n", "MetaIO does not read as ElementDataFile"),
    "fifo.mhd": ("ElementDataFile = pipe.raw\n", "FIFO"),
    "zero.mhd": ("ElementDataFile = /dev/zero\n", "outside the folder"),
    "list.nhdr": ("data file: LIST 2\n../outside/secret.raw\nin1.raw\nin2.raw\nin3.raw\n", "outside the folder"),
    "pattern.nhdr": ("data file: ../outside/s%d.raw 0 3 1\n", "outside the folder"),
    "upper.nhdr": ("DATA FILE: ../outside/secret.raw\n", "outside the folder"),
    "nospace.nhdr": ("datafile: ../outside/secret.raw\n", "outside the folder"),
    "cr.nhdr": ("data file: ../outside/secret.raw\n", "outside the folder"),
    "stdin.nhdr": ("data file: -\n", "standard input"),
    "comments.nrrd": ("# " + "x" * 90_000 + "\ndata file: ../outside/secret.raw\n\n", "outside the folder"),
    "no_end.nrrd": ("# " + "x" * 1000 + "\n" + ("# " + "y" * 1000 + "\n") * 1100 + "data file: ../outside/s.raw\n\n",
                    "the header's end is not found"),
    "fifo.nhdr": ("data file: pipe.raw\n", "FIFO"),
}  # fmt: skip
_MET = "ObjectType = Image\nNDims = 3\nDimSize = 8 2 4\nElementType = MET_UCHAR\n"
_NRRD = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 2 4\nencoding: raw\n"


def _case(folder, outside, name):
    tail, _ = CASES[name]
    text = (_MET if name.endswith((".mha", ".mhd")) else _NRRD) + tail.replace("{outside}", str(outside))
    if name.startswith("crlf"):
        text = text.replace("\n", "\r\n")
    if name.startswith("cr."):
        text = text.replace("\n", "\r")
    path = folder / f"case_{name}"
    path.write_text(text, newline="")
    return path


@pytest.mark.parametrize("name", sorted(CASES))
def test_each_header_case_is_refused_with_its_reason(tree, name):
    folder, outside = tree
    path = _case(folder, outside, name)
    for reader in (read_image, read_image_information, image_data_files):
        start = time.perf_counter()
        with pytest.raises(FileFormatError, match=CASES[name][1]) as info:
            reader(path, within=folder)
        assert str(path) in str(info.value) and time.perf_counter() - start < 5


def test_itk_alone_reads_the_secret_of_the_cases(tree):
    """What the cases above are refused for: SimpleITK, given each header, loads the outside file's bytes (in a child
    process: nothing in this process opens the secrets)."""
    folder, outside = tree
    names = sorted(n for n in CASES if "outside the folder" in CASES[n][1] and n != "zero.mhd")
    paths = [str(_case(folder, outside, name)) for name in names]
    code = ("import sys, SimpleITK as sitk\nfor p in sys.argv[1:]:\n"
            f"    print(int((sitk.GetArrayFromImage(sitk.ReadImage(p)) == {SECRET}).sum()))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code, *paths], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    counts = dict(zip(names, map(int, out.stdout.split()), strict=True))
    assert all(count >= 16 for count in counts.values()), counts


def test_a_notebook_reads_what_the_header_names(tree):
    """Without ``within`` (a notebook: the user's own files) a header reads the files it names, as ITK does;
    special files are still refused."""
    folder, outside = tree
    path = folder / "notebook.mhd"
    path.write_text(_MET + f"ElementDataFile = {outside}/secret.raw\n")
    assert not _holds_no_secret(read_image(path))
    path.write_text(_MET + "ElementDataFile = pipe.raw\n")
    with pytest.raises(FileFormatError, match="FIFO"):
        read_image(path)
    path.write_text(_MET + "ElementDataFile = /dev/zero\n")
    with pytest.raises(FileFormatError, match="character device"):
        read_image(path)


@pytest.mark.parametrize(
    "tail",
    ["ElementDataFile = LOCAL\n", "ElementDataFile = in.raw\n", "ElementDataFile = LIST\nin0.raw\nin1.raw\nin2.raw\n"
     "in3.raw\n", "ElementDataFile = in%d.raw 0 3 1\n", "ElementDataFile = sub/../in.raw\n"],
)  # fmt: skip
def test_inside_data_files_load_as_itk_reads_them(tree, tail):
    folder, _ = tree
    path = folder / "good.mhd"
    data = bytes(i % 16 + 1 for i in range(64))
    path.write_bytes((_MET + tail).encode() + (data if "LOCAL" in tail else b""))
    ours = sitk.GetArrayFromImage(read_image(path, within=folder))
    np.testing.assert_array_equal(ours, sitk.GetArrayFromImage(sitk.ReadImage(str(path))))
    assert open_image(path, within=folder).layout.format == "MetaImage"
    assert [p.name for p in image_data_files(path, within=folder)] == (
        [] if "LOCAL" in tail else [Path(n).name for n in tail.split()[2:] if n.endswith(".raw")]
        if "LIST" in tail else [f"in{i}.raw" for i in range(4)] if "%" in tail else ["in.raw"]
    )  # fmt: skip
