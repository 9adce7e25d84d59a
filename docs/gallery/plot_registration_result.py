"""
A registration result on a mesh
===============================

What a registration tool leaves behind, read back and applied to a mesh. An elastix B-spline result
(written here from a known FFD with ``save_deformation(..., format="elastix")``, as elastix writes its
``TransformParameters.0.txt``) is read with :func:`~ffd_notebook.io.load_elastix`, which moves points as
transformix does; the same deformation sampled as an ITK displacement field is fitted back onto a
lattice with :func:`~ffd_notebook.io.fit_lattice`. Left the face moved by the elastix chain, right what
the fitted lattice misses.
"""

import tempfile
from pathlib import Path

import numpy as np
import pyvista as pv

from ffd_notebook import FFD, Lattice
from ffd_notebook.datasets import face
from ffd_notebook.io import fit_lattice, load_deformation, load_elastix, save_deformation, save_displacement_field

mesh = face()
folder = Path(tempfile.mkdtemp())

# a smooth "registration result": a 6x6x6 B-spline lattice with random offsets
lattice = Lattice.around(mesh.points, shape=6)
lattice.offsets[1:-1, 1:-1, 1:-1] = np.random.default_rng(4).normal(scale=0.15, size=(4, 4, 4, 3)) * lattice.spacing
save_deformation(folder / "TransformParameters.0.txt", FFD(lattice), format="elastix")

chain = load_elastix(folder / "TransformParameters.0.txt")
moved = chain.deform(mesh.points)

# the same deformation as a dense field on a 32^3 grid over the mesh, then a lattice fitted to it
lo, hi = mesh.points.min(0) - 5, mesh.points.max(0) + 5
grid = {"size": (32, 32, 32), "spacing": tuple((hi - lo) / 31), "origin": tuple(lo)}
save_displacement_field(folder / "warp.nii.gz", chain, grid)
fitted = fit_lattice(load_deformation(folder / "warp.nii.gz"), (8, 8, 8))
missed = np.linalg.norm(fitted.deform(mesh.points) - moved, axis=1)
print(f"fitted 8^3 lattice: residual on the mesh {missed.mean():.3f} mm mean, {missed.max():.3f} mm max")

result = mesh.copy()
result.points = moved
pl = pv.Plotter(shape=(1, 2))
pl.add_mesh(
    result,
    scalars=np.linalg.norm(moved - mesh.points, axis=1),
    cmap="viridis",
    scalar_bar_args={"title": "elastix moved (mm)"},
)
pl.view_xy()
pl.subplot(0, 1)
pl.add_mesh(result, scalars=missed, cmap="magma", scalar_bar_args={"title": "fit residual (mm)"})
pl.view_xy()
pl.link_views()
pl.show()
