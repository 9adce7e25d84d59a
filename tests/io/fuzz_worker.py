"""Fuzzing worker: reads one file per stdin line, answers one JSON line per file on stdout.

Run by tests/io/test_fuzz_readers.py in a subprocess, so that a reader crashing the process (or
hanging) is seen by the test as a dead (or silent) worker and reported with the case that did it.
The answer is ``{"outcome": "loaded" | "FileFormatError" | "OSError" | "unexpected", "detail": ...}``.
A loaded file is also used the way the editor uses it (surface normals; a deformation), because
bad connectivity used to crash VTK filters only after a silent load.
"""

from __future__ import annotations

import json
import sys
import traceback


def _use(path: str) -> None:
    from ffd_notebook import FFD
    from ffd_notebook.io import load_deformation, load_elastix, load_ffd, read_mesh

    if path.lower().endswith(".ffd"):
        lattice = load_ffd(path)
        FFD(lattice).deform(lattice.control_points(deformed=True).reshape(-1, 3)[:16])
        return
    if path.lower().endswith(".txt"):  # elastix parameter files: the chain, then the FFD it lowers onto
        chain = load_elastix(path)
        ffd = load_deformation(path)
        points = ffd.lattice.control_points().reshape(-1, 3)[:16]
        chain.deform(points), ffd.deform(points)
        return
    mesh = read_mesh(path)
    surface = mesh if mesh.GetClassName() == "vtkPolyData" else mesh.extract_surface(algorithm=None)
    if surface.GetNumberOfPolys() or surface.GetNumberOfStrips():  # normals need polygons
        surface.triangulate().compute_normals(split_vertices=False)


def main() -> None:
    import warnings

    from ffd_notebook.errors import FileFormatError

    warnings.simplefilter("ignore")
    for line in sys.stdin:
        path = line.rstrip("\n")
        try:
            _use(path)
            answer = {"outcome": "loaded", "detail": ""}
        except FileFormatError as exc:
            answer = {"outcome": "FileFormatError", "detail": str(exc)[:300]}
        except OSError as exc:
            answer = {"outcome": "OSError", "detail": repr(exc)[:300]}
        except Exception as exc:
            answer = {"outcome": "unexpected", "detail": f"{exc!r}\n{traceback.format_exc()[-3000:]}"}
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
