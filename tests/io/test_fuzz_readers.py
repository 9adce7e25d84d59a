"""Hypothesis fuzzing of every reader, in a worker subprocess (issue 8).

Mutations of real files (.ffd, OBJ from the shared data) and of PLY/STL/VTK files written by
PyVista (headers, counts, connectivity, bytes) go to ``fuzz_worker.py``; the only acceptable
outcomes are a load or a ``FileFormatError``. A worker that dies is a crash, one that does not
answer within 5 s a hang: both fail the example (Hypothesis then shrinks it) naming the case.

The number of examples per format is ``FFD_FUZZ_EXAMPLES`` (default: a CI-sized run), e.g.
``FFD_FUZZ_EXAMPLES=5000 python -m pytest tests/io/test_fuzz_readers.py -s`` for a campaign;
``-s`` shows the outcome counts per format.
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
import pyvista as pv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice
from ffd_notebook.io import save_elastix

WORKER = Path(__file__).with_name("fuzz_worker.py")
REPO = Path(__file__).resolve().parents[2]
DEADLINE_S = 5.0
# CI-sized defaults per format (VTK formats cost a child process per case)
DEFAULTS = {"ffd": 100, "obj": 100, "ply": 100, "stl": 15, "vtk": 20, "vtp": 12, "elastix": 100}
HOSTILE_NUMBERS = [
    "0", "-1", "1", "2", "3", "255", "256", "65536", "2147483647", "2147483648", "4294967295", "4294967296",
    "4000000000", "9223372036854775807", "9223372036854775808", "-9223372036854775809", "9" * 30, "7" * 5000,
    "1e308", "-1e308", "1e-320", "1.7e308", "nan", "inf", "-0", "0x10", "1_000", "\u0662", "\uff13", "1\u00a02",
    "1\x0c2", "",
]  # fmt: skip
TOKENS = [*HOSTILE_NUMBERS, "\n", "\r", "\t", "\x00", "#", "##", "/", "//", "\\\n", "\xff", "end_header\n",
          "element face 5\n", "property list uchar int vertex_indices\n", "#offsets of the control points#\n",
          "POLYGONS 1 4\n", "CELLS 1 4\n", "f 1 2 3\n", "v 0 0 0\n", "<", ">", '"',
          'NumberOfPoints="9999999"', "(", ")", '(GridSize 4 4 4)\n', '(Transform "AffineTransform")\n',
          '(InitialTransformParameterFileName "seed.affine.txt")\n', '(HowToCombineTransforms "Compose")\n',
          '(BSplineTransformSplineOrder 1)\n', '(GridDirection 1 0 0 1 0 0 0 0 1)\n']  # fmt: skip
OUTCOMES: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
ELASTIX_AFFINE: list[bytes] = []  # the affine file the elastix seeds name as their initial transform


def _examples(fmt: str) -> int:
    scale = os.environ.get("FFD_FUZZ_EXAMPLES")
    return int(scale) if scale else DEFAULTS[fmt]


class Worker:
    """A fuzz_worker.py subprocess, restarted after a crash or a hang."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None

    def _start(self) -> subprocess.Popen:
        env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        return subprocess.Popen([sys.executable, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True, env=env, bufsize=1)  # fmt: skip

    def run(self, path: Path) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            self.proc = self._start()
            self.run_warm()
        self.proc.stdin.write(f"{path}\n")
        self.proc.stdin.flush()
        return self._answer(path, DEADLINE_S)

    def run_warm(self) -> None:
        """Let the worker import everything before the first timed case (imports take seconds)."""
        self.proc.stdin.write("/nonexistent/warm-up.ply\n")
        self.proc.stdin.flush()
        self._answer(Path("warm-up"), 120.0)

    def _answer(self, path: Path, limit: float) -> dict:
        ready, _, _ = select.select([self.proc.stdout], [], [], limit)
        if not ready:
            self.stop()
            pytest.fail(f"reader hung for more than {limit:.0f} s on {path.name} ({path.stat().st_size} bytes)")
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            self.proc = None
            pytest.fail(f"reader crashed the process (exit status {code}) on {path.name}: {path.read_bytes()[:300]!r}")
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
def seeds(shared_data, tmp_path_factory) -> dict[str, list[bytes]]:
    """Files to mutate, per format."""
    folder = tmp_path_factory.mktemp("seeds")
    sphere = pv.Sphere(theta_resolution=6, phi_resolution=5)
    sphere.point_data["RGB"] = np.arange(sphere.n_points * 3, dtype=np.uint8).reshape(-1, 3)
    out: dict[str, list[bytes]] = {"ply": [], "stl": [], "vtk": [], "vtp": []}
    for binary in (True, False):
        for fmt in out:
            target = folder / f"s{int(binary)}.{fmt}"
            kwargs = {"texture": "RGB"} if fmt == "ply" else {}
            sphere.save(target, binary=binary, **kwargs)
            out[fmt].append(target.read_bytes())
    head = b"# vtk DataFile Version 3.0\nx\nASCII\nDATASET "
    out["vtk"].append(head + b"UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n"
                      b"CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n")  # fmt: skip
    out["vtk"].append(head + b"POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"
                      b"POINT_DATA 3\nSCALARS h float 1\nLOOKUP_TABLE default\n0 1 2\n")  # fmt: skip
    seed_lineage = shared_data / "seed-lineage"
    out["ffd"] = [(seed_lineage / "registration_11x12x11.FFD").read_bytes()]
    out["obj"] = [(seed_lineage / n).read_bytes() for n in ("cube.obj", "face.obj", "monkey.obj")]
    out["obj"].append((shared_data / "face" / "james_colored.obj").read_bytes()[:60_000])  # v/vt/vn faces, colours
    # elastix: a B-spline file (4x5x4, some offsets) added to an affine one, the affine one alone, and one
    # B-spline composed after the affine (a rotation: the grid stays orthogonal); _fuzz puts the affine file
    # beside every case, so mutated B-spline files follow a real chain
    lattice = Lattice((4, 5, 4), (1.0, 2.0, 1.5), origin=(1.0, -2.0, 0.5))
    lattice.offsets[1:3, 1:4, 1:3] = np.random.default_rng(0).normal(0, 0.3, (2, 3, 2, 3))
    rotation = np.eye(4)
    rotation[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    save_elastix(folder / "seed.txt", FFD(lattice, affine=rotation, only_inside=True))
    composed = (folder / "seed.txt").read_text().replace('"Add"', '"Compose"')
    out["elastix"] = [(folder / "seed.txt").read_bytes(), (folder / "seed.affine.txt").read_bytes(), composed.encode()]
    ELASTIX_AFFINE.append((folder / "seed.affine.txt").read_bytes())
    return out


@st.composite
def mutations(draw, seeds: list[bytes]) -> bytes:
    data = bytearray(draw(st.sampled_from(seeds)))
    numbers = [m.span() for m in re.finditer(rb"-?[0-9]+(?:\.[0-9]*)?(?:[eE][-+]?[0-9]+)?", bytes(data[:4096]))]
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["number", "number", "token", "bytes", "int32", "delete", "duplicate", "cut"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "number" and numbers:  # header counts, indices, coordinates near the start
            start, end = draw(st.sampled_from(numbers))
            data[start:end] = draw(st.sampled_from(HOSTILE_NUMBERS)).encode()
            numbers = []  # spans moved
        elif kind == "token":
            data[at:at] = draw(st.sampled_from(TOKENS)).encode("utf-8")
        elif kind == "bytes":
            data[at : at + 4] = draw(st.binary(min_size=1, max_size=4))
        elif kind == "int32":  # binary counts and indices
            value = draw(st.sampled_from([-1, -7, 3, 255, 2**16, 2**31 - 1, 2**31, 2**32 - 1, 10**9]))
            data[at : at + 4] = (value % 2**32).to_bytes(4, draw(st.sampled_from(["little", "big"])))
        elif kind == "delete":
            del data[at : at + draw(st.integers(1, 64))]
        elif kind == "duplicate":
            data[at:at] = data[at : at + draw(st.integers(1, 64))]
        else:
            del data[at:]
    return bytes(data)


def _fuzz(fmt: str, suffix: str, worker, seeds, tmp_path_factory) -> None:
    folder = tmp_path_factory.mktemp(f"fuzz-{fmt}")
    if fmt == "elastix":
        (folder / "seed.affine.txt").write_bytes(ELASTIX_AFFINE[0])
    counter = iter(range(10**9))

    @settings(max_examples=_examples(fmt), deadline=None, database=None, derandomize=not os.environ.get(
        "FFD_FUZZ_EXAMPLES"), suppress_health_check=list(HealthCheck))  # fmt: skip
    @given(mutations(seeds[fmt]))
    def case(data: bytes) -> None:
        path = folder / f"case{next(counter)}{suffix}"
        path.write_bytes(data)
        answer = worker.run(path)
        OUTCOMES[fmt][answer["outcome"]] += 1
        assert answer["outcome"] in ("loaded", "FileFormatError"), f"{path.name}: {answer['detail']}"
        path.unlink()

    case()


@pytest.mark.parametrize(("fmt", "suffix"), [("ffd", ".ffd"), ("obj", ".obj"), ("ply", ".ply"), ("elastix", ".txt")])
def test_fuzz_text_readers(fmt, suffix, worker, seeds, tmp_path_factory):
    _fuzz(fmt, suffix, worker, seeds, tmp_path_factory)


@pytest.mark.parametrize(("fmt", "suffix"), [("stl", ".stl"), ("vtk", ".vtk"), ("vtp", ".vtp")])
def test_fuzz_vtk_readers(fmt, suffix, worker, seeds, tmp_path_factory):
    _fuzz(fmt, suffix, worker, seeds, tmp_path_factory)
