"""BLAS threads: small dense linear algebra on one thread.

OpenBLAS splits even tiny products and factorisations across its threads; when the cores are
busy (a shared machine, Dask workers, a notebook next to a render loop) the threads wait for
each other and a 60 x 50 SVD that takes 0.2 ms on one thread takes 30 ms. Code whose matrices
are landmark-sized, or that runs many independent jobs in parallel already, runs its BLAS on
one thread through :func:`one_blas_thread` (scikit-learn limits its inner loops the same way).

The limit is the process's (OpenBLAS has one thread count), so blocks in several threads share it:
the first block to start sets one thread, the last to end restores what was there before, under a
lock (a limit per block, restored per block, left the process at one thread for good when two
blocks overlapped: the second saved the first's limit as "the original"). While any block runs,
every thread's BLAS runs on one thread. Products that can be cut into pieces below OpenBLAS's
threading threshold need no limit at all (the FFD evaluators do that: :data:`~ffd_notebook.ffd.oneshot.SERIAL_MADDS`).

threadpoolctl 3.8 lets one thread at a time set OpenBLAS's count and silently ignores the others
(its "controlling thread"): the block that restores may run in another thread than the one that
set, so each change here first clears that thread and leaves none controlling afterwards.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import threadpoolctl
from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_CONTROLLER: list[ThreadpoolController] = []
_LOCK = threading.Lock()
_ACTIVE: list[Any] = []  # the limiter of the blocks running now, once per block: its length is their count


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """A context manager that runs its block with every loaded BLAS library on one thread.

    The BLAS libraries are found once, on first use (NumPy's and SciPy's are loaded by then);
    entering and leaving the block then costs a few microseconds. Blocks may nest and overlap in
    several threads: the thread count before the first is restored when the last one ends.

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     u, s, vt = np.linalg.svd(np.eye(3))
    >>> s.tolist()
    [1.0, 1.0, 1.0]
    """
    with _LOCK:
        if not _CONTROLLER:
            _CONTROLLER.append(ThreadpoolController())
        if _ACTIVE:
            limiter = _ACTIVE[0]
        else:
            _release_control()
            limiter = _CONTROLLER[0].limit(limits=1, user_api="blas")
            _release_control()
        _ACTIVE.append(limiter)
    try:
        yield
    finally:
        with _LOCK:
            _ACTIVE.pop()
            if not _ACTIVE:
                _release_control()
                limiter.restore_original_limits()
                _release_control()


def _release_control() -> None:
    """Let any thread set OpenBLAS's thread count next (threadpoolctl >= 3.8 keeps one controlling thread)."""
    clear = getattr(getattr(threadpoolctl, "OpenBLASController", None), "clear_controlling_thread", None)
    if clear is not None:
        clear(force=True)
