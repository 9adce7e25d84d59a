"""The editor's lattice files beyond .ffd: ITK transforms and PyGeM .prm, loaded and saved by extension.

Real files: ITK files written by ffd_notebook and by SimpleITK itself, PyGeM's own test parameters.
A loaded file brings its whole FFD (basis, border, affine part, only_inside), undo restores it, and
a format that cannot hold the editor's FFD is refused with a message, writing nothing.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from editor_testing import assert_view_matches_model, shown_points

from ffd_notebook import FFD, Lattice, load_transform, save_transform
from ffd_notebook.io import load_deformation

AFFINE = np.array([[1.1, 0.05, 0.0, 0.2], [0.0, 0.95, 0.1, -0.1], [0.02, 0.0, 1.0, 0.05], [0, 0, 0, 1.0]])


def random_ffd(mesh, rng, affine=None) -> FFD:
    """A zero-border B-spline FFD around ``mesh`` with random offsets (and an optional affine part)."""
    lattice = Lattice.around(mesh, (5, 6, 5), border="zero")
    lattice.offsets[:] = rng.normal(scale=0.05, size=lattice.offsets.shape)
    return FFD(lattice, "bspline", affine=affine)


def assert_shows(editor, ffd: FFD) -> None:
    """The editor's deformed mesh is ``ffd.deform`` of its rest points (float32 view, so 1e-5)."""
    expected = ffd.deform(editor.mesh.points)
    np.testing.assert_allclose(editor.session.deformed_points, expected, atol=1e-5)
    np.testing.assert_allclose(shown_points(editor), expected, atol=1e-5)
    assert_view_matches_model(editor)


def test_itk_file_with_an_affine_part_and_undo(editor, tmp_path):
    rng = np.random.default_rng(11)
    path = tmp_path / "warp.tfm"
    save_transform(path, random_ffd(editor.mesh, rng, AFFINE))
    before = editor.mesh.points.copy()
    editor.load_deformation(path)
    assert_shows(editor, load_transform(path))
    np.testing.assert_allclose(editor.session.ffd.affine, AFFINE, atol=1e-12)
    assert "warp.tfm (bspline, at the file's own placement)" in editor.messages[-1]
    assert np.abs(editor.session.deformed_points - before).max() > 0.1  # the affine part shows

    loaded = load_transform(path)
    editor.session.set_shape((4, 4, 4))  # a fitted lattice: identity affine part
    assert np.array_equal(editor.session.ffd.affine, np.eye(4))
    editor.undo()  # brings the file's whole FFD back, affine part included
    np.testing.assert_array_equal(editor.session.ffd.affine, loaded.affine)
    assert editor.session.ffd.only_inside == loaded.only_inside
    assert_shows(editor, loaded)
    editor.redo()
    editor.undo()
    assert_shows(editor, loaded)

    saved = tmp_path / "again.h5"  # the session's FFD, affine included, round-trips through ITK
    editor.save_deformation(saved)
    np.testing.assert_allclose(load_transform(saved).deform(before), loaded.deform(before), atol=1e-9)


def test_itk_file_written_by_simpleitk(editor, tmp_path):
    sitk = pytest.importorskip("SimpleITK")
    lo, hi = editor.mesh.points.min(axis=0) - 0.2, editor.mesh.points.max(axis=0) + 0.2
    image = sitk.Image([8, 8, 8], sitk.sitkFloat32)
    image.SetOrigin(lo.tolist())
    image.SetSpacing(((hi - lo) / 7).tolist())
    transform = sitk.BSplineTransformInitializer(image, [4, 5, 4], 3)
    rng = np.random.default_rng(3)
    transform.SetParameters(rng.normal(scale=0.05, size=len(transform.GetParameters())).tolist())
    path = tmp_path / "sitk.tfm"
    sitk.WriteTransform(transform, str(path))

    editor.load_deformation(path)
    assert_shows(editor, load_transform(path))
    reference = np.array([transform.TransformPoint(p) for p in editor.mesh.points.astype(float).tolist()])
    np.testing.assert_allclose(editor.session.deformed_points, reference, atol=1e-5)  # SimpleITK itself


def test_pygem_parameters(shared_data):
    from ffd_notebook.view.editor import Editor

    folder = shared_data / "pygem"
    original = np.load(folder / "meshpoints_sphere_orig.npy")
    editor = Editor(pv.PolyData(original), window_size=(160, 120))
    try:
        editor.load_deformation(folder / "parameters_test_ffd_sphere.prm")
        assert editor.session.basis == "bernstein" and editor.session.ffd.only_inside
        np.testing.assert_allclose(editor.session.deformed_points, np.load(folder / "meshpoints_sphere_mod.npy"),
                                   atol=1e-5)  # fmt: skip
        assert_shows(editor, load_deformation(folder / "parameters_test_ffd_sphere.prm"))
    finally:
        editor.close()


