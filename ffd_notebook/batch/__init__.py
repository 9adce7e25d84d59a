"""Many deformed copies of a mesh: random models, fold-free sampling, replay, Dask execution.

- Models (NumPy only): :class:`RandomLattice` (TorchIO's ``num_control_points``,
  ``max_displacement``, ``locked_borders``), :class:`RandomGP` (low-rank Gaussian process,
  Gaussian or B-spline kernel) and :class:`LatticeFiles` (deformations given as files).
- :class:`FoldFree`: accept a sample only if det J stays above a threshold at every vertex and on
  a grid through the mesh's box; otherwise redraw or scale down.
- :func:`generate` writes meshes, parameters and ``manifest.csv`` on Dask (local or a
  ``distributed`` cluster); :func:`replay` rebuilds one sample's mesh from its parameters;
  :func:`local_cluster` starts a ``LocalCluster`` whose workers are set up for it.
- ``python -m ffd_notebook batch MESH --model random-lattice --n 1000 --out DIR``.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.batch import RandomLattice, sample_rng
>>> points = np.random.default_rng(0).random((500, 3))
>>> bound = RandomLattice(num_control_points=6, max_displacement=0.02).bind(points)
>>> moved = bound.draw(sample_rng(seed=0, index=4), 4).deform(points)
>>> bool(0 < np.abs(moved - points).max() < 0.02)
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._util.lazy import lazy_getattr
from .folding import FoldFree, volume_grid
from .gp_model import RandomGP
from .models import LatticeSample, RandomLattice
from .seeds import sample_rng

if TYPE_CHECKING:  # the lazy names below, declared for type checkers and IDEs
    from ..errors import BatchError as BatchError
    from .cluster import local_cluster as local_cluster
    from .engine import BatchResult as BatchResult
    from .engine import generate as generate
    from .engine import replay as replay
    from .files import LatticeFiles as LatticeFiles
    from .output import read_manifest as read_manifest

# the engine writes meshes and LatticeFiles reads files through ffd_notebook.io (PyVista): imported on first use
_LAZY = {
    "LatticeFiles": "ffd_notebook.batch.files",
    "generate": "ffd_notebook.batch.engine",
    "local_cluster": "ffd_notebook.batch.cluster",
    "replay": "ffd_notebook.batch.engine",
    "BatchResult": "ffd_notebook.batch.engine",
    "BatchError": "ffd_notebook.errors",
    "read_manifest": "ffd_notebook.batch.output",
}

__all__ = [
    "FoldFree",
    "LatticeSample",
    "RandomGP",
    "RandomLattice",
    "sample_rng",
    "volume_grid",
    *sorted(_LAZY),
]


__getattr__ = lazy_getattr(__name__, _LAZY)
