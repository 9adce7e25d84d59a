"""Where a lattice from a .ffd file sits in space.

A .ffd file places its lattice with an optional ``#quaternion qf,qb,qc,qd,qx,qy,qz#`` section in the
NIfTI-1 qform convention: with ``a = sqrt(1 - b^2 - c^2 - d^2)`` and ``R`` the rotation of the unit
quaternion ``(a, b, c, d)``, control point ``(i, j, k)`` rests at
``R @ (i*sx, j*sy, qf*k*sz) + (qx, qy, qz)``. As a :class:`~ffd_notebook.Lattice` that is
``origin = (qx, qy, qz)`` and ``rotation = R @ diag(1, 1, qf)`` (a reflection when ``qf = -1``).

Without that section the FFD platform put control point (0, 0, 0) at the minimum corner of the
mesh's bounding box, axis-aligned: :func:`place_at_mesh_minimum` does the same.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from ..ffd.lattice import Lattice

__all__ = ["place_at_mesh_minimum", "quaternion_to_rotation", "rotation_to_quaternion"]


def quaternion_to_rotation(qf: float, qb: float, qc: float, qd: float) -> NDArray[np.float64]:
    """Lattice rotation (columns = lattice axes in world space) from NIfTI qform parameters.

    Follows ``nifti_quatern_to_mat44``: if ``b^2 + c^2 + d^2`` is 1 or more (up to rounding),
    ``(b, c, d)`` is normalised and ``a = 0``; ``qf < 0`` flips the third axis, otherwise it is 1.

    Examples
    --------
    >>> quaternion_to_rotation(-1.0, 0.0, 1.0, 0.0).tolist()   # the real registration file
    [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    >>> quaternion_to_rotation(1.0, 0.0, 0.0, 0.0).tolist() == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    True
    """
    b, c, d = float(qb), float(qc), float(qd)
    a = 1.0 - (b * b + c * c + d * d)
    if a < 1e-7:
        scale = 1.0 / np.sqrt(b * b + c * c + d * d)
        b, c, d, a = b * scale, c * scale, d * scale, 0.0
    else:
        a = float(np.sqrt(a))
    r = np.array(
        [
            [a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
            [2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)],
            [2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b],
        ]
    )
    r[:, 2] *= -1.0 if qf < 0 else 1.0
    return r + 0.0  # no negative zeros: -0.0 would print differently after a round trip


def rotation_to_quaternion(rotation: ArrayLike) -> tuple[float, float, float, float]:
    """NIfTI qform parameters ``(qf, qb, qc, qd)`` of an orthogonal lattice rotation.

    ``qf`` is the sign of the determinant; the proper rotation ``rotation @ diag(1, 1, qf)`` goes
    through :class:`scipy.spatial.transform.Rotation`, with the quaternion's ``a >= 0``. Turning
    the result back with :func:`quaternion_to_rotation` gives the matrix again up to rounding
    (a float matrix is in general not exactly the image of any float quaternion). The format
    stores ``b, c, d`` but not ``a``, so close to a half turn (small ``a``) the error grows like
    ``1e-16 / a``, and rotations with ``a**2 < 1e-7`` come back as the exact half turn (NIfTI rule).

    Examples
    --------
    >>> import numpy as np
    >>> rot = np.diag([-1.0, 1.0, 1.0])
    >>> [abs(v) for v in rotation_to_quaternion(rot)]
    [1.0, 0.0, 1.0, 0.0]
    >>> bool(np.allclose(quaternion_to_rotation(*rotation_to_quaternion(rot)), rot))
    True
    """
    from scipy.spatial.transform import Rotation

    m = np.asarray(rotation, dtype=np.float64)
    qf = -1.0 if np.linalg.det(m) < 0 else 1.0
    proper = m * np.array([1.0, 1.0, qf])  # = m @ diag(1, 1, qf)
    x, y, z, w = Rotation.from_matrix(proper).as_quat()
    if w < 0:
        x, y, z = -x, -y, -z
    return qf, float(x) + 0.0, float(y) + 0.0, float(z) + 0.0


def place_at_mesh_minimum(lattice: Lattice, points_or_mesh: Any) -> Lattice:
    """Place a lattice the way the FFD platform did for a .ffd file without placement.

    Control point (0, 0, 0) goes to the minimum corner of the mesh's axis-aligned bounding box, the
    lattice axes are the world axes and the file's spacing is kept. Returns a new lattice (offsets
    and other metadata copied); ``metadata["placement"]`` becomes ``None`` since the old
    placement no longer applies.

    Parameters
    ----------
    lattice : Lattice
        Typically the result of :func:`~ffd_notebook.io.load_ffd` on a file without quaternion.
    points_or_mesh : array_like or mesh
        ``(N, 3)`` points, or anything with a ``points`` attribute (a PyVista mesh).

    Returns
    -------
    Lattice
        The placed copy.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> lat = Lattice((4, 4, 4), spacing=2.0)
    >>> pts = np.array([[1.0, 5.0, -2.0], [3.0, 6.0, 0.0]])
    >>> placed = place_at_mesh_minimum(lat, pts)
    >>> placed.origin.tolist(), placed.spacing.tolist()
    ([1.0, 5.0, -2.0], [2.0, 2.0, 2.0])
    """
    pts = as_points(points_or_mesh)
    placed = lattice.copy()
    placed.origin = pts.min(axis=0)
    placed.rotation = np.eye(3)
    placed.metadata["placement"] = None
    return placed
