"""Batch deformation benchmark (issue 12): fold-free samples of the 53k-vertex face, written as PLY.

Run from the repository root (reads ../shared/data; writes to a temporary folder it removes):

    python tests/benchmarks/bench_batch.py                 # 500 samples per configuration, as in the issue
    python tests/benchmarks/bench_batch.py --n 200 --repeat 3
    python tests/benchmarks/bench_batch.py --defaults      # also a LocalCluster with distributed's defaults

Measures, on the same samples: a plain loop (no Dask) over the same per-task function and the same
task groups ``generate`` uses, the local Dask scheduler ``generate`` picks by default, and
``local_cluster(2)`` (two worker processes). The loop and the cluster runs alternate ``--repeat``
times so that both see the same machine load. Prints samples/s and their ratio, the split of a
sample's time (draw, fold check, deform, write), peak memory per worker, and the CPU time per
sample: of the thread that made it (the same work in the loop and on a worker: a penalty on the
workers would show here) and of every process of the run (scheduler, client and workers' other
threads: Dask's overhead). CPU times do not depend on what else runs on the machine; samples/s do
(on a shared 2-core machine each process gets less than a core). Cluster start-up is reported
apart (it is paid once per session, not per run).
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
import psutil

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from ffd_notebook.batch import FoldFree, RandomLattice, generate, local_cluster  # noqa: E402
from ffd_notebook.batch.engine import task_groups  # noqa: E402
from ffd_notebook.batch.output import Layout  # noqa: E402
from ffd_notebook.batch.sample import Job, file_sha256, run_samples  # noqa: E402
from ffd_notebook.io import read_mesh  # noqa: E402

FACE = ROOT.parent / "shared" / "data" / "face" / "template.ply"
WORKERS = 2


def verdict(ok: bool) -> str:
    return "ok" if ok else "MISSED"


def split(seconds: dict[str, np.ndarray]) -> str:
    parts = [f"{k} {1000 * v.mean():.1f}" for k, v in seconds.items()]
    return ", ".join(parts) + f"  (total {1000 * sum(v.mean() for v in seconds.values()):.1f} ms)"


def process_cpu(processes: list[psutil.Process]) -> float:
    """CPU seconds (user + system) used so far by these processes."""
    return sum(sum(p.cpu_times()[:2]) for p in processes)


def run_queue_wait(paths: list[Path]) -> float:
    """Seconds these threads spent ready to run but waiting for a core (Linux schedstat; 0 elsewhere)."""
    total = 0
    for path in paths:
        try:
            total += int(path.read_text().split()[1])
        except (OSError, IndexError, ValueError):
            continue  # a thread that ended, or no /proc
    return total / 1e9


def threads_of(processes: list[psutil.Process]) -> list[Path]:
    return [t / "schedstat" for p in processes for t in Path(f"/proc/{p.pid}/task").glob("*")]


class Measured:
    """One timed run: samples/s, the sample split, CPU per sample (the task's thread, all processes), cores used."""

    def __init__(
        self, n: int, wall: float, seconds: dict, thread_cpu: np.ndarray, all_cpu: float, waited: float
    ) -> None:
        self.rate = n / wall
        self.seconds = seconds
        self.thread_cpu = float(thread_cpu.mean())
        self.all_cpu = all_cpu / n
        self.cores = all_cpu / wall
        self.waited = waited / n

    def cpu(self) -> str:
        return (f"CPU per sample {1000 * self.thread_cpu:.1f} ms in the task, {1000 * self.all_cpu:.1f} ms in all; "
                f"{self.cores:.2f} cores used, {1000 * self.waited:.0f} ms/sample waiting for a core")  # fmt: skip


def run_loop(job: Job, indices: list[int]) -> Measured:
    """The plain loop: the same per-task function over the same task groups, in this thread."""
    # this thread's CPU: the idle cluster's scheduler shares the process, and is not the loop's cost
    me = [Path("/proc/thread-self/schedstat")]
    cpu, waited, tic = time.thread_time(), run_queue_wait(me), time.perf_counter()
    outs = [out for group in task_groups(indices, WORKERS) for out in run_samples(job, group)]
    wall, cpu, waited = time.perf_counter() - tic, time.thread_time() - cpu, run_queue_wait(me) - waited
    errors = [o["error"] for o in outs if "error" in o]
    if errors:
        raise RuntimeError(errors[0])
    seconds = {k: np.array([o["seconds"][k] for o in outs]) for k in outs[0]["seconds"]}
    return Measured(len(outs), wall, seconds, np.array([o["cpu"] for o in outs]), cpu, waited)


def run_generate(mesh, model, rule, n, out: Path, **kwargs) -> tuple[Measured, object]:
    """``generate``, with the CPU and core waits of this process and its children (the cluster's workers)."""
    me = psutil.Process()
    processes = [me, *me.children(recursive=True)]
    threads = threads_of(processes)
    cpu, waited, tic = process_cpu(processes), run_queue_wait(threads), time.perf_counter()
    result = generate(mesh, model, n, out, fold_free=rule, progress=False, **kwargs)
    wall, cpu, waited = time.perf_counter() - tic, process_cpu(processes) - cpu, run_queue_wait(threads) - waited
    shutil.rmtree(out)
    return Measured(n, wall, result.seconds, result.cpu, cpu, waited), result


def _spin(seconds: float) -> float:
    """Busy-loop for ``seconds`` of wall time; returns the CPU seconds this process got."""
    tic = time.perf_counter()
    while time.perf_counter() - tic < seconds:
        pass
    return time.process_time()


def cores_available(processes: int, seconds: float = 2.0) -> float:
    """Cores this session gets now for ``processes`` busy processes (CPU seconds per second, all together).

    On a free 2-core machine: 1 for one process, 2 for two. On a busy one it is what the kernel
    shares out; with Linux autogroup scheduling one session gets one share however many processes
    it runs, so two workers get no more than one loop (then no ratio above ~1 can be measured).
    """
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(processes) as pool:
        return sum(pool.map(_spin, [seconds] * processes)) / seconds


def dask_default_cluster():
    """A LocalCluster with distributed's own worker settings (malloc trim on, profiler on)."""
    from distributed import LocalCluster

    return LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=True, dashboard_address=None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=500, help="samples per run (default 500)")
    parser.add_argument("--repeat", type=int, default=2, help="loop/cluster run pairs, alternating (default 2)")
    parser.add_argument("--mesh", default=str(FACE), help="the mesh (default: the 53k-vertex face)")
    parser.add_argument("--defaults", action="store_true", help="also time a LocalCluster with distributed's defaults")
    args = parser.parse_args()
    n = args.n
    mesh = str(Path(args.mesh).resolve())
    points = read_mesh(mesh).points
    extent = float(np.ptp(points, axis=0).max())
    model = RandomLattice(num_control_points=7, max_displacement=0.2 * extent, locked_borders=2)
    rule = FoldFree(threshold=0.1, grid=12)
    print(f"mesh {args.mesh}: {len(points)} vertices; {model}")
    groups = task_groups(list(range(n)), WORKERS)
    print(f"{n} samples per run, PLY, fold-free (det J > {rule.threshold}, grid {rule.grid}^3, redraw); "
          f"{len(groups)} tasks of <= {len(groups[0])} samples")  # fmt: skip
    print(f"cores {os.cpu_count()}, load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    spun = [(cores_available(1), cores_available(WORKERS))]
    print(f"cores this session gets now: {spun[0][0]:.2f} for 1 busy process, {spun[0][1]:.2f} for {WORKERS}")
    scratch = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    loops, clusters = [], []
    try:
        job = Job(mesh, model.to_spec(), 0, rule, str(scratch / "loop"), "ply")
        Layout(job.out).claim(job.settings(file_sha256(mesh)))
        run_samples(job, [n])  # bind the model outside the timing, as the loop's set-up

        local, result = run_generate(mesh, model, rule, n, scratch / "local", workers=WORKERS)
        print(f"\nlocal dask ({result.scheduler}): {local.rate:6.2f} samples/s; {local.cpu()}")
        print(f"      per sample: {split(local.seconds)}")

        from distributed import Client

        tic = time.perf_counter()
        with local_cluster(WORKERS, dashboard_address=None) as cluster, Client(cluster) as client:
            startup = time.perf_counter() - tic
            run_generate(mesh, model, rule, 4 * WORKERS, scratch / "warm", client=client)  # binds the model
            for r in range(args.repeat):
                loop = run_loop(job, list(range(n)))
                shutil.rmtree(job.out)
                Layout(job.out).claim(job.settings(file_sha256(mesh)))
                cl, _ = run_generate(mesh, model, rule, n, scratch / "cluster", client=client)
                loops.append(loop)
                clusters.append(cl)
                print(f"\nrun {r + 1}: plain loop         {loop.rate:6.2f} samples/s; {loop.cpu()}")
                ratio = cl.rate / loop.rate
                print(f"       local_cluster(2)   {cl.rate:6.2f} samples/s = {ratio:.2f}x loop; {cl.cpu()}")
                print(f"       per sample, loop:    {split(loop.seconds)}")
                print(f"       per sample, workers: {split(cl.seconds)}")
                print(f"       load average now: {os.getloadavg()[0]:.2f}")
            memory = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
        print(f"\nlocal_cluster(2) start-up {startup:.1f} s (not counted); peak memory per worker: "
              f"{', '.join(f'{m:.0f} MB' for m in memory.values())}")  # fmt: skip

        if args.defaults:
            with dask_default_cluster() as cluster, Client(cluster) as client:
                run_generate(mesh, model, rule, 4 * WORKERS, scratch / "warm", client=client)
                loop = run_loop(job, list(range(n)))
                cl, _ = run_generate(mesh, model, rule, n, scratch / "cluster", client=client)
            print(f"LocalCluster(2) with distributed's defaults: {cl.rate:6.2f} samples/s = {cl.rate / loop.rate:.2f}x "
                  f"the loop next to it; {cl.cpu()}")  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    ratios = [c.rate / lo.rate for lo, c in zip(loops, clusters, strict=True)]
    task_penalty = float(np.median([c.thread_cpu / lo.thread_cpu - 1 for lo, c in zip(loops, clusters, strict=True)]))
    overhead = float(np.median([c.all_cpu / c.thread_cpu - 1 for c in clusters]))
    loop_overhead = float(np.median([lo.all_cpu / lo.thread_cpu - 1 for lo in loops]))
    ceiling = float(np.median([WORKERS * lo.all_cpu / c.all_cpu for lo, c in zip(loops, clusters, strict=True)]))
    worst = max(memory.values())
    print(f"\nCPU per sample (median of {len(loops)}): a worker's task costs {100 * task_penalty:+.1f}% of the loop's; "
          f"all processes of the cluster run cost {100 * overhead:.1f}% more than its tasks "
          f"(the loop: {100 * loop_overhead:.1f}%)")  # fmt: skip
    print(f"CPU-bound on {WORKERS} free cores the cluster would reach {ceiling:.2f}x (2 x loop CPU / cluster CPU)")
    cores = [(lo.cores, c.cores) for lo, c in zip(loops, clusters, strict=True)]
    print(f"cores used (CPU seconds per second), loop / cluster: {', '.join(f'{a:.2f} / {b:.2f}' for a, b in cores)}")
    spun.append((cores_available(1), cores_available(WORKERS)))
    allowed = float(np.median([two / one for one, two in spun]))
    shares = ", ".join(f"{one:.2f} / {two:.2f}" for one, two in spun)
    print(f"cores this session gets for 1 / {WORKERS} busy processes (before, after): {shares}: "
          f"the machine allows ~{allowed:.2f}x now")  # fmt: skip
    print("\ntargets")
    median = float(np.median(ratios))
    print(f"  local_cluster(2) >= 1.6x the plain loop: {', '.join(f'{x:.2f}x' for x in ratios)} (median "
          f"{median:.2f}x)  {verdict(median >= 1.6)} (the machine allowed ~{allowed:.2f}x)")  # fmt: skip
    print(f"  Dask overhead <= 10% of the work (CPU):   {100 * overhead:.1f}%  {verdict(overhead <= 0.10)}")
    print(f"  <= 300 MB per worker:                    {worst:.0f} MB  {verdict(worst <= 300)}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (2 cores; other work lowers samples/s)")


if __name__ == "__main__":
    main()
