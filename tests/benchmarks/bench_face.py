"""Benchmark of face_from_photo: python tests/benchmarks/bench_face.py

Prints, for scikit-image's 512x512 ``astronaut()``:
- the time to load each bundled model (LiteRT interpreter, allocated) and the first call, in a fresh process;
- the median of several calls after the first, split into detection (with reading the array), landmarks
  (two passes of the landmark model), subdivision (butterfly, 3 levels), colours (bilinear, full resolution)
  and the whole; target: the whole <= 1 s on this 2-core machine;
- the same for a 1536x1536 photo (3x), where the crops are shrunk for the models but the colours are not.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time

import numpy as np
from skimage import data, transform

TARGET_S = 1.0
REPEATS = 7
STEPS = ("detection", "landmarks", "subdivision", "colours", "total")

LOAD = """
import time
t0 = time.perf_counter()
from ffd_notebook.face import models
t1 = time.perf_counter()
import ai_edge_litert.interpreter
t2 = time.perf_counter(); models.detector(); t3 = time.perf_counter(); models.landmark_model(); t4 = time.perf_counter()
from skimage import data
import ffd_notebook as fn
photo = data.astronaut()
t5 = time.perf_counter(); fn.face_from_photo(photo); t6 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3, t6 - t5)
"""


def split(photo: np.ndarray) -> dict[str, float]:
    import ffd_notebook as fn

    fn.face_from_photo(photo)  # the first call loads the models and PyVista
    runs = []
    for _ in range(REPEATS):
        timings: dict[str, float] = {}
        fn.face_from_photo(photo, timings=timings)
        runs.append(timings)
    return {step: statistics.median(run[step] for run in runs) for step in STEPS}


def main() -> None:
    out = subprocess.run([sys.executable, "-c", LOAD], capture_output=True, text=True, check=True).stdout.split()
    imports, litert, detector, landmarks, first = (float(v) for v in out)
    print("fresh process:")
    print(f"  import ffd_notebook.face (SciPy, Pillow)  {imports * 1e3:8.1f} ms")
    print(f"  import LiteRT (ai_edge_litert)            {litert * 1e3:8.1f} ms")
    print(f"  load the detector (229 KB)                {detector * 1e3:8.1f} ms")
    print(f"  load the landmark model (1.2 MB)          {landmarks * 1e3:8.1f} ms")
    print(f"  first face_from_photo (512x512)           {first * 1e3:8.1f} ms   (imports PyVista)")
    astronaut = data.astronaut()
    big = transform.rescale(astronaut, 3, channel_axis=-1, preserve_range=True).round().astype(np.uint8)
    for name, photo in (("512x512 astronaut()", astronaut), ("1536x1536 (3x)", big)):
        times = split(photo)
        print(f"face_from_photo, {name}, median of {REPEATS} after the first:")
        for step in STEPS:
            print(f"  {step:<12} {times[step] * 1e3:8.1f} ms")
        verdict = "met" if times["total"] <= TARGET_S else "MISSED"
        print(f"  target: total <= {TARGET_S * 1e3:.0f} ms: {verdict}")
    start = time.perf_counter()
    import ffd_notebook as fn

    mesh = fn.face_from_photo(astronaut)
    print(f"mesh: {mesh.n_points} vertices, {mesh.n_cells} triangles ({(time.perf_counter() - start) * 1e3:.0f} ms)")


if __name__ == "__main__":
    main()
