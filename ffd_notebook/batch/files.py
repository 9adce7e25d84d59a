"""Replaying deformations made elsewhere: a given list of deformation files.

Sample ``i`` is file ``i``, read by :func:`ffd_notebook.io.load_deformation`, so every format it
knows works: ``.ffd`` lattices, ITK transforms (``.tfm``, ``.txt``, ``.h5``, ``.hdf5``) and PyGeM
``.prm`` files. Each file says its deformation: its basis (``.ffd`` and ITK: B-spline, ``.prm``:
Bernstein), border rule (a ``.ffd`` file's ``#border#`` section), affine part and whether points
outside the lattice move, so the model has no basis or border of its own. The reader is imported
with this module, so it is there in every worker process that unpickles a :class:`LatticeFiles`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike

from ..ffd.deform import FFD
from ..io.deformation_files import load_deformation
from .models import LatticeSample

__all__ = ["LatticeFiles"]


@dataclass(frozen=True)
class LatticeFiles:
    """A fixed list of deformations read from files; sample ``i`` is ``files[i]``.

    Parameters
    ----------
    files : sequence of paths
        Deformation files in any format :func:`ffd_notebook.io.load_deformation` reads (chosen
        by extension). Each is read once up front, so a bad file is an error before any work
        starts.

    Notes
    -----
    A given file cannot be drawn again: with a fold check, use ``on_fold="scale"`` or the
    sample fails with an error naming it. The parameters file of a sample is the given file
    itself (plus the scale factor in the manifest).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import Lattice, save_ffd, save_prm
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> save_ffd(folder / "a.ffd", Lattice((4, 4, 4), 1.0)); save_prm(folder / "b.prm", Lattice((3, 3, 3), 1.0))
    >>> bound = LatticeFiles([folder / "a.ffd", folder / "b.prm"]).bind(None)
    >>> [(s.ffd.basis, s.ffd.lattice.shape) for s in (bound.draw(None, 0), bound.draw(None, 1))]
    [('bspline', (4, 4, 4)), ('bernstein', (3, 3, 3))]
    """

    files: tuple[str, ...]

    name = "files"

    def __post_init__(self) -> None:
        if isinstance(self.files, str | os.PathLike) or not isinstance(self.files, Sequence) or not self.files:
            raise ValueError(f"files must be a non-empty list of paths, got {self.files!r}")
        object.__setattr__(self, "files", tuple(str(Path(f).resolve()) for f in self.files))
        for f in self.files:
            if not isinstance(load_deformation(f), FFD):  # every file checked before any work starts
                raise ValueError(f"{f}: a displacement field is not a lattice; fit one first (fit_lattice, or "
                                 "python -m ffd_notebook convert FIELD OUT --fit SHAPE)")  # fmt: skip

    def to_spec(self) -> dict[str, Any]:
        """The parameters as JSON values, with the model's name under ``"model"``.

        Returns
        -------
        dict
            JSON-serialisable: what the run records and ``model_from_spec`` reads back.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from ffd_notebook import Lattice, save_ffd
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.ffd"
        >>> save_ffd(path, Lattice((4, 4, 4), 1.0))
        >>> spec = LatticeFiles([path]).to_spec()
        >>> spec["model"], spec["files"] == [str(path.resolve())]
        ('files', True)
        """
        return {"model": self.name, "files": list(self.files)}

    def bind(self, points: ArrayLike | None) -> BoundFiles:
        """The files do not depend on the mesh: read them.

        Parameters
        ----------
        points : array_like or None
            Not used: the deformations are the files'.

        Returns
        -------
        BoundFiles
            The files read: sample ``i`` is the ``i``-th deformation.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from ffd_notebook import FFD, Lattice
        >>> from ffd_notebook.io import save_deformation
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.ffd"
        >>> save_deformation(path, FFD(Lattice((4, 4, 4), 1.0)))
        >>> bound = LatticeFiles([path]).bind(None)
        >>> len(bound.deformations)
        1
        """
        # every file was checked to hold an FFD in __post_init__
        return BoundFiles(self, tuple(cast(FFD, load_deformation(f)) for f in self.files))


@dataclass(frozen=True)
class BoundFiles:
    """The loaded deformations of a :class:`LatticeFiles`."""

    model: LatticeFiles
    deformations: tuple[FFD, ...]
    can_redraw = False

    def draw(self, rng: np.random.Generator | None, index: int) -> LatticeSample:
        """File ``index`` (no randomness), on a copy of its lattice."""
        if not 0 <= index < len(self.deformations):
            raise IndexError(f"sample {index}: only {len(self.deformations)} files were given")
        return LatticeSample(self.deformations[index].copy())
