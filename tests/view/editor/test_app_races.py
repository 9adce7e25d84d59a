"""Edits made while the app works in a worker thread (issue 36): a decimation, a rebuild, a basis change or an image
load runs off the event loop, and the user keeps painting, dragging and changing options meanwhile. What the
worker hands back must not undo those edits, and what is shown must stay what saving writes.

Deterministic, not timed: a :class:`WorkerGate` holds the worker thread once its work is done (the result is then
"old") until the test, running on the app's own asyncio loop, has made its edits; the test then releases it and
waits for the app to install the result.
"""

from __future__ import annotations

import asyncio
import functools
import threading
import time
import uuid

import numpy as np
import pytest
import pyvista as pv
import SimpleITK as sitk
from editor_testing import colored_sphere, full_slices

from ffd_notebook import FFD
from ffd_notebook.images import read_image, warp_image
from ffd_notebook.view import Editor
from ffd_notebook.view.editor.app import EditorApp
from ffd_notebook.view.editor.session.image import SessionImage

TIMEOUT_S = 120.0  # generous: the machine running the suite is shared


class WorkerGate:
    """Holds a function's calls made in a worker thread, after they did their work, until :meth:`open`.

    Calls on the main thread (the event loop's) pass at once, and so does every call once the gate is open.
    """

    def __init__(self) -> None:
        self.holding = threading.Event()
        self._open = threading.Event()

    def around(self, function):
        """``function``, held after its work (its result is then older than the loop's edits)."""

        @functools.wraps(function)
        def held(*args, **kwargs):
            result = function(*args, **kwargs)
            self._hold()
            return result

        return held

    def before(self, function):
        """``function``, held before it starts (it then runs after the loop's edits)."""

        @functools.wraps(function)
        def held(*args, **kwargs):
            self._hold()
            return function(*args, **kwargs)

        return held

    def _hold(self) -> None:
        if threading.current_thread() is not threading.main_thread() and not self._open.is_set():
            self.holding.set()
            if not self._open.wait(TIMEOUT_S):
                raise TimeoutError("the test never opened the gate")

    def open(self) -> None:
        self._open.set()


async def until(condition, what: str) -> None:
    """Poll ``condition()`` on the loop (the worker and the loop's callbacks run meanwhile) until it holds."""
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what}: still not done after {TIMEOUT_S} s")
        await asyncio.sleep(0.01)


@pytest.fixture
def app(tmp_path):
    editor = Editor(colored_sphere(), shape=(4, 5, 4), window_size=(160, 120))
    app = EditorApp(editor, name=f"races_{uuid.uuid4().hex}", root=tmp_path)
    yield app
    app.close()


def expected_points(session):
    """The outside reference: FFD.deform with the session's lattice and options (weights included)."""
    ffd = session.ffd
    reference = FFD(session.lattice, ffd.basis, ffd.border, affine=ffd.affine, outside=ffd.outside,
                    strength=ffd.strength, weights=ffd.weights)  # fmt: skip
    return reference.deform(session.rest_points)


def assert_consistent(session):
    """The mesh shown is the model's, the weights fit the mesh, and everything saving writes is derived from them."""
    weights = session.ffd.weights
    assert weights is None or len(weights) == len(session.rest_points), "weights of another mesh"
    np.testing.assert_allclose(session.deformed_points, expected_points(session), atol=1e-5)


def stroke(session, vertex):
    """One brush event at a vertex of the rest mesh, as the scene sends it (a failure becomes a message)."""
    return session.attempt(session.paint.stroke, session.rest_points[vertex])


