"""fit_lattice: exact recovery, the separable path against the general one, regions, weights, residuals."""

from __future__ import annotations

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.io import fit_lattice, sample_displacement_field
from ffd_notebook.io.lattice_fitting import _sparse_fit

ROTATED = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
GRID = {"size": (21, 18, 15), "spacing": (1.0, 1.2, 1.5), "origin": (4.0, -2.0, 1.0), "direction": ROTATED}


def _truth(shape=(7, 6, 5), seed=0) -> Lattice:
    lat = Lattice(shape, (4.0, 5.0, 6.0), origin=(4.0, -2.0, 1.0) - ROTATED @ np.array([4.0, 5.0, 6.0]),
                  rotation=ROTATED)  # fmt: skip
    lat.offsets[...] = np.random.default_rng(seed).normal(0.0, 1.0, lat.offsets.shape)
    return lat


def test_field_from_the_same_lattice_is_recovered_exactly():
    truth = _truth()
    field = sample_displacement_field(FFD(truth), GRID)
    fitted = fit_lattice(field, truth)
    assert np.abs(fitted.lattice.offsets - truth.offsets).max() < 1e-9
    assert fitted.lattice.metadata["fit"]["max"] < 1e-10 and fitted.lattice.metadata["fit"]["samples"] == 21 * 18 * 15
    assert np.array_equal(fitted.affine, np.eye(4))


def test_separable_solve_equals_the_general_least_squares():
    """A deformation no lattice holds: both paths give the same least-squares offsets."""

    def swirl(p):
        c = p - [14.0, 8.0, 11.0]
        return p + 0.8 * np.sin(c[:, [1, 2, 0]] / 4.0)

    field = sample_displacement_field(swirl, GRID)
    fitted = fit_lattice(field, (6, 6, 5))
    assert fitted.lattice.metadata["fit"]["rms"] > 1e-3  # not exact: the residual is real
    points = field.grid_points()
    general, _, residual = _sparse_fit(points, swirl(points), fitted.lattice.copy(), None, False)
    assert np.abs(general - fitted.lattice.offsets).max() < 1e-7
    lengths = np.linalg.norm(residual, axis=1)
    assert np.isclose(np.sqrt(np.mean(lengths**2)), fitted.lattice.metadata["fit"]["rms"], rtol=1e-6)
    assert np.isclose(lengths.max(), fitted.lattice.metadata["fit"]["max"], rtol=1e-6)


def test_mesh_points_region_recovers_an_ffd_with_its_affine_part():
    truth = _truth((6, 6, 6), seed=1)
    affine = np.array([[1.1, 0.1, 0.0, 2.0], [0.0, 0.9, 0.05, -1.0], [0.02, 0.0, 1.05, 0.5], [0, 0, 0, 1]])
    ffd = FFD(truth, affine=affine)
    points = truth.to_world(np.random.default_rng(2).random((4000, 3)) * 3 + 1)  # the lattice's domain
    fitted = fit_lattice(ffd, truth, region=points, affine=True)
    assert fitted.lattice.metadata["fit"]["max"] < 1e-8
    probe = truth.to_world(np.random.default_rng(3).random((500, 3)) * 3 + 1)
    assert np.abs(fitted.deform(probe) - ffd.deform(probe)).max() < 1e-8
    assert not np.array_equal(fitted.affine, np.eye(4))
    plain = fit_lattice(ffd, truth, region=points)  # without the affine part: the lattice takes it all
    assert np.array_equal(plain.affine, np.eye(4)) and plain.lattice.metadata["fit"]["max"] < 1e-8


def test_mask_and_weights_choose_what_is_matched():
    truth = _truth()
    field = sample_displacement_field(FFD(truth), GRID)
    field.vectors[:5] += 10.0  # a corrupt slab
    mask = np.ones(field.shape, bool)
    mask[:5] = False
    masked = fit_lattice(field, truth, region=mask)
    weights = mask.astype(float)
    weighted = fit_lattice(field, truth, weights=weights)
    whole = fit_lattice(field, truth)
    inside = field.grid_points()[mask.reshape(-1)]
    exact = FFD(truth).deform(inside)
    assert np.abs(masked.deform(inside) - exact).max() < 1e-8
    assert np.abs(weighted.deform(inside) - exact).max() < 1e-8
    assert np.abs(whole.deform(inside) - exact).max() > 0.1
    assert masked.lattice.metadata["fit"]["samples"] == int(mask.sum())


def test_a_callable_and_bad_input():
    points = np.random.default_rng(4).random((300, 3)) * 10
    fitted = fit_lattice(lambda p: p + [1.0, 0.0, -2.0], 5, region=points)
    assert np.abs(fitted.deform(points) - points - [1.0, 0.0, -2.0]).max() < 1e-9
    with pytest.raises(ValueError, match="a region is needed"):
        fit_lattice(lambda p: p, 5)
    with pytest.raises(ValueError, match="at least 4"):
        fit_lattice(lambda p: p, (3, 5, 5), region=points)
    with pytest.raises(ValueError, match="non-negative"):
        fit_lattice(lambda p: p, 5, region=points, weights=-np.ones(300))
    with pytest.raises(ValueError, match="mask region must have the field's shape"):
        fit_lattice(sample_displacement_field(lambda p: p, GRID), 5, region=np.ones((2, 2, 2), bool))


