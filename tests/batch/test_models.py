"""The random models, the fold rule and the seeds, without Dask."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyvista import examples
from scipy import stats

from ffd_notebook import FFD, Lattice, save_ffd
from ffd_notebook.batch import FoldFree, LatticeFiles, RandomGP, RandomLattice, sample_rng
from ffd_notebook.batch.evaluate import PointEvaluator
from ffd_notebook.batch.folding import accept
from ffd_notebook.io import read_mesh


@pytest.fixture(scope="module")
def ant() -> np.ndarray:
    return np.asarray(read_mesh(examples.antfile).points, dtype=np.float64)


def test_offsets_are_uniform_with_torchio_meaning(ant):
    model = RandomLattice(num_control_points=(6, 7, 8), max_displacement=(1.0, 2.0, 3.0), locked_borders=0)
    bound = model.bind(ant)
    offsets = np.stack([bound.draw(sample_rng(0, i), i).ffd.lattice.offsets for i in range(40)])
    assert offsets.shape == (40, 6, 7, 8, 3)
    for axis, d in enumerate((1.0, 2.0, 3.0)):
        values = offsets[..., axis].ravel()
        assert np.abs(values).max() <= d
        assert stats.kstest(values, stats.uniform(-d, 2 * d).cdf).pvalue > 1e-3


@pytest.mark.parametrize("locked", [1, 2])
def test_locked_borders_hold_the_outer_layers(ant, locked):
    bound = RandomLattice(7, max_displacement=1.0, locked_borders=locked).bind(ant)
    offsets = bound.draw(sample_rng(3, 0), 0).ffd.lattice.offsets
    inner = offsets[locked:-locked, locked:-locked, locked:-locked]
    assert np.all(inner != 0)
    assert np.count_nonzero(np.any(offsets != 0, axis=-1)) == inner.shape[0] * inner.shape[1] * inner.shape[2]


def test_locked_borders_two_damps_the_bounding_box_faces(ant):
    """With B-splines the second layer sits on the box: a point on a face keeps only P2/6 (P0 = P1 = 0)."""
    bound = RandomLattice(6, max_displacement=3.0, locked_borders=2, margin=0.0).bind(ant)
    sample = bound.draw(sample_rng(1, 0), 0)
    lo = ant.min(axis=0)
    face = ant.copy()
    face[:, 0] = lo[0]  # project every vertex onto the box's -x face
    moved = sample.deform(face)
    assert np.abs(moved - face).max() <= 3.0 / 6 + 1e-12
    assert np.abs(sample.deform(ant) - ant).max() > 3.0 / 6


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"max_displacement": -1.0}, "max_displacement must be >= 0"),
        ({"num_control_points": 3}, "at least 4 control points"),
        ({"num_control_points": (4, 4)}, "one number or three"),
        ({"locked_borders": 3}, "locked_borders must be 0, 1 or 2"),
        ({"num_control_points": 4, "locked_borders": 2}, "locks every control point"),
        ({"basis": "nurbs"}, "basis must be one of"),
        ({"border": "mirror"}, "border must be one of"),
    ],
)
def test_bad_parameters_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RandomLattice(**kwargs)


def test_bernstein_needs_two_points_per_axis(ant):
    bound = RandomLattice(num_control_points=3, max_displacement=0.5, locked_borders=1, basis="bernstein").bind(ant)
    assert bound.draw(sample_rng(0, 0), 0).ffd.basis == "bernstein"


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**63), index=st.integers(0, 10**6), n=st.integers(1, 50))
def test_sample_seed_is_the_spawned_child(seed, index, n):
    """Sample i's generator does not depend on how many samples the run has."""
    children = np.random.SeedSequence(seed).spawn(index + n)
    expected = np.random.default_rng(children[index]).integers(0, 2**62, 4)
    assert np.array_equal(sample_rng(seed, index).integers(0, 2**62, 4), expected)


def test_redraw_accepts_only_fold_free_draws_and_counts_them(ant):
    bound = RandomLattice(5, max_displacement=25.0, locked_borders=0).bind(ant)
    rule = FoldFree(threshold=0.2, grid=0)
    redraws = []
    for i in range(8):
        got = accept(bound, i, sample_rng(0, i), lambda s: s.jacobian_determinant(ant).min(), rule)
        assert got.min_det_j > 0.2
        assert got.sample.jacobian_determinant(ant).min() == got.min_det_j
        redraws.append(got.redraws)
    assert sum(redraws) > 0  # the displacement is large enough that some draws fold