def test_a_brush_stroke_across_a_decimation_paints_the_mesh_it_ends_on(app, monkeypatch, tmp_path):
    session = app.editor.session
    session.move_control_point((1, 2, 1), (0.0, 0.0, 0.3))
    gate = WorkerGate()
    monkeypatch.setattr(session, "decimation", gate.around(session.decimation))
    n_before = len(session.rest_points)

    async def scenario():
        session.paint.begin()  # the mouse is pressed in "paint weights" mode
        assert stroke(session, 0)
        app.run("decimate", [0.5])
        await until(gate.holding.is_set, "the decimation")
        assert stroke(session, 5)  # painting on while the worker decimates
        gate.open()
        await until(lambda: len(session.rest_points) < n_before and not app.state.busy, "installing the decimation")
        assert stroke(session, 3), list(session.messages)  # the mouse is still down: it paints the new mesh
        session.paint.end()

    asyncio.run(scenario())
    assert_consistent(session)
    assert session.weights is not None and session.weights.max() > 0  # what was painted after the decimation
    app.run("strength", [0.5])  # the slider and saving work from then on
    assert session.ffd.strength == 0.5 and not app.state.messages[0]["error"]
    assert_consistent(session)
    session.files.save_mesh(tmp_path / "painted.ply")
    np.testing.assert_allclose(pv.read(tmp_path / "painted.ply").points, session.deformed_points, atol=1e-5)
    while session.undo():  # every step of the history fits the mesh it is undone on
        assert_consistent(session)


def test_a_brush_stroke_across_a_rebuild_is_undone_on_the_lattice_it_ended_on(app, monkeypatch):
    session = app.editor.session
    gate = WorkerGate()
    monkeypatch.setattr(FFD, "bind", gate.around(FFD.bind))

    async def scenario():
        session.paint.begin()
        assert stroke(session, 0)
        app.run("rebuild", [5, 5, 6])
        await until(gate.holding.is_set, "the rebuild")
        assert stroke(session, 10)
        gate.open()
        await until(lambda: session.lattice.shape == (5, 5, 6) and not app.state.busy, "installing the rebuild")
        assert stroke(session, 20)
        session.paint.end()

    asyncio.run(scenario())
    assert_consistent(session)
    painted = session.weights
    assert painted is not None and painted[[0, 10, 20]].min() > 0  # every part of the stroke is kept
    assert session.undo()  # the stroke's last part: on the new lattice
    assert session.lattice.shape == (5, 5, 6), "an undo step holding the old lattice"
    assert session.weights is not None and session.weights[0] > 0 and session.weights[10] > 0
    assert_consistent(session)
    while session.undo():
        assert_consistent(session)
    assert session.lattice.shape == (4, 5, 4) and session.weights is None


def test_a_rebuild_keeps_a_strength_interpolation_or_weights_change_made_while_it_runs(app, monkeypatch):
    session = app.editor.session
    gate = WorkerGate()
    monkeypatch.setattr(FFD, "bind", gate.around(FFD.bind))
    weights = np.linspace(0.0, 1.0, len(session.rest_points))

    async def scenario():
        app.run("rebuild", [5, 5, 6])
        await until(gate.holding.is_set, "the rebuild")
        app.run("strength", [0.5])
        app.run("interpolation", ["bspline", "catmull-rom", "linear"])
        session.paint.set(weights)
        gate.open()
        await until(lambda: session.lattice.shape == (5, 5, 6) and not app.state.busy, "installing the rebuild")

    asyncio.run(scenario())
    assert session.ffd.strength == 0.5 and session.interpolation == ("bspline", "catmull-rom", "linear")
    np.testing.assert_array_equal(session.weights, weights)
    assert app.state.strength == 0.5 and app.state.interp_y == "catmull-rom" and app.state.has_weights
    session.lattice.offsets[2, 2, 3] = (0.0, 0.0, 0.4)
    session.update()
    assert_consistent(session)
    assert [step.label for step in session.history._done][-2:] == ["shape", "code"]


def test_a_basis_change_keeps_a_strength_change_made_while_it_runs(app, monkeypatch):
    session = app.editor.session
    gate = WorkerGate()
    monkeypatch.setattr(FFD, "bind", gate.around(FFD.bind))

    async def scenario():
        app.run("basis", ["bernstein"])
        await until(gate.holding.is_set, "the basis change")
        app.run("strength", [0.25])
        gate.open()
        await until(lambda: session.basis == "bernstein" and not app.state.busy, "installing the basis")

    asyncio.run(scenario())
    assert session.ffd.strength == 0.25 and app.state.strength == 0.25
    assert_consistent(session)


