"""Batch deformation benchmark (issue 12): fold-free samples of the 53k-vertex face, written as PLY.

Run from the repository root (reads ../shared/data; writes to a temporary folder it removes):

    python tests/benchmarks/bench_batch.py            # 500 samples per configuration, as in the issue
    python tests/benchmarks/bench_batch.py --n 60     # a quick run on a busy machine

Measures, in one run and on the same samples: a plain loop over the per-sample function (no
Dask), the local Dask scheduler that ``generate`` picks by default, and a ``LocalCluster`` of two
worker processes. Prints samples/s, the split of a sample's time (draw, fold check, deform,
write), Dask's overhead per sample, peak memory per worker, and each target with its verdict.
Cluster start-up is reported apart (it is paid once per session, not per run).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from ffd_notebook.batch import FoldFree, RandomLattice, generate  # noqa: E402
from ffd_notebook.batch.sample import Job, run_sample  # noqa: E402
from ffd_notebook.io import read_mesh  # noqa: E402

FACE = ROOT.parent / "shared" / "data" / "face" / "template.ply"


def peak_rss_mb() -> float:
    """Peak resident memory of this process, MB (Linux reports KB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def verdict(ok: bool) -> str:
    return "ok" if ok else "MISSED"


def split(seconds: dict[str, np.ndarray]) -> str:
    parts = [f"{k} {1000 * v.mean():.1f}" for k, v in seconds.items()]
    return ", ".join(parts) + f"  (total {1000 * sum(v.mean() for v in seconds.values()):.1f} ms)"


def overhead(result, workers: int) -> float:
    """Dask's time per sample beyond the work itself, as a fraction of the work.

    ``workers * wall`` is the worker time available; the tasks' own seconds are the work. What
    is left is scheduling, transfer, idle workers at the start and end, and process start-up.
    """
    work = sum(v.sum() for v in result.seconds.values())
    return (workers * result.wall - work) / work


def run_cluster(mesh, model, rule, n, workers, out: Path, trim):
    """One timed run on a fresh ``LocalCluster``; returns the result, peak MB per worker, start-up seconds."""
    import dask
    from distributed import Client, LocalCluster

    tic = time.perf_counter()
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": trim}):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                startup = time.perf_counter() - tic
                generate(mesh, model, 4 * workers, out.with_name("warm"), fold_free=rule, client=client, progress=False)
                result = generate(mesh, model, n, out, fold_free=rule, client=client, progress=False)
                memory = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    shutil.rmtree(out)
    shutil.rmtree(out.with_name("warm"))
    return result, memory, startup


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=500, help="samples per configuration (default 500)")
    parser.add_argument("--mesh", default=str(FACE), help="the mesh (default: the 53k-vertex face)")
    args = parser.parse_args()
    n, workers = args.n, 2
    points = read_mesh(args.mesh).points
    extent = float(np.ptp(points, axis=0).max())
    model = RandomLattice(num_control_points=7, max_displacement=0.2 * extent, locked_borders=2)
    rule = FoldFree(threshold=0.1, grid=12)
    print(f"mesh {args.mesh}: {len(points)} vertices; {model}")
    print(f"{n} samples per configuration, PLY, fold-free (det J > {rule.threshold}, grid {rule.grid}^3, redraw)")
    print(f"cores {os.cpu_count()}, load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    scratch = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    try:
        # 1. plain loop: the same per-sample function, no Dask
        out = scratch / "loop"
        job = Job(str(Path(args.mesh).resolve()), model.to_spec(), 0, rule, str(out), "ply")
        from ffd_notebook.batch.output import Layout
        from ffd_notebook.batch.sample import mesh_sha256

        Layout(out).claim(job.settings(mesh_sha256(args.mesh)))
        run_sample(job, 0)  # bind the model outside the timing, as the loop's set-up
        tic = time.perf_counter()
        results = [run_sample(job, i) for i in range(1, n + 1)]
        loop_wall = time.perf_counter() - tic
        loop_rate = n / loop_wall
        seconds = {k: np.array([r["seconds"][k] for r in results]) for k in results[0]["seconds"]}
        redraws = sum(r["row"]["redraws"] for r in results)
        print(f"\nplain loop        {loop_rate:6.2f} samples/s   per sample: {split(seconds)}")
        print(f"                  redraws {redraws}, peak memory {peak_rss_mb():.0f} MB")
        shutil.rmtree(out)

        # 2. the local Dask scheduler generate() picks
        local = generate(args.mesh, model, n, scratch / "local", fold_free=rule, progress=False, workers=workers)
        local_rate = n / local.wall
        print(f"local dask ({local.scheduler}) {local_rate:6.2f} samples/s  ({local_rate / loop_rate:.2f}x loop), "
              f"overhead {100 * overhead(local, workers):.1f}% of the work (includes the pool's start-up)")  # fmt: skip
        print(f"                  per sample in the pool: {split(local.seconds)}")
        shutil.rmtree(scratch / "local")

        # 3. LocalCluster, two worker processes: with distributed's default worker environment, then
        # without its MALLOC_TRIM_THRESHOLD_ (see the README: it makes glibc map and fault in every large
        # temporary array afresh, 2-4x slower NumPy work here)
        # (this order: a nanny leaks the variable into this process's environment, and later workers inherit it)
        measured = {}
        for label, trim in (("no malloc trim", None), ("dask defaults", 65536)):
            cl, memory, startup = run_cluster(args.mesh, model, rule, n, workers, scratch / "cluster", trim)
            measured[label] = cl, memory
            cluster_rate = n / cl.wall
            over = overhead(cl, workers)
            print(f"LocalCluster(2), {label}: {cluster_rate:6.2f} samples/s ({cluster_rate / loop_rate:.2f}x loop); "
                  f"overhead {100 * over:.1f}%; start-up {startup:.1f} s (not counted)")  # fmt: skip
            print(f"                  per sample on the workers: {split(cl.seconds)}")
            print(f"                  peak memory per worker: {', '.join(f'{m:.0f} MB' for m in memory.values())}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    cl, memory = measured["no malloc trim"]  # the set-up the README recommends
    speedup, over, worst = n / cl.wall / loop_rate, overhead(cl, workers), max(memory.values())
    print("\ntargets (LocalCluster without malloc trim)")
    print(f"  LocalCluster(2) >= 1.6x the plain loop: {speedup:.2f}x  {verdict(speedup >= 1.6)}")
    print(f"  Dask overhead <= 10% of the work:       {100 * over:.1f}%  {verdict(over <= 0.10)}")
    print(f"  <= 300 MB per worker:                   {worst:.0f} MB  {verdict(worst <= 300)}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (2 cores; other work inflates times)")


if __name__ == "__main__":
    main()
