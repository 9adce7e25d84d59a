import numpy as np
import pytest
import SimpleITK as sitk
from hypothesis import given, settings
from hypothesis import strategies as st
from reference_ffd import bernstein_loop, deform_loop
from test_lattice import random_rotation

from ffd_notebook import FFD, Lattice


def random_lattice(seed, shape=(6, 5, 7), reflect=True, scale=0.5):
    rng = np.random.default_rng(seed)
    lat = Lattice(
        shape,
        spacing=rng.uniform(0.5, 3, 3),
        origin=rng.normal(size=3) * 10,
        rotation=random_rotation(rng, reflect=reflect),
    )
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * scale
    return lat


def sitk_transform(lat):
    """SimpleITK's order-3 BSplineTransform on the same grid: mesh size n - 3, domain one spacing in."""
    n = np.array(lat.shape)
    tx = sitk.BSplineTransform(3, 3)
    tx.SetTransformDomainOrigin(tuple(lat.origin + lat.rotation @ lat.spacing))
    tx.SetTransformDomainPhysicalDimensions(tuple((n - 3) * lat.spacing))
    tx.SetTransformDomainMeshSize(tuple(int(m) for m in n - 3))
    tx.SetTransformDomainDirection(tuple(lat.rotation.ravel()))
    # ITK images run x fastest: offsets[i, j, k] -> index (i, j, k) in an (nz, ny, nx) C array
    tx.SetParameters(tuple(np.concatenate([lat.offsets[..., d].transpose(2, 1, 0).ravel() for d in range(3)])))
    return tx


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.tuples(*[st.integers(4, 8)] * 3), st.booleans())
def test_bspline_ffd_equals_simpleitk(seed, shape, reflect):
    lat = random_lattice(seed, shape, reflect)
    tx = sitk_transform(lat)
    assert tx.GetCoefficientImages()[0].GetSize() == lat.shape
    rng = np.random.default_rng(seed + 1)
    # SimpleITK's domain is where the whole 4x4x4 support is inside the grid: u in [1, n - 2]
    pts = lat.to_world(rng.uniform(1, np.array(shape) - 2, size=(100, 3)))
    ours = FFD(lat).deform(pts)
    theirs = np.array([tx.TransformPoint(tuple(p)) for p in pts])
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)


def test_bspline_matches_report_loop_everywhere_including_outside():
    lat = random_lattice(7, reflect=True)
    rng = np.random.default_rng(8)
    # points well outside too: neighbours outside the lattice contribute zero
    pts = lat.to_world(rng.uniform(-4, np.array(lat.shape) + 3, size=(300, 3)))
    affine = np.eye(4)
    affine[:3, :3] = rng.normal(size=(3, 3))
    affine[:3, 3] = rng.normal(size=3)
    ref = deform_loop(pts, lat.offsets, lat.spacing, lat.origin, lat.rotation, affine)
    np.testing.assert_allclose(FFD(lat, affine=affine).deform(pts), ref, atol=1e-12)
    far = lat.to_world([[-5.0, 1, 1], [30, 30, 30]])
    np.testing.assert_allclose(FFD(lat).displacement(far), 0)


def test_bernstein_matches_sederberg_parry_loop():
    lat = random_lattice(9, shape=(3, 4, 2))
    rng = np.random.default_rng(10)
    pts = lat.to_world(rng.uniform(0, np.array(lat.shape) - 1, size=(60, 3)))
    ref = bernstein_loop(pts, lat.offsets, lat.spacing, lat.origin, lat.rotation)
    np.testing.assert_allclose(FFD(lat, basis="bernstein").deform(pts), ref, atol=1e-12)
    lat.reset()
    np.testing.assert_allclose(FFD(lat, basis="bernstein").deform(pts), pts, atol=1e-12)


@pytest.mark.parametrize("basis, shape", [("bspline", (5, 6, 4)), ("bernstein", (3, 4, 3))])
def test_jacobian_matches_finite_differences(basis, shape):
    lat = random_lattice(11, shape=shape, scale=0.3)
    affine = np.diag([1.2, 0.9, 1.0, 1.0])
    ffd = FFD(lat, basis=basis, affine=affine)
    rng = np.random.default_rng(12)
    lo = 1 if basis == "bspline" else 0
    pts = lat.to_world(rng.uniform(lo + 0.05, np.array(shape) - 1 - lo - 0.05, size=(40, 3)))
    h = 1e-6
    fd = np.stack([(ffd.deform(pts + h * e) - ffd.deform(pts - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(ffd.jacobian(pts), fd, atol=1e-6)
    np.testing.assert_allclose(ffd.jacobian_determinant(pts), np.linalg.det(fd), atol=1e-5)


def test_folding_is_found_by_the_jacobian_determinant():
    pts = np.random.default_rng(0).random((2000, 3))
    lat = Lattice.around(pts, shape=5)
    ffd = FFD(lat)
    assert np.all(ffd.jacobian_determinant(pts) > 0.99)
    lat.offsets[2, :, :, 0] -= 2.5 * lat.spacing[0]  # drag a layer past its neighbours
    det = ffd.jacobian_determinant(pts)
    assert (det <= 0).any() and (det > 0).any()


@pytest.mark.parametrize("basis", ["bspline", "bernstein"])
@pytest.mark.parametrize("dtype, tol", [(np.float64, 1e-11), (np.float32, 2e-6)])
def test_deformer_full_and_incremental_updates_match_deform(basis, dtype, tol):
    rng = np.random.default_rng(13)
    pts = rng.normal(size=(3000, 3))
    pts[:50] *= 5  # some points outside the lattice
    lat = Lattice.around(pts[50:], shape=(6, 5, 7), basis=basis)
    ffd = FFD(lat, basis=basis, affine=np.diag([1.0, 2.0, 1.0, 1.0]))
    deformer = ffd.bind(pts, dtype=dtype)
    rtol = tol  # float32 weights: error relative to the size of the (extrapolated) displacement
    tol *= 1 + np.abs(ffd.deform(pts) - pts).max()
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts), rtol=rtol, atol=tol)
    for _ in range(20):
        ijk = tuple(int(rng.integers(n)) for n in lat.shape)
        lat.offsets[ijk] += rng.normal(size=3) * 0.2
        got = deformer.update(changed=[ijk])
        np.testing.assert_allclose(got, ffd.deform(pts), rtol=rtol * 10, atol=tol * 10)
    lat.offsets[...] += rng.normal(size=lat.offsets.shape) * 0.1
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts), rtol=rtol, atol=tol)
    # geometry or affine changes are noticed and rebind
    ffd.affine = np.eye(4)
    np.testing.assert_allclose(deformer.update(changed=[(0, 0, 0)]), ffd.deform(pts), rtol=rtol, atol=tol)
    lat.spacing = lat.spacing * 1.1
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts), rtol=rtol, atol=tol)
    with pytest.raises(IndexError):
        deformer.update(changed=[(99, 0, 0)])


