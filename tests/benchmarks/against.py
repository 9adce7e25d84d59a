"""Time the same code under this tree and under an older revision of the package, interleaved, in one run.

The machine is shared: a figure measured an hour earlier says little. :func:`compare` starts one
Python process per tree (this working tree, and ``git archive REV`` unpacked in a temporary folder),
each runs the ``setup`` code once, then the two time ``statement`` in turn, ``repeats`` times each,
so both see the same load. Used by ``bench_images.py --against REV`` and ``bench_registration.py --against REV``.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent

_CHILD = r"""
import sys, time
sys.path.insert(0, {here!r})
exec(compile({setup!r}, "<setup>", "exec"), globals())
print("ready", flush=True)
for line in sys.stdin:
    start = time.perf_counter()
    exec(compile({statement!r}, "<statement>", "exec"), globals())
    print(time.perf_counter() - start, flush=True)
"""


def checkout(revision: str) -> Path:
    """The package as it was at ``revision``, unpacked into a temporary folder (kept until the process ends)."""
    folder = Path(tempfile.mkdtemp(prefix="bench-" + revision.replace("/", "_")[:20] + "-"))
    archive = subprocess.run(
        ["git", "archive", revision, "ffd_notebook"], cwd=ROOT, check=True, capture_output=True
    ).stdout
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    return folder


def _start(tree: Path, setup: str, statement: str) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    code = _CHILD.format(here=str(HERE), setup=setup, statement=statement)
    child = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env,
                             text=True, cwd=tree)  # fmt: skip
    assert child.stdout is not None
    if child.stdout.readline().strip() != "ready":
        raise RuntimeError(f"the benchmark's setup failed under {tree}")
    return child


def compare(label: str, setup: str, statement: str, revision: str, repeats: int = 3) -> float:
    """Print the median seconds of ``statement`` under this tree and under ``revision``, and their ratio.

    Returns the ratio (this tree's median over the revision's: above 1 is slower now).
    """
    children = {"now": _start(ROOT, setup, statement), revision: _start(checkout(revision), setup, statement)}
    times: dict[str, list[float]] = {name: [] for name in children}
    try:
        for _ in range(repeats):
            for name, child in children.items():
                assert child.stdin is not None and child.stdout is not None
                child.stdin.write("run\n")
                child.stdin.flush()
                times[name].append(float(child.stdout.readline()))
    finally:
        for child in children.values():
            child.kill()
            child.wait()
    medians = {name: statistics.median(t) for name, t in times.items()}
    ratio = medians["now"] / medians[revision]
    runs = "; ".join(f"{name} " + ", ".join(f"{t:.2f}" for t in ts) for name, ts in times.items())
    print(f"{label}: now {medians['now']:.2f} s, {revision} {medians[revision]:.2f} s, ratio {ratio:.2f} ({runs})")
    return ratio
