"""Interop benchmark (issue 11): file formats of the real lattice, ``convert``, one-shot deform vs PyGeM.

Run from the repository root (needs ../shared/data):

    python tests/benchmarks/bench_interop.py

Prints, in one run: load and save time of the real 11x12x11 lattice as .ffd, ITK .tfm and ITK .h5
(and of PyGeM's sphere .prm), the cost of ``python -m ffd_notebook convert`` on it (in process),
and one-shot ``FFD.deform`` on the 53k-vertex face at 5^3, 7^3 and 11^3 next to the baselines
of issue 11, measured in the same run, interleaved so that both see the same load:

- Bernstein: PyGeM's ``FFD.__call__`` on the same lattice (written with ``save_prm``, read with
  PyGeM's ``read_parameters``); target: ours at least 3x faster.
- B-spline ("zero" and "clamp" borders): ``bind(points).update()``; target: ``deform`` within 2x.

PyGeM (mathLab's shape-optimisation library) is not on PyPI (the ``pygem`` package there is a
glacier model) and is not a dependency: point ``PYGEM_PATH`` at a source checkout of it (the
folder holding ``pygem/``) to measure it; without it the issue's figures (5^3 16 ms, 7^3 35 ms,
11^3 105 ms on this mesh, another machine and load) stand in for it, and the script says so.

    PYGEM_PATH=/tmp/pygem_src python tests/benchmarks/bench_interop.py

The deform section runs twice: BLAS held to one thread, then BLAS's default thread count.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ffd_notebook import (
    FFD,
    Lattice,
    load_ffd,
    load_prm,
    load_transform,
    read_mesh,
    save_ffd,
    save_prm,
    save_transform,
)
from ffd_notebook.io.convert import convert

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_ffd import median_ms  # noqa: E402  (median of repeats after a warm-up)

DATA = HERE.parents[2] / "shared" / "data"
REAL = DATA / "seed-lineage" / "registration_11x12x11.FFD"
PRM = DATA / "pygem" / "parameters_test_ffd_sphere.prm"
FACE = DATA / "face" / "template.ply"
PYGEM_MS = {5: 16.0, 7: 35.0, 11: 105.0}  # the measurement of PyGeM's FFD.__call__ on the face
SHAPES = (5, 7, 11)


def import_pygem():
    """PyGeM's ``FFD`` class from the checkout at ``$PYGEM_PATH``, or None (and why)."""
    path = os.environ.get("PYGEM_PATH")
    if not path:
        return None, "PYGEM_PATH not set"
    sys.path.insert(0, path)
    try:
        from pygem import FFD as PyGeMFFD
    except ImportError as exc:
        return None, f"cannot import pygem from {path}: {exc}"
    return PyGeMFFD, f"PyGeM from {path}"


def files(folder: Path) -> None:
    lattice = load_ffd(REAL)
    ffd = FFD(lattice)
    print(f"real lattice {lattice.shape} ({REAL.name}); median of repeats")
    print(f"{'format':<10} {'load ms':>9} {'save ms':>9} {'bytes':>9}")
    for suffix, load, save in (
        (".ffd", load_ffd, lambda p: save_ffd(p, lattice)),
        (".tfm", load_transform, lambda p: save_transform(p, ffd)),
        (".h5", load_transform, lambda p: save_transform(p, ffd)),
    ):
        path = folder / f"real{suffix}"
        save_ms = median_ms(lambda path=path, save=save: save(path))
        load_ms = median_ms(lambda path=path, load=load: load(path))
        print(f"{suffix:<10} {load_ms:9.2f} {save_ms:9.2f} {path.stat().st_size:9d}")
    sphere = load_prm(PRM)
    path = folder / "sphere.prm"
    save_ms = median_ms(lambda: save_prm(path, sphere))
    print(f"{'.prm':<10} {median_ms(lambda: load_prm(path)):9.2f} {save_ms:9.2f} {path.stat().st_size:9d}"
          f"   (PyGeM's {sphere.shape} sphere box)")  # fmt: skip
    print("\nconvert (in process: read, check, write)")
    for target in ("real.tfm", "real.h5", "real.prm-refused"):
        out = folder / target
        if target.endswith("refused"):
            try:
                convert(str(REAL), str(folder / "real.prm"))
            except ValueError as exc:
                print(f"  .FFD -> .prm: refused ({str(exc).split(': ', 1)[1][:70]}...)")
            continue
        ms = median_ms(lambda out=out: convert(str(REAL), str(out)))
        print(f"  .FFD -> {out.suffix:<5} {ms:8.2f} ms")
    back = folder / "back.ffd"
    ms = median_ms(lambda: convert(str(folder / "real.h5"), str(back)))
    print(f"  .h5  -> .ffd  {ms:8.2f} ms  (identical lattice: {load_ffd(back) == lattice})")