@pytest.mark.parametrize("basis", ["bspline", "bernstein"])
def test_deformer_jacobian_determinant_matches_the_ffd(basis):
    rng = np.random.default_rng(21)
    pts = rng.normal(size=(2000, 3))
    pts[:20] *= 4  # some outside the lattice
    lat = Lattice.around(pts[20:], shape=(6, 5, 5), basis=basis)
    ffd = FFD(lat, basis=basis, affine=np.diag([1.1, 0.9, 1.0, 1.0]))
    deformer = ffd.bind(pts)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * lat.spacing * 1.5  # enough to fold somewhere
    det = deformer.jacobian_determinant()
    np.testing.assert_allclose(det, np.linalg.det(ffd.jacobian(pts)), rtol=1e-9, atol=1e-9)
    assert (det <= 0).any() and (det > 0).any()


def test_deformer_cache_is_small():
    pts = np.random.default_rng(0).random((10000, 3))
    d = FFD(Lattice.around(pts, shape=8)).bind(pts)
    assert d.cache_bytes / len(pts) < 100


def test_ffd_argument_checks():
    lat = Lattice((3, 4, 4), 1.0)
    with pytest.raises(ValueError, match="at least 4"):
        FFD(lat)
    with pytest.raises(ValueError, match="basis"):
        FFD(lat, basis="nurbs")
    with pytest.raises(ValueError, match="affine"):
        FFD(lat, basis="bernstein", affine=np.ones((4, 4)))
    with pytest.raises(TypeError):
        FFD("lattice")
    np.testing.assert_allclose(FFD(lat, "bernstein", affine=np.eye(4)[:3]).affine, np.eye(4))


@pytest.mark.parametrize("basis", ["bspline", "bernstein"])
def test_deformer_follows_the_ffd_s_weights_unless_it_has_its_own(basis):
    """Weights set on the FFD after binding (or edited in place) reach the deformer, as its strength does."""
    rng = np.random.default_rng(23)
    pts = rng.normal(size=(600, 3))
    lat = Lattice.around(pts, shape=5, basis=basis)
    lat.offsets[...] = rng.normal(size=lat.offsets.shape) * 0.3
    ffd = FFD(lat, basis=basis)
    deformer = ffd.bind(pts, dtype=np.float64)
    for weights in (rng.random(600), None, rng.random(600)):
        ffd.weights = weights
        np.testing.assert_allclose(deformer.current(), ffd.deform(pts), rtol=0, atol=1e-12)
        lat.offsets[2, 2, 2] += 0.1
        np.testing.assert_allclose(deformer.update([(2, 2, 2)]), ffd.deform(pts), rtol=0, atol=1e-12)
        np.testing.assert_allclose(deformer.jacobian_determinant(), ffd.jacobian_determinant(pts), rtol=0, atol=1e-9)
    ffd.weights[:300] = 0.0  # the FFD's array edited in place
    np.testing.assert_allclose(deformer.update([(1, 1, 1)]), ffd.deform(pts), rtol=0, atol=1e-12)
    assert np.array_equal(deformer.weights, ffd.weights)
    ffd.weights = np.ones(5)  # weights for another point set: refused when used, and again next time
    for _ in range(2):
        with pytest.raises(ValueError, match="one number per point"):
            deformer.update()
    ffd.weights = None
    # weights of its own (given at binding, or set) stay whatever the FFD's become
    half = np.full(600, 0.5)
    own = ffd.bind(pts, dtype=np.float64, weights=half)
    ffd.weights = rng.random(600)
    np.testing.assert_allclose(own.update(), ffd.deform(pts, weights=half), rtol=0, atol=1e-12)
    deformer.weights = half
    ffd.weights = None
    np.testing.assert_allclose(deformer.update(), ffd.deform(pts, weights=half), rtol=0, atol=1e-12)
