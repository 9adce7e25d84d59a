"""Image fuzzing worker: reads one image file per stdin line, answers one JSON line per file.

Run by tests/images/test_fuzz_images.py in a subprocess, so that a reader crashing the process (or
hanging) is seen by the test as a dead (or silent) worker. A loaded image is also warped, as
``warp_image`` and the editor use it.
"""

from __future__ import annotations

import json
import sys
import traceback


def _use(path: str) -> None:
    from ffd_notebook import FFD, Lattice
    from ffd_notebook.images import ImageGrid, read_image, warp_image

    image = read_image(path)
    lo, hi = ImageGrid.of(image).bounds()
    lattice = Lattice.around([lo, hi + 1.0], shape=4)
    lattice.offsets[1, 1, 1] = 0.3 * lattice.spacing
    warp_image(image, FFD(lattice), interpolation="nearest")


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
