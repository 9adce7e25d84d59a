"""Replaying deformations made elsewhere: a given list of lattice (or transform) files.

Sample ``i`` is file ``i``. Each format is one loader function ``path -> FFD`` in
:data:`LOADERS`, keyed by file suffix; ``.ffd`` is read by :func:`~ffd_notebook.load_ffd`.
Other formats (ITK transforms, PyGeM parameter files) plug in with :func:`register_loader`.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..deform import BASES, FFD
from .models import LatticeSample, make_ffd

__all__ = ["LOADERS", "LatticeFiles", "load_deformation", "register_loader"]


def _load_ffd_file(path: Path, basis: str, border: str) -> FFD:
    from ..io import load_ffd  # the io package loads PyVista: only when a file is read

    return make_ffd(load_ffd(path), basis, border)


#: suffix -> loader(path, basis, border) returning an FFD
LOADERS: dict[str, Callable[[Path, str, str], FFD]] = {".ffd": _load_ffd_file}


def register_loader(suffix: str, loader: Callable[[Path, str, str], FFD]) -> None:
    """Read files ending in ``suffix`` with ``loader(path, basis, border) -> FFD``.

    Examples
    --------
    >>> register_loader(".ffd", _load_ffd_file)
    >>> sorted(LOADERS)[:1]
    ['.ffd']
    """
    LOADERS[suffix.lower()] = loader


def load_deformation(path: str | os.PathLike[str], basis: str = "bspline", border: str = "zero") -> FFD:
    """Read one lattice/transform file as an FFD, choosing the loader by suffix."""
    path = Path(path)
    loader = LOADERS.get(path.suffix.lower())
    if loader is None:
        raise ValueError(f"{path}: no loader for {path.suffix or 'files without a suffix'!r}; known: {sorted(LOADERS)}")
    return loader(path, basis, border)


@dataclass(frozen=True)
class LatticeFiles:
    """A fixed list of deformations read from files; sample ``i`` is ``files[i]``.

    Parameters
    ----------
    files : sequence of paths
        Lattice or transform files (``.ffd``; more formats through :func:`register_loader`).
        Each is read once up front, so a bad file is an error before any work starts.
    basis, border
        The FFD basis and border rule the lattices are evaluated with (``.ffd`` stores neither).

    Notes
    -----
    A given file cannot be drawn again: with a fold check, use ``on_fold="scale"`` or the
    sample fails with an error naming it. The parameters file of a sample is the given file
    itself (plus the scale factor in the manifest).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import Lattice, save_ffd
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.ffd"
    >>> save_ffd(path, Lattice((4, 4, 4), 1.0))
    >>> LatticeFiles([path]).bind(None).draw(None, 0).ffd.lattice.shape
    (4, 4, 4)
    """

    files: tuple[str, ...]
    basis: str = "bspline"
    border: str = "zero"

    name = "files"

    def __post_init__(self) -> None:
        if isinstance(self.files, str | os.PathLike) or not isinstance(self.files, Sequence) or not self.files:
            raise ValueError(f"files must be a non-empty list of paths, got {self.files!r}")
        if self.basis not in BASES:
            raise ValueError(f"basis must be one of {BASES}, got {self.basis!r}")
        object.__setattr__(self, "files", tuple(str(Path(f).resolve()) for f in self.files))
        for f in self.files:
            load_deformation(f, self.basis, self.border)  # every file checked before any work starts

    def to_spec(self) -> dict[str, Any]:
        """The parameters as JSON values, with the model's name under ``"model"``."""
        return {"model": self.name, "files": list(self.files), "basis": self.basis, "border": self.border}

    def bind(self, points: ArrayLike | None) -> BoundFiles:
        """The files do not depend on the mesh: read them."""
        return BoundFiles(self, tuple(load_deformation(f, self.basis, self.border) for f in self.files))


@dataclass(frozen=True)
class BoundFiles:
    """The loaded deformations of a :class:`LatticeFiles`."""

    model: LatticeFiles
    deformations: tuple[FFD, ...]
    can_redraw = False

    def draw(self, rng: np.random.Generator | None, index: int) -> LatticeSample:
        """File ``index`` (no randomness)."""
        if not 0 <= index < len(self.deformations):
            raise IndexError(f"sample {index}: only {len(self.deformations)} files were given")
        ffd = self.deformations[index]
        lattice = ffd.lattice.copy()
        return LatticeSample(make_ffd(lattice, ffd.basis, getattr(ffd, "border", "zero"), ffd.affine))
