"""What reading an image whole or not at all costs (issue 34): ``read_image`` against plain ``sitk.ReadImage``.

Run from the repository root:

    python tests/benchmarks/bench_whole_read.py [--size 256] [--repeats 3]

For a float32 ``size^3`` image (64 MiB at 256^3, a smooth CT-like volume with noise) written by SimpleITK in
each format the package reads volumes in, prints the median time of ``sitk.ReadImage`` (what the package did
before: no checks), of ``read_image`` (the header checked before ITK reads it, then the pixels read whole or
refused), and of the whole-or-nothing check alone (``check_whole``), with the ratio. Raw data is checked
against the file's size (one ``stat``); compressed data (``.nii.gz``, gzip NRRD, compressed MetaImage) is
inflated once more to the end of its stream, which is the cost that shows. The machine may be shared: the
figures are medians of ``--repeats`` runs, each on a file in the page cache.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import SimpleITK as sitk
from bench_io import median_seconds

from ffd_notebook.images import open_image, read_image
from ffd_notebook.images.data_files import check_whole

FORMATS = {"volume.nii": False, "volume.nii.gz": True, "volume.nrrd": False, "gzip.nrrd": True,
           "volume.mha": False, "zlib.mha": True}  # fmt: skip


def _volume(size: int) -> sitk.Image:
    axis = np.linspace(-1.0, 1.0, size, dtype=np.float32)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij", sparse=True)
    body = np.where(x**2 + (1.3 * y) ** 2 + (0.9 * z) ** 2 < 0.7, 40.0, -900.0).astype(np.float32)
    noise = np.random.default_rng(0).normal(0.0, 8.0, body.shape).astype(np.float32)
    return sitk.GetImageFromArray(np.round(body + noise))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    image = _volume(args.size)
    print(f"{args.size}^3 float32 ({args.size**3 * 4 / 2**20:.0f} MiB of pixels), medians of {args.repeats} runs")
    print(f"{'file':15s} {'MiB':>6s} {'sitk.ReadImage':>15s} {'read_image':>11s} {'ratio':>6s} {'check alone':>12s}")
    for name, compress in FORMATS.items():
        path = folder / name
        sitk.WriteImage(image, str(path), compress)
        sitk.ReadImage(str(path))  # into the page cache
        plain = median_seconds(lambda p=path: sitk.ReadImage(str(p)), args.repeats)
        ours = median_seconds(lambda p=path: read_image(p), args.repeats)
        layout = open_image(path).layout
        check = median_seconds(lambda layout=layout: check_whole(layout), args.repeats)
        mib = path.stat().st_size / 2**20
        print(f"{name:15s} {mib:6.1f} {plain:14.3f}s {ours:10.3f}s {ours / plain:6.2f} {check:11.3f}s")


if __name__ == "__main__":
    main()
