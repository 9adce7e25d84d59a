"""Points exactly on the faces of a B-spline's valid region: elastix's is open at its far faces, ITK's closed.

elastix (``AdvancedBSplineDeformableTransform``) moves a point when its grid index is in
``[1, n - 2)`` on every axis; ITK's ``BSplineTransform`` when it is in ``[1, n - 2]``. An FFD lowered
from an elastix file has ``only_inside="half-open"``, one read from an ITK file ``only_inside=True``;
each is checked against its tool (transformix, SimpleITK) on grids whose indices are exact in binary,
at the faces and one rounding step either side (issue 35 item 9).
"""

from __future__ import annotations

import numpy as np
import SimpleITK as sitk
from elastix_reference import TRANSFORMIX_ROUNDING, transformix_points

from ffd_notebook import FFD, Lattice, load_transform, save_transform
from ffd_notebook.io import load_deformation, load_elastix, save_elastix


def _face_points(lat: Lattice) -> np.ndarray:
    """Points on the faces at lattice coordinates 1 and n - 2 of each axis, and one rounding step either side."""
    rows = []
    middle = (np.array(lat.shape) - 1) / 2.0
    for axis in range(3):  # the lattice runs along x, y, z: axis a of the lattice is coordinate a
        for face in (1.0, lat.shape[axis] - 2.0):
            uvw = middle.copy()
            uvw[axis] = face
            point = lat.to_world(uvw[None])[0]
            for x in (point[axis], np.nextafter(point[axis], np.inf), np.nextafter(point[axis], -np.inf)):
                rows.append(point.copy())
                rows[-1][axis] = x
    corner = np.array(lat.shape, dtype=np.float64) - 2.0  # the far corner: on three far faces at once
    return np.vstack([np.array(rows), lat.to_world(np.array([corner, np.ones(3)]))])


def _exact_lattice() -> Lattice:
    """Power-of-two spacing, integer origin, axes along x, y, z: every grid index below is computed exactly."""
    lat = Lattice((6, 7, 5), (2.0, 1.0, 0.5), origin=(-4.0, 2.0, 1.0))
    lat.offsets[...] = np.random.default_rng(3).normal(0.0, 0.3, lat.offsets.shape)
    return lat


def test_elastix_lowered_ffd_leaves_the_far_faces_as_transformix_does(tmp_path):
    lat = _exact_lattice()
    path = tmp_path / "TransformParameters.0.txt"
    save_elastix(path, FFD(lat, only_inside=True))  # unpadded: the lattice is elastix's whole grid
    points = _face_points(lat)
    reference = transformix_points(path, points, tmp_path / "out")
    lowered = load_deformation(path)
    assert lowered.only_inside == "half-open"
    moved = np.abs(reference - points).max(axis=1) > 1e-3
    u = lat.to_lattice(points)
    far = (u == np.array(lat.shape) - 2.0).any(axis=1)  # exactly on a far face (a step outward may round onto it)
    near = (u == 1.0).any(axis=1) & ~far
    assert far.sum() >= 4 and not moved[far].any(), "transformix leaves points on the far faces"
    assert near.sum() >= 4 and moved[near].all(), "and moves those on the near faces"
    tolerance = TRANSFORMIX_ROUNDING * 1.01
    for deformation in (lowered, load_elastix(path)):
        np.testing.assert_allclose(deformation.deform(points), reference, rtol=0, atol=tolerance)
    # the same FFD as an ITK file: ITK's domain is closed, SimpleITK moves the far faces. (Only the points
    # on the faces: ITK's grid index of a point one rounding step off a face rounds its own way.)
    tfm = tmp_path / "t.tfm"
    save_transform(tfm, FFD(lat, only_inside=True))
    transform = sitk.ReadTransform(str(tfm))
    on_faces = points[far | near]
    itk = np.array([transform.TransformPoint(tuple(p)) for p in on_faces])
    assert (np.abs(itk - on_faces).max(axis=1) > 1e-3).all()
    itk_ffd = load_transform(tfm)
    assert itk_ffd.only_inside is True
    np.testing.assert_allclose(itk_ffd.deform(on_faces), itk, rtol=0, atol=1e-9)
