"""
The border rule
===============

Move every control point of a lattice by one unit along x: at a point ``x`` the mesh then moves by the
sum of the B-spline weights there. With ``border="zero"`` (ITK's rule) control points beyond the lattice
count nothing, so the sum drops to zero in the outer cells; with ``border="clamp"`` (Blender's) the border
points are copied outward and the sum is one everywhere.
"""

import matplotlib.pyplot as plt
import numpy as np

import ffd_notebook as fn

x = np.linspace(-0.5, 4.5, 501)
points = np.column_stack([x, np.full_like(x, 2.0), np.full_like(x, 2.0)])

fig, ax = plt.subplots(figsize=(7, 3.2))
for border in ("zero", "clamp"):
    lattice = fn.Lattice((5, 5, 5), 1.0, border=border)
    lattice.offsets[..., 0] = 1.0
    moved = fn.FFD(lattice).deform(points) - points
    ax.plot(x, moved[:, 0], label=f'border="{border}"')
ax.scatter(np.arange(5), np.zeros(5), color="k", zorder=3, label="control points (rest)")
ax.set_xlabel("x (lattice spacing 1)")
ax.set_ylabel("sum of the weights")
ax.legend(loc="center")
fig.tight_layout()
plt.show()
