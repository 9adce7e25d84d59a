"""one_blas_thread in several threads at once: the first block sets one BLAS thread, the last restores the count.

A limit per block, restored per block, left the process at one BLAS thread for good when two blocks
overlapped (the editor warps in worker threads): the second block saved the first's limit as the
original and restored it last (issue 35 item 7).
"""

from __future__ import annotations

import threading

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from ffd_notebook._util.blas import one_blas_thread


def blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def overlapping(inside: list[list[int]]) -> None:
    """Block A starts, block B starts, A ends, B ends: each in its own thread; record the counts inside.

    A's thread stays alive until B's block has ended (a worker thread of a pool: threadpoolctl 3.8 lets
    only the thread that set a limit change it while that thread lives).
    """
    a_in, b_in, a_out, b_out = threading.Event(), threading.Event(), threading.Event(), threading.Event()

    def first() -> None:
        with one_blas_thread():
            a_in.set()
            b_in.wait(5)
            inside.append(blas_threads())
        a_out.set()
        b_out.wait(5)

    def second() -> None:
        a_in.wait(5)
        with one_blas_thread():
            b_in.set()
            a_out.wait(5)
            inside.append(blas_threads())  # A has ended: B's block must still run on one thread
        inside.append(blas_threads())  # B has ended too, A's thread still alive: the count is restored
        b_out.set()

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert not any(t.is_alive() for t in threads)


def test_overlapping_blocks_in_two_threads_restore_the_count():
    with threadpool_limits(limits=2, user_api="blas"):  # a count above one to restore (capped on one core)
        before = blas_threads()
        inside: list[list[int]] = []
        overlapping(inside)
        assert inside == [[1] * len(before)] * 2 + [before]
        assert blas_threads() == before


def test_nested_and_many_threads():
    with threadpool_limits(limits=2, user_api="blas"):
        before = blas_threads()
        with one_blas_thread():
            with one_blas_thread():
                assert set(blas_threads()) == {1}
            assert set(blas_threads()) == {1}
        assert blas_threads() == before
        start = threading.Barrier(8)
        errors: list[BaseException] = []

        def work(seed: int) -> None:
            rng = np.random.default_rng(seed)
            try:
                start.wait(5)
                for _ in range(20):
                    with one_blas_thread():
                        assert set(blas_threads()) == {1}
                        np.linalg.svd(rng.random((30, 20)))
            except BaseException as exc:  # reported by the main thread
                errors.append(exc)

        threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(30)
        assert not errors and not any(t.is_alive() for t in threads)
        assert blas_threads() == before
