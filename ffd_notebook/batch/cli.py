"""``python -m ffd_notebook batch``: many deformed copies of a mesh from the command line.

Examples
--------
::

    python -m ffd_notebook batch face.ply --model random-lattice --n 1000 --out augmented \\
        --num-control-points 7 --max-displacement 2000 --locked-borders 2
    python -m ffd_notebook batch face.ply --n 1000 --out augmented --scheduler tcp://10.0.0.5:8786
    python -m ffd_notebook batch liver.vtp --n 100 --out pairs --image ct.nii.gz --label-image liver_labels.nii.gz
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .folding import FoldFree

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``python -m ffd_notebook batch``.

    Examples
    --------
    >>> args = build_parser().parse_args(["face.ply", "--n", "10", "--out", "d", "--max-displacement", "2", "3", "4"])
    >>> args.model, args.n, args.max_displacement, args.num_control_points, args.locked_borders
    ('random-lattice', 10, [2.0, 3.0, 4.0], [7], 2)
    """
    p = argparse.ArgumentParser(
        prog="python -m ffd_notebook batch",
        description="Write N randomly deformed copies of a mesh (fold-free, replayable) plus manifest.csv, on Dask.",
    )
    p.add_argument("mesh", help="the source mesh (PLY, OBJ with colours, VTP, STL, ...)")
    p.add_argument("--model", choices=["random-lattice", "gp", "files"], default="random-lattice",
                   help="random-lattice: TorchIO-style random B-spline grid; gp: low-rank Gaussian process; "
                        "files: the deformation files given with --files, one sample each")  # fmt: skip
    p.add_argument("--n", type=int, help="number of samples (default with --model files: one per file)")
    p.add_argument("--out", required=True, help="output folder; a rerun skips the samples already in it")
    p.add_argument("--seed", type=int, default=0, help="root seed; sample i uses the i-th spawned seed (default 0)")
    p.add_argument("--format", choices=["ply", "vtp", "obj"], default="ply", help="mesh file format (default ply)")
    p.add_argument("--scheduler", metavar="ADDR",
                   help="a distributed scheduler address (tcp://host:8786), or threads / processes / sync for the "
                        "local scheduler (default: threads, the fastest measured here)")  # fmt: skip
    p.add_argument("--workers", type=int, help="local workers (default: one per core)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    img = p.add_argument_group("images (warped by each sample's transform, written beside its mesh)")
    img.add_argument("--image", metavar="IMG",
                     help="an image in the mesh's space (NIfTI, NRRD, MetaImage...); the mesh is then moved by the "
                          "inverse of the transform the image is resampled through, so both stay together")  # fmt: skip
    img.add_argument("--label-image", metavar="LABELS", help="a label map in the mesh's space (nearest interpolation)")
    img.add_argument("--image-interpolation", choices=["linear", "bspline", "nearest"], default="linear",
                     help="interpolation of --image (default linear)")  # fmt: skip
    lat = p.add_argument_group("random-lattice (TorchIO's names)")
    lat.add_argument("--num-control-points", type=int, nargs="+", default=[7], metavar="N",
                     help="control points per axis: one number or three (>= 4 for B-splines; default 7)")  # fmt: skip
    lat.add_argument("--max-displacement", type=float, nargs="+", default=[7.5], metavar="D",
                     help="largest offset of a control point per axis, in mesh units: one number or three; each "
                          "offset component is uniform in [-D, D] (default 7.5)")  # fmt: skip
    lat.add_argument("--locked-borders", type=int, choices=[0, 1, 2], default=2,
                     help="layers of border control points kept still: 0 none, 1 the outer ring, 2 also the ring "
                          "on the mesh's bounding box (default 2)")  # fmt: skip
    # default None: --model files refuses them (each file says its basis and border)
    lat.add_argument("--basis", choices=["bspline", "bernstein"], help="FFD basis (default bspline)")
    lat.add_argument("--border", choices=["zero", "clamp"],
                     help="control points beyond the lattice: zero (ITK's rule; the lattice's outer ring lies a "
                          "spacing outside the mesh) or clamp (copies of the border ones, Blender's; the lattice "
                          "hugs the mesh's box; its .ffd files record it) (default zero)")  # fmt: skip
    gp = p.add_argument_group("gp")
    gp.add_argument(
        "--kernel", choices=["gaussian", "bspline"], default="gaussian", help="GP kernel (default gaussian)"
    )
    gp.add_argument("--scale", type=float, default=5.0, help="std of a displacement (or offset) component")
    gp.add_argument("--sigma", type=float, default=50.0, help="Gaussian kernel width, mesh units")
    gp.add_argument("--rank", type=int, default=50, help="basis functions kept (default 50)")
    gp.add_argument("--n-inducing", type=int, default=300, help="Nystrom inducing points (default 300)")
    files = p.add_argument_group("files")
    files.add_argument("--files", nargs="+", metavar="FILE",
                       help="deformation files, sample i is file i: .ffd lattices, ITK transforms (.tfm, .txt, "
                            ".h5, .hdf5) or PyGeM .prm files, read by extension; each says its own basis and "
                            "border")  # fmt: skip
    fold = p.add_argument_group("fold check")
    fold.add_argument("--no-fold-check", action="store_true", help="keep every draw (min det J is still recorded)")
    fold.add_argument("--min-det", type=float, default=0.1,
                      help="accept a sample only if det J > this at every vertex and grid point")  # fmt: skip
    fold.add_argument("--on-fold", choices=["redraw", "scale"], default="redraw",
                      help="redraw a folding sample, or scale it down by 0.8 until it passes")  # fmt: skip
    fold.add_argument("--grid", type=int, default=12, help="grid points per axis through the mesh's box (default 12)")
    fold.add_argument("--max-tries", type=int, default=100, help="draws or shrinks per sample before it fails")
    return p


def _one_or_three(values: list, name: str, parser: argparse.ArgumentParser):
    if len(values) not in (1, 3):
        parser.error(f"{name} takes one value or three, got {len(values)}")
    return values[0] if len(values) == 1 else tuple(values)


def _model(args: argparse.Namespace, parser: argparse.ArgumentParser):
    from . import LatticeFiles, RandomGP, RandomLattice

    if args.model == "random-lattice":
        return RandomLattice(
            num_control_points=_one_or_three(args.num_control_points, "--num-control-points", parser),
            max_displacement=_one_or_three(args.max_displacement, "--max-displacement", parser),
            locked_borders=args.locked_borders,
            basis=args.basis or "bspline",
            border=args.border or "zero",
        )
    if args.model == "gp":
        counts = _one_or_three(args.num_control_points, "--num-control-points", parser)
        return RandomGP(kernel=args.kernel, scale=args.scale, sigma=args.sigma, rank=args.rank,
                        n_inducing=args.n_inducing, num_control_points=counts)  # fmt: skip
    if not args.files:
        parser.error("--model files needs --files")
    if args.basis or args.border:
        parser.error("--basis and --border do not apply to --model files: each file says its own")
    return LatticeFiles(args.files)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``python -m ffd_notebook batch ...`` (``argv`` without the word ``batch``); returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.model != "files" and args.n is None:
        parser.error("--n is required")
    from ..errors import BatchError, FileFormatError
    from .engine import generate

    try:
        rule = None if args.no_fold_check else FoldFree(args.min_det, args.grid, args.on_fold, args.max_tries)
        model = _model(args, parser)
        result = generate(args.mesh, model, args.n, args.out, seed=args.seed, fold_free=rule, format=args.format,
                          scheduler=args.scheduler, workers=args.workers, progress=not args.no_progress,
                          image=args.image, label_image=args.label_image,
                          image_interpolation=args.image_interpolation)  # fmt: skip
    except BatchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except (FileFormatError, ValueError, OSError, TypeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(
        f"{len(result.made)} samples made, {len(result.skipped)} already there, in {result.wall:.1f} s "
        f"({result.scheduler}); manifest: {result.out / 'manifest.csv'}"
    )
    return 0
