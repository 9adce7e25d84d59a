"""Every edit as code: ``to_code()`` run in a fresh interpreter rebuilds the session's FFD bit for bit.

Random sequences of the commands the panels and the mouse give (drags of spheres and of the mesh, typed
displacements, undo, redo, resets, rebuilds, basis and interpolation, strength, weights set and painted, deformation
files loaded, saves) run on a session of a mesh file; its ``script.to_code()`` then runs in another Python
process (started once for the module, importing nothing of the package before the code does) and sends back
what it built: the offsets, the lattice's placement and every option of the FFD must be the same doubles, and the
deformed points the same as the session's.
"""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ffd_notebook import FFD, Lattice, save_deformation, save_displacement_field, save_prm
from ffd_notebook.view.editor import EditingSession
from ffd_notebook.view.editor.meshes import PYVISTA_MESH_IO, read_surface
from ffd_notebook.view.editor.session.script import OUTSIDE_HISTORY, MeshOrigin

REPO = Path(__file__).resolve().parents[3]

# The fresh interpreter: runs each script it is sent in a namespace of its own, answers with what it built.
WORKER = r"""
import base64, json, sys, traceback

def packed(a):
    import numpy as np
    a = np.ascontiguousarray(a, dtype=np.float64)
    return {"shape": list(a.shape), "data": base64.b64encode(a.tobytes()).decode()}

for line in sys.stdin:
    request = json.loads(line)
    ns = {}
    try:
        if request.get("given"):
            import pyvista
            ns["mesh"] = pyvista.read(request["given"])
        exec(compile(request["code"], "<editor.to_code()>", "exec"), ns)
        ffd, mesh, deformed = ns["ffd"], ns["mesh"], ns["deformed"]
        assert ns["lattice"] is ffd.lattice, "lattice is not ffd.lattice"
        w = ffd.weights
        answer = {
            "offsets": packed(ffd.lattice.offsets), "spacing": packed(ffd.lattice.spacing),
            "origin": packed(ffd.lattice.origin), "rotation": packed(ffd.lattice.rotation),
            "border": ffd.border, "lattice_border": ffd.lattice.border, "basis": ffd.basis,
            "affine": packed(ffd.affine), "only_inside": ffd.only_inside, "outside": ffd.outside,
            "strength": ffd.strength, "weights": None if w is None else packed(w),
            "deform": packed(ffd.deform(mesh.points)), "deformed": packed(deformed.points),
        }
    except Exception:
        answer = {"error": traceback.format_exc()}
    print(json.dumps(answer), flush=True)
"""


