"""The deformation as an animation (issue 33): a 60-frame GIF of the 53k-vertex face, target <= 20 s here.

Run from the repository root (needs ../shared/data; falls back to the bundled 6k face):

    python tests/benchmarks/bench_animation.py [--frames 60] [--repeat 2]

Prints, for an editor at 640x480 with the top layer of its 5x5x5 lattice lifted (the lattice drawn, the mesh's
own colours): the whole ``editor.animate("lesson.gif", frames=60)`` (scene, frames, GIF written), its time per
frame, the bare render time of that scene (``render_window.Render()``) and the share of the frame that is not
rendering (Pillow's palette for each GIF frame, the blend, the copy), and the same for a 60-frame MP4. Each
figure is the median of ``--repeat`` runs (the machine is shared: say so with the figures).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
FACE = HERE.parents[2] / "shared" / "data" / "face" / "template_colored.obj"
TARGET_GIF_S = 20.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    sys.path.insert(0, str(HERE.parents[1]))
    import ffd_notebook as fn
    from ffd_notebook.datasets import sample_mesh
    from ffd_notebook.view import Editor

    mesh = fn.read_mesh(FACE) if FACE.exists() else sample_mesh()
    editor = Editor(mesh, window_size=(640, 480))
    spacing = editor.lattice.spacing
    editor.lattice.offsets[:, 3, :] += (0.0, 0.6 * spacing[1], 0.0)
    editor.update()
    renders = []
    for _ in range(20):
        t0 = time.perf_counter()
        editor.plotter.render_window.Render()
        renders.append(time.perf_counter() - t0)
    render_ms = 1000 * statistics.median(renders)
    folder = Path(tempfile.mkdtemp())
    print(f"mesh: {mesh.n_points} vertices, {mesh.n_cells} faces; 640x480; {args.frames} frames; "
          f"a render of the scene: {render_ms:.0f} ms")  # fmt: skip
    for suffix in (".gif", ".mp4"):
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            editor.animate(folder / f"lesson{suffix}", frames=args.frames)
            times.append(time.perf_counter() - t0)
        total = statistics.median(times)
        per_frame = 1000 * total / args.frames
        line = (f"{suffix[1:].upper()}: {total:.1f} s ({per_frame:.0f} ms a frame, {per_frame / render_ms:.1f}x a "
                f"render; {(folder / f'lesson{suffix}').stat().st_size / 2**20:.1f} MB)")  # fmt: skip
        if suffix == ".gif":
            line += f"  target <= {TARGET_GIF_S:.0f} s: {'met' if total <= TARGET_GIF_S else 'MISSED'}"
        print(line)
    editor.close()


if __name__ == "__main__":
    main()
