import numpy as np
from scipy.spatial import Delaunay

from ffd_notebook.solidtex import boundary_faces


def _signed_volume(points, faces):
    a, b, c = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def test_boundary_of_a_delaunay_ball_is_its_convex_hull_oriented_outwards():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(300, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    p = np.vstack([p, 0.5 * rng.random((100, 3)) - 0.25])
    tri = Delaunay(p)
    faces = boundary_faces(tri.simplices, p)
    hull = np.sort(tri.convex_hull, axis=1)
    assert {tuple(f) for f in np.sort(faces, axis=1)} == {tuple(h) for h in hull}
    tet_volume = (
        np.abs(
            np.einsum(
                "ij,ij->i",
                p[tri.simplices[:, 1]] - p[tri.simplices[:, 0]],
                np.cross(
                    p[tri.simplices[:, 2]] - p[tri.simplices[:, 0]], p[tri.simplices[:, 3]] - p[tri.simplices[:, 0]]
                ),
            )
        ).sum()
        / 6
    )
    assert np.isclose(_signed_volume(p, faces), tet_volume)
    # every edge of a closed surface is shared by exactly two triangles, in opposite directions
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    assert len({tuple(e) for e in edges}) == len(edges)
    assert {tuple(e) for e in edges} == {tuple(e[::-1]) for e in edges}


def test_interior_faces_disappear():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    assert len(boundary_faces([[0, 1, 2, 3]], pts)) == 4
    assert len(boundary_faces([[0, 1, 2, 3], [4, 3, 2, 1]])) == 6
