"""Benchmark of the file readers: python tests/benchmarks/bench_io.py

Prints the median of several repeats (the machine is shared) for
- read_obj on the 53k-vertex template_colored.obj, against pyvista.read (VTK's OBJ reader) as baseline,
- load_ffd / save_ffd on the real 11x12x11 registration file.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import pyvista as pv

from ffd_notebook.io import load_ffd, read_obj, save_ffd, write_obj

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
REPEATS = 7


def median_seconds(func, repeats: int = REPEATS) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def row(label: str, seconds: float, note: str) -> None:
    print(f"{label:<58} {seconds * 1e3:8.2f} ms   {note}")


def main() -> None:
    template = DATA / "face" / "template_colored.obj"
    ffd = DATA / "seed-lineage" / "registration_11x12x11.FFD"
    read_obj(template), pv.read(template)  # warm the imports and the file cache

    ours = median_seconds(lambda: read_obj(template))
    vtk = median_seconds(lambda: pv.read(template))
    mesh = read_obj(template)
    row(f"read_obj template_colored.obj ({mesh.n_points} vertices, colours)", ours, "target < 1000 ms")
    row("pyvista.read template_colored.obj (baseline: VTK reader)", vtk, f"read_obj / VTK = {ours / vtk:.1f}x")
    with tempfile.TemporaryDirectory() as tmp:
        write = median_seconds(lambda: write_obj(Path(tmp) / "template.obj", mesh), repeats=3)
        row("write_obj template_colored.obj", write, "target < 2000 ms")
        lattice = load_ffd(ffd)
        row(f"load_ffd registration_11x12x11.FFD ({lattice.n_points} points)", median_seconds(lambda: load_ffd(ffd)),
            "target < 100 ms")  # fmt: skip
        save = median_seconds(lambda: save_ffd(Path(tmp) / "copy.ffd", lattice))
        row("save_ffd registration_11x12x11.FFD", save, "target < 100 ms")


if __name__ == "__main__":
    main()
