"""Batch runs from deformation files keep every option the files hold, and the files are part of a run's identity.

Every format :func:`~ffd_notebook.io.save_deformation` writes a lattice in, with every option it can hold (strength,
Blender's "outside" mode and per-axis interpolations, the clamp border in .ffd files; PyGeM's Bernstein box; ITK,
elastix and NiftyReg transforms with an affine part), gives samples equal to the FFD that was saved, on the cached
evaluators as on the direct path, after a fold check's scaling too, and in ``replay``. (FNIRT coefficients need the
images they map between, which a list of files does not give: load_deformation refuses them alone.)
"""

from __future__ import annotations

import numpy as np
import pytest
from pyvista import examples

from ffd_notebook import FFD, Lattice
from ffd_notebook.batch import LatticeFiles, RandomGP, generate, replay
from ffd_notebook.batch.cli import _model, build_parser
from ffd_notebook.batch.evaluate import PointEvaluator
from ffd_notebook.io import load_deformation, read_mesh, save_deformation

ANT = examples.antfile


@pytest.fixture(scope="module")
def ant() -> np.ndarray:
    return np.asarray(read_mesh(ANT).points, dtype=np.float64)


def _random_ffd(points, rng, *, shape=5, size=0.03, basis="bspline", border="zero", **options) -> FFD:
    lattice = Lattice.around(points, shape=shape, basis="bernstein" if basis == "bernstein" else "bspline",
                             border=border)  # fmt: skip
    lattice.offsets = rng.uniform(-size, size, size=lattice.offsets.shape) * np.ptp(points, axis=0)
    return FFD(lattice, basis, **options)


def _every_option(points) -> dict[str, FFD]:
    """An FFD per file format, each with the options that format holds (not the defaults)."""
    rng = np.random.default_rng(36)
    affine = np.eye(4)
    affine[:3, :3] += rng.uniform(-0.02, 0.02, (3, 3))
    affine[:3, 3] = 0.01 * np.ptp(points, axis=0)
    interpolations = ("linear", "catmull-rom", "bspline")
    return {
        "blender.ffd": _random_ffd(points, rng, basis=interpolations, border="clamp", outside=True, strength=0.4),
        "clamp.ffd": _random_ffd(points, rng, border="clamp", strength=0.7),
        "zero.ffd": _random_ffd(points, rng, shape=6, outside=True),
        "itk.tfm": _random_ffd(points, rng, affine=affine, strength=0.5),  # written as its baked FFD
        "itk.h5": _random_ffd(points, rng, shape=6, affine=affine),
        "elastix.txt": _random_ffd(points, rng, affine=affine, strength=0.8),
        "niftyreg.nii.gz": _random_ffd(points, rng, affine=affine, outside=True, strength=0.6),  # a float32 grid
        "pygem.prm": _random_ffd(points, rng, shape=3, basis="bernstein", only_inside=True, outside=True, strength=0.6),
    }


def test_a_file_s_strength_and_outside_reach_its_samples(tmp_path, ant):
    ffd = _random_ffd(ant, np.random.default_rng(1), border="clamp", outside=True, strength=0.4)
    save_deformation(tmp_path / "a.ffd", ffd)
    bound = LatticeFiles([tmp_path / "a.ffd"]).bind(None)
    sample = bound.draw(None, 0)
    np.testing.assert_allclose(sample.deform(ant), ffd.deform(ant), rtol=0, atol=1e-12)
    # the fold check's scaling scales the lattice's offsets and keeps the options
    half = ffd.copy()
    half.lattice.offsets *= 0.5
    np.testing.assert_allclose(sample.scaled(0.5).deform(ant), half.deform(ant), rtol=0, atol=1e-12)
    # the cached evaluators (the file is their template) give the direct path's numbers
    fast = PointEvaluator(ant, bound.deformations[0])
    for s in (sample, sample.scaled(0.5)):
        np.testing.assert_allclose(fast.deform(s), s.deform(ant), rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.jacobian_determinant(s), s.jacobian_determinant(ant), rtol=0, atol=1e-9)
    assert fast._deformer is not None and fast._jacobian is not None  # the cached path was taken


