"""Hypothesis fuzzing of image reading (SimpleITK's readers behind ``read_image``), in a worker subprocess.

Mutations of small NRRD, MetaImage, NIfTI and PNG files (header numbers, tokens, bytes, cuts) go to
``image_fuzz_worker.py``; the only acceptable outcomes are a load (then a warp) or a
``FileFormatError``. A worker that dies is a crash, one that does not answer within 10 s a hang.
``FFD_FUZZ_EXAMPLES`` sets the number of examples per format (default: a CI-sized run).
"""

from __future__ import annotations

import collections
import json
import os
import re
import select
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook.images import ImageGrid, write_image

WORKER = Path(__file__).with_name("image_fuzz_worker.py")
REPO = Path(__file__).resolve().parents[2]
DEADLINE_S = 10.0
FORMATS = {".nrrd": 40, ".mha": 40, ".nii": 30, ".png": 15}
HOSTILE = ["0", "-1", "1", "2", "3", "65536", "2147483647", "4294967296", "9" * 30, "1e308", "nan", "inf", "-0", ""]
TOKENS = [*HOSTILE, "\n", "\x00", "\xff", " ", "=", ":", "LOCAL", "gzip", "raw", "big", "little", "MET_DOUBLE",
          "vector", "double", "NDims = 7\n", "dimension: 1\n", "ElementNumberOfChannels = 9\n",
          "kinds: RGB-color\n"]  # fmt: skip
OUTCOMES: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)


def _examples(suffix: str) -> int:
    scale = os.environ.get("FFD_FUZZ_EXAMPLES")
    return int(scale) if scale else FORMATS[suffix]


class Worker:
    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None

    def run(self, path: Path) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
            self.proc = subprocess.Popen([sys.executable, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=subprocess.DEVNULL, text=True, env=env, bufsize=1)  # fmt: skip
            self._ask(Path("/nonexistent/warm-up.nrrd"), 120.0)
        return self._ask(path, DEADLINE_S)

    def _ask(self, path: Path, limit: float) -> dict:
        self.proc.stdin.write(f"{path}\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], limit)
        if not ready:
            self.stop()
            pytest.fail(f"image reading hung for more than {limit:.0f} s on {path.name}")
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            self.proc = None
            pytest.fail(f"image reading crashed the process (exit status {code}) on {path.name}: "
                        f"{path.read_bytes()[:300]!r}")  # fmt: skip
        return json.loads(line)

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None


@pytest.fixture(scope="module")
def worker():
    w = Worker()
    yield w
    w.stop()
    for fmt, counts in sorted(OUTCOMES.items()):
        print(f"\nfuzz {fmt}: {sum(counts.values())} cases, {dict(counts)}")


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, list[bytes]]:
    folder = tmp_path_factory.mktemp("image-seeds")
    rng = np.random.default_rng(0)
    volume = ImageGrid((6, 5, 4), spacing=(0.5, 1.0, 2.0), origin=(3.0, -1.0, 0.5))
    plane = ImageGrid((7, 6))
    out: dict[str, list[bytes]] = {}
    for suffix in FORMATS:
        out[suffix] = []
        grids = [plane] if suffix == ".png" else [volume, plane]
        for grid in grids:
            dtype = np.uint8 if suffix == ".png" else np.float32
            array = (rng.random(grid.shape) * 200).astype(dtype)
            target = folder / f"seed{grid.dim}{suffix}"
            write_image(target, grid.to_sitk(sitk.GetImageFromArray(array)))
            out[suffix].append(target.read_bytes())
    return out


@st.composite
def mutations(draw, seeds: list[bytes]) -> bytes:
    data = bytearray(draw(st.sampled_from(seeds)))
    numbers = [m.span() for m in re.finditer(rb"-?[0-9]+(?:\.[0-9]*)?(?:[eE][-+]?[0-9]+)?", bytes(data[:1024]))]
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["number", "number", "token", "bytes", "delete", "cut"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "number" and numbers:  # header sizes, spacings, offsets near the start
            start, end = draw(st.sampled_from(numbers))
            data[start:end] = draw(st.sampled_from(HOSTILE)).encode()
            numbers = []
        elif kind == "token":
            data[at:at] = draw(st.sampled_from(TOKENS)).encode("latin-1")
        elif kind == "bytes":
            data[at : at + 4] = draw(st.binary(min_size=1, max_size=4))
        elif kind == "delete":
            del data[at : at + draw(st.integers(1, 16))]
        else:
            del data[at:]
    return bytes(data)


@pytest.mark.parametrize("suffix", list(FORMATS))
def test_mutated_images_load_or_fail_cleanly(suffix, seeds, worker, tmp_path_factory):
    folder = tmp_path_factory.mktemp(f"fuzz{suffix.strip('.')}")

    @settings(max_examples=_examples(suffix), deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])  # fmt: skip
    @given(data=mutations(seeds[suffix]))
    def check(data: bytes) -> None:
        path = folder / f"case{suffix}"
        path.write_bytes(data)
        answer = worker.run(path)
        OUTCOMES[suffix][answer["outcome"]] += 1
        assert answer["outcome"] in ("loaded", "FileFormatError"), answer["detail"]

    check()
