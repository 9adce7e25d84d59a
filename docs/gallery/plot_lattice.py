"""
A lattice around a mesh
=======================

:meth:`ffd_notebook.Lattice.around` fits a lattice of control points to a mesh: here the bundled face
scan in a 5x5x5 lattice with the "clamp" border, which hugs the mesh's box.
"""

import pyvista as pv

import ffd_notebook as fn
from ffd_notebook.datasets import face

mesh = face()
lattice = fn.Lattice.around(mesh.points, shape=5, border="clamp")

# the control points and the lattice's edges as PyVista objects
points = lattice.control_points().reshape(-1, 3)
edges = lattice.edges()
lines = pv.PolyData(points, lines=[[2, a, b] for a, b in edges])

pl = pv.Plotter()
pl.add_mesh(mesh, scalars="RGB", rgb=True)
pl.add_mesh(lines, color="grey", line_width=1)
pl.add_points(points, color="orange", point_size=12, render_points_as_spheres=True)
pl.view_xy()
pl.show()
