"""The free-form deformation engine: lattice, basis functions, border rule, evaluators, fitting, Jacobian.

Plain NumPy/SciPy. :class:`Lattice` holds the control points, :class:`FFD` evaluates a deformation
once (``deform``, ``jacobian``, ``fit_points``), :class:`Deformer` is an FFD bound to one point set
for repeated updates (the editor's drag path), :class:`GridEvaluator` evaluates a deformation on
the voxels of an image grid (separably when the lattice runs along it). Where the B-spline's
support meets the lattice's border is decided in one module, :mod:`ffd_notebook.ffd.support`.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook.ffd import FFD, Lattice
>>> pts = np.random.default_rng(0).random((20, 3))
>>> lat = Lattice.around(pts, shape=5)
>>> lat.offsets[...] = (0.0, 0.5, 0.0)
>>> bool(np.allclose(FFD(lat).deform(pts), pts + (0.0, 0.5, 0.0)))
True
"""

from __future__ import annotations

from .basis import BasisName
from .deform import FFD
from .deformer import Deformer
from .grid import GridEvaluator
from .lattice import Lattice
from .support import Border

__all__ = ["FFD", "BasisName", "Border", "Deformer", "GridEvaluator", "Lattice"]
