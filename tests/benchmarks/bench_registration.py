"""Benchmark of registration results in and out: python tests/benchmarks/bench_registration.py [--against REV]

Prints (median of a few repeats where cheap; the machine is shared):
- loading a 51,300-parameter elastix file (a 19x25x36 B-spline grid, the issue's size): the chain,
  and the chain lowered onto an FFD (``load_deformation``),
- deforming 1M points with a loaded affine-then-B-spline "Compose" chain, and with its FFD form
  (the same deformation written by this package: affine plus B-spline combined by "Add"),
- writing a displacement field at 256^3 (NIfTI, and compressed NIfTI),
- ``fit_lattice`` of a 160x160x128 field by a 16^3 lattice: time and peak memory (tracemalloc:
  NumPy's arrays; targets <= 10 s and <= 2 GB).

With ``--against REV`` it times instead, under this tree and under the package at git revision ``REV``,
interleaved in one run (:mod:`against`), ``fit_lattice`` of that field, sampling an FFD's field on a
160x160x128 grid along its lattice, and ``save_displacement_field`` of a 256^3 grid along it, with
the ratios (issue 35: no slower than 1.2x).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from ffd_notebook import FFD, Lattice
from ffd_notebook.io import (
    fit_lattice,
    load_deformation,
    load_elastix,
    sample_displacement_field,
    save_displacement_field,
    save_elastix,
)
from ffd_notebook.io.elastix_text import read_parameter_file, write_parameter_file

ROTATED = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])


def median_seconds(func, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def row(label: str, seconds: float, note: str = "") -> None:
    print(f"{label:<66} {seconds * 1e3:9.1f} ms   {note}")


def _registration_like(folder: Path) -> tuple[Path, Path]:
    """A 19x25x36 B-spline (51,300 parameters) after an affine map: as "Add" (ours) and as "Compose" (elastix's)."""
    rng = np.random.default_rng(0)
    lattice = Lattice((19, 25, 36), (8.0, 7.5, 6.0), origin=(-20.0, -30.0, -15.0), rotation=ROTATED)
    lattice.offsets[...] = rng.normal(0.0, 1.5, lattice.offsets.shape)
    affine = np.eye(4)
    affine[:3] = [[1.05, 0.08, 0.0, 3.0], [-0.04, 0.97, 0.03, -2.0], [0.01, 0.0, 1.02, 1.0]]
    added = folder / "TransformParameters.1.txt"
    save_elastix(added, FFD(lattice, affine=affine, only_inside=True))
    params = read_parameter_file(added)
    entries = []
    for name, entry in params.entries.items():
        values: list = [v if v[0].isalpha() else float(v) for v in entry.values]
        entries.append((name, ["Compose"] if name == "HowToCombineTransforms" else values))
    composed = folder / "TransformParameters.compose.txt"
    write_parameter_file(composed, entries)
    return added, composed


_SETUP = """
import tempfile
from pathlib import Path
import numpy as np
from bench_registration import ROTATED
from ffd_notebook import FFD, Lattice
from ffd_notebook.io import fit_lattice, sample_displacement_field, save_displacement_field
field_grid = {"size": (160, 160, 128), "spacing": (1.0, 1.0, 1.25), "origin": (5.0, -3.0, 2.0), "direction": ROTATED}
spacing = (np.array(field_grid["size"]) - 1) * field_grid["spacing"] / 13
truth = Lattice((16, 16, 16), spacing, origin=np.array(field_grid["origin"]) - ROTATED @ spacing, rotation=ROTATED)
truth.offsets[...] = np.random.default_rng(2).normal(0.0, 2.0, truth.offsets.shape)
field = sample_displacement_field(lambda p: FFD(truth).deform(p) + 0.3 * np.sin(p / 7.0), field_grid)
big = {"size": (256, 256, 256), "spacing": (1.0, 1.0, 1.0), "origin": (-40.0, -60.0, -20.0), "direction": ROTATED}
folder = Path(tempfile.mkdtemp())
"""


def against(revision: str, repeats: int) -> None:
    from against import compare

    compare("fit_lattice 160x160x128 field, 16^3 lattice", _SETUP, "fit_lattice(field, (16, 16, 16))", revision,
            repeats)  # fmt: skip
    compare("sample_displacement_field of an FFD, 160x160x128 grid along its lattice", _SETUP,
            "sample_displacement_field(FFD(truth), field_grid)", revision, repeats)  # fmt: skip
    compare("save_displacement_field 256^3 .nii, grid along the lattice", _SETUP,
            "save_displacement_field(folder / 'f.nii', FFD(truth), big)", revision, repeats)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", metavar="REV", help="time fit_lattice and field sampling against revision REV")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(sys.argv[1:])
    if args.against:
        against(args.against, args.repeats)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        added, composed = _registration_like(folder)
        count = len(read_parameter_file(added).values("TransformParameters"))
        load_elastix(added)  # warm the imports and the file cache
        row(f"load_elastix, {count} parameters (19x25x36) + affine file", median_seconds(lambda: load_elastix(added)))
        row("load_deformation of it (chain lowered onto an FFD)", median_seconds(lambda: load_deformation(added)))
        chain = load_elastix(composed)
        ffd = load_deformation(added)
        points = ffd.lattice.to_world(np.random.default_rng(1).random((1_000_000, 3)) * (np.array((19, 25, 36)) - 1))
        row("deform 1M points, affine-then-B-spline Compose chain", median_seconds(lambda: chain.deform(points), 3))
        row("deform 1M points, the FFD of the Add chain (FFD.deform)", median_seconds(lambda: ffd.deform(points), 3))

        grid = {"size": (256, 256, 256), "spacing": (1.0, 1.0, 1.0), "origin": (-40.0, -60.0, -20.0)}
        along = dict(grid, direction=ROTATED)  # the image's axes along the lattice's: sampled axis by axis
        for label, reference, suffix in (("grid along the lattice", along, ".nii"),
                                         ("grid along the lattice", along, ".nii.gz"),
                                         ("axis-aligned grid, rotated lattice", grid, ".nii")):  # fmt: skip
            start = time.perf_counter()
            save_displacement_field(folder / f"field{suffix}", ffd, reference)
            size = (folder / f"field{suffix}").stat().st_size
            row(f"save_displacement_field 256^3 {suffix} ({size / 2**20:.0f} MB), {label}", time.perf_counter() - start)
            (folder / f"field{suffix}").unlink()

    field_grid = {"size": (160, 160, 128), "spacing": (1.0, 1.0, 1.25), "origin": (5.0, -3.0, 2.0),
                  "direction": ROTATED}  # fmt: skip
    # a 16^3 lattice whose domain is the field's box (as fit_lattice places one), random offsets
    spacing = (np.array(field_grid["size"]) - 1) * field_grid["spacing"] / 13
    truth = Lattice((16, 16, 16), spacing, origin=np.array(field_grid["origin"]) - ROTATED @ spacing, rotation=ROTATED)
    truth.offsets[...] = np.random.default_rng(2).normal(0.0, 2.0, truth.offsets.shape)
    start = time.perf_counter()
    field = sample_displacement_field(lambda p: FFD(truth).deform(p) + 0.3 * np.sin(p / 7.0), field_grid)
    row("sample a 160x160x128 field (an FFD plus a swirl no lattice holds)", time.perf_counter() - start)
    tracemalloc.start()
    start = time.perf_counter()
    fitted = fit_lattice(field, (16, 16, 16))
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    report = fitted.lattice.metadata["fit"]
    row("fit_lattice 160x160x128 field, 16^3 lattice", seconds,
        f"peak {peak / 2**30:.2f} GB; residual RMS {report['rms']:.3g}, max {report['max']:.3g}; "
        "targets <= 10 s, <= 2 GB")  # fmt: skip
    exact = sample_displacement_field(FFD(truth), field_grid)
    start = time.perf_counter()
    again = fit_lattice(exact, (16, 16, 16))
    row("fit_lattice of a field sampled from a 16^3 FFD (exact recovery)", time.perf_counter() - start,
        f"max offset error {np.abs(again.lattice.offsets - truth.offsets).max():.2g}")  # fmt: skip


if __name__ == "__main__":
    main()