def test_samples_that_differ_from_the_template_only_in_strength_are_evaluated_for_what_they_are(tmp_path, ant):
    rng = np.random.default_rng(2)
    weak = _random_ffd(ant, rng, strength=0.3)
    strong = weak.copy(strength=1.0)
    strong.lattice.offsets = rng.uniform(-0.03, 0.03, size=weak.lattice.offsets.shape) * np.ptp(ant, axis=0)
    save_deformation(tmp_path / "weak.ffd", weak)
    save_deformation(tmp_path / "strong.ffd", strong)
    bound = LatticeFiles([tmp_path / "weak.ffd", tmp_path / "strong.ffd"]).bind(None)
    fast = PointEvaluator(ant, bound.deformations[0])
    for i, ffd in enumerate((weak, strong)):
        sample = bound.draw(None, i)
        np.testing.assert_allclose(fast.deform(sample), ffd.deform(ant), rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.jacobian_determinant(sample), ffd.jacobian_determinant(ant), rtol=0,
                                   atol=1e-9)  # fmt: skip


def test_a_run_from_files_in_every_format_with_every_option(tmp_path, ant):
    ffds = _every_option(ant)
    files = []
    for name, ffd in ffds.items():
        files.append(tmp_path / name)
        by_content = name.startswith(("elastix", "niftyreg"))  # formats chosen by name, not by extension
        save_deformation(files[-1], ffd, format=name.split(".")[0] if by_content else None)
    loaded = [load_deformation(f) for f in files]
    assert loaded[0].strength == 0.4 and loaded[0].outside and loaded[0].border == "clamp"
    out = tmp_path / "out"
    result = generate(ANT, LatticeFiles(files), None, out, format="vtp", fold_free=False, scheduler="sync",
                      progress=False)  # fmt: skip
    assert result.made == list(range(len(files)))
    for i, (name, ffd) in enumerate(ffds.items()):
        saved = read_mesh(out / "meshes" / f"sample_{i:06d}.vtp").points
        assert np.abs(saved - ant).max() > 1e-3 * np.ptp(ant), name  # each file really moved the mesh
        # the FFD that was saved, to the vtp's float32 (and for elastix its text's, NiftyReg its float32 rounding)
        np.testing.assert_allclose(saved, ffd.deform(ant), rtol=0, atol=1e-5 * np.ptp(ant), err_msg=name)
        np.testing.assert_allclose(saved, loaded[i].deform(ant), rtol=0, atol=1e-9 * np.ptp(ant), err_msg=name)
        assert np.array_equal(replay(out, i).points, saved), name


def test_an_edited_lattice_file_is_another_run(tmp_path, ant):
    path = tmp_path / "a.ffd"
    first = _random_ffd(ant, np.random.default_rng(3), strength=0.5)
    save_deformation(path, first)
    run = {"format": "vtp", "fold_free": False, "scheduler": "sync", "progress": False}
    generate(ANT, LatticeFiles([path]), None, tmp_path / "one", **run)
    edited = first.copy()
    edited.lattice.offsets *= -1.0
    save_deformation(path, edited)  # the same size: only the contents tell
    generate(ANT, LatticeFiles([path]), None, tmp_path / "two", **run)  # the same process, the same paths
    points = read_mesh(tmp_path / "two" / "meshes" / "sample_000000.vtp").points
    np.testing.assert_allclose(points, edited.deform(ant), rtol=0, atol=1e-5 * np.ptp(ant))
    with pytest.raises(ValueError, match=r"a\.ffd changed since the run"):
        replay(tmp_path / "one", 0)
    with pytest.raises(ValueError, match="other settings"):
        generate(ANT, LatticeFiles([path]), None, tmp_path / "one", **run)
    save_deformation(path, first)  # restored: the first run is whole again
    np.testing.assert_array_equal(replay(tmp_path / "one", 0).points,
                                  read_mesh(tmp_path / "one" / "meshes" / "sample_000000.vtp").points)  # fmt: skip


def test_gp_command_line_takes_three_control_point_counts(ant):
    parser = build_parser()
    args = parser.parse_args([ANT, "--model", "gp", "--kernel", "bspline", "--n", "1", "--out", "x",
                              "--num-control-points", "5", "6", "7"])  # fmt: skip
    model = _model(args, parser)
    assert model.num_control_points == (5, 6, 7)
    assert model.to_spec()["num_control_points"] == [5, 6, 7]
    bound = RandomGP(kernel="bspline", num_control_points=(5, 6, 7), rank=4, n_inducing=30).bind(ant)
    assert bound.process._space.kernel.lattice.shape == (5, 6, 7)
    assert RandomGP(num_control_points=7).to_spec()["num_control_points"] == 7  # earlier runs' settings unchanged
    with pytest.raises(ValueError, match="num_control_points"):
        RandomGP(kernel="bspline", num_control_points=(5, 3, 7))
