"""
A Gaussian-process deformation field
====================================

A random smooth displacement field drawn from a :class:`~ffd_notebook.gp.GaussianProcess` with a
Gaussian kernel (its width ``sigma`` sets the smoothness), on a sub-sample of the face's vertices, and the
face deformed by it.
"""

import numpy as np
import pyvista as pv

from ffd_notebook.datasets import face
from ffd_notebook.gp import GaussianKernel, GaussianProcess

mesh = face()
gp = GaussianProcess(GaussianKernel(sigma=40.0, scale=6.0))
rng = np.random.default_rng(0)
sub = rng.choice(mesh.n_points, 600, replace=False)
field = gp.sample(mesh.points[sub], n=1, rng=1)[0]  # (600, 3): one smooth field on those points

arrows = pv.PolyData(mesh.points[sub])
arrows["u"] = field
arrows["|u|"] = np.linalg.norm(field, axis=1)

pl = pv.Plotter()
pl.add_mesh(mesh, color="lightgrey", opacity=0.6)
pl.add_mesh(
    arrows.glyph(orient="u", scale="|u|", factor=2.0),
    scalars="|u|",
    cmap="plasma",
    scalar_bar_args={"title": "|u| (mm)"},
)
pl.view_xy()
pl.show()
