"""
An augmentation grid
====================

Six random fold-free deformations of the face, as :func:`ffd_notebook.batch.generate` makes them on Dask:
a :class:`~ffd_notebook.batch.RandomLattice` with TorchIO's parameter names, sample ``i`` drawn from the
``i``-th child of one seed. Each sample's smallest Jacobian determinant on the mesh is in its title.
"""

import pyvista as pv

from ffd_notebook.batch import RandomLattice, sample_rng
from ffd_notebook.datasets import face

mesh = face()
model = RandomLattice(num_control_points=6, max_displacement=8.0, locked_borders=1)
bound = model.bind(mesh.points)

pl = pv.Plotter(shape=(2, 3), border=False)
for i in range(6):
    sample = bound.draw(sample_rng(0, i), i)
    copy = mesh.copy()
    copy.points = sample.deform(mesh.points)
    pl.subplot(i // 3, i % 3)
    pl.add_mesh(copy, scalars="RGB", rgb=True)
    pl.add_text(f"sample {i}: min det J {sample.jacobian_determinant(mesh.points).min():.2f}", font_size=9)
    pl.view_xy()
pl.link_views()
pl.show()
