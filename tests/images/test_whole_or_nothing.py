"""Images and displacement fields are read whole or not at all (issue 34).

Before: a NIfTI file cut short (a copy that stopped, a full disk) loaded through ``read_image``, ``warp_image`` and
``load_deformation`` with zeros where its bytes were missing (SimpleITK's NIfTI reader fills short reads and says
nothing), so did a gzip stream cut in its trailer (NIfTI and NRRD), a BMP, a JPEG (grey where the data stopped) and
a TIFF missing its last tag bytes; MetaImage files cut short were refused with "No such file or directory". Now
every format the package reads is checked against what its header (or structure) promises before ITK reads it, and
a file that ends early is refused with a FileFormatError naming it and saying how many bytes of how many it holds,
or that its compressed stream ends before its end.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice, warp_image
from ffd_notebook.errors import FileFormatError
from ffd_notebook.images import read_image, read_image_information
from ffd_notebook.io import DisplacementField, load_deformation, load_displacement_field, save_displacement_field

CUTS = (0.5, 0.9, 0.995)  # fractions of the file kept; one byte short and, for gzip, inside the trailer come on top
VOLUME = {  # name -> (file to cut, compress)
    "volume.nii": ("volume.nii", False),
    "volume.nii.gz": ("volume.nii.gz", True),
    "volume.nrrd": ("volume.nrrd", False),
    "gzip.nrrd": ("gzip.nrrd", True),
    "volume.mha": ("volume.mha", False),
    "zlib.mha": ("zlib.mha", True),
    "mdetached.mhd": ("mdetached.raw", False),  # the header is whole, its data file is cut
    "ndetached.nhdr": ("ndetached.raw", False),
}
PICTURE = ("picture.png", "picture.tif", "picture.jpg", "picture.bmp")
FIELDS = ("field.nii", "field.nii.gz", "field.nrrd", "field.mha")


def _volume() -> sitk.Image:
    values = np.random.default_rng(1).normal(100.0, 30.0, (16, 18, 20)).astype(np.float32)
    image = sitk.GetImageFromArray(values)
    image.SetSpacing((1.0, 1.1, 0.9))
    image.SetOrigin((-10.0, -9.0, -7.0))
    return image


def _picture() -> sitk.Image:
    rgb = (np.random.default_rng(2).random((30, 40, 3)) * 255).astype(np.uint8)
    return sitk.GetImageFromArray(rgb, isVector=True)


@pytest.fixture(scope="module")
def originals(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("whole")
    volume = _volume()
    for name, (_, compress) in VOLUME.items():
        sitk.WriteImage(volume, str(folder / name), compress)
    picture = _picture()
    for name in PICTURE:
        sitk.WriteImage(picture, str(folder / name))
    vectors = np.random.default_rng(3).normal(0.0, 0.3, (9, 10, 11, 3))
    field = DisplacementField(vectors, spacing=(0.5, 0.5, 0.5), origin=(-2.5, -2.5, -2.5))
    for name in FIELDS:
        save_displacement_field(folder / name, field)
    return folder


def _data_file(folder: Path, name: str) -> Path:
    """The file whose bytes are cut: the image itself, or the data file its detached header names."""
    if name.endswith((".mhd", ".nhdr")):
        header = (folder / name).read_text(errors="replace")
        line = next(line for line in header.splitlines() if line.lower().replace(" ", "").startswith(
            ("elementdatafile", "datafile")))  # fmt: skip
        return folder / line.split("=" if "=" in line else ":", 1)[1].strip()
    return folder / name


def _cut_copies(originals: Path, tmp_path: Path, name: str) -> list[tuple[str, Path]]:
    """Copies of ``name`` (and its data file) in ``tmp_path``, its data cut at each length: ``(what, path)``."""
    data = _data_file(originals, name).read_bytes()
    lengths = {f"{round(100 * f, 1)}%": int(len(data) * f) for f in CUTS} | {"1 byte short": len(data) - 1}
    if data[:2] == b"\x1f\x8b" or name in ("zlib.mha", "gzip.nrrd"):
        lengths["in the gzip trailer"] = len(data) - 5
    copies = []
    for what, length in lengths.items():
        folder = tmp_path / what.replace(" ", "_").replace("%", "pc")
        folder.mkdir(parents=True)
        for original in originals.iterdir():
            if original.name.startswith(Path(name).stem.split(".")[0]):
                (folder / original.name).write_bytes(original.read_bytes())
        target = _data_file(folder, name)
        target.write_bytes(data[:length])
        copies.append((what, folder / name))
    return copies


@pytest.mark.parametrize("name", sorted(VOLUME) + list(PICTURE))
def test_an_image_cut_short_is_refused_by_every_reader(originals, tmp_path, name):
    lattice = Lattice((4, 4, 4), 12.0, origin=(-18.0, -18.0, -18.0))
    lattice.offsets[1, 2, 1] = (1.0, 0.0, 0.0)
    for what, path in _cut_copies(originals, tmp_path, name):
        for read in (read_image, lambda p: warp_image(p, FFD(lattice))):
            with pytest.raises(FileFormatError, match="ends early") as info:
                read(path)
            message = str(info.value)
            assert str(path) in message and "No such file" not in message, (what, message)
            if not name.endswith((".png", ".jpg")):  # sized formats say how many bytes of how many
                assert " bytes of " in message or "ends before its end" in message, (what, message)
        if name in VOLUME:  # the header alone is whole: its information is still read (a reference grid)
            read_image_information(path)


@pytest.mark.parametrize("name", FIELDS)
def test_a_field_cut_short_is_refused(originals, tmp_path, name):
    for what, path in _cut_copies(originals, tmp_path, name):
        for read in (load_displacement_field, load_deformation):
            with pytest.raises(FileFormatError, match="ends early") as info:
                read(path)
            assert str(path) in str(info.value), (what, str(info.value))


@pytest.mark.parametrize("name", sorted(VOLUME) + list(PICTURE) + list(FIELDS))
def test_a_whole_file_still_loads_as_simpleitk_reads_it(originals, name):
    ours = read_image(originals / name)
    theirs = sitk.ReadImage(str(originals / name))
    np.testing.assert_array_equal(sitk.GetArrayViewFromImage(ours), sitk.GetArrayViewFromImage(theirs))
    assert ours.GetSpacing() == theirs.GetSpacing() and ours.GetOrigin() == theirs.GetOrigin()
    if name in FIELDS:
        field = load_displacement_field(originals / name)
        np.testing.assert_allclose(field.vectors, sitk.GetArrayFromImage(theirs))


def test_the_messages_say_what_ends_early(originals, tmp_path):
    short = {}
    for name in ("volume.nii", "volume.nii.gz", "volume.mha", "mdetached.mhd", "gzip.nrrd"):
        for what, path in _cut_copies(originals, tmp_path / name, name):
            with pytest.raises(FileFormatError) as info:
                read_image(path)
            short[(name, what)] = info.value.problem
    size = (originals / "volume.nii").stat().st_size
    assert (
        short[("volume.nii", "1 byte short")] == f"the pixel data ends early: the file has {size - 1} bytes of {size}"
    )
    assert short[("mdetached.mhd", "50.0%")].startswith("the pixel data ends early: its data file mdetached.raw has")
    assert "compressed stream of the file ends before its end" in short[("volume.nii.gz", "in the gzip trailer")]
    assert "compressed stream" in short[("gzip.nrrd", "1 byte short")]


def test_a_cut_image_is_refused_by_the_editor_the_app_and_batch(originals, tmp_path):
    from ffd_notebook.batch import RandomLattice, generate
    from ffd_notebook.view import Editor

    cut = tmp_path / "cut.nii.gz"
    data = (originals / "volume.nii.gz").read_bytes()
    cut.write_bytes(data[: len(data) - 3])
    with pytest.raises(FileFormatError, match="ends early"):  # fn.edit(image=...) makes this editor
        Editor(image=cut, window_size=(80, 60))
    mesh = pv.Sphere(radius=5.0, theta_resolution=8, phi_resolution=8)
    mesh.save(tmp_path / "mesh.vtp")
    with pytest.raises(FileFormatError, match="ends early"):
        model = RandomLattice(num_control_points=6, max_displacement=0.5, locked_borders=1)
        generate(tmp_path / "mesh.vtp", model, 1, tmp_path / "out", image=cut, scheduler="sync", progress=False)
    assert not (tmp_path / "out").exists()
    import uuid

    from ffd_notebook.view.editor.app import EditorApp

    editor = Editor(mesh, shape=(4, 4, 4), window_size=(80, 60))
    app = EditorApp(editor, name=f"test_{uuid.uuid4().hex}", root=tmp_path)
    try:
        app.run("load_image", ["cut.nii.gz"])
        message = app.state.messages[0]
        assert message["error"] and "ends early" in message["text"] and not app.state.has_image, message
    finally:
        app.close()
        editor.close()


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz", ".nrrd", ".mha"])
def test_non_finite_values(tmp_path, suffix):
    """A field with NaN or infinite components is refused naming how many vectors have one (ITK's NIfTI reader would
    make them 0: no displacement); an image keeps them where its format does (NRRD, MetaImage) and reads them as 0
    from NIfTI (ITK's NIfTI library rule), as the site's file-format page says."""
    vectors = np.zeros((4, 5, 6, 3))
    vectors[1, 2, 3] = (np.nan, 0.0, 0.0)
    vectors[0, 0, 0] = (0.0, np.inf, -np.inf)
    vectors[3, 4, 5, 2] = np.nan
    field = tmp_path / f"field{suffix}"
    sitk.WriteImage(sitk.GetImageFromArray(vectors, isVector=True), str(field))
    for read in (load_displacement_field, load_deformation):
        with pytest.raises(FileFormatError, match="3 of its 120 vectors hold NaN or infinite values"):
            read(field)
    values = np.zeros((4, 5, 6), np.float32)
    values[1, 2, 3] = np.nan
    image = tmp_path / f"image{suffix}"
    sitk.WriteImage(sitk.GetImageFromArray(values), str(image))
    pixels = sitk.GetArrayFromImage(read_image(image))
    assert (pixels[1, 2, 3] == 0.0) if suffix.startswith(".nii") else np.isnan(pixels[1, 2, 3])


def test_a_header_end_that_is_not_found_is_refused(tmp_path):
    """The file is read only from what its header says: a NRRD header with no blank line before the limit, or a
    MetaImage header with no ElementDataFile line, is refused (before: the first 64 KiB were scanned and the rest
    passed to ITK)."""
    path = tmp_path / "long.nrrd"
    path.write_bytes(b"NRRD0004\ntype: uint8\ndimension: 1\nsizes: 4\nencoding: raw\n" + b"#" * (2 << 20))
    with pytest.raises(FileFormatError, match="the header's end is not found"):
        read_image(path)
    path = tmp_path / "no_end.mha"
    path.write_text("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n")
    with pytest.raises(FileFormatError, match="the header's end is not found"):
        read_image(path)
    assert os.path.exists(path)


def test_a_nifti_file_with_header_extensions_loads(tmp_path):
    """dcm2niix, AFNI and FreeSurfer write extensions after the header; the check sizes the pixels from vox_offset."""
    import nibabel

    image = nibabel.Nifti1Image(np.arange(24, dtype=np.float32).reshape(2, 3, 4), np.eye(4))
    image.header.extensions.append(nibabel.nifti1.Nifti1Extension(6, b"an extension of some length " * 7))
    for name in ("ext.nii", "ext.nii.gz"):
        nibabel.save(image, tmp_path / name)
        ours = sitk.GetArrayFromImage(read_image(tmp_path / name))
        np.testing.assert_array_equal(ours, sitk.GetArrayFromImage(sitk.ReadImage(str(tmp_path / name))))
        data = (tmp_path / name).read_bytes()
        (tmp_path / f"cut_{name}").write_bytes(data[:-6])
        with pytest.raises(FileFormatError, match="ends early"):
            read_image(tmp_path / f"cut_{name}")