def interleaved_ms(fns, repeat=7):
    """Median wall and CPU ms of each function, taking turns so that all see the same load.

    CPU time (``time.process_time``: every thread of this process, BLAS's included) counts what
    the code costs, not the time it waits for a core on this shared machine.
    """
    for fn in fns:
        fn()  # warm-up
    wall, cpu = [[] for _ in fns], [[] for _ in fns]
    for _ in range(repeat):
        for w, c, fn in zip(wall, cpu, fns, strict=True):
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            c.append(1000 * (time.process_time() - c0))
            w.append(1000 * (time.perf_counter() - t0))
    return [(statistics.median(w), statistics.median(c)) for w, c in zip(wall, cpu, strict=True)]


def random_lattice(points: np.ndarray, n: int, basis: str, border: str = "zero") -> Lattice:
    lattice = Lattice.around(points, n, basis=basis, border=border)
    rng = np.random.default_rng(n)
    lattice.offsets[...] = rng.normal(size=lattice.offsets.shape) * lattice.spacing.min() * 0.1
    return lattice


def pygem_ffd(PyGeMFFD, lattice: Lattice, folder: Path):
    """PyGeM's FFD of the same lattice, through a .prm file (PyGeM's own reader)."""
    path = folder / "bench.prm"
    save_prm(path, lattice)
    ffd = PyGeMFFD()
    ffd.read_parameters(str(path))
    return ffd


def deform_bernstein(points: np.ndarray, PyGeMFFD, folder: Path) -> None:
    source = "PyGeM ms" if PyGeMFFD else "issue ms"
    head = f"{'Bernstein':<10} {'deform ms':>10} {source:>9} {'speed-up':>9} {'(CPU)':>7}"
    print(f"{head}  target >= 3x  max|ours-PyGeM|")
    for n in SHAPES:
        lattice = random_lattice(points, n, "bernstein")
        ffd = FFD(lattice, "bernstein")
        if PyGeMFFD:
            theirs = pygem_ffd(PyGeMFFD, lattice, folder)
            check = f"{np.abs(theirs(points) - ffd.deform(points)).max():.1e}"
            pair = [lambda f=ffd: f.deform(points), lambda t=theirs: t(points)]
            (ours, ours_cpu), (base, base_cpu) = interleaved_ms(pair)
        else:
            (ours, ours_cpu), check = interleaved_ms([lambda f=ffd: f.deform(points)])[0], ""
            base = base_cpu = PYGEM_MS[n]
        speedup = base / ours
        verdict = "ok" if speedup >= 3 else "MISSED"
        cpu = base_cpu / ours_cpu
        print(f"  {n}^3      {ours:10.2f} {base:9.1f} {speedup:8.1f}x {cpu:6.1f}x  {verdict:<12}  {check}")


def deform_bspline(points: np.ndarray) -> None:
    print(f"{'B-spline':<10} {'deform ms':>10} {'update ms':>9} {'ratio':>9} {'(CPU)':>7}  target <= 2")
    for border in ("zero", "clamp"):
        for n in SHAPES:
            ffd = FFD(random_lattice(points, n, "bspline", border), "bspline")
            deformer = ffd.bind(points)
            (ours, ours_cpu), (base, base_cpu) = interleaved_ms([lambda f=ffd: f.deform(points), deformer.update], 15)
            ratio = ours / base
            verdict = "ok" if ratio <= 2 else "MISSED"
            print(f"  {n}^3 {border:<5}{ours:10.2f} {base:9.2f} {ratio:9.2f} {ours_cpu / base_cpu:7.2f}  {verdict}")


def deform(points: np.ndarray, folder: Path) -> None:
    from threadpoolctl import threadpool_info, threadpool_limits

    PyGeMFFD, why = import_pygem()
    print(f"\none-shot FFD.deform on the face ({len(points)} vertices), interleaved with the baseline:")
    print("medians of wall time (the verdict) and, beside them, the same ratio in CPU time")
    print(why if PyGeMFFD else f"PyGeM not measured ({why}): the issue's figures stand in for it")
    default = max((pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"), default=1)
    # one BLAS thread first: on this shared, loaded machine OpenBLAS's second thread can make
    # mid-sized products many times slower (waiting for a busy core), which measures the neighbours
    for threads in (1, default):
        with threadpool_limits(threads, user_api="blas"):
            print(f"\nBLAS threads: {threads}   load average: {os.getloadavg()[0]:.2f} (2 shared cores)")
            deform_bernstein(points, PyGeMFFD, folder)
            deform_bspline(points)


def main() -> None:
    from threadpoolctl import threadpool_limits

    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 shared cores)\n")
    with tempfile.TemporaryDirectory() as folder:
        with threadpool_limits(1):
            files(Path(folder))
        deform(np.asarray(read_mesh(FACE).points, dtype=np.float64), Path(folder))


if __name__ == "__main__":
    main()
