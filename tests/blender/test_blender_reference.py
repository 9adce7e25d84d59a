"""ffd_notebook's FFD against Blender's own lattice modifier, evaluated by Blender (``bpy`` 4.5).

Random lattices (2-7 points per axis, each axis its own interpolation, random ``co_deform``, a
rotated, scaled and translated lattice object, "outside" mode on or off), meshes of random points
inside and outside the lattice on a rotated, scaled and translated object, the modifier with a
random strength and a random vertex group: ffd_notebook's result equals Blender's evaluated mesh
to 1e-5 of the lattice's size (Blender computes in float32). The exchange functions of
:mod:`ffd_notebook.blender` round trip through Blender's own evaluation.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.blender import BLENDER_INTERPOLATIONS, ffd_from_record, record_from_ffd

KINDS = tuple(BLENDER_INTERPOLATIONS)  # Blender's enum names
TOLERANCE = 1e-5  # of the lattice's size

# Run in Blender: helpers shared by the scripts below (``IN`` and ``save`` come from run_blender).
BLENDER_PRELUDE = r"""
import bpy
from mathutils import Matrix
from ffd_notebook import blender as fb

def pack(out, prefix, record):
    for key, value in record.items():
        if value is None:
            continue
        out[f"{prefix}{key}"] = np.asarray(value)

def new_lattice(shape, kinds, matrix, name="L"):
    lat = bpy.data.lattices.new(name)
    obj = bpy.data.objects.new(name, lat)
    bpy.context.scene.collection.objects.link(obj)
    lat.points_u, lat.points_v, lat.points_w = (int(n) for n in shape)
    for axis, kind in zip("uvw", kinds):
        setattr(lat, f"interpolation_type_{axis}", kind)
    obj.matrix_world = Matrix(np.asarray(matrix).tolist())
    return obj

def new_points(points, matrix, name="M"):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(points).tolist(), [], [])
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.matrix_world = Matrix(np.asarray(matrix).tolist())
    return obj

def world_rest_points(obj):
    # the mesh's own (float32) vertices, in world coordinates: the input the FFD gets
    mesh = obj.data
    flat = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", flat)
    m = np.array([list(r) for r in obj.matrix_world])
    return flat.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]

def add_group(obj, weights, name="group"):
    group = obj.vertex_groups.new(name=name)
    for i, w in enumerate(weights):
        if w > 0:
            group.add([i], float(w), "REPLACE")
    return group
"""

CASES_SCRIPT = r"""
out = {}
for c, case in enumerate(IN["json"]):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = new_lattice(case["shape"], case["kinds"], IN[f"{c}_lattice_matrix"])
    lat = obj.data
    count = len(lat.points)
    co = np.empty(3 * count, np.float32)
    lat.points.foreach_get("co", co)
    co = co.reshape(-1, 3)
    step = (co.max(axis=0) - co.min(axis=0)) / np.maximum(np.array(case["shape"]) - 1, 1)
    lat.points.foreach_set("co_deform", (co + IN[f"{c}_jitter"] * step).astype(np.float32).ravel())
    pack(out, f"{c}_before_", fb.lattice_record(obj))       # inner points as set, before "outside"
    lat.use_outside = case["outside"]
    mesh = new_points(IN[f"{c}_local_points"], IN[f"{c}_mesh_matrix"])
    modifier = mesh.modifiers.new("lattice", "LATTICE")
    modifier.object = obj
    modifier.strength = case["strength"]
    if case["group"]:
        add_group(mesh, IN[f"{c}_weights"])
        modifier.vertex_group = "group"
        modifier.invert_vertex_group = case["invert"]
    out[f"{c}_points"] = world_rest_points(mesh)
    out[f"{c}_blender"] = fb.evaluated_points(mesh)
    pack(out, f"{c}_record_", fb.lattice_record(obj, modifier))
    # the exchange inside Blender's own Python: the FFD it reads deforms as the modifier does ...
    ffd = fb.ffd_from_lattice(obj, modifier)
    out[f"{c}_ffd_in_blender"] = ffd.deform(out[f"{c}_points"])
    # ... and the lattice it writes back (on a copy of the mesh) deforms as Blender's first one did
    copy = new_points(IN[f"{c}_local_points"], IN[f"{c}_mesh_matrix"], name="copy")
    if case["group"]:
        pass  # lattice_from_ffd makes the vertex group from the FFD's weights
    fb.lattice_from_ffd(ffd, "L2", target=copy)
    out[f"{c}_round_trip"] = fb.evaluated_points(copy)
