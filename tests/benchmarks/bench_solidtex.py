"""Solid-texture benchmark (issue: solid textures for organ models).

Run from the repository root:

    python tests/benchmarks/bench_solidtex.py [--quick]

Prints, in one run: synthesis of 128^3 from a 64^3 exemplar (target <= 10 s), synthesis of 256^3
with the reuse growth against fixed blocks (target: reuse >= 3x faster at similar quality, with
the histogram distance to the exemplar, the seam energy at the final block borders and the
gradient energy as quality figures), tetrahedralisation and texture mapping on the frog liver,
and one cut update (target < 100 ms for a ~20k-tetrahedron model). Medians of several repeats:
the machine is shared.
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np
import skimage.data

import ffd_notebook.view  # noqa: F401  (headless settings first)
from ffd_notebook import FFD, Lattice
from ffd_notebook.datasets import frog_liver
from ffd_notebook.solidtex import (
    SolidTexture,
    choose_block_size,
    gradient_energy,
    histogram_distance,
    plan_stages,
    seam_energy,
    sliding_crops,
    synthesize,
    volume_from_slices,
)
from ffd_notebook.view.organ import organ_surface, tetrahedralize, texture_surface
from ffd_notebook.view.solid_cut import CutViewer, TexturedOrgan


def timed(fn, repeat):
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def row(name, value, unit, target=""):
    print(f"{name:<58} {value:10.3f} {unit:<3} {target}")


def exemplar():
    img = skimage.data.immunohistochemistry()
    return volume_from_slices(sliding_crops(img, 64, 64, step=(1, 1), start=(100, 100)))


def synthesis(ex, quick):
    block = choose_block_size(ex)
    print(f"exemplar 64^3 from immunohistochemistry crops; block size by feature inclusiveness: {block}\n")
    rep = 1 if quick else 3
    s128, _ = timed(lambda: synthesize(ex, 128, progress=False), rep)
    p128, _ = timed(lambda: synthesize(ex, 128, reuse=False, progress=False), rep)
    row("synthesis 128^3 (reuse)", s128, "s", f"target <= 10 s  {'ok' if s128 <= 10 else 'MISSED'}")
    row("synthesis 128^3 (fixed blocks)", p128, "s", f"target <= 10 s  {'ok' if p128 <= 10 else 'MISSED'}")
    size = 192 if quick else 256
    r256, reuse = timed(lambda: synthesize(ex, size, progress=False), rep)
    f256, plain = timed(lambda: synthesize(ex, size, reuse=False, progress=False), 1 if quick else 2)
    ratio = f256 / r256
    row(f"synthesis {size}^3 (reuse)", r256, "s")
    row(f"synthesis {size}^3 (fixed blocks, baseline)", f256, "s")
    row("  speed-up of reuse", ratio, "x", f"target >= 3x  {'ok' if ratio >= 3 else 'MISSED'}")
    print(f"\nquality at {size}^3 (exemplar gradient energy {gradient_energy(ex):.0f}):")
    print(f"{'':<26}{'hist. dist.':>12}{'seam (own)':>12}{'seam (16)':>12}{'grad. energy':>14}")
    fixed = plan_stages(ex.shape, (size,) * 3, block, reuse=False)[-1]
    for name, vol in (("reuse", reuse), ("fixed blocks", plain)):
        last = plan_stages(ex.shape, (size,) * 3, block, reuse=name == "reuse")[-1]
        print(
            f"{name:<26}{histogram_distance(vol, ex):12.4f}{seam_energy(vol, last.step, last.overlap):12.3f}"
            f"{seam_energy(vol, fixed.step, fixed.overlap):12.3f}{gradient_energy(vol):14.0f}"
        )
    print("  (histogram distance: L2 of 8^3-bin RGB histograms, 0 = same; seam energy: 1 = borders as smooth as")
    print("   the rest; 'own' at the method's final block borders, '16' at the fixed-block borders)\n")
    return synthesize(ex, 128, progress=False)


def organ(volume, quick):
    liver = frog_liver(2500)
    rep = 3 if quick else 7
    for method in ("tetgen", "delaunay"):
        t, grid = timed(lambda m=method: tetrahedralize(liver, method=m), 3)
        row(f"tetrahedralise liver ({liver.n_points} pts, {method}): {grid.n_cells} tets", 1000 * t, "ms")
    grid = tetrahedralize(liver, method="tetgen")
    texture = SolidTexture.fit(volume, grid.bounds)
    outer = organ_surface(grid)
    for n in (0, 1, 2, 3):
        t, dense = timed(lambda n=n: texture_surface(outer, texture, subdivisions=n), rep)
        colours = len(np.unique(dense.point_data["RGB"], axis=0))
        row(f"map texture onto surface, {n} subdivisions: {dense.n_points} pts, {colours} colours", 1000 * t, "ms")
    t, model = timed(lambda: TexturedOrgan(grid, texture), 3)
    print(f"  auto subdivisions: display surface {model.surface.n_points} points (texture voxel {texture.spacing:.2f})")
    centre = np.array(grid.center)
    planes = [(centre + (d, 0, 0), (1.0, 0.3 * np.sin(d), 0.2)) for d in np.linspace(-20, 20, 9)]
    times = []
    for origin, normal in planes * (2 if quick else 4):
        t0 = time.perf_counter()
        model.cut(origin, normal)
        times.append(time.perf_counter() - t0)
    cut = 1000 * statistics.median(times)
    row(
        f"one cut ({grid.n_cells} tets, clip + section + sampling)",
        cut,
        "ms",
        f"target < 100 ms  {'ok' if cut < 100 else 'MISSED'}",
    )
    viewer = CutViewer(model, window_size=(600, 400))
    viewer.look_at_cut()
    t, _ = timed(lambda: viewer.update(centre + (5, 0, 0), (1, 0.2, 0)), rep)
    row("one cut in the viewer (in-place update + software render)", 1000 * t, "ms")
    lattice = Lattice.around(grid.points, shape=(5, 5, 5))
    lattice.offsets[..., 0] = np.random.default_rng(0).normal(size=lattice.offsets.shape[:3]) * 8
    ffd = FFD(lattice)
    t, _ = timed(lambda: model.deform(ffd.deform), rep)
    row(f"deform organ with an FFD (tets + {model.surface.n_points}-pt surface)", 1000 * t, "ms")
    viewer.plotter.close()


def main() -> None:
    quick = "--quick" in sys.argv
    print("solid textures, machine: 2 shared cores (medians)\n")
    volume = synthesis(exemplar(), quick)
    organ(volume, quick)


if __name__ == "__main__":
    main()
