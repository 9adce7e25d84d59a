"""The boundary of a tetrahedral mesh: the triangles that belong to one tetrahedron only.

A face shared by two tetrahedra is inside the organ; a face without a neighbour is on its surface.
The surface triangles are oriented outwards (away from the tetrahedron's fourth vertex), so their
normals shade correctly.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["boundary_faces"]

# the four faces of tetrahedron (a, b, c, d), each listed with the vertex opposite to it
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
_OPPOSITE = np.array([0, 1, 2, 3])


def boundary_faces(tets: ArrayLike, points: ArrayLike | None = None) -> NDArray[np.int64]:
    """Triangles of the tetrahedra faces that have no neighbouring tetrahedron.

    Parameters
    ----------
    tets : array_like
        ``(T, 4)`` point indices of the tetrahedra.
    points : array_like, optional
        ``(N, 3)`` point coordinates; when given, every triangle is oriented with its normal
        pointing away from the opposite vertex of its tetrahedron (outwards).

    Returns
    -------
    numpy.ndarray
        ``(F, 3)`` point indices of the surface triangles, in tetrahedron order.

    Examples
    --------
    Two tetrahedra glued on the face (1, 2, 3) have six boundary faces:

    >>> pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    >>> faces = boundary_faces([[0, 1, 2, 3], [4, 1, 2, 3]], pts)
    >>> len(faces), bool(np.any(np.all(np.sort(faces, axis=1) == [1, 2, 3], axis=1)))
    (6, False)
    """
    t = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    faces = t[:, _FACES].reshape(-1, 3)  # (4T, 3), face f of tet i at row 4i + f
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    single = counts[inverse.ravel()] == 1
    out = faces[single]
    if points is not None and len(out):
        p = np.asarray(points, dtype=np.float64)
        opposite = t[:, _OPPOSITE].reshape(-1)[single]
        a, b, c = p[out[:, 0]], p[out[:, 1]], p[out[:, 2]]
        normal = np.cross(b - a, c - a)
        inward = np.einsum("ij,ij->i", normal, p[opposite] - a) > 0
        out[inward] = out[inward][:, [0, 2, 1]]
    return out