save(**out)
"""


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _trs(rng, scale_range=(0.5, 3.0), *, allow_mirror=False):
    m = np.eye(4)
    scale = rng.uniform(*scale_range, size=3)
    if allow_mirror and rng.random() < 0.3:
        scale[rng.integers(3)] *= -1
    m[:3, :3] = _rotation(rng) * scale
    m[:3, 3] = rng.uniform(-3, 3, size=3)
    return m


def make_cases(rng, n_cases, *, kinds=None, outside=None, strength=None, group=None):
    cases, arrays = [], {}
    for c in range(n_cases):
        shape = rng.integers(2, 8, size=3).tolist()
        case = {
            "shape": shape,
            "kinds": list(kinds) if kinds is not None else [str(k) for k in rng.choice(KINDS, size=3)],
            "outside": bool(rng.random() < 0.3) if outside is None else outside,
            "strength": float(rng.uniform(-0.5, 1.5)) if strength is None else strength,
            "group": bool(rng.random() < 0.5) if group is None else group,
            "invert": bool(rng.random() < 0.3),
        }
        lattice_matrix = _trs(rng, allow_mirror=True)
        mesh_matrix = _trs(rng, (0.5, 2.0))
        # points inside and outside the lattice, in world, then into the mesh object's space
        n_points = 400
        world = rng.uniform(-0.8, 0.8, size=(n_points, 3)) @ lattice_matrix[:3, :3].T + lattice_matrix[:3, 3]
        local = (world - mesh_matrix[:3, 3]) @ np.linalg.inv(mesh_matrix[:3, :3]).T
        weights = np.where(rng.random(n_points) < 0.2, 0.0, rng.random(n_points))
        arrays.update(
            {
                f"{c}_lattice_matrix": lattice_matrix,
                f"{c}_mesh_matrix": mesh_matrix,
                f"{c}_jitter": rng.uniform(-0.6, 0.6, size=(int(np.prod(shape)), 3)),
                f"{c}_local_points": local,
                f"{c}_weights": weights,
            }
        )
        cases.append(case)
    return cases, arrays


def unpack(result, prefix):
    record = {k[len(prefix) :]: v for k, v in result.items() if k.startswith(prefix)}
    record["interpolation"] = tuple(str(s) for s in record["interpolation"])
    record["shape"] = tuple(int(n) for n in record["shape"])
    record.setdefault("weights", None)
    return record


def lattice_size(record):
    m = record["matrix_world"]
    rest = record["rest"].reshape(-1, 3) @ m[:3, :3].T
    return float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0)))


@pytest.fixture(scope="module")
def random_cases(blender):
    rng = np.random.default_rng(23)
    cases, arrays = make_cases(rng, 24)
    # make sure each interpolation is on some axis and both modes of "outside" are there
    cases[0].update(kinds=["KEY_BSPLINE", "KEY_CATMULL_ROM", "KEY_LINEAR"], outside=False, group=True)
    cases[1].update(kinds=["KEY_CARDINAL", "KEY_BSPLINE", "KEY_CATMULL_ROM"], outside=True, group=True)
    cases[1]["shape"] = [5, 4, 6]
    arrays["1_jitter"] = rng.uniform(-0.6, 0.6, size=(5 * 4 * 6, 3))
    return cases, blender(BLENDER_PRELUDE + CASES_SCRIPT, {**arrays, "json": cases})


def test_ffd_equals_blender_lattice_modifier(random_cases):
    """The FFD read from Blender's data deforms the mesh's points as Blender's modifier does."""
    cases, result = random_cases
    worst, largest_move = 0.0, 0.0
    for c, case in enumerate(cases):
        record = unpack(result, f"{c}_record_")
        size = lattice_size(record)
        ffd = ffd_from_record(record)
        if case["group"]:
            assert ffd.weights is not None and len(ffd.weights) == len(result[f"{c}_points"])
        ours = ffd.deform(result[f"{c}_points"])
        blender = result[f"{c}_blender"]
        largest_move = max(largest_move, np.abs(blender - result[f"{c}_points"]).max() / size)
        error = np.abs(ours - blender).max() / size
        worst = max(worst, error)
        assert error < TOLERANCE, f"case {c} {case}: off by {error:.2e} of the lattice size"
    assert largest_move > 0.02, "Blender's modifier hardly deformed anything: the comparison proves little"
    print(f"worst difference from Blender: {worst:.2e} of the lattice size over {len(cases)} lattices")