def test_a_gaussian_process_sample_on_mesh_points():
    import pyvista as pv

    from ffd_notebook.gp import GaussianKernel, GaussianProcess

    points = pv.Sphere(radius=5.0, theta_resolution=24, phi_resolution=18).points.astype(np.float64)
    sample = GaussianProcess(GaussianKernel(4.0, 0.5)).sample(points, rng=0)[0]
    fitted = fit_lattice(sample, (7, 7, 7), region=points)
    report = fitted.lattice.metadata["fit"]
    moved = fitted.deform(points) - points
    assert np.isclose(np.sqrt(np.mean(np.sum((moved - sample) ** 2, axis=1))), report["rms"], rtol=1e-6)
    assert report["rms"] < 0.1 * np.sqrt(np.mean(np.sum(sample**2, axis=1)))  # a smooth sample: a good fit
    with pytest.raises(ValueError, match="match the region's points"):
        fit_lattice(sample[:10], 5, region=points)


def test_scattered_points_solve_for_the_control_points_they_reach_only(monkeypatch):
    """A 100^3 lattice around 20 points: the factorised system has at most 20 * 64 unknowns, not a million."""
    import scipy.sparse.linalg

    factorise = scipy.sparse.linalg.splu
    sizes = []

    def spy(matrix, *args, **kwargs):
        sizes.append(matrix.shape[0])
        if matrix.shape[0] > 20 * 64:
            raise AssertionError(f"a {matrix.shape[0]}-unknown system for 20 points")
        return factorise(matrix, *args, **kwargs)

    monkeypatch.setattr(scipy.sparse.linalg, "splu", spy)
    points = np.random.default_rng(5).random((20, 3)) * 10
    fitted = fit_lattice(lambda p: p + 0.1 * np.sin(p[:, [1, 2, 0]]), 100, region=points)
    assert 0 < sizes[0] <= 20 * 64
    assert fitted.lattice.metadata["fit"]["max"] < 1e-9  # 20 points, a thousand unknowns: met exactly
    moved = np.argwhere(fitted.lattice.offsets.any(axis=-1))
    assert 0 < len(moved) <= sizes[0]  # every other control point keeps a zero offset


def test_a_system_that_would_not_fit_is_refused_with_its_size():
    points = np.random.default_rng(6).random((5000, 3))  # filling the box: they reach almost every control point
    with pytest.raises(ValueError, match=r"reach 6\d{4} control points of the 40x40x40 lattice.*GiB"):
        fit_lattice(lambda p: p, 40, region=points)
    with pytest.raises(ValueError, match=r"2000x2000x2000 lattice's offsets alone would take 179 GiB"):
        fit_lattice(lambda p: p, 2000, region=points)


def test_sheared_and_permuted_grids_take_the_separable_solve(monkeypatch):
    """A field on a sheared grid (NiftyReg, FSL, elastix affine-then-B-spline) and a lattice whose axes run along
    the grid's in another order, flipped: the per-axis solve of the engine's grid pairing, exactly."""
    from ffd_notebook.io import lattice_fitting

    def general(*args, **kwargs):
        raise AssertionError("the scattered-points solve ran where the separable one holds")

    monkeypatch.setattr(lattice_fitting, "_sparse_fit", general)
    shear = np.array([[1.0, 0.3, 0.1], [0.0, 1.0, -0.2], [0.0, 0.0, 1.0]])
    shear /= np.linalg.norm(shear, axis=0)
    grid = {"size": (17, 15, 13), "spacing": (1.0, 1.3, 0.8), "origin": (2.0, -1.0, 3.0), "direction": shear}
    axes = shear[:, [2, 0, 1]] * [1.0, -1.0, 1.0]  # lattice x along the grid's k, y along -i, z along j
    spacing = np.array([3.0, 5.0, 4.0])
    truth = Lattice((6, 7, 8), spacing, origin=(4.0, 9.0, 0.0), rotation=axes)
    truth.offsets[...] = np.random.default_rng(4).normal(0.0, 1.0, truth.offsets.shape)
    field = sample_displacement_field(FFD(truth), grid)
    fitted = fit_lattice(field, truth)
    assert fitted.lattice.metadata["fit"]["max"] < 1e-9
    reached = np.abs(field.vectors).max() > 0.5  # the field is not zero: the recovery means something
    assert reached
    new = fit_lattice(field, (7, 6, 6))  # a new lattice over a sheared field: its axes are the grid's
    assert new.lattice.sheared and np.allclose(new.lattice.rotation, shear)
