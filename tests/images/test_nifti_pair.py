"""NIfTI pairs (``.hdr`` + ``.img``, as SPM and FSL write them): read whole, the ``.img`` checked as a file the header
names, Analyze 7.5 headers refused (their orientation is not in the file)."""

from __future__ import annotations

import os

import nibabel
import numpy as np
import pytest
import SimpleITK as sitk

from ffd_notebook.errors import FileFormatError
from ffd_notebook.images import read_image, read_image_information


def _pair(folder, name="scan"):
    image = sitk.GetImageFromArray(np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6))
    image.SetSpacing((1.0, 2.0, 3.0))
    image.SetOrigin((4.0, 5.0, 6.0))
    sitk.WriteImage(image, str(folder / f"{name}.hdr"))
    return image


def test_a_pair_reads_as_simpleitk_reads_it_from_either_file(tmp_path):
    image = _pair(tmp_path)
    assert sorted(os.listdir(tmp_path)) == ["scan.hdr", "scan.img"]
    for name in ("scan.hdr", "scan.img"):
        read = read_image(tmp_path / name)
        assert np.array_equal(sitk.GetArrayFromImage(read), sitk.GetArrayFromImage(image))
        assert read.GetSpacing() == image.GetSpacing() and read.GetOrigin() == image.GetOrigin()
    assert read_image_information(tmp_path / "scan.hdr").size == (6, 5, 4)


@pytest.mark.parametrize("cut", [1, 120])
def test_a_pair_whose_img_is_cut_short_is_refused(tmp_path, cut):
    _pair(tmp_path)
    data = (tmp_path / "scan.img").read_bytes()
    (tmp_path / "scan.img").write_bytes(data[:-cut])
    with pytest.raises(FileFormatError, match=rf"ends early: its data file scan.img has {480 - cut} bytes of 480"):
        read_image(tmp_path / "scan.hdr")


def test_the_img_is_a_file_the_header_names(tmp_path):
    folder, outside = tmp_path / "folder", tmp_path / "outside"
    folder.mkdir()
    outside.mkdir()
    _pair(outside)
    os.link(outside / "scan.hdr", folder / "scan.hdr")
    (folder / "scan.img").symlink_to(outside / "scan.img")  # the pixels outside the folder
    with pytest.raises(FileFormatError, match="outside the folder"):
        read_image(folder / "scan.hdr", within=folder)
    assert read_image(folder / "scan.hdr").GetSize() == (6, 5, 4)  # in a notebook: read as ITK reads it
    (folder / "scan.img").unlink()
    with pytest.raises(FileFormatError, match=r"scan\.img"):
        read_image(folder / "scan.hdr")
    os.mkfifo(folder / "scan.img")
    with pytest.raises(FileFormatError, match="FIFO"):
        read_image(folder / "scan.hdr")


def test_two_candidate_data_files_and_analyze_headers_are_refused(tmp_path):
    _pair(tmp_path)
    (tmp_path / "scan.img.gz").write_bytes(b"")
    with pytest.raises(FileFormatError, match=r"both scan\.img and scan\.img\.gz"):
        read_image(tmp_path / "scan.hdr")
    analyze = nibabel.AnalyzeImage(np.zeros((3, 4, 5), np.int16), np.eye(4))
    nibabel.save(analyze, str(tmp_path / "old.hdr"))
    with pytest.raises(FileFormatError, match=r"Analyze 7\.5 header"):
        read_image(tmp_path / "old.hdr")
