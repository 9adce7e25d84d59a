"""``python -m ffd_notebook``: the FFD editor as a standalone web app.

Examples
--------
Open the bundled sample mesh and browse to the printed address::

    python -m ffd_notebook
    python -m ffd_notebook face.obj --ffd face.ffd --port 8765
    python -m ffd_notebook --image fixed.nii.gz --ffd cpp.nii.gz   # a NiftyReg result on its image
    python -m ffd_notebook me.jpg                 # the coloured 3D face in a photo
    python -m ffd_notebook --shape 6 6 4 --basis bernstein
    python -m ffd_notebook --root ~/meshes --host 0.0.0.0

The printed address carries a session token; the page's file paths stay inside ``--root``.

Subcommands (each with its own ``--help``)::

    python -m ffd_notebook convert lattice.ffd lattice.tfm     # between the deformation formats
    python -m ffd_notebook batch face.ply --n 1000 --out augmented
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["build_parser", "main"]

#: ``python -m ffd_notebook NAME ...`` -> (module, function taking the remaining arguments)
_SUBCOMMANDS = {"convert": ("ffd_notebook.io.convert", "convert_main"), "batch": ("ffd_notebook.batch.cli", "main")}


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``python -m ffd_notebook``.

    Examples
    --------
    >>> args = build_parser().parse_args(["mesh.obj", "--shape", "6", "5", "4", "--port", "0"])
    >>> args.mesh, args.shape, args.port, args.host, args.basis
    ('mesh.obj', [6, 5, 4], 0, '127.0.0.1', 'bspline')
    """
    parser = argparse.ArgumentParser(
        prog="python -m ffd_notebook",
        description="Deform a mesh by dragging the control points of a free-form deformation lattice, in the browser.",
    )
    parser.add_argument("mesh", nargs="?",
                        help="mesh file (OBJ with colours, PLY, VTP, STL, ...), or a photo of a face (JPEG, PNG...: "
                             "the coloured face in it); default: the sample face")  # fmt: skip
    parser.add_argument("--ffd", metavar="FILE",
                        help="a deformation file to start from: .ffd, ITK .tfm/.h5, elastix, NiftyReg, ANTs, FSL "
                             "FNIRT, PyGeM .prm or a displacement field (a lattice is edited as it is, an affine "
                             "as the affine part, a field or a chain fitted by a lattice)")  # fmt: skip
    parser.add_argument("--image", metavar="IMG",
                        help="an image to show with the mesh as three slices warped by the lattice (NIfTI, NRRD, "
                             "MetaImage...); without a mesh, the lattice is fitted to the image's box")  # fmt: skip
    parser.add_argument("--port", type=int, default=8080, help="port to listen on (0: any free port; default 8080)")
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine)")
    parser.add_argument("--shape", type=int, nargs=3, default=[5, 5, 5], metavar=("NX", "NY", "NZ"),
                        help="control points per axis of the fitted lattice (default 5 5 5)")  # fmt: skip
    parser.add_argument("--basis", choices=["bspline", "bernstein"], default="bspline", help="FFD basis")
    parser.add_argument("--root", metavar="DIR", default=".",
                        help="folder the page's file paths are confined to (default: the current folder)")  # fmt: skip
    parser.add_argument("--max-file-mb", type=float, default=512, metavar="MB",
                        help="largest file the page may load or upload (default 512)")  # fmt: skip
    return parser


def main(argv: Sequence[str] | None = None, *, setup: Callable[[Any], None] | None = None) -> int:
    """Parse ``argv`` (``sys.argv[1:]`` by default), build the editor and serve it until interrupted.

    ``setup(app)`` (code only, e.g. a test's instrumentation) runs on the app before it serves.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in _SUBCOMMANDS:  # imported on use: the editor needs neither
        module, function = _SUBCOMMANDS[argv[0]]
        return getattr(importlib.import_module(module), function)(argv[1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    for path, what in ((args.mesh, "mesh"), (args.ffd, "lattice file")):
        if path is not None and not os.path.isfile(path):
            parser.error(f"no such {what}: {path}")
    if not os.path.isdir(args.root):
        parser.error(f"no such folder: {args.root}")
    from .view.serving.web_security import is_loopback  # standard library only

    if not is_loopback(args.host):
        print(
            f"warning: listening on {args.host}: whoever has the printed address (it holds the session token) "
            f"can edit, and read or write mesh and .ffd files in {os.path.abspath(args.root)}, as this user",
            file=sys.stderr,
        )
    # trame would parse sys.argv again on start; the arguments above are the only ones that count
    os.environ.setdefault("TRAME_ARGS", "")
    print("loading the editor...", flush=True)
    from .errors import FileFormatError
    from .face.models import LiteRTMissingError
    from .view.editor.app import run_app

    try:
        run_app(args.mesh, ffd=args.ffd, port=args.port, host=args.host, shape=tuple(args.shape), basis=args.basis,
                root=args.root, max_file_bytes=int(args.max_file_mb * 2**20), setup=setup,
                image=args.image)  # fmt: skip
    except (FileFormatError, ValueError, OSError, LiteRTMissingError) as exc:  # NoFaceError is a ValueError
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