def test_outside_mode_derives_inner_points_as_blender_does(random_cases):
    """With ``outside``, the inner points follow the outer ones: from the points as they were set (before
    Blender recomputed the inner ones), the FFD gives Blender's result."""
    cases, result = random_cases
    checked = 0
    for c, case in enumerate(cases):
        if not case["outside"] or min(case["shape"]) < 3:
            continue
        before = unpack(result, f"{c}_before_")
        after = unpack(result, f"{c}_record_")
        assert not np.allclose(before["deformed"], after["deformed"]), "Blender recomputed no inner point"
        before.update(outside=True, strength=after["strength"], weights=after["weights"])
        ours = ffd_from_record(before).deform(result[f"{c}_points"])
        error = np.abs(ours - result[f"{c}_blender"]).max() / lattice_size(after)
        assert error < TOLERANCE, f"case {c}: off by {error:.2e}"
        checked += 1
    assert checked >= 1


def test_exchange_inside_blender(random_cases):
    """Inside Blender's Python, ``ffd_from_lattice`` gives Blender's result, and ``lattice_from_ffd``
    makes a lattice and modifier that Blender evaluates to the same mesh."""
    cases, result = random_cases
    for c in range(len(cases)):
        size = lattice_size(unpack(result, f"{c}_record_"))
        assert np.abs(result[f"{c}_ffd_in_blender"] - result[f"{c}_blender"]).max() / size < TOLERANCE
        assert np.abs(result[f"{c}_round_trip"] - result[f"{c}_blender"]).max() / size < TOLERANCE


ROUND_TRIP_SCRIPT = r"""
out = {}
for c, _ in enumerate(IN["json"]):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    record = {k[len(f"{c}_record_"):]: IN[k] for k in IN if k.startswith(f"{c}_record_")}
    record["interpolation"] = tuple(str(s) for s in record["interpolation"])
    record.setdefault("weights", None)
    mesh = new_points(IN[f"{c}_points"], np.eye(4))
    obj = fb.lattice_from_record(record, "FromFFD")
    modifier = mesh.modifiers.new("lattice", "LATTICE")
    modifier.object = obj
    modifier.strength = float(record["strength"])
    if record["weights"] is not None:
        add_group(mesh, record["weights"])
        modifier.vertex_group = "group"
    out[f"{c}_blender"] = fb.evaluated_points(mesh)
    out[f"{c}_points"] = world_rest_points(mesh)
    pack(out, f"{c}_back_", fb.lattice_record(obj, modifier))
save(**out)
"""


