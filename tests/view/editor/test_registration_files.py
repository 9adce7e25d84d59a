"""The editor's session loads registration results like any lattice file: elastix chains (by content) and fields.

No rendering: an EditingSession with real files written by ffd_notebook's elastix and field writers (the writers
themselves are checked against transformix and SimpleITK in tests/io). A loaded elastix chain shows what the chain
does, its lattice (sheared when an affine map with shear comes before the B-spline) is editable and saves back
as elastix; a displacement field becomes a lattice of the session's shape, fitted, the residual in the message.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook import FFD, Lattice
from ffd_notebook.io import load_deformation, load_elastix, save_displacement_field, save_elastix
from ffd_notebook.io.elastix_text import read_parameter_file, write_parameter_file
from ffd_notebook.view.editor import EditingSession
from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO

SHEAR = np.array([[1.05, 0.12, 0.0, 0.3], [0.0, 0.95, 0.08, -0.2], [0.04, 0.0, 1.02, 0.1], [0.0, 0.0, 0.0, 1.0]])


def new_session() -> EditingSession:
    mesh = pv.Sphere(radius=2.0, theta_resolution=16, phi_resolution=16)
    return EditingSession(mesh, mesh_io=PYVISTA_MESH_IO, shape=(5, 5, 5))


def _random_ffd(session: EditingSession, affine=None) -> FFD:
    lattice = Lattice.around(session.rest_points, (6, 5, 6), margin=0.2)
    lattice.offsets[...] = np.random.default_rng(0).normal(0.0, 0.1, lattice.offsets.shape)
    return FFD(lattice, affine=affine)


def _compose_chain(folder, ffd: FFD):
    """elastix's own affine-then-B-spline run: the same files with "Compose" (the affine shears the grid)."""
    save_elastix(folder / "TransformParameters.1.txt", ffd)
    params = read_parameter_file(folder / "TransformParameters.1.txt")
    entries = []
    for name, entry in params.entries.items():
        values = [v if v[0].isalpha() else float(v) for v in entry.values]
        entries.append((name, ["Compose"] if name == "HowToCombineTransforms" else values))
    write_parameter_file(folder / "TransformParameters.1.txt", entries)
    return folder / "TransformParameters.1.txt"


def test_an_elastix_chain_loads_edits_and_saves_back(tmp_path):
    session = new_session()
    path = _compose_chain(tmp_path, _random_ffd(session, SHEAR))
    chain = load_elastix(path)
    before = len(session.history)
    session.files.load_deformation(path)
    assert session.lattice.sheared
    np.testing.assert_allclose(session.deformed_points, chain.deform(session.rest_points), atol=1e-5)
    assert "TransformParameters.1.txt" in session.messages[-1] and len(session.history) == before + 1
    session.move_control_point((2, 2, 3), (0.0, 0.3, 0.0))  # the sheared lattice is editable
    edited = FFD(session.lattice, affine=session.ffd.affine, only_inside=session.ffd.only_inside)
    np.testing.assert_allclose(session.deformed_points, edited.deform(session.rest_points), atol=1e-5)
    saved = tmp_path / "edited" / "TransformParameters.1.txt"
    saved.parent.mkdir()
    session.files.save_deformation(saved)  # .txt, read from elastix: written as elastix (ITK refuses a sheared grid)
    assert saved.read_text().startswith('(Transform "BSplineTransform")')
    np.testing.assert_allclose(load_elastix(saved).deform(session.rest_points), session.deformed_points, atol=1e-5)
    with pytest.raises(ValueError, match="sheared"):
        session.files.save_deformation(tmp_path / "edited.tfm")
    assert not (tmp_path / "edited.tfm").exists() and "sheared" in session.messages[-1]
    session.undo()
    session.undo()  # back to the sphere's own lattice
    assert not session.lattice.sheared and len(session.history) >= before


def test_a_displacement_field_becomes_a_fitted_lattice(tmp_path):
    session = new_session()
    truth = _random_ffd(session)
    path = tmp_path / "warp.nii.gz"
    save_displacement_field(path, truth, {"size": (24, 24, 24), "spacing": 0.2, "origin": (-2.3, -2.3, -2.3)})
    session.files.load_deformation(path)
    assert session.lattice.shape == (5, 5, 5)
    fit = session.lattice.metadata["fit"]
    assert f"{fit['rms']:.3g}" in session.messages[-1] and "fitted" in session.messages[-1]
    field = load_deformation(path)
    assert np.abs(session.deformed_points - field.deform(session.rest_points)).max() < 0.05
    np.testing.assert_allclose(session.deformed_points, session.ffd.deform(session.rest_points), atol=1e-5)


def test_a_bad_chain_changes_nothing(tmp_path):
    session = new_session()
    lattice, history = session.lattice.copy(), len(session.history)
    (tmp_path / "a.txt").write_text('(Transform "TranslationTransform")\n(TransformParameters 1 2 3)\n'
                                     '(InitialTransformParameterFileName "a.txt")\n')  # fmt: skip
    with pytest.raises(ValueError, match="loops back"):
        session.files.load_deformation(tmp_path / "a.txt")
    assert session.lattice == lattice and len(session.history) == history
    assert "loops back" in session.messages[-1]


def test_the_app_takes_elastix_and_field_uploads(tmp_path):
    import uuid

    from ffd_notebook.view import Editor
    from ffd_notebook.view.editor.app import EditorApp

    mesh = pv.Sphere(radius=2.0, theta_resolution=16, phi_resolution=16)
    app = EditorApp(Editor(mesh, shape=(4, 5, 4), window_size=(160, 120)), name=f"test_{uuid.uuid4().hex}",
                    root=tmp_path)  # fmt: skip
    try:
        truth = _random_ffd(app.editor.session, SHEAR)
        save_elastix(tmp_path / "TransformParameters.0.txt", truth)
        save_displacement_field(tmp_path / "warp.nii.gz", truth, {"size": (20, 20, 20), "spacing": 0.25,
                                                                  "origin": (-2.4, -2.4, -2.4)})  # fmt: skip
        # the B-spline file names its affine file: an upload alone cannot follow it, the path in the root can
        app.files.receive_ffd_upload({"name": "TransformParameters.0.txt",
                                      "content": (tmp_path / "TransformParameters.0.txt").read_bytes()})  # fmt: skip
        assert app.state.messages[0]["error"] and "the initial transform" in app.state.messages[0]["text"]
        app.files.load_deformation_in_background("TransformParameters.0.txt")
        assert not app.state.messages[0]["error"], app.state.messages[0]["text"]
        np.testing.assert_allclose(app.editor.deformed_mesh.points, truth.deform(mesh.points), atol=1e-4)
        app.files.receive_ffd_upload({"name": "warp.nii.gz", "content": (tmp_path / "warp.nii.gz").read_bytes()})
        assert "fitted to the displacement field" in app.state.messages[0]["text"], app.state.messages[0]["text"]
        assert app.editor.lattice.shape == (6, 5, 6)  # the session's shape: the elastix lattice's
        np.testing.assert_allclose(app.editor.deformed_mesh.points, truth.deform(mesh.points), atol=0.05)
    finally:
        app.close()
