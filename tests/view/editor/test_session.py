"""EditingSession without rendering: commands on real meshes, checked against FFD.deform, and the change path.

No plotter is made here: the session imports no VTK (checked in a fresh interpreter), so these tests exercise
the editor's whole state machine (drag, move, reset, undo/redo, lattices, files, decimation) alone.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD
from ffd_notebook.view.editor import Change, EditingSession
from ffd_notebook.view.editor.meshes import PYVISTA_MESH_IO, read_surface

SESSION_DIR = Path(__file__).resolve().parents[3] / "ffd_notebook" / "view" / "editor" / "session"
VIEW_LIBRARIES = ("vtk", "vtkmodules", "pyvista", "trame", "ipywidgets")


def new_session(mesh=None, **kw) -> EditingSession:
    mesh = pv.Sphere(theta_resolution=16, phi_resolution=16) if mesh is None else mesh
    return EditingSession(mesh, mesh_io=PYVISTA_MESH_IO, **{"shape": (4, 4, 4), **kw})


def assert_follows_the_model(session: EditingSession) -> None:
    """The session's deformed points are what FFD.deform (the outside reference) gives for its lattice."""
    expected = FFD(session.lattice, session.basis).deform(session.rest_points)
    np.testing.assert_allclose(session.deformed_points, expected, atol=1e-5)


class Mirror:
    """An observer that keeps its own copy of the offsets and copies ONLY the rows a Change names."""

    def __init__(self, session: EditingSession) -> None:
        self.session = session
        self.offsets = session.lattice.offsets.reshape(-1, 3).copy()
        self.changes: list[Change] = []
        session.subscribe(self.follow)

    def follow(self, change: Change) -> None:
        self.changes.append(change)
        truth = self.session.lattice.offsets.reshape(-1, 3)
        if change.kind in ("lattice", "mesh"):
            self.offsets = truth.copy()
        elif change.kind in ("drag", "offsets"):
            rows = slice(None) if change.points is None else change.points
            self.offsets[rows] = truth[rows]


def test_importing_the_session_loads_no_view_library():
    """In a fresh interpreter, importing the session package and every module in it loads no VTK, PyVista,
    trame or ipywidgets (through ``sys.modules``: an import anywhere, also an indirect one, counts)."""
    modules = ["ffd_notebook.view.editor.session"] + [
        f"ffd_notebook.view.editor.session.{p.stem}" for p in sorted(SESSION_DIR.glob("*.py")) if p.stem != "__init__"
    ]
    code = (
        "import importlib, sys\n"
        f"for name in {modules!r}: importlib.import_module(name)\n"
        "from ffd_notebook.view.editor import EditingSession, Change, MeshIO\n"
        f"print(','.join(sorted(m for m in sys.modules if m.split('.')[0] in {VIEW_LIBRARIES!r})))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SESSION_DIR.parents[3]), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert out.stdout.strip() == "", f"the session imported: {out.stdout.strip()}"
    assert len(modules) >= 8  # the package and its seven modules


@pytest.mark.parametrize("path", sorted(SESSION_DIR.glob("*.py")), ids=lambda p: p.name)
def test_the_session_source_imports_no_view_library(path):
    """A function-level import would escape the check above until the function runs."""
    tree = ast.parse(path.read_text())
    imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    imported += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level == 0]
    assert not [m for m in imported if m.split(".")[0] in VIEW_LIBRARIES]


def test_commands_follow_the_model_and_undo(shared_data):
    session = new_session(read_surface(shared_data / "seed-lineage" / "monkey.obj"))
    mirror = Mirror(session)
    session.move_control_point((1, 2, 1), (0.0, 0.1, 0.0))
    assert_follows_the_model(session)
    assert mirror.changes[-2].points.tolist() == [session.flat_index((1, 2, 1))] and session.selected == (1, 2, 1)
    session.begin_drag(5)
    for _ in range(3):  # one drag: three events, one undo step
        session.drag(5, session.control_points()[5] + [0.02, 0.0, 0.0])
    session.end_drag()
    assert len(session.history) == 2 and [c.kind for c in mirror.changes[-5:]] == ["select"] + ["drag"] * 3 + [
        "offsets"
    ]
    assert_follows_the_model(session)
    session.reset((1, 2, 1))
    assert_follows_the_model(session)
    session.reset((1, 2, 1))  # already at rest: nothing to undo, no step recorded
    session.reset((0, 0, 0))
    assert len(session.history) == 3
    assert session.undo() and session.undo() and session.undo() and not session.can_undo
    assert not session.lattice.offsets.any()
    assert_follows_the_model(session)
    assert session.redo() and session.lattice.offsets[1, 2, 1, 1] == pytest.approx(0.1)
    np.testing.assert_array_equal(mirror.offsets, session.lattice.offsets.reshape(-1, 3))