def test_ffd_to_blender_and_back(blender):
    """An FFD made here, written as a Blender lattice: Blender deforms points as the FFD does, and
    reading the lattice back gives the same FFD."""
    rng = np.random.default_rng(5)
    ffds, arrays = [], {}
    for c in range(6):
        shape = tuple(int(n) for n in rng.integers(2, 8, size=3))
        lat = Lattice(shape, rng.uniform(0.3, 2.0, size=3), origin=rng.uniform(-2, 2, 3), rotation=_rotation(rng))
        lat.border = "clamp"
        lat.offsets[...] = rng.normal(scale=0.2, size=lat.offsets.shape) * lat.spacing
        basis = "bspline" if c == 0 else tuple(str(b) for b in rng.choice(list(BLENDER_INTERPOLATIONS.values()), 3))
        ffd = FFD(lat, basis=basis, border="clamp")
        if c >= 2:
            ffd.strength = float(rng.uniform(-0.5, 1.5))
        if c >= 3:
            ffd.outside = bool(c % 2)
        box = lat.control_points().reshape(-1, 3)
        lo, hi = box.min(axis=0), box.max(axis=0)
        points = rng.uniform(lo - 0.3 * (hi - lo), hi + 0.3 * (hi - lo), size=(300, 3))
        if c >= 4:
            ffd.weights = rng.random(len(points))
        ffds.append(ffd)
        arrays[f"{c}_points"] = points
        for key, value in record_from_ffd(ffd).items():
            if value is not None:
                arrays[f"{c}_record_{key}"] = np.asarray(value)
    result = blender(BLENDER_PRELUDE + ROUND_TRIP_SCRIPT, {**arrays, "json": list(range(len(ffds)))})
    for c, ffd in enumerate(ffds):
        size = float(np.linalg.norm(ffd.lattice.spacing * (np.array(ffd.lattice.shape) - 1)))
        ours = ffd.deform(result[f"{c}_points"])
        error = np.abs(ours - result[f"{c}_blender"]).max() / size
        assert error < TOLERANCE, f"FFD {c} ({ffd.basis}): Blender differs by {error:.2e} of the lattice size"
        back = ffd_from_record(unpack(result, f"{c}_back_"))
        assert back.basis == ffd.basis
        assert np.allclose(back.lattice.control_points(), ffd.lattice.control_points(), atol=1e-5 * size)
        # with "outside", Blender recomputed the inner points: what both use is the same
        assert np.allclose(back.offsets_in_use(), ffd.offsets_in_use(), atol=1e-5 * size)
        assert back.outside == ffd.outside
        assert back.strength == pytest.approx(getattr(ffd, "strength", 1.0), abs=1e-6)


def test_run_blender_reports_a_failing_script(blender):
    """A Blender script that fails is an error with Blender's message, not an empty result."""
    with pytest.raises(RuntimeError, match="no_such_lattice"):
        blender("import bpy\nbpy.data.objects['no_such_lattice']\n")


def test_harness_passes_arrays_both_ways(blender):
    result = blender("import bpy\nsave(twice=IN['x'] * 2, version=np.array(bpy.app.version))\n", {"x": np.arange(3)})
    assert result["twice"].tolist() == [0, 2, 4]
    assert tuple(result["version"][:2]) == (4, 5)


def test_cases_json_is_plain():
    cases, _ = make_cases(np.random.default_rng(0), 2)
    assert json.loads(json.dumps(cases)) == cases


def test_without_bpy_the_message_says_what_to_do():
    """This interpreter has no ``bpy`` (NumPy 2): the Blender side says how to get it; the NumPy side works."""
    import importlib.util

    if importlib.util.find_spec("bpy") is not None:
        pytest.skip("bpy is importable here")
    from ffd_notebook.blender import lattice_from_record, lattice_record

    with pytest.raises(ImportError, match="pip install bpy"):
        lattice_record(object())
    with pytest.raises(ImportError, match="inside Blender"):
        lattice_from_record({})


def test_what_a_blender_lattice_cannot_hold_is_refused_with_the_reason():
    lat = Lattice((4, 4, 4), 1.0)
    with pytest.raises(ValueError, match=r"affine part.*border is 'zero'"):
        record_from_ffd(FFD(lat, affine=np.diag([2.0, 1.0, 1.0, 1.0])))
    with pytest.raises(ValueError, match="'bernstein' is none of Blender's interpolations"):
        record_from_ffd(FFD(lat, "bernstein"))
    clamp = FFD(Lattice((4, 4, 4), 1.0, border="clamp"), weights="nose")
    with pytest.raises(ValueError, match="give the array itself"):
        record_from_ffd(clamp)
    record = record_from_ffd(FFD(Lattice((3, 3, 3), 1.0, border="clamp")))
    # a lattice under a non-uniformly scaled, rotated parent is sheared: read as a sheared lattice, not written back
    sheared = dict(record, matrix_world=np.array([[1.0, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    ffd = ffd_from_record(sheared)
    assert ffd.lattice.sheared
    world = record["rest"].reshape(-1, 3) @ sheared["matrix_world"][:3, :3].T
    np.testing.assert_allclose(ffd.lattice.control_points().reshape(-1, 3), world, atol=1e-12)
    with pytest.raises(ValueError, match="sheared"):
        record_from_ffd(ffd)
    flat = dict(record, shape=(1, 3, 3), rest=record["rest"][:1], deformed=record["deformed"][:1])
    with pytest.raises(ValueError, match="one point along an axis"):
        ffd_from_record(flat)
