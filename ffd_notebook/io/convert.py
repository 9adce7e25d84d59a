"""``python -m ffd_notebook convert IN OUT``: a deformation from one file format to another.

Formats by extension: ``.ffd``, ITK transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``) and PyGeM
``.prm``. A conversion that could not be exact (a Bernstein lattice to ITK, an ITK transform that
leaves points outside its domain unmoved to ``.ffd``, ...) is refused with the reason.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..errors import FileFormatError
from .deformation_files import DEFORMATION_SUFFIXES, load_deformation, save_deformation

__all__ = ["convert", "convert_main"]


def convert(source: str, target: str) -> list[str]:
    """Convert ``source`` to ``target`` by extension; return notes worth telling the user.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import Lattice
    >>> from ffd_notebook.io import save_ffd
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> save_ffd(folder / "a.ffd", Lattice((4, 4, 4), 2.0, origin=(1.0, 2.0, 3.0)))
    >>> convert(str(folder / "a.ffd"), str(folder / "a.h5"))
    []
    """
    ffd = load_deformation(source)
    notes = []
    if source.lower().endswith(".ffd") and ffd.lattice.metadata.get("placement") is None:
        notes.append(f"{source} has no placement (#quaternion#) section: its lattice is written at origin "
                     "(0, 0, 0), axis-aligned (the FFD platform put it at the mesh's minimum corner)")  # fmt: skip
    save_deformation(target, ffd)
    return notes


def convert_main(argv: Sequence[str]) -> int:
    """Command line of ``python -m ffd_notebook convert``; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m ffd_notebook convert",
        description="Convert a deformation between .ffd, ITK transform and PyGeM .prm files (by extension); "
        "refuses conversions that would not be exact.",
        epilog=f"extensions: {' '.join(DEFORMATION_SUFFIXES)}",
    )
    parser.add_argument("source", metavar="IN", help="file to read")
    parser.add_argument("target", metavar="OUT", help="file to write (replaced atomically)")
    args = parser.parse_args(list(argv))
    try:
        notes = convert(args.source, args.target)
    except (FileFormatError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    print(f"{args.source} -> {args.target}")
    return 0
