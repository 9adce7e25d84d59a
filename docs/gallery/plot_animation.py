"""
The deformation as an animation
===============================

A lesson's deformation as a GIF for the slides: :func:`ffd_notebook.animate` draws the mesh going from rest to an
FFD (or through saved states) off-screen, as the editor shows it, the camera turning a little, and writes the
frames through PyVista's movie writing (a ``.mp4`` works the same way; the gallery shows the GIF as PyVista's own
animated examples do). The editor's **Record** button and
``editor.animate(path)`` do this for the deformation on screen.
"""

import ffd_notebook as fn
from ffd_notebook.datasets import face

mesh = face()
lattice = fn.Lattice.around(mesh, (4, 5, 4), border="clamp")
s = lattice.spacing
lattice.offsets[0, 1, 3] = (-0.8 * s[0], 0.0, 0.3 * s[2])  # the chin pulled out on both sides
lattice.offsets[3, 1, 3] = (0.8 * s[0], 0.0, 0.3 * s[2])
lattice.offsets[:, 4, :] += (0.0, 0.5 * s[1], 0.0)  # the top layer up

fn.animate(mesh, fn.FFD(lattice), "face_deformation.gif", frames=16, fps=8, orbit=40, window_size=(480, 360))