def test_lattice_shape_basis_and_files(shared_data, tmp_path):

    session = new_session()
    session.set_shape((5, 4, 4))
    assert session.lattice.shape == (5, 4, 4) and session.messages[-1] == "new 5x4x4 lattice around the mesh"
    session.set_basis("bernstein")
    session.move_control_point((2, 1, 1), (0.0, 0.0, 0.3))
    assert_follows_the_model(session)
    lattice = session.files.load_deformation(shared_data / "seed-lineage" / "registration_11x12x11.FFD").lattice
    assert session.lattice is lattice and lattice.shape == (11, 12, 11)
    assert_follows_the_model(session)
    state = (session.lattice, len(session.history), len(session.messages))
    bad = tmp_path / "bad.ffd"
    bad.write_text("#dimension#\nthree\n")
    with pytest.raises(ValueError):
        session.files.load_deformation(bad)
    assert (session.lattice, len(session.history)) == state[:2] and len(session.messages) == state[2] + 1
    assert session.messages[-1].startswith(f"Error: could not load the lattice {str(bad)!r}")
    session.undo()  # back to the Bernstein lattice with its moved point
    assert session.basis == "bernstein" and session.lattice.offsets[2, 1, 1, 2] == pytest.approx(0.3)
    saved = tmp_path / "saved.ffd"
    with pytest.raises(ValueError, match="cannot hold this FFD exactly"):  # .ffd lattices are B-splines
        session.files.save_deformation(saved)
    assert not saved.exists()
    assert session.messages[-1].startswith(f"Error: could not save the lattice to {str(saved)!r}")
    session.redo()  # the loaded B-spline .ffd lattice
    session.files.save_deformation(saved)
    assert session.messages[-1] == f"saved the lattice to {saved}"


def test_decimation_keeps_lattice_and_history():

    session = new_session(pv.Sphere(theta_resolution=40, phi_resolution=40))
    session.move_control_point((1, 1, 2), (0.0, 0.0, 0.2))
    mirror = Mirror(session)
    mesh = session.decimate(0.5)
    assert session.mesh is mesh and mesh.n_points < session.source_mesh.n_points
    assert [c.kind for c in mirror.changes[:1]] == ["mesh"] and session.can_undo
    assert_follows_the_model(session)
    session.decimate(0.0)  # back to the mesh as loaded
    assert session.mesh.n_points == session.source_mesh.n_points


def test_update_picks_up_in_place_edits():
    session = new_session()
    mirror = Mirror(session)
    session.lattice.offsets[2, 1, 3] = (0.1, 0.0, 0.0)
    session.lattice.offsets[0, 0, 0] = (0.0, 0.2, 0.0)
    session.update()
    change = mirror.changes[-1]
    assert change.kind == "offsets" and sorted(change.points.tolist()) == [0, session.flat_index((2, 1, 3))]
    assert len(session.history) == 1 and session.history.undo() is not None
    session.history.redo()
    assert_follows_the_model(session)
    np.testing.assert_array_equal(mirror.offsets, session.lattice.offsets.reshape(-1, 3))
    session.update(changed=[(3, 3, 3)])  # nothing edited: the hint alone, no new step
    assert mirror.changes[-1].points.tolist() == [session.flat_index((3, 3, 3))] and len(session.history) == 1


