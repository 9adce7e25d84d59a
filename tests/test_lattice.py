import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice


def random_rotation(rng, reflect=False):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q @ np.diag([1, 1, -1]) if reflect else q


def test_control_point_positions_follow_the_design_formula():
    rng = np.random.default_rng(3)
    rot = random_rotation(rng, reflect=True)
    lat = Lattice((3, 4, 5), spacing=(1.0, 2.0, 0.5), origin=(10, 20, 30), rotation=rot)
    cp = lat.control_points()
    assert cp.shape == (3, 4, 5, 3)
    for ijk in [(0, 0, 0), (2, 3, 4), (1, 2, 3)]:
        np.testing.assert_allclose(cp[ijk], lat.origin + rot @ (np.array(ijk) * lat.spacing))
    np.testing.assert_allclose(lat.to_lattice(cp.reshape(-1, 3)), lat.indices().reshape(-1, 3), atol=1e-12)
    np.testing.assert_allclose(lat.to_world(lat.indices().reshape(-1, 3)), cp.reshape(-1, 3), atol=1e-12)
    lat.offsets[1, 2, 3] = (1, 2, 3)
    np.testing.assert_allclose(lat.control_points(deformed=True)[1, 2, 3], cp[1, 2, 3] + (1, 2, 3))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"shape": (1, 2, 2), "spacing": 1}, "shape"),
        ({"shape": (2, 2), "spacing": 1}, "shape"),
        ({"shape": (2, 2, 2), "spacing": 0}, "spacing"),
        ({"shape": (2, 2, 2), "spacing": (1, -1, 1)}, "spacing"),
        ({"shape": (2, 2, 2), "spacing": 1, "rotation": np.diag([2, 1, 1])}, "orthogonal"),
        ({"shape": (2, 2, 2), "spacing": 1, "origin": (0, np.nan, 0)}, "origin"),
        ({"shape": (2, 2, 2), "spacing": 1, "offsets": np.zeros((2, 2, 3, 3))}, "offsets"),
    ],
)
def test_bad_arguments_raise_clear_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Lattice(**kwargs)


def test_offsets_are_writable_and_set_offsets_keeps_views():
    lat = Lattice((4, 4, 4), 1.0)
    view = lat.offsets[2, :, 3]
    view += (0, 0, 5)
    assert lat.offsets[2, 1, 3, 2] == 5
    lat.set_offsets(np.ones(lat.offsets.shape))
    assert view[0, 0] == 1
    lat.reset()
    assert not lat.offsets.any()


@settings(max_examples=40, deadline=None)
@given(
    st.tuples(*[st.integers(4, 8)] * 3),
    st.floats(0.0, 0.3),
    st.integers(0, 2**31),
    st.sampled_from([(1, 1, 1), (10, 0.1, 3), (1, 1e-9, 1)]),
)
def test_around_puts_every_point_where_weights_sum_to_one(shape, margin, seed, scale):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(200, 3)) * scale + rng.normal(size=3) * 100
    lat = Lattice.around(pts, shape=shape, margin=margin)
    uvw = lat.to_lattice(pts)
    assert np.all(uvw >= 1 - 1e-9) and np.all(uvw <= np.array(shape) - 2 + 1e-9)
    d = rng.normal(size=3)
    lat.offsets[...] = d
    np.testing.assert_allclose(FFD(lat).deform(pts), pts + d, atol=1e-9 * (1 + np.abs(pts).max()))


def test_around_for_bernstein_spans_the_box_and_accepts_meshes():
    class Mesh:  # anything with .points works, like a PyVista mesh
        points = np.array([[0.0, 0, 0], [4, 2, 1]])

    lat = Lattice.around(Mesh(), shape=(3, 3, 2), margin=0.0, basis="bernstein")
    np.testing.assert_allclose(lat.origin, 0)
    np.testing.assert_allclose(lat.control_points()[-1, -1, -1], [4, 2, 1])
    with pytest.raises(ValueError, match="at least 4"):
        Lattice.around(Mesh.points, shape=3)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        Lattice.around(np.zeros((0, 3)))


