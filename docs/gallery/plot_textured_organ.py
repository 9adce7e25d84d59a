"""
A textured organ, cut open
==========================

A solid texture grown from scikit-image's immunohistochemistry picture (slices stacked into a small
exemplar volume, then :func:`~ffd_notebook.solidtex.synthesize`), sampled inside PyVista's frog liver
and cut open with a plane: the cut face shows the interior.
"""

import numpy as np
import pyvista as pv
import skimage.data

from ffd_notebook.datasets import frog_liver
from ffd_notebook.meshing.organ import tetrahedralize
from ffd_notebook.solidtex import SolidTexture, sliding_crops, synthesize, volume_from_slices
from ffd_notebook.view.camera import frame_camera, view_direction
from ffd_notebook.view.solidtex import TexturedOrgan, add_cut

slices = sliding_crops(skimage.data.immunohistochemistry(), n_slices=32, size=48, step=(1, 1), start=(84, 84))
exemplar = volume_from_slices(slices)
grid = tetrahedralize(frog_liver(1500))
texture = SolidTexture.fit(synthesize(exemplar, 64, rng=0, progress=False), grid.bounds)
organ = TexturedOrgan(grid, texture)

normal = np.array([0.3, 1.0, 0.0])
pl = pv.Plotter()
outside, cut = add_cut(pl, organ, grid.center, normal)
frame_camera(pl, np.vstack([outside.points, cut.points]), view_direction(normal), margin=1.03)
pl.show()
