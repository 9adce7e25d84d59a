"""
A textured organ, cut open
==========================

A solid texture grown from scikit-image's immunohistochemistry picture (a small exemplar volume whose
slices look like a crop of cells cut across, :func:`~ffd_notebook.solidtex.exemplar_from_image`), synthesised
voxel by voxel where PyVista's frog liver samples it (:class:`~ffd_notebook.solidtex.LazySolidTexture`, which keeps
the cells whole), and cut open with a plane: the cut face shows the interior.
"""

import numpy as np
import pyvista as pv
import skimage.data

from ffd_notebook.datasets import frog_liver
from ffd_notebook.meshing.organ import tetrahedralize
from ffd_notebook.solidtex import LazySolidTexture, exemplar_from_image
from ffd_notebook.view import frame_camera, view_direction
from ffd_notebook.view.solidtex import TexturedOrgan, add_cut

cells = skimage.data.immunohistochemistry()[340:388, 290:338]  # 48 px of a gland cut across
exemplar = exemplar_from_image(cells, rng=0)  # 48^3: its x, y and z slices all look like the crop
grid = tetrahedralize(frog_liver(1500))
texture = LazySolidTexture.fit(exemplar, grid.bounds, resolution=128, rng=0)  # made where the organ samples it
organ = TexturedOrgan(grid, texture)

normal = np.array([0.3, 1.0, 0.0])
pl = pv.Plotter()
outside, cut = add_cut(pl, organ, grid.center, normal)
frame_camera(pl, np.vstack([outside.points, cut.points]), view_direction(normal), margin=1.03)
pl.show()