def test_scale_down_shrinks_until_it_passes(ant):
    bound = RandomLattice(5, max_displacement=40.0, locked_borders=0).bind(ant)
    first = bound.draw(sample_rng(0, 0), 0)
    assert first.jacobian_determinant(ant).min() <= 0.2
    got = accept(bound, 0, sample_rng(0, 0), lambda s: s.jacobian_determinant(ant).min(), FoldFree(0.2, 0, "scale"))
    assert got.scale_downs > 0 and got.redraws == 0
    assert got.sample.scale == pytest.approx(0.8**got.scale_downs)
    np.testing.assert_allclose(got.sample.ffd.lattice.offsets, first.ffd.lattice.offsets * got.sample.scale)


def test_too_many_tries_is_an_error(ant):
    bound = RandomLattice(5, max_displacement=400.0, locked_borders=0).bind(ant)
    with pytest.raises(ValueError, match="no fold-free draw in 3 tries"):
        accept(bound, 0, sample_rng(0, 0), lambda s: s.jacobian_determinant(ant).min(), FoldFree(0.5, 0, max_tries=3))


def test_cached_evaluator_matches_the_ffd(ant):
    bound = RandomLattice(6, max_displacement=2.0, locked_borders=1).bind(ant)
    fast = PointEvaluator(ant, bound.sample_ffd(bound.lattice.offsets))
    for i in range(3):
        sample = bound.draw(sample_rng(5, i), i)
        np.testing.assert_allclose(fast.deform(sample), sample.deform(ant), rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.jacobian_determinant(sample), sample.jacobian_determinant(ant), atol=1e-9)
    elsewhere = FFD(Lattice.around(ant + 1.0, shape=6))  # another placement: evaluated directly
    from ffd_notebook.batch.models import LatticeSample

    other = LatticeSample(elsewhere)
    assert np.array_equal(fast.deform(other), elsewhere.deform(ant))


@pytest.mark.parametrize("kernel", ["gaussian", "bspline"])
def test_gp_samples_are_smooth_fields_with_the_kernels_variance(ant, kernel):
    model = RandomGP(kernel=kernel, scale=0.5, sigma=20.0, num_control_points=6, rank=40, n_inducing=200)
    bound = model.bind(ant)
    draws = np.stack([bound.draw(sample_rng(0, i), i).deform(ant) - ant for i in range(300)])
    # pointwise variance of the samples ~ the model's variance (held by its rank)
    np.testing.assert_allclose(draws.var(axis=0).mean(), bound.process.variance().mean(), rtol=0.2)
    sample = bound.draw(sample_rng(0, 0), 0)
    det = sample.jacobian_determinant(ant)
    # central differences against a coarser independent difference quotient
    h = 1e-3
    shifted = sample.deform(ant + [h, 0, 0]) - sample.deform(ant - [h, 0, 0])
    assert np.all(np.isfinite(det)) and np.abs(det - 1).max() < 0.5
    assert np.abs(shifted[:, 0] / (2 * h) - 1).max() < 0.5


def test_gp_bad_parameters():
    with pytest.raises(ValueError, match="kernel must be one of"):
        RandomGP(kernel="matern")
    with pytest.raises(ValueError, match="scale must be a positive number"):
        RandomGP(scale=-1.0)


def test_lattice_files_read_each_file_and_name_a_bad_one(tmp_path, ant):
    lattice = Lattice.around(ant, shape=5)
    lattice.offsets[2, 2, 2] = (1.0, 0.0, 0.0)
    save_ffd(tmp_path / "a.ffd", lattice)
    model = LatticeFiles([tmp_path / "a.ffd"])
    sample = model.bind(None).draw(None, 0)
    assert np.array_equal(sample.deform(ant), FFD(lattice).deform(ant))
    (tmp_path / "bad.ffd").write_text("#dimension#\n3\n#control grid size#\n4 x 4\n")
    with pytest.raises(ValueError, match=r"bad\.ffd, line"):
        LatticeFiles([tmp_path / "a.ffd", tmp_path / "bad.ffd"])
    (tmp_path / "x.vtk").write_text("")
    with pytest.raises(ValueError, match=r"x\.vtk: unknown deformation file extension"):
        LatticeFiles([tmp_path / "a.ffd", tmp_path / "x.vtk"])
