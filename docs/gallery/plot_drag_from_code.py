"""
A drag from code
================

What a drag in the editor does, from code: move one control point (an entry of ``lattice.offsets``)
and deform the mesh with :meth:`ffd_notebook.FFD.deform`. Left the rest mesh, right the deformed one,
the moved control point in red.
"""

import numpy as np
import pyvista as pv

import ffd_notebook as fn
from ffd_notebook.datasets import face

mesh = face()
lattice = fn.Lattice.around(mesh.points, shape=5, border="clamp")
ffd = fn.FFD(lattice)

ijk = (2, 1, 4)  # a control point in front of the chin
lattice.offsets[ijk] = (0.0, -0.4 * lattice.spacing[1], 0.6 * lattice.spacing[2])
deformed = mesh.copy()
deformed.points = ffd.deform(mesh.points)
moved = np.linalg.norm(deformed.points - mesh.points, axis=1)
print(f"largest vertex move: {moved.max():.1f} mm; vertices moved: {(moved > 1e-9).sum()} of {mesh.n_points}")

pl = pv.Plotter(shape=(1, 2))
pl.add_mesh(mesh, scalars="RGB", rgb=True)
pl.add_points(
    lattice.control_points().reshape(-1, 3)[np.ravel_multi_index(ijk, lattice.shape)],
    color="red",
    point_size=16,
    render_points_as_spheres=True,
)
pl.view_yz()
pl.subplot(0, 1)
pl.add_mesh(deformed, scalars=moved, cmap="viridis", scalar_bar_args={"title": "moved (mm)"})
pl.add_points(
    lattice.control_points(deformed=True).reshape(-1, 3)[np.ravel_multi_index(ijk, lattice.shape)],
    color="red",
    point_size=16,
    render_points_as_spheres=True,
)
pl.view_yz()
pl.link_views()
pl.show()
