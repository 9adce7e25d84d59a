"""The clamp border rule in batch runs, the cached evaluator on every rule, and replaying ITK/PyGeM/.ffd files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pyvista import examples

from ffd_notebook import FFD, Lattice, load_ffd, save_ffd, save_prm, save_transform
from ffd_notebook.batch import FoldFree, LatticeFiles, RandomLattice, generate, read_manifest, replay, sample_rng
from ffd_notebook.batch.cli import build_parser, main
from ffd_notebook.batch.evaluate import PointEvaluator
from ffd_notebook.batch.models import LatticeSample
from ffd_notebook.io import load_deformation, read_mesh

ANT = examples.antfile


@pytest.fixture(scope="module")
def ant() -> np.ndarray:
    return np.asarray(read_mesh(ANT).points, dtype=np.float64)


def _compare(fast: PointEvaluator, sample: LatticeSample, points: np.ndarray) -> None:
    np.testing.assert_allclose(fast.deform(sample), sample.deform(points), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        fast.jacobian_determinant(sample), sample.jacobian_determinant(points), rtol=0, atol=1e-9
    )


def test_clamp_samples_take_the_cached_path_with_the_direct_results(ant):
    bound = RandomLattice(5, max_displacement=3.0, locked_borders=0, border="clamp", margin=0.0).bind(ant)
    assert bound.lattice.border == "clamp"
    outside = ant.min(axis=0) - [[2.0, 0.0, 0.0], [0.0, 5.0, 1.0]]  # beyond the lattice: clamped supports
    points = np.vstack([ant, outside])
    fast = PointEvaluator(points, bound.sample_ffd(bound.lattice.offsets))
    for i in range(3):
        sample = bound.draw(sample_rng(2, i), i)
        assert sample.ffd.border == "clamp"
        _compare(fast, sample, points)
        # clamped outer control points move the points beyond the lattice: not the zero rule's values
        assert not np.allclose(sample.deform(outside), FFD(sample.ffd.lattice, border="zero").deform(outside))
    assert fast._deformer is not None and fast._jacobian is not None  # the cached path was used


@pytest.mark.parametrize("border", ["zero", "clamp"])
def test_only_inside_samples_take_the_cached_path_with_the_direct_results(ant, border):
    lattice = Lattice.around(ant[::2], shape=6, border=border)  # half the vertices' box: some points lie outside
    center = ant.mean(axis=0)
    lattice.origin = center - 0.3 * np.ptp(ant, axis=0)
    lattice.spacing = 0.12 * np.ptp(ant, axis=0)
    template = FFD(lattice, only_inside=True)
    fast = PointEvaluator(ant, template)
    for i in range(2):
        moved = lattice.copy()
        moved.offsets = sample_rng(7, i).uniform(-0.5, 0.5, size=moved.offsets.shape)
        sample = LatticeSample(FFD(moved, only_inside=True))
        _compare(fast, sample, ant)
    assert np.any(sample.jacobian_determinant(ant) == 1.0)  # points outside the domain: identity
    assert fast._deformer is not None and fast._jacobian is not None
    # a sample with another rule than the template is evaluated directly, not with the template's cache
    other = LatticeSample(FFD(moved, only_inside=False))
    assert np.array_equal(fast.deform(other), other.deform(ant))


def test_clamp_run_records_the_border_and_replays(tmp_path, ant):
    extent = np.ptp(ant, axis=0).max()
    model = RandomLattice(5, max_displacement=0.1 * extent, locked_borders=0, border="clamp")
    rule = FoldFree(threshold=0.2, grid=6)
    result = generate(ANT, model, 3, tmp_path, seed=3, fold_free=rule, format="vtp", scheduler="sync", progress=False)
    assert [row["id"] for row in result.rows] == [0, 1, 2]
    for row in result.rows:
        path = tmp_path / row["parameters_file"]
        assert "#border#" in path.read_text()
        lattice = load_ffd(path)
        assert lattice.border == "clamp"
        direct = FFD(lattice).deform(ant)  # the file alone says how to deform: border and all
        saved = read_mesh(tmp_path / row["mesh_file"]).points
        np.testing.assert_allclose(saved, direct, rtol=0, atol=1e-9)
        assert np.array_equal(replay(tmp_path, row["id"]).points, saved)
        assert FFD(lattice).jacobian_determinant(ant).min() > rule.threshold
    # the clamp lattice hugs the mesh: no ring a spacing outside it, as with the zero rule
    assert model.bind(ant).lattice.origin[0] > RandomLattice(5, border="zero").bind(ant).lattice.origin[0]


def _deformation_files(folder: Path, points: np.ndarray) -> list[Path]:
    """A clamp .ffd, an ITK .tfm with an affine part and a PyGeM .prm, each deforming the points a little."""
    rng = np.random.default_rng(0)
    spread = np.ptp(points, axis=0).max()
    lattice = Lattice.around(points, shape=5, border="clamp")
    lattice.offsets = rng.uniform(-0.02, 0.02, size=lattice.offsets.shape) * spread
    save_ffd(folder / "a.ffd", lattice)
    lattice = Lattice.around(points, shape=6)
    lattice.offsets = rng.uniform(-0.02, 0.02, size=lattice.offsets.shape) * spread
    affine = np.eye(4)
    affine[:3, 3] = (0.01 * spread, 0.0, -0.01 * spread)
    save_transform(folder / "b.tfm", FFD(lattice, affine=affine))
    lattice = Lattice.around(points, shape=3, basis="bernstein")
    lattice.offsets = rng.uniform(-0.02, 0.02, size=lattice.offsets.shape) * spread
    save_prm(folder / "c.prm", lattice)
    return [folder / "a.ffd", folder / "b.tfm", folder / "c.prm"]


@pytest.mark.parametrize("first", [0, 1, 2])
def test_files_in_every_format_replay(tmp_path, ant, first):
    files = _deformation_files(tmp_path, ant)
    files = files[first:] + files[:first]  # each file in turn is the evaluators' template
    loaded = [load_deformation(f) for f in files]
    assert {(d.basis, d.border, d.only_inside) for d in loaded} == {
        ("bspline", "clamp", False), ("bspline", "zero", False), ("bernstein", "zero", True)
    }  # fmt: skip
    out = tmp_path / "out"
    result = generate(ANT, LatticeFiles(files), None, out, format="vtp", scheduler="sync", progress=False)
    assert [row["scale_downs"] for row in result.rows] == [0, 0, 0]
    assert read_manifest(out)["parameters_file"].tolist() == [str(f.resolve()) for f in files]
    for i, ffd in enumerate(loaded):
        saved = read_mesh(out / "meshes" / f"sample_{i:06d}.vtp").points
        np.testing.assert_allclose(saved, ffd.deform(ant), rtol=0, atol=1e-9)
        assert np.abs(saved - ant).max() > 0  # each file really moved the mesh
        assert np.array_equal(replay(out, i).points, saved)


def test_command_line_takes_every_format_and_clamp(tmp_path, ant):
    helptext = " ".join(build_parser().format_help().split())
    for word in (".ffd", ".tfm", ".h5", ".prm", "clamp"):
        assert word in helptext
    files = [str(f) for f in _deformation_files(tmp_path, ant)]
    args = ["--out", str(tmp_path / "f"), "--model", "files", "--scheduler", "sync", "--no-progress", "--files"]
    assert main([ANT, *args, *files]) == 0
    assert read_manifest(tmp_path / "f")["parameters_file"].tolist() == files
    with pytest.raises(SystemExit) as info:
        main([ANT, "--border", "clamp", *args, *files])
    assert info.value.code == 2  # a file says its own border
    clamp = ["--n", "2", "--out", str(tmp_path / "c"), "--border", "clamp", "--max-displacement", "1",
             "--num-control-points", "5", "--scheduler", "sync", "--no-progress"]  # fmt: skip
    assert main([ANT, *clamp]) == 0
    assert load_ffd(tmp_path / "c" / "parameters" / "sample_000001.ffd").border == "clamp"