def test_control_points_moved_while_an_image_loads_reach_the_slices(app, ct, monkeypatch):
    session = app.editor.session
    gate = WorkerGate()
    monkeypatch.setattr(SessionImage, "read", gate.around(SessionImage.read))

    async def scenario():
        app.run("load_image", [ct.name])
        await until(gate.holding.is_set, "reading the image")
        session.move_control_point((1, 2, 1), (0.3, -0.2, 0.25))  # typed in the panel while the image loads
        session.begin_drag(session.flat_index((2, 3, 2)))
        session.drag(session.flat_index((2, 3, 2)), session.control_points()[session.flat_index((2, 3, 2))] + 0.2)
        session.end_drag()
        gate.open()
        await until(lambda: session.image.loaded and not app.state.busy, "showing the image")

    asyncio.run(scenario())
    slices = session.image.slices
    expected = full_slices(ct, session.ffd, slices.positions)
    for axis in slices.axes:
        np.testing.assert_allclose(slices.values[axis], expected[axis], atol=1e-3)
    app.run("save_image", ["warped.nii.gz"])  # what is shown is what is saved
    saved = sitk.GetArrayFromImage(read_image(ct.parent / "warped.nii.gz"))
    i, j, k = slices.positions
    for axis, shown in ((0, saved[:, :, i]), (1, saved[:, j, :]), (2, saved[k])):
        np.testing.assert_allclose(shown, slices.values[axis], atol=1e-3)


def test_save_image_writes_the_lattice_of_the_click(app, ct, monkeypatch):
    """Saving the image runs in a worker: a drag made meanwhile is not half in the file (as for the lattice and
    the mesh, the save writes what was shown when it was asked for)."""
    session = app.editor.session
    app.run("load_image", [ct.name])
    assert session.image.loaded
    session.move_control_point((1, 2, 1), (0.3, 0.0, 0.0))
    at_click = FFD(session.lattice.copy(), session.basis, session.ffd.border)
    gate = WorkerGate()
    import ffd_notebook.view.editor.session.image as image_module

    monkeypatch.setattr(image_module, "warp_image", gate.before(image_module.warp_image))

    async def scenario():
        app.run("save_image", ["warped.mha"])
        await until(gate.holding.is_set, "writing the image")
        session.move_control_point((2, 2, 2), (0.0, 0.4, 0.0))
        gate.open()
        await until(lambda: not app.state.busy, "writing the image")

    asyncio.run(scenario())
    saved = sitk.GetArrayFromImage(read_image(ct.parent / "warped.mha"))
    np.testing.assert_allclose(saved, sitk.GetArrayFromImage(warp_image(ct, at_click)), atol=1e-4)


def test_a_decimation_error_is_one_message_posted_on_the_loop(app):
    session = app.editor.session
    threads = []
    session.subscribe(lambda change: threads.append(threading.current_thread()))
    n_points = len(session.rest_points)

    def errors():
        return [m for m in session.messages if m.startswith("Error")]

    async def scenario():
        # not a number, out of range (both refused at once), nothing left (the worker's own error)
        for reduction in ("abc", 1.5, 0.999999):
            before = len(errors())
            app.run("decimate", [reduction])
            await until(lambda: not app.state.busy, "the decimation")
            await asyncio.sleep(0.05)  # anything posted late would be seen
            assert len(errors()) == before + 1, errors()[before:]
            assert "decimate" in errors()[-1] and app.state.messages[0]["text"] == errors()[-1]

    asyncio.run(scenario())
    assert all(thread is threading.main_thread() for thread in threads), "a change posted from a worker thread"
    assert len(session.rest_points) == n_points