@pytest.mark.parametrize("suffix", [".ffd", ".tfm", ".txt", ".h5", ".hdf5", ".prm"])
def test_save_and_reload_each_format(editor, tmp_path, suffix):
    rng = np.random.default_rng(5)
    if suffix == ".prm":  # a PyGeM lattice: Bernstein, moving only the points inside its box
        lattice = Lattice.around(editor.mesh, (4, 5, 3), basis="bernstein")
        lattice.offsets[:] = rng.normal(scale=0.05, size=lattice.offsets.shape)
        ffd = FFD(lattice, "bernstein", only_inside=True)
        source = tmp_path / "source.prm"
    else:
        ffd = random_ffd(editor.mesh, rng)
        source = tmp_path / "source.ffd"
    from ffd_notebook.io import save_deformation

    save_deformation(source, ffd)
    editor.load_deformation(source)
    shown = editor.session.deformed_points.copy()
    path = tmp_path / f"saved{suffix}"
    editor.save_deformation(path)
    assert editor.messages[-1] == f"saved the lattice to {path}"
    editor.session.set_shape((4, 4, 4))
    editor.load_deformation(path)
    np.testing.assert_allclose(editor.session.deformed_points, shown, atol=1e-5)
    np.testing.assert_allclose(load_deformation(path).deform(editor.mesh.points), ffd.deform(editor.mesh.points),
                               atol=1e-9)  # fmt: skip
    assert editor.session.basis == ffd.basis


@pytest.mark.parametrize(
    ("setup", "target", "why"),
    [
        ("bernstein", "x.tfm", "'bernstein' basis has no ITK transform"),
        ("bernstein", "x.ffd", "cubic B-splines"),
        ("affine", "x.ffd", "affine part"),
        ("affine", "x.prm", "'bspline' basis"),
    ],
)
def test_a_refused_save_changes_nothing_and_writes_nothing(editor, tmp_path, setup, target, why):
    if setup == "bernstein":
        editor.session.set_basis("bernstein")
    else:
        source = tmp_path / "affine.tfm"
        save_transform(source, random_ffd(editor.mesh, np.random.default_rng(2), AFFINE))
        editor.load_deformation(source)
    editor.session.move_control_point((1, 1, 1), (0.0, 0.1, 0.0))
    ffd, points = editor.session.ffd, editor.session.deformed_points.copy()
    state = (editor.lattice.copy(), ffd.affine.copy(), len(editor.session.history), points)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert not editor.session.attempt(
        editor.save_deformation, tmp_path / target
    )  # the panels' way: a message, no exception
    assert editor.messages[-1].startswith(f"Error: could not save the lattice to {str(tmp_path / target)!r}")
    assert why in editor.messages[-1]
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no file, no temporary left over
    assert editor.lattice == state[0] and np.array_equal(editor.session.ffd.affine, state[1])
    assert len(editor.session.history) == state[2]
    np.testing.assert_array_equal(editor.session.deformed_points, state[3])


def test_a_bad_itk_file_changes_nothing(editor, tmp_path):
    bad = tmp_path / "bad.tfm"
    bad.write_text("#Insight Transform File V1.0\n#Transform 0\nTransform: Euler3DTransform_double_3_3\n")
    lattice, n_history = editor.lattice.copy(), len(editor.session.history)
    assert not editor.session.attempt(editor.load_deformation, bad)
    assert editor.messages[-1].startswith(f"Error: could not load the lattice {str(bad)!r}")
    assert editor.lattice == lattice and len(editor.session.history) == n_history


def test_old_names_warn_and_still_work(tmp_path):
    """The 0.1 names of the file commands keep working until 0.3, each warning with the name to use."""
    from ffd_notebook.view.editor import Editor

    editor = Editor(off_screen=True, window_size=(200, 150))
    try:
        editor.lattice.offsets[1, 1, 1] = (0.5, 0.0, 0.0)
        path = tmp_path / "old.ffd"
        with pytest.warns(DeprecationWarning, match=r"save_ffd is deprecated .* 0\.3\.0: use save_deformation"):
            editor.save_ffd(path)
        editor.reset()
        with pytest.warns(DeprecationWarning, match=r"Editor\.load_ffd is deprecated .*: use Editor\.load_deformation"):
            lattice = editor.load_ffd(path)
        assert lattice is editor.lattice and lattice.offsets[1, 1, 1, 0] == 0.5  # a Lattice, as in 0.1
        with pytest.warns(DeprecationWarning, match="load_lattice is deprecated"):
            assert editor.session.files.load_lattice(path) is editor.lattice
        with pytest.warns(DeprecationWarning, match="save_lattice is deprecated"):
            editor.session.files.save_lattice(tmp_path / "again.ffd")
        assert (tmp_path / "again.ffd").read_text() == path.read_text()
        ffd = editor.load_deformation(path)  # the new name: no warning, returns the FFD in use
        assert ffd is editor.session.ffd
    finally:
        editor.close()
