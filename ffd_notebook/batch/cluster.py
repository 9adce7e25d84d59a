"""A ``distributed.LocalCluster`` set up for batch deformation.

``distributed``'s defaults cost this workload CPU that does no work (measured on the 53k-vertex
face, 2 cores; a sample is ~25 ms of CPU; ``tests/benchmarks/bench_batch.py``):

- ``MALLOC_TRIM_THRESHOLD_=65536`` in every worker's environment turns off glibc's adaptive mmap
  threshold, so every large temporary NumPy array is mapped and faulted in afresh: each sample
  ~2x slower. The workers start without it.
- the statistical profiler walks every thread's stack every 10 ms: ~2-4 ms of CPU per sample on
  each worker. It is off (the dashboard's task stream and progress still work; only its
  "Profile" page stays empty).
- an idle cluster of two workers used ~95 ms of CPU per second (event-loop ticks every 20 ms in
  every process, the system monitor every 0.5 s, the memory monitor every 0.1 s): ~3 ms per
  sample at 30 samples/s. With ticks every 1 s, the system monitor (the dashboard's system
  graphs) every 5 s and the memory monitor (spilling, the memory limit) every 0.5 s: ~16 ms/s.
- one BLAS/OpenMP thread per worker process (``distributed``'s own default, kept explicitly):
  the workers already use every core, and more threads would only fight for them.

These settings are read when the scheduler and the workers start, so they can only be chosen
for a cluster started here; for a cluster you start yourself, put :data:`CLUSTER_CONFIG` in its
Dask configuration on every machine (see the README's batch section).
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["CLUSTER_CONFIG", "local_cluster"]

CLUSTER_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.nanny.pre-spawn-environ.OMP_NUM_THREADS": 1,
    "distributed.nanny.pre-spawn-environ.OPENBLAS_NUM_THREADS": 1,
    "distributed.nanny.pre-spawn-environ.MKL_NUM_THREADS": 1,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "500ms",
}


def local_cluster(n_workers: int | None = None, **kwargs: Any):
    """A ``LocalCluster`` of single-threaded worker processes with :data:`CLUSTER_CONFIG`.

    Parameters
    ----------
    n_workers : int, optional
        Worker processes (default: one per core).
    **kwargs
        Passed to ``distributed.LocalCluster`` (for example ``dashboard_address=":0"``).

    Returns
    -------
    distributed.LocalCluster
        Use it as a context manager, with ``distributed.Client(cluster)``.

    Examples
    --------
    >>> import dask
    >>> from distributed import Client
    >>> with local_cluster(1, dashboard_address=None) as cluster, Client(cluster) as client:
    ...     client.submit(dask.config.get, "distributed.worker.profile.enabled", pure=False).result()
    False
    """
    import dask
    from distributed import LocalCluster

    options: dict[str, Any] = {"threads_per_worker": 1, "processes": True, **kwargs}
    # the scheduler and the nannies read it when they are made (the nannies keep it for restarted workers)
    with dask.config.set(CLUSTER_CONFIG):
        return LocalCluster(n_workers=n_workers or os.cpu_count() or 1, **options)
