"""The editor opens the registration tools' own files (no rendering but for ``Editor(deformation=...)``): a
NiftyReg grid as its editable lattice, ANTs' affine as the FFD's affine part, a SyN chain as a lattice fitted to
it (the residual in the message), an FSL file through ``load_deformation(path, reference=..., source=...)``."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from ffd_notebook import FFD
from ffd_notebook.io import load_deformation
from ffd_notebook.view.editor import EditingSession
from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO


def brain_session(centre) -> EditingSession:
    """A sphere where the MRI is (LPS), as a surface of the brain would be."""
    mesh = pv.Sphere(radius=15.0, center=centre, theta_resolution=16, phi_resolution=16)
    return EditingSession(mesh, mesh_io=PYVISTA_MESH_IO, shape=(5, 5, 5))


def _centre(run):
    from ffd_notebook.images import reference_grid

    return reference_grid(str(run["fixed"])).physical_points().mean(axis=0)


def test_a_niftyreg_grid_opens_as_its_own_editable_lattice(niftyreg_run):
    session = brain_session(_centre(niftyreg_run))
    ffd = session.files.load_deformation(niftyreg_run["cpp"])
    grid = load_deformation(niftyreg_run["cpp"])
    assert ffd.lattice.shape == grid.lattice.shape and ffd.border == "clamp"
    points = session.rest_points
    assert np.allclose(session.deformer.update(), grid.deform(points))
    assert "loaded a 12x15x12 lattice from" in list(session.messages)[-1]
    before = session.deformer.update().copy()
    session.lattice.offsets[6, 7, 6] += (2.0, 0.0, 0.0)  # a hand correction of the grid moves the surface
    assert np.abs(session.deformer.update() - before).max() > 0.1
    session.undo()  # back to the session's own lattice before the file
    assert session.lattice.shape == (5, 5, 5)


def test_ants_affine_is_the_ffd_affine_part_and_the_syn_chain_a_fitted_lattice(ants_run):
    session = brain_session(_centre(ants_run))
    affine = load_deformation(ants_run["affine"])
    ffd = session.files.load_deformation(ants_run["affine"])
    assert isinstance(ffd, FFD) and np.array_equal(ffd.affine, affine.matrix) and not ffd.lattice.offsets.any()
    points = session.rest_points
    assert np.allclose(session.deformer.update(), affine.deform(points))
    chain = load_deformation([ants_run["warp"], ants_run["affine"]])
    session.files.load_deformation(chain)
    fit = session.lattice.metadata["fit"]
    assert "fitted to the transforms of TransformChain" in list(session.messages)[-1]
    assert fit["samples"] == len(points) and fit["rms"] < 0.2
    assert np.abs(session.deformer.update() - chain.deform(points)).max() < 5 * fit["max"] + 1e-9


def test_a_bad_file_changes_nothing(tmp_path):
    session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    lattice = session.lattice.copy()
    (tmp_path / "bad.mat").write_bytes(b"\x00" * 30)
    with pytest.raises(ValueError, match=r"bad\.mat"):
        session.files.load_deformation(tmp_path / "bad.mat")
    assert session.lattice == lattice and "could not load" in list(session.messages)[-1]


def test_edit_opens_a_registration_file(niftyreg_run):
    from ffd_notebook.view import Editor

    sphere = pv.Sphere(radius=15.0, center=_centre(niftyreg_run), theta_resolution=8, phi_resolution=8)
    editor = Editor(sphere, deformation=niftyreg_run["cpp"], window_size=(64, 48))
    try:
        assert editor.lattice.shape == (12, 15, 12)
        assert np.allclose(editor.deformed_mesh.points, load_deformation(niftyreg_run["cpp"]).deform(sphere.points))
    finally:
        editor.close()
