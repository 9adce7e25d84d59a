"""Image warping benchmark (issue 22): ``warp_image`` of a 256^3 image through an FFD.

Run from the repository root:

    python tests/benchmarks/bench_images.py [--size 256] [--repeats 3] [--only warp,rotated,interpolators,slices]
                                           [--against REV]

Prints, for a float32 ``size^3`` image (64 MiB at 256^3) with an 11 x 12 x 11 lattice of random
offsets over it:

* ``warp``: ``warp_image`` (linear), SimpleITK image in, SimpleITK image out; the lattice's axes
  along the image's (the usual case: a lattice fitted to the image, a registration's grid),
  so ``T`` is evaluated through the grid's structure. Targets: <= 5 s, and peak memory above
  the memory before the call (input image loaded) <= 3x the image;
* ``rotated``: the same with a lattice turned 20 degrees against the image's axes, where ``T`` is
  evaluated point by point (``FFD.deform`` per slab): the general path, no target;
* ``interpolators``: the interpolation step alone on the same precomputed ``T``, slab by slab:
  ``scipy.ndimage.map_coordinates`` (what ``warp_image`` uses) against ``sitk.Resample`` with a
  ``DisplacementFieldTransform`` per slab (the alternative the issue names);
* ``slices``: the editor's three warped slices of the image (``WarpedSlices``): binding them, and
  one drag step of a control point (``update``), lattice along the image;
* ``--against REV``: ``warp`` and ``slices`` timed under this tree and under the package at git
  revision ``REV`` (e.g. the commit before a change), interleaved in one run, with their ratio
  (:mod:`against`; issue 35: no slower than 1.2x).

Timings are medians of ``--repeats`` runs (the machine is shared); memory is the peak resident set
(``VmHWM``, reset through ``/proc/self/clear_refs``) above the resident set before the call.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import SimpleITK as sitk
from scipy import ndimage
from scipy.spatial.transform import Rotation

from ffd_notebook import FFD, Lattice
from ffd_notebook.images import ImageGrid, warp_image
from ffd_notebook.images.sample import IndexSampler, slab_rows


def _status(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(field)


def peak_above_start(fn):
    """Run ``fn``; return its result, seconds, and the peak RSS above the RSS at the start (bytes)."""
    Path("/proc/self/clear_refs").write_text("5")  # reset VmHWM to the current RSS
    start = _status("VmRSS")
    t0 = time.perf_counter()
    result = fn()
    seconds = time.perf_counter() - t0
    return result, seconds, _status("VmHWM") - start


def make_image(size: int) -> sitk.Image:
    rng = np.random.default_rng(0)
    coarse = rng.random((size // 8,) * 3).astype(np.float32)
    volume = ndimage.zoom(coarse, 8, order=1).astype(np.float32)
    image = sitk.GetImageFromArray(volume)
    image.SetSpacing((0.8, 0.8, 1.0))
    image.SetOrigin((-100.0, -90.0, 40.0))
    return image


def make_ffd(grid: ImageGrid, rotated: bool) -> FFD:
    lo, hi = grid.bounds()
    rotation = Rotation.from_euler("z", 20.0, degrees=True).as_matrix() if rotated else None
    lat = Lattice.around(np.array([lo, hi]), shape=(11, 12, 11))
    if rotated:
        centre = (lo + hi) / 2
        lat = Lattice(
            lat.shape, lat.spacing * 1.3, origin=centre - rotation @ (lat.spacing * 1.3 * 5.25), rotation=rotation
        )
    lat.offsets[...] = np.random.default_rng(1).normal(scale=0.3 * lat.spacing.min(), size=lat.offsets.shape)
    return FFD(lat)


def bench_warp(image: sitk.Image, repeats: int, rotated: bool) -> None:
    grid = ImageGrid.of(image)
    ffd = make_ffd(grid, rotated)
    nbytes = sitk.GetArrayViewFromImage(image).nbytes
    times, peaks = [], []
    for _ in range(repeats):
        out, seconds, peak = peak_above_start(lambda: warp_image(image, ffd))
        times.append(seconds)
        peaks.append(peak)
        del out
    name = "rotated" if rotated else "warp"
    target = "" if rotated else "  (targets <= 5 s, <= 3.0x)"
    runs = ", ".join(f"{t:.2f}" for t in times)
    peak = max(peaks)
    print(f"{name:8s} {grid.size}: {statistics.median(times):6.2f} s (runs {runs}), "
          f"peak memory above start {peak / 2**20:.0f} MiB = {peak / nbytes:.2f}x the image{target}")  # fmt: skip


def bench_interpolators(image: sitk.Image, repeats: int) -> None:
    grid = ImageGrid.of(image)
    ffd = make_ffd(grid, rotated=False)
    sampler = IndexSampler(ffd, grid, grid)
    step = slab_rows(grid)
    slabs = [(s, min(s + step, grid.shape[0])) for s in range(0, grid.shape[0], step)]
    index = [sampler.rows(a, b) for a, b in slabs]  # precomputed: only the interpolation is timed
    pixels = sitk.GetArrayViewFromImage(image)
    to_physical = grid.index_to_physical()
    out = np.empty(grid.shape, dtype=np.float32)

    def scipy_way() -> None:
        for (a, b), idx in zip(slabs, index, strict=True):
            ndimage.map_coordinates(pixels, idx, output=out[a:b], order=1, mode="nearest", prefilter=False)

    def sitk_way() -> None:
        for (a, b), idx in zip(slabs, index, strict=True):
            # displacement T(x) - x in physical units on the slab's grid
            moved = to_physical[:3, :3] @ idx[::-1].reshape(3, -1) + to_physical[:3, 3, None]
            rest = to_physical[:3, :3] @ sampler.slab_index(a, b)[:3] + to_physical[:3, 3, None]
            field = sitk.GetImageFromArray((moved - rest).T.reshape(*idx.shape[1:], 3), isVector=True)
            slab = ImageGrid(
                (grid.size[0], grid.size[1], b - a), grid.spacing, to_physical[:3] @ [0, 0, a, 1], grid.direction
            )
            slab.to_sitk(field)
            transform = sitk.DisplacementFieldTransform(field)
            ref = slab.to_sitk(sitk.Image(list(slab.size), sitk.sitkFloat32))
            out[a:b] = sitk.GetArrayViewFromImage(sitk.Resample(image, ref, transform, sitk.sitkLinear, 0.0))

    for name, fn in (("map_coordinates", scipy_way), ("sitk.Resample+field", sitk_way)):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        runs = ", ".join(f"{t:.2f}" for t in times)
        print(f"interpolation alone, {name:20s}: {statistics.median(times):6.2f} s (runs {runs})")


def bench_slices(image: sitk.Image, repeats: int) -> None:
    from ffd_notebook.images import WarpedSlices

    ffd = make_ffd(ImageGrid.of(image), rotated=False)
    binds, drags = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        slices = WarpedSlices(image, ffd)
        binds.append(time.perf_counter() - start)
        ffd.lattice.offsets[5, 6, 5] += (0.5, -0.3, 0.2)
        start = time.perf_counter()
        slices.update([(5, 6, 5)])
        drags.append(time.perf_counter() - start)
    print(f"slices   {ImageGrid.of(image).size}: bind {statistics.median(binds) * 1e3:.1f} ms, one drag step "
          f"{statistics.median(drags) * 1e3:.1f} ms (medians of {repeats})")  # fmt: skip


_SETUP = """
from bench_images import make_image, make_ffd
from ffd_notebook.images import ImageGrid, WarpedSlices, warp_image
image = make_image({size})
ffd = make_ffd(ImageGrid.of(image), rotated=False)
slices = WarpedSlices(image, ffd)
"""
_DRAG = "ffd.lattice.offsets[5, 6, 5] += (0.01, 0.0, 0.0); slices.update([(5, 6, 5)])"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", default="warp,rotated,interpolators,slices")
    parser.add_argument("--against", metavar="REV", help="also time warp and slices under git revision REV")
    args = parser.parse_args()
    only = set(args.only.split(","))
    if args.against:
        from against import compare

        setup = _SETUP.format(size=args.size)
        compare(f"warp_image {args.size}^3, lattice along the image", setup, "warp_image(image, ffd)", args.against,
                args.repeats)  # fmt: skip
        compare("WarpedSlices, bind the three slices", setup, "WarpedSlices(image, ffd)", args.against, args.repeats)
        compare("WarpedSlices, 20 drag steps of one control point", setup, f"for _ in range(20): {_DRAG}",
                args.against, args.repeats)  # fmt: skip
    image = make_image(args.size)
    print(f"image {args.size}^3 float32 ({sitk.GetArrayViewFromImage(image).nbytes / 2**20:.0f} MiB), "
          f"{sitk.ProcessObject.GetGlobalDefaultNumberOfThreads()} ITK threads")  # fmt: skip
    if "warp" in only:
        bench_warp(image, args.repeats, rotated=False)
    if "rotated" in only:
        bench_warp(image, 1, rotated=True)
    if "interpolators" in only:
        bench_interpolators(image, args.repeats)
    if "slices" in only:
        bench_slices(image, args.repeats)


if __name__ == "__main__":
    main()
