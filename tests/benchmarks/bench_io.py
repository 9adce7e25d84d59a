"""Benchmark of the file readers: python tests/benchmarks/bench_io.py

Prints the median of several repeats (the machine is shared) for
- read_obj on the 53k-vertex template_colored.obj, against pyvista.read (VTK's OBJ reader) as baseline,
- load_ffd / save_ffd on the real 11x12x11 registration file,
- read_ply on a 44 MB ASCII file (500k coloured vertices, 1M triangles) and on a binary file whose faces mix
  triangles and quads (1M faces): time against pyvista.read (VTK's PLY reader) as baseline, and the peak memory
  the reading adds to the process's resident size (in a fresh interpreter) as a multiple of the file's size.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyvista as pv

from ffd_notebook.io import load_ffd, read_obj, save_ffd, write_obj
from ffd_notebook.io.ply import read_ply

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


def peak_rss_growth(path: Path) -> int:
    """Growth of the peak resident size while a fresh interpreter reads ``path`` with read_ply (bytes).

    Resident size, not tracemalloc: ``read_bytes`` asks Python for a buffer of the size limit (1 GiB) that the
    kernel never backs with memory, which tracemalloc would count.
    """
    # VmHWM of /proc, not ru_maxrss, which Linux carries over from the parent through fork and exec
    code = (
        "import re, sys\n"
        "from ffd_notebook.io.ply import read_ply\n"
        "peak = lambda: int(re.search(r'VmHWM:\\s*(\\d+)', open('/proc/self/status').read()).group(1))\n"
        "before = peak()\n"
        "read_ply(sys.argv[1])\n"
        "print(peak() - before)\n"
    )
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    return int(done.stdout) * 1024  # KiB


def ascii_ply(path: Path, n_vertices: int = 500_000) -> None:
    """A coloured triangle mesh in ASCII PLY (about 44 MB for 500k vertices and 1M faces)."""
    rng = np.random.default_rng(0)
    header = (f"ply\nformat ascii 1.0\nelement vertex {n_vertices}\nproperty float x\nproperty float y\n"
              "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              f"element face {2 * n_vertices}\nproperty list uchar int vertex_indices\nend_header\n")  # fmt: skip
    with open(path, "w") as f:
        f.write(header)
        xyz = rng.uniform(-100, 100, (n_vertices, 3))
        rgb = rng.integers(0, 256, (n_vertices, 3))
        np.savetxt(f, np.column_stack([xyz, rgb]), fmt="%.6f %.6f %.6f %d %d %d")
        faces = rng.integers(0, n_vertices, (2 * n_vertices, 3))
        np.savetxt(f, np.column_stack([np.full(len(faces), 3), faces]), fmt="%d")


def mixed_binary_ply(path: Path, n_faces: int = 1_000_000) -> None:
    """A binary PLY whose faces are triangles and quads in random order (their rows differ in size)."""
    rng = np.random.default_rng(1)
    n_vertices = n_faces // 2
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {n_vertices}\nproperty float x\n"
              f"property float y\nproperty float z\nelement face {n_faces}\n"
              "property list uchar int vertex_indices\nend_header\n")  # fmt: skip
    sizes = rng.choice([3, 4], n_faces)
    rows = bytearray()
    indices = np.split(rng.integers(0, n_vertices, sizes.sum()), np.cumsum(sizes)[:-1])
    for size, face in zip(sizes, indices, strict=True):
        rows += bytes([size]) + face.astype("<i4").tobytes()
    path.write_bytes(header.encode() + rng.uniform(-1, 1, (n_vertices, 3)).astype("<f4").tobytes() + bytes(rows))


def ply_rows(folder: Path) -> None:
    for name, make in (("ascii.ply", ascii_ply), ("mixed-faces.ply", mixed_binary_ply)):
        path = folder / name
        make(path)
        size = path.stat().st_size
        mesh = read_ply(path)
        ours = median_seconds(lambda path=path: read_ply(path), repeats=3)
        vtk = median_seconds(lambda path=path: pv.read(path), repeats=3)
        peak = peak_rss_growth(path)
        row(f"read_ply {name} ({size / 1e6:.0f} MB, {mesh.n_points} vertices, {mesh.n_cells} faces)", ours,
            f"read_ply / VTK = {ours / vtk:.1f}x ({vtk * 1e3:.0f} ms)")  # fmt: skip
        print(f"{'  resident memory added by read_ply':<58} {peak / 1e6:8.0f} MB   {peak / size:.1f}x the file")


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
        ply_rows(Path(tmp))


if __name__ == "__main__":
    main()