def test_edges_copy_equality_and_repr():
    lat = Lattice((2, 3, 4), 1.0)
    e = lat.edges()
    assert len(e) == 1 * 3 * 4 + 2 * 2 * 4 + 2 * 3 * 3
    cp = lat.control_points().reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(cp[e[:, 0]] - cp[e[:, 1]], axis=1), 1.0)
    other = lat.copy()
    assert other == lat
    other.offsets[0, 0, 0, 0] = 1
    assert other != lat and "moved=1/24" in repr(other)


def _near_rotation(error, seed=3):
    """A matrix of unit columns whose ``|M.T @ M - I|`` is about ``error``, near a random reflection."""
    rng = np.random.default_rng(seed)
    tilt = rng.uniform(-1.0, 1.0, (3, 3))
    tilt = (tilt + tilt.T) / 2 - np.diag(np.diag(tilt))
    m = random_rotation(rng, reflect=True) @ (np.eye(3) + tilt * error / np.abs(tilt).max() / 2)
    return m / np.linalg.norm(m, axis=0)


def _blender_lattice(m):
    from ffd_notebook.blender import ffd_from_record

    rest = np.stack(np.meshgrid(*[[-0.5, 0.0, 0.5]] * 3, indexing="ij"), axis=-1)
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = m * [2.0, 3.0, 4.0], (1.0, 2.0, 3.0)
    record = {"shape": (3, 3, 3), "rest": rest, "deformed": rest, "matrix_world": matrix,
              "interpolation": ("bspline",) * 3}  # fmt: skip
    return ffd_from_record(record).lattice


def _elastix_lattice(m, folder):
    from ffd_notebook.io import load_deformation, save_deformation

    path = folder / "TransformParameters.0.txt"
    save_deformation(path, FFD(Lattice((5, 5, 5), 2.0, origin=(-3.0, 1.0, 2.0))), format="elastix")
    text = path.read_text()
    written = " ".join(repr(float(v)) for v in m.T.ravel())
    text = "\n".join(f"(GridDirection {written})" if line.startswith("(GridDirection") else line
                     for line in text.splitlines())  # fmt: skip
    path.write_text(text)
    return load_deformation(path).lattice


def _itk_lattice(m, folder):
    import SimpleITK as sitk

    from ffd_notebook.io import load_transform

    transform = sitk.BSplineTransform(3, 3)
    transform.SetTransformDomainMeshSize((2, 2, 2))
    transform.SetTransformDomainPhysicalDimensions((4.0, 4.0, 4.0))
    transform.SetTransformDomainDirection(tuple(m.ravel()))
    sitk.WriteTransform(transform, str(folder / "t.tfm"))
    return load_transform(folder / "t.tfm").lattice


@pytest.mark.parametrize("error", [1e-7, 6e-7, 3e-6, 1e-4])
def test_every_reader_tells_rotations_from_sheared_grids_alike(tmp_path, error):
    """One tolerance: within it ITK, elastix, Blender and Lattice snap to the nearest rotation; beyond, none does."""
    from ffd_notebook.errors import FileFormatError
    from ffd_notebook.ffd.lattice import ROTATION_TOLERANCE, nearest_rotation, orthogonality_error

    m = _near_rotation(error)
    assert error / 3 < orthogonality_error(m) < 3 * error
    snapped = nearest_rotation(m)
    readers = {"lattice": lambda: Lattice((4, 4, 4), 1.0, rotation=m), "blender": lambda: _blender_lattice(m),
               "elastix": lambda: _elastix_lattice(m, tmp_path)}  # fmt: skip
    if orthogonality_error(m) <= ROTATION_TOLERANCE:
        assert orthogonality_error(snapped) < 1e-14 and np.abs(snapped - m).max() < ROTATION_TOLERANCE
        for name, read in {**readers, "itk": lambda: _itk_lattice(m, tmp_path)}.items():
            lattice = read()
            assert not lattice.sheared, name
            np.testing.assert_allclose(lattice.rotation, snapped, rtol=0, atol=1e-14, err_msg=name)
    else:
        assert snapped is None
        for name, read in readers.items():  # the ones that hold a sheared lattice
            lattice = read()
            assert lattice.sheared, name
            np.testing.assert_allclose(lattice.rotation, m, rtol=0, atol=1e-12, err_msg=name)
        with pytest.raises(FileFormatError, match="not orthogonal"):
            _itk_lattice(m, tmp_path)