class FreshInterpreter:
    """One Python process that runs scripts sent to it (the package imported by the first script, not before)."""

    def __init__(self, cwd: Path) -> None:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
        env["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
        self.process = subprocess.Popen([sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        cwd=cwd, env=env, text=True)  # fmt: skip
        self.modules_before: list[str] = []

    def run(self, code: str, given: str | None = None) -> dict:
        assert self.process.stdin is not None and self.process.stdout is not None
        self.process.stdin.write(json.dumps({"code": code, "given": given}) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        assert line, f"the interpreter exited ({self.process.poll()})"
        answer = json.loads(line)
        assert "error" not in answer, f"the script failed:\n{code}\n{answer['error']}"
        return answer

    def close(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        self.process.wait(30)


def unpacked(packed: dict) -> np.ndarray:
    return np.frombuffer(base64.b64decode(packed["data"]), dtype=np.float64).reshape(packed["shape"])


def same_bits(a, b) -> bool:
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def assert_rebuilt(session: EditingSession, answer: dict) -> None:
    """What the script built is the session's FFD, double for double, and deforms the mesh as the session does."""
    ffd = session.ffd
    lat = ffd.lattice
    for name, mine in (("offsets", lat.offsets), ("spacing", lat.spacing), ("origin", lat.origin),
                       ("rotation", lat.rotation), ("affine", ffd.affine)):  # fmt: skip
        assert same_bits(unpacked(answer[name]), mine), name
    assert answer["basis"] == (ffd.basis if isinstance(ffd.basis, str) else list(ffd.basis))
    assert (answer["border"], answer["lattice_border"]) == (ffd.border, lat.border)
    assert (answer["only_inside"], answer["outside"], answer["strength"]) == (ffd.only_inside, ffd.outside,
                                                                              ffd.strength)  # fmt: skip
    weights = session.weights
    assert (answer["weights"] is None) == (weights is None)
    if weights is not None:
        assert same_bits(unpacked(answer["weights"]), weights)
    # the same FFD on the same points: the same doubles; and the mesh the session shows, to its float32 points
    assert same_bits(unpacked(answer["deform"]), ffd.deform(session.rest_points))
    shown = np.asarray(session.deformed_mesh.points, dtype=np.float64)
    scale = float(np.ptp(session.rest_points))
    np.testing.assert_allclose(unpacked(answer["deformed"]), shown, atol=1e-6 * scale)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A mesh file, deformation files of three kinds for the load box, and the interpreter, shared by the module."""
    folder = tmp_path_factory.mktemp("script")
    mesh = pv.Sphere(theta_resolution=9, phi_resolution=9, radius=1.0)
    mesh.save(folder / "ball.ply")  # (PLY: read in process; VTK formats are read in a child process, 0.6 s)
    lat = Lattice.around(mesh, (4, 5, 4), border="clamp")
    lat.offsets[1, 2, 1] = (0.05, -0.1, 0.2)
    save_deformation(folder / "bulge.ffd", FFD(lat))  # with its placement: used as it is
    prm = Lattice.around(mesh, (3, 3, 3), basis="bernstein")
    prm.offsets[1, 1, 2] = (0.0, 0.0, 0.3)
    save_prm(folder / "pygem.prm", prm)
    save_displacement_field(folder / "field.nii.gz", FFD(lat), {"size": (6, 6, 6), "spacing": 0.4,
                                                                  "origin": (-1.0, -1.0, -1.0)})  # fmt: skip
    interpreter = FreshInterpreter(folder)
    yield {"folder": folder, "mesh": folder / "ball.ply", "interpreter": interpreter}
    interpreter.close()


def new_session(files) -> EditingSession:
    path = files["mesh"]
    session = EditingSession(read_surface(path), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    session.script.origin = MeshOrigin("file", str(path))  # what the editor says when it opens a file
    return session


FILES = ("bulge.ffd", "pygem.prm", "field.nii.gz")
COMMANDS = st.lists(
    st.one_of(
        st.tuples(st.just("drag"), st.integers(0, 10_000), st.integers(1, 3), st.floats(-0.3, 0.3)),
        st.tuples(st.just("move"), st.integers(0, 10_000), st.floats(-0.3, 0.3)),
        st.tuples(st.just("reset"), st.one_of(st.just(-1), st.integers(0, 10_000))),
        st.tuples(st.just("undo")),
        st.tuples(st.just("redo")),
        st.tuples(st.just("code"), st.integers(0, 2), st.integers(0, 3), st.floats(-0.3, 0.3)),
        st.tuples(st.just("shape"), st.tuples(st.integers(4, 6), st.integers(4, 6), st.integers(4, 6))),
        st.tuples(st.just("basis"), st.sampled_from(("bspline", "bernstein"))),
        st.tuples(st.just("interpolation"), st.tuples(*[st.sampled_from(("linear", "catmull-rom", "bspline"))] * 3)),
        st.tuples(st.just("strength"), st.floats(-1.0, 2.0)),
        st.tuples(st.just("weights"), st.integers(0, 2**31)),
        st.tuples(st.just("paint"), st.lists(st.integers(0, 10_000), min_size=1, max_size=4), st.booleans()),
        st.tuples(st.just("clear weights")),
        st.tuples(st.just("surface"), st.integers(0, 10_000), st.floats(-0.2, 0.2), st.booleans()),
        st.tuples(st.just("load"), st.sampled_from(FILES)),
        st.tuples(st.just("save")),
        st.tuples(st.just("decimate"), st.sampled_from((0.0, 0.5))),
    ),
    max_size=10,
)


def apply(session: EditingSession, command: tuple, folder: Path) -> None:
    """One command as the panels or the mouse give it (a refusal, e.g. a shape a basis cannot take, is fine)."""
    name, lat = command[0], session.lattice
    n_points, n_vertices = lat.n_points, len(session.rest_points)
    try:
        if name == "drag":
            index = command[1] % n_points
            session.begin_drag(index)
            for k in range(command[2]):
                session.drag(index, session.control_points()[index] + (command[3] * (k + 1), 0.0, -command[3]))
            session.end_drag()
        elif name == "move":
            session.move_control_point(np.unravel_index(command[1] % n_points, lat.shape), (command[2], 0.1, 0.0))
        elif name == "reset":
            session.reset(None if command[1] < 0 else np.unravel_index(command[1] % n_points, lat.shape))
        elif name in ("undo", "redo"):
            getattr(session, name)()
        elif name == "code":  # a plane of control points moved in place from code, then editor.update()
            index: list = [slice(None)] * 3
            index[command[1]] = command[2] % lat.shape[command[1]]
            lat.offsets[tuple(index)] += (command[3], 0.1 * command[3], 0.0)
            session.update()
        elif name == "shape":
            session.set_shape(command[1])
        elif name == "basis":
            session.set_basis(command[1])
        elif name == "interpolation":
            session.set_interpolation(command[1])
        elif name == "strength":
            session.set_strength(command[1])
        elif name == "weights":
            session.paint.set(np.random.default_rng(command[1]).random(n_vertices).round(3))
        elif name == "paint":
            session.paint.set_brush("raise" if command[2] else "lower")
            session.paint.begin()
            for vertex in command[1]:
                session.paint.stroke(session.rest_points[vertex % n_vertices])
            session.paint.end()
        elif name == "clear weights":
            session.paint.clear()
        elif name == "surface":
            vertex = command[1] % n_vertices
            if command[3]:
                session.surface.pin((vertex + n_vertices // 2) % n_vertices)
            session.surface.begin(vertex)
            session.surface.move(session.ffd.deform(session.rest_points[[vertex]])[0] + (0.0, command[2], 0.0))
            session.surface.end()
        elif name == "load":
            session.files.load_deformation(folder / command[1])
        elif name == "decimate":  # (not an undo step: the code decimates the mesh it reads likewise)
            session.decimate(command[1])
        elif name == "save":
            session.files.save_deformation(folder / "saved.ffd")
            session.files.save_mesh(folder / "saved.ply")
    except ValueError:
        pass


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(commands=COMMANDS)
def test_the_code_of_any_edits_rebuilds_the_ffd_bit_for_bit(files, commands):
    session = new_session(files)
    for command in commands:
        apply(session, command, files["folder"])
    code = session.script.to_code()
    decimated = any(c[0] == "decimate" for c in commands)  # (it clears painted weights outside the history)
    assert decimated or OUTSIDE_HISTORY not in code, code  # every step explained by its own statement
    assert_rebuilt(session, files["interpreter"].run(code))


def test_a_teaching_session_reads_as_the_steps_it_took(files):
    """The statements a teacher's edits give: one per step, in the public API, undone steps absent."""
    session = new_session(files)
    session.begin_drag(5)
    for _ in range(3):  # one drag, three mouse events: one step
        session.drag(5, session.control_points()[5] + (0.0, 0.0, 0.05))
    session.end_drag()
    session.move_control_point((2, 3, 1), (0.0, 5.2, 0.0))
    session.move_control_point((0, 0, 0), (1.0, 0.0, 0.0))
    session.undo()  # absent from the code
    session.lattice.offsets[1, 1, 3] = (0.0, 0.0, 0.25)
    session.update()
    session.lattice.offsets[:, :, 3] += (0.0, 0.0, 0.5)  # (different offsets before: "+=")
    session.update()
    session.set_shape((5, 5, 4))
    session.reset()  # nothing moved yet on the new lattice: no step
    session.move_control_point((4, 4, 3), (0.1, 0.0, 0.0))
    session.move_control_point((1, 1, 1), (0.1, 0.0, 0.0))
    session.reset()
    session.files.save_deformation(files["folder"] / "taught.ffd")
    code = session.script.to_code()
    assert "lattice.offsets[2, 3, 1] = (0.0, 5.2, 0.0)" in code
    assert "lattice.offsets[:, :, 3] += (0.0, 0.0, 0.5)" in code
    assert "(1.0, 0.0, 0.0)" not in code
    assert 'lattice = fn.Lattice.around(mesh, (5, 5, 4), border="clamp")' in code
    assert "lattice.reset()" in code and code.count("lattice.offsets[0, 1, 1] = ") == 1  # (the drag: index 5)
    assert f"mesh = fn.read_mesh({str(files['mesh'])!r})" in code
    assert f"fn.save_deformation({str(files['folder'] / 'taught.ffd')!r}, ffd)" in code
    assert len(session.script.recent(3)) == 3 and session.script.recent(1)[0] == "# reset all\nlattice.reset()"
    assert_rebuilt(session, files["interpreter"].run(code))


def test_a_sum_that_does_not_round_back_is_written_as_values(files):
    """``before + (after - before)`` is not always ``after`` in floating point: then the values, not ``+=``."""
    session = new_session(files)
    session.lattice.offsets[:, 0, :] = 0.2
    session.update()
    session.lattice.offsets[:, 0, :] = 0.9
    session.update()
    assert 0.2 + (0.9 - 0.2) != 0.9
    code = session.script.to_code()
    assert "lattice.offsets[:, 0, :] = (0.9, 0.9, 0.9)" in code and "+=" not in code
    session.lattice.offsets[:, 0, :] += np.arange(4)[:, None, None] * 0.1  # now each row differs
    session.update()
    session.lattice.offsets[:, 0, :] += (0.0, 0.25, 0.0)  # one displacement for all: exact here
    session.update()
    code = session.script.to_code()
    assert "lattice.offsets[:, 0, :] += (0.0, 0.25, 0.0)" in code
    assert_rebuilt(session, files["interpreter"].run(code))


def test_a_given_lattice_and_a_mesh_object_and_a_long_history(files):
    """A lattice placed by hand is written out; the editor's mesh object is the script's variable ``mesh``; steps
    that fell off the bounded history are folded into where the script starts."""
    mesh = read_surface(files["mesh"])
    lattice = Lattice((4, 4, 4), spacing=(0.7, 0.75, 0.8), origin=(-1.05, -1.1, -1.2), border="clamp")
    lattice.offsets[1, 1, 1] = (0.0, -0.0, 0.25)
    session = EditingSession(mesh, mesh_io=PYVISTA_MESH_IO, lattice=lattice)
    session.history.limit = 3
    for k in range(6):
        session.move_control_point((k % 4, 2, 2), (0.01 * k, 0.0, 0.0))
    assert len(session.history) == 3
    code = session.script.to_code()
    assert "# mesh: the mesh the editor was given" in code
    assert "fn.Lattice((4, 4, 4), spacing=(0.7, 0.75, 0.8)" in code and "(0.0, -0.0, 0.25)" in code
    assert "(3 steps of its undo history" in code
    assert_rebuilt(session, files["interpreter"].run(code, given=str(files["mesh"])))


def test_what_the_history_does_not_hold_is_set_at_the_end(files):
    """A placement edited in place (no undo step) still ends in the same FFD, marked as outside the history."""
    session = new_session(files)
    session.move_control_point((1, 1, 1), (0.0, 0.2, 0.0))
    session.lattice.origin = session.lattice.origin + 0.125
    session.update()
    code = session.script.to_code()
    assert OUTSIDE_HISTORY in code
    assert_rebuilt(session, files["interpreter"].run(code))


def test_every_option_of_an_ffd_given_to_the_editor(files):
    """A lattice installed with every option (elastix's half-open domain, an affine part, another border, the outside
    rule, a strength) is written with each of them."""
    session = new_session(files)
    lattice = Lattice.around(session.mesh, (5, 4, 4))
    lattice.offsets[2, 1, 1] = (0.1, 0.0, -0.05)
    affine = np.diag([1.1, 0.9, 1.0, 1.0])
    affine[:3, 3] = (0.01, -0.02, 0.0)
    for options in ({"only_inside": "half-open", "affine": affine, "strength": 0.7},
                    {"border": "clamp", "outside": True, "only_inside": True}):  # fmt: skip
        session.swap_ffd(FFD(lattice.copy(), "bspline", **options), label="lattice", source="given")
        session.move_control_point((1, 1, 1), (0.0, 0.05, 0.0))
        code = session.script.to_code()
        assert OUTSIDE_HISTORY not in code
        assert "only_inside='half-open'" in code  # (the first swap stays in the history)
        assert_rebuilt(session, files["interpreter"].run(code))
    assert "only_inside=True" in code and "outside=True" in code and 'border="clamp"' in code