def test_a_failed_update_or_set_offsets_changes_nothing():
    """Commands check everything before they change anything (issue 36): a hint outside the lattice used to
    record the step, then raise from the deformer, leaving the mesh off the lattice from then on; a negative
    index wrote the wrapped row, then raised."""
    session = new_session()
    session.move_control_point((1, 1, 1), (0.0, 0.0, 0.05))
    shown, n_steps = session.deformed_points.copy(), len(session.history)
    session.lattice.offsets[2, 2, 2] = (0.05, 0.0, 0.0)  # an edit in place, then a bad hint
    for hint in ([(9, 9, 9)], [(-1, 0, 0)], [(1, 1)], [(0.5, 0, 0)]):
        with pytest.raises(ValueError, match="control point"):
            session.update(hint)
        assert len(session.history) == n_steps
        np.testing.assert_array_equal(session.deformed_points, shown)
    session.update([(2, 2, 2)])  # once called right, the edit is one step and the mesh follows
    assert len(session.history) == n_steps + 1
    assert_follows_the_model(session)
    offsets, shown, n_steps = session.lattice.offsets.copy(), session.deformed_points.copy(), len(session.history)
    for points, values in (
        ([(-1, 0, 0)], [[0.0, 0.0, 0.1]]),  # would write row (3, 0, 0)
        ([(0, 0, 4)], [[0.0, 0.0, 0.1]]),
        ([(0, 0, 1), (0, 0, 2)], [[0.0, 0.0, 0.1]] * 3),
        ([(0, 0, 1)], [[0.0, np.nan, 0.1]]),
    ):
        with pytest.raises(ValueError):
            session.set_offsets(points, values, label="code")
        np.testing.assert_array_equal(session.lattice.offsets, offsets)
        np.testing.assert_array_equal(session.deformed_points, shown)
        assert len(session.history) == n_steps
    session.set_offsets([(0, 0, 1), (0, 0, 2)], [0.0, 0.0, 0.1], label="code")  # one row for all still works
    assert session.lattice.offsets[0, 0, 1:3, 2].tolist() == [0.1, 0.1]
    assert_follows_the_model(session)


def test_a_failing_view_becomes_a_message_and_the_others_still_follow():
    session = new_session()
    seen = []
    session.subscribe(lambda change: 1 / 0)
    session.subscribe(lambda change: seen.append(change.kind))
    session.move_control_point((1, 1, 1), (0.1, 0.0, 0.0))
    assert seen == ["offsets", "select"]
    assert session.messages[-1].startswith("Error: a view failed to follow the editor: ZeroDivisionError")


COMMANDS = st.lists(
    st.one_of(
        st.tuples(st.just("drag"), st.integers(0, 63), st.integers(1, 4), st.floats(-0.2, 0.2)),
        st.tuples(st.just("move"), st.integers(0, 63), st.floats(-0.3, 0.3)),
        st.tuples(st.just("reset"), st.one_of(st.just(-1), st.integers(0, 63))),  # -1: all of them
        st.tuples(st.just("undo")),
        st.tuples(st.just("redo")),
        st.tuples(st.just("code"), st.integers(0, 63), st.floats(-0.3, 0.3)),
    ),
    max_size=12,
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(commands=COMMANDS)
def test_changes_name_every_moved_control_point(commands):
    """An observer that copies only the rows each Change names always equals lattice.offsets: the
    session says which control points changed, completely, and a drag event names exactly one."""
    session = new_session(pv.Sphere(theta_resolution=10, phi_resolution=10))
    mirror = Mirror(session)
    for command in commands:
        n_before = len(mirror.changes)
        name = command[0]
        if name == "drag":
            _, index, events, step = command
            session.begin_drag(index)
            for _ in range(events):
                session.drag(index, session.control_points()[index] + step)
            session.end_drag()
            drags = [c for c in mirror.changes[n_before:] if c.kind == "drag"]
            assert len(drags) == events and all(c.points.tolist() == [index] for c in drags)
        elif name == "move":
            ijk = np.unravel_index(command[1], session.lattice.shape)
            session.move_control_point(ijk, (command[2], 0.0, -command[2]))
        elif name == "reset":
            session.reset(None if command[1] < 0 else np.unravel_index(command[1], session.lattice.shape))
        elif name in ("undo", "redo"):
            getattr(session, name)()
        else:
            session.lattice.offsets.reshape(-1, 3)[command[1]] += command[2]
            session.update()
        np.testing.assert_array_equal(mirror.offsets, session.lattice.offsets.reshape(-1, 3))
    assert_follows_the_model(session)
