"""Exchange with Blender: a Blender lattice object as an :class:`~ffd_notebook.FFD`, and back.

Blender's lattice modifier moves a vertex ``x`` (world coordinates here) by
``strength * weight(x) * sum_ijk w_u(i) w_v(j) w_w(k) d_ijk``, where ``d_ijk`` is the displacement
of control point ``(i, j, k)`` (its ``co_deform`` minus its rest ``co``, through the object's
transform), the weights are those of each axis' interpolation (linear, cardinal, Catmull-Rom or
B-spline) with indices clamped at the lattice's ends, and ``weight`` is the vertex group's weight
(Blender's ``lattice_deform.cc``). That is exactly ``FFD(lattice, basis=(...), border="clamp")``
with the modifier's strength and vertex-group weights, which is what :func:`ffd_from_lattice`
builds; :func:`lattice_from_ffd` goes the other way.

Blender's ``bpy`` is imported only when a function here needs it, so this module imports in any
Python: the conversions are split into a part that talks to Blender (:func:`lattice_record`,
:func:`lattice_from_record`) and a NumPy part (:func:`ffd_from_record`, :func:`record_from_ffd`),
whose "record" is a plain dict of arrays, strings and numbers that can be saved with
``numpy.savez`` and carried between Blender's Python and another one. Inside Blender, put the
folder holding ``ffd_notebook`` on ``sys.path``: the engine needs NumPy only.

Examples
--------
>>> import numpy as np
>>> from ffd_notebook import Lattice, FFD
>>> from ffd_notebook.blender import ffd_from_record, record_from_ffd
>>> lat = Lattice((3, 4, 2), spacing=(1.0, 0.5, 2.0), origin=(1, 2, 3), border="clamp")
>>> lat.offsets[1, 2, 0] = (0.0, 0.3, 0.0)
>>> rec = record_from_ffd(FFD(lat, border="clamp"))
>>> rec["interpolation"], rec["matrix_world"].round(3)[:3, 3].tolist()
(('bspline', 'bspline', 'bspline'), [2.0, 2.75, 4.0])
>>> back = ffd_from_record(rec)
>>> bool(np.allclose(back.lattice.offsets, lat.offsets)), back.lattice.shape
(True, (3, 4, 2))
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BLENDER_INTERPOLATIONS",
    "evaluated_points",
    "ffd_from_lattice",
    "ffd_from_record",
    "lattice_from_ffd",
    "lattice_from_record",
    "lattice_record",
    "record_from_ffd",
    "vertex_group_weights",
]

#: Blender's interpolation enum (``Lattice.interpolation_type_u``) -> the FFD basis of an axis.
BLENDER_INTERPOLATIONS = {
    "KEY_LINEAR": "linear",
    "KEY_CARDINAL": "cardinal",
    "KEY_CATMULL_ROM": "catmull-rom",
    "KEY_BSPLINE": "bspline",
}
_TO_BLENDER = {v: k for k, v in BLENDER_INTERPOLATIONS.items()}
_AXES = ("u", "v", "w")


def _bpy() -> Any:
    try:
        import bpy
    except ImportError as exc:  # the message says what to do, not only what failed
        raise ImportError(
            "ffd_notebook.blender needs Blender's Python module 'bpy': run this inside Blender "
            "(with ffd_notebook's folder on sys.path), or install Blender as a module with "
            "'pip install bpy' (Blender 4.5 is built for Python 3.11)"
        ) from exc
    return bpy


def _matrix_array(matrix: Any) -> NDArray[np.float64]:
    return np.array([list(row) for row in matrix], dtype=np.float64)


def _point_array(collection: Any, attribute: str, count: int) -> NDArray[np.float64]:
    flat = np.empty(count * 3, dtype=np.float32)
    collection.foreach_get(attribute, flat)
    return flat.astype(np.float64).reshape(count, 3)


# ---------------------------------------------------------------------------------------------- Blender side
def lattice_record(lattice_object: Any, modifier: Any = None) -> dict[str, Any]:
    """Everything an FFD needs from a Blender lattice object (and a lattice modifier), as NumPy data.

    Parameters
    ----------
    lattice_object : bpy.types.Object
        An object whose data is a ``bpy.types.Lattice``.
    modifier : bpy.types.LatticeModifier, optional
        A lattice modifier using ``lattice_object``; its strength and vertex group (the weights of
        the vertices of the mesh object that owns the modifier, inverted if it says so) are added.

    Returns
    -------
    dict
        ``shape`` (points per axis u, v, w), ``rest`` and ``deformed`` (``(nu, nv, nw, 3)``, the
        points' ``co`` and ``co_deform`` in the lattice object's space), ``matrix_world`` (4x4),
        ``interpolation`` (one FFD basis name per axis), ``outside`` (bool), ``strength``
        (float) and ``weights`` (``(N,)`` array or None).

    Examples
    --------
    Inside Blender (these examples run in Blender's Python in the test suite):

    >>> import bpy
    >>> data = bpy.data.lattices.new("Cage")
    >>> data.points_u, data.points_v, data.points_w = 3, 2, 2
    >>> data.interpolation_type_u = "KEY_LINEAR"
    >>> cage = bpy.data.objects.new("Cage", data)
    >>> bpy.context.scene.collection.objects.link(cage)
    >>> record = lattice_record(cage)
    >>> record["shape"], record["interpolation"], record["rest"][:, 0, 0, 0].tolist()
    ((3, 2, 2), ('linear', 'bspline', 'bspline'), [-1.0, 0.0, 1.0])
    """
    bpy = _bpy()
    lattice = lattice_object.data
    if not isinstance(lattice, bpy.types.Lattice):
        raise TypeError(f"{lattice_object.name!r} is not a lattice object (its data is {type(lattice).__name__})")
    shape = (lattice.points_u, lattice.points_v, lattice.points_w)
    count = int(np.prod(shape))
    # Blender numbers points u fastest: index = (w * nv + v) * nu + u
    grid = (shape[2], shape[1], shape[0], 3)
    rest = _point_array(lattice.points, "co", count).reshape(grid).transpose(2, 1, 0, 3)
    deformed = _point_array(lattice.points, "co_deform", count).reshape(grid).transpose(2, 1, 0, 3)
    record: dict[str, Any] = {
        "shape": shape,
        "rest": np.ascontiguousarray(rest),
        "deformed": np.ascontiguousarray(deformed),
        "matrix_world": _matrix_array(lattice_object.matrix_world),
        "interpolation": tuple(BLENDER_INTERPOLATIONS[getattr(lattice, f"interpolation_type_{a}")] for a in _AXES),
        "outside": bool(lattice.use_outside),
        "strength": 1.0,
        "weights": None,
    }
    if modifier is not None:
        if modifier.type != "LATTICE":
            raise TypeError(f"modifier {modifier.name!r} is a {modifier.type} modifier, not a lattice modifier")
        if modifier.object is not None and modifier.object.name != lattice_object.name:
            raise ValueError(
                f"modifier {modifier.name!r} deforms with lattice {modifier.object.name!r}, not {lattice_object.name!r}"
            )
        record["strength"] = float(modifier.strength)
        if modifier.vertex_group:
            owner = modifier.id_data
            weights = vertex_group_weights(owner, modifier.vertex_group)
            record["weights"] = 1.0 - weights if modifier.invert_vertex_group else weights
    return record


def vertex_group_weights(mesh_object: Any, name: str) -> NDArray[np.float64]:
    """Weights of the vertex group ``name`` of a mesh object, one per vertex (0 where a vertex is not in it).

    Parameters
    ----------
    mesh_object : bpy.types.Object
        A mesh object.
    name : str
        The name of one of its vertex groups.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` float64, one weight in [0, 1] per vertex of the mesh.

    Raises
    ------
    KeyError
        If the object has no vertex group of that name.

    Examples
    --------
    Inside Blender:

    >>> import bpy
    >>> mesh = bpy.data.meshes.new("Triangle")
    >>> mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    >>> triangle = bpy.data.objects.new("Triangle", mesh)
    >>> nose = triangle.vertex_groups.new(name="nose")
    >>> nose.add([1], 0.5, "REPLACE")
    >>> vertex_group_weights(triangle, "nose").tolist()
    [0.0, 0.5, 0.0]
    """
    group = mesh_object.vertex_groups.get(name)
    if group is None:
        raise KeyError(f"object {mesh_object.name!r} has no vertex group {name!r}")
    vertices = mesh_object.data.vertices
    out = np.zeros(len(vertices))
    for i, vertex in enumerate(vertices):
        for element in vertex.groups:
            if element.group == group.index:
                out[i] = element.weight
                break
    return out


def evaluated_points(mesh_object: Any, *, world: bool = True) -> NDArray[np.float64]:
    """Vertex positions of a mesh object after its modifiers (Blender's evaluated mesh), ``(N, 3)``.

    Parameters
    ----------
    mesh_object : bpy.types.Object
        A mesh object.
    world : bool
        World coordinates (through the object's ``matrix_world``) rather than the object's own.

    Returns
    -------
    numpy.ndarray
        ``(N, 3)`` float64, one row per vertex of the evaluated mesh.

    Examples
    --------
    Inside Blender: two vertices of an object moved 10 along x (no modifier, so only the move applies).

    >>> import bpy
    >>> mesh = bpy.data.meshes.new("Two")
    >>> mesh.from_pydata([(0, 0, 0), (0.25, 0, 0)], [], [])
    >>> two = bpy.data.objects.new("Two", mesh)
    >>> bpy.context.scene.collection.objects.link(two)
    >>> two.location = (10.0, 0.0, 0.0)
    >>> evaluated_points(two).round(3).tolist()
    [[10.0, 0.0, 0.0], [10.25, 0.0, 0.0]]
    >>> evaluated_points(two, world=False).round(3).tolist()
    [[0.0, 0.0, 0.0], [0.25, 0.0, 0.0]]
    """
    bpy = _bpy()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    evaluated = mesh_object.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        points = _point_array(mesh.vertices, "co", len(mesh.vertices))
    finally:
        evaluated.to_mesh_clear()
    if world:
        m = _matrix_array(mesh_object.matrix_world)
        points = points @ m[:3, :3].T + m[:3, 3]
    return points


def lattice_from_record(record: dict[str, Any], name: str = "Lattice", *, collection: Any = None) -> Any:
    """Create a Blender lattice object from a record (see :func:`record_from_ffd`).

    The object is linked into ``collection`` (the scene's own by default) and placed by its
    ``matrix_world`` so that its rest points are the record's; its points' ``co_deform`` carry
    the displacements, and its interpolations and "outside" flag are the record's.

    Parameters
    ----------
    record : dict
        A record as :func:`lattice_record` or :func:`record_from_ffd` makes.
    name : str
        Name of the new lattice data and object.
    collection : bpy.types.Collection, optional
        Where to link the new object (the scene's collection by default).

    Returns
    -------
    bpy.types.Object
        The new lattice object.

    Examples
    --------
    Inside Blender: a 2 x 2 x 2 lattice twice Blender's unit size, its top corner point raised.

    >>> import bpy
    >>> import numpy as np
    >>> rest = np.stack(np.meshgrid(*[[-1.0, 1.0]] * 3, indexing="ij"), axis=-1)
    >>> deformed = rest.copy()
    >>> deformed[1, 1, 1, 2] += 0.5
    >>> record = {"shape": (2, 2, 2), "rest": rest, "deformed": deformed, "matrix_world": np.eye(4),
    ...           "interpolation": ("linear",) * 3, "outside": False}
    >>> cage = lattice_from_record(record, "Raised")
    >>> cage.data.points_u, cage.data.interpolation_type_w, np.round(cage.matrix_world.to_scale(), 3).tolist()
    (2, 'KEY_LINEAR', [2.0, 2.0, 2.0])
    >>> np.round(lattice_record(cage)["deformed"][1, 1, 1] - lattice_record(cage)["rest"][1, 1, 1], 3).tolist()
    [0.0, 0.0, 0.25]
    """
    bpy = _bpy()
    from mathutils import Matrix  # Blender's, present wherever bpy is

    shape = tuple(int(n) for n in record["shape"])
    lattice = bpy.data.lattices.new(name)
    obj = bpy.data.objects.new(name, lattice)
    (collection or bpy.context.scene.collection).objects.link(obj)
    lattice.points_u, lattice.points_v, lattice.points_w = shape
    for axis, kind in zip(_AXES, record["interpolation"], strict=True):
        setattr(lattice, f"interpolation_type_{axis}", _TO_BLENDER[kind])
    count = int(np.prod(shape))
    # Blender chose the rest points (they depend on how the lattice was made): read them, and map
    # them onto the record's with the object's transform.
    local_rest = _point_array(lattice.points, "co", count).reshape(shape[::-1] + (3,)).transpose(2, 1, 0, 3)
    first = local_rest[0, 0, 0]
    local_step = np.array([local_rest[1, 0, 0, 0], local_rest[0, 1, 0, 1], local_rest[0, 0, 1, 2]]) - first
    world = np.asarray(record["matrix_world"], dtype=np.float64)
    rest = np.asarray(record["rest"], dtype=np.float64)
    record_step = np.array([rest[1, 0, 0, 0], rest[0, 1, 0, 1], rest[0, 0, 1, 2]]) - rest[0, 0, 0]
    # record: world = M (rest); rest = rest0 + idx * record_step (per axis)  ->  new local = first + idx * local_step
    scale = record_step / local_step
    linear = world[:3, :3] * scale
    translation = world[:3, :3] @ rest[0, 0, 0] + world[:3, 3] - linear @ first
    matrix = np.eye(4)
    matrix[:3, :3] = linear
    matrix[:3, 3] = translation
    obj.matrix_world = Matrix(matrix.tolist())
    displacement_world = (np.asarray(record["deformed"]) - rest) @ world[:3, :3].T
    deformed_local = local_rest + displacement_world @ np.linalg.inv(linear).T
    flat = np.ascontiguousarray(deformed_local.transpose(2, 1, 0, 3), dtype=np.float32).ravel()
    lattice.points.foreach_set("co_deform", flat)
    lattice.use_outside = bool(record.get("outside", False))
    lattice.update_tag()
    return obj


def ffd_from_lattice(lattice_object: Any, modifier: Any = None) -> Any:
    """The :class:`~ffd_notebook.FFD` of a Blender lattice object (and lattice modifier), in world coordinates.

    The FFD's lattice is placed where Blender's rest points are (through the object's transform),
    its offsets are the points' displacements (``co_deform - co``), each axis' basis is the
    lattice's interpolation and the border is ``"clamp"``, Blender's. With a modifier, the FFD's
    ``strength`` is the modifier's and its ``weights`` the vertex group's, one per vertex of the
    mesh object that owns the modifier.

    Parameters
    ----------
    lattice_object : bpy.types.Object
        A lattice object.
    modifier : bpy.types.LatticeModifier, optional
        A lattice modifier using it.

    Returns
    -------
    FFD
        ``ffd.deform(world_points)`` gives what Blender's modifier gives (in world coordinates).

    Examples
    --------
    Inside Blender: a 3 x 3 x 3 lattice with its centre point raised by 0.25 (of its unit size).

    >>> import bpy
    >>> data = bpy.data.lattices.new("Centre")
    >>> data.points_u = data.points_v = data.points_w = 3
    >>> cage = bpy.data.objects.new("Centre", data)
    >>> bpy.context.scene.collection.objects.link(cage)
    >>> data.points[13].co_deform.z += 0.25
    >>> ffd = ffd_from_lattice(cage)
    >>> ffd.lattice.shape, ffd.basis, ffd.border, ffd.lattice.offsets[1, 1, 1].round(3).tolist()
    ((3, 3, 3), 'bspline', 'clamp', [0.0, 0.0, 0.25])
    """
    return ffd_from_record(lattice_record(lattice_object, modifier))


def lattice_from_ffd(ffd: Any, name: str = "Lattice", *, target: Any = None, collection: Any = None) -> Any:
    """Create the Blender lattice object that deforms a mesh as ``ffd`` does.

    Parameters
    ----------
    ffd : FFD
        A lattice FFD Blender can hold: no affine part, the ``"clamp"`` border, Blender's bases.
    name : str
        Name of the new lattice data and object.
    target : bpy.types.Object, optional
        A mesh object to give a lattice modifier using the new lattice, with the FFD's strength
        and, if the FFD has per-vertex weights, a vertex group of them (named ``name + "_weights"``).
    collection : bpy.types.Collection, optional
        Where to link the new object (the scene's collection by default).

    Returns
    -------
    bpy.types.Object
        The new lattice object.

    Examples
    --------
    Inside Blender: the lattice modifier of the new lattice moves a mesh's vertices as the FFD does.

    >>> import bpy
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lattice = Lattice((3, 3, 3), spacing=1.0, border="clamp")
    >>> lattice.offsets[1, 1, 1] = (0.0, 0.0, 0.5)
    >>> ffd = FFD(lattice, border="clamp")
    >>> points = np.array([[1.0, 1.0, 1.0], [0.5, 1.2, 0.8]])
    >>> mesh = bpy.data.meshes.new("Blob")
    >>> mesh.from_pydata(points.tolist(), [], [])
    >>> blob = bpy.data.objects.new("Blob", mesh)
    >>> bpy.context.scene.collection.objects.link(blob)
    >>> cage = lattice_from_ffd(ffd, "Cage", target=blob)
    >>> bool(np.allclose(evaluated_points(blob), ffd.deform(points), atol=1e-5))
    True
    >>> bool(np.allclose(ffd_from_lattice(cage).lattice.offsets, lattice.offsets, atol=1e-6))
    True
    """
    record = record_from_ffd(ffd)
    obj = lattice_from_record(record, name, collection=collection)
    if target is not None:
        modifier = target.modifiers.new(name, "LATTICE")
        modifier.object = obj
        modifier.strength = float(record["strength"])
        weights = record["weights"]
        if weights is not None:
            weights = np.asarray(weights, dtype=np.float64)
            if len(weights) != len(target.data.vertices):
                raise ValueError(
                    f"the FFD has {len(weights)} weights but {target.name!r} has {len(target.data.vertices)} vertices"
                )
            group = target.vertex_groups.new(name=f"{name}_weights")
            for value in np.unique(weights):
                if value > 0:
                    group.add(np.flatnonzero(weights == value).tolist(), float(value), "REPLACE")
            modifier.vertex_group = group.name
    return obj


# ---------------------------------------------------------------------------------------------- NumPy side
def ffd_from_record(record: dict[str, Any]) -> Any:
    """The :class:`~ffd_notebook.FFD` a record describes (see :func:`lattice_record`), in world coordinates.

    Parameters
    ----------
    record : dict
        ``shape``, ``rest``, ``deformed``, ``matrix_world`` and ``interpolation``, and optionally
        ``outside``, ``strength`` and ``weights`` (see :func:`lattice_record`).

    Returns
    -------
    FFD
        A lattice FFD with the ``"clamp"`` border, in world coordinates, deforming as Blender's modifier.

    Raises
    ------
    ValueError
        If the lattice cannot be an FFD lattice: an axis with one point, or rest points that are
        not a regular grid. (A lattice under a non-uniformly scaled, rotated parent is sheared: a
        sheared :class:`~ffd_notebook.Lattice`.)

    Examples
    --------
    A 2x2x2 Blender lattice (the default unit box, scaled by 2 and moved), its corner (1, 1, 1) raised by 0.5
    in the lattice's space (1 in the world's), linear along every axis:

    >>> rest = np.stack(np.meshgrid(*[[-0.5, 0.5]] * 3, indexing="ij"), axis=-1)
    >>> deformed = rest.copy()
    >>> deformed[1, 1, 1, 2] += 0.5
    >>> matrix = np.diag([2.0, 2.0, 2.0, 1.0])
    >>> matrix[:3, 3] = (10.0, 0.0, 0.0)
    >>> record = {"shape": (2, 2, 2), "rest": rest, "deformed": deformed, "matrix_world": matrix,
    ...           "interpolation": ("linear", "linear", "linear")}
    >>> ffd = ffd_from_record(record)
    >>> ffd.lattice.origin.tolist(), ffd.lattice.spacing.tolist(), ffd.lattice.offsets[1, 1, 1].tolist()
    ([9.0, -1.0, -1.0], [2.0, 2.0, 2.0], [0.0, 0.0, 1.0])
    >>> ffd.deform(np.array([[11.0, 1.0, 1.0], [10.0, 0.0, 0.0]])).round(3).tolist()
    [[11.0, 1.0, 2.0], [10.0, 0.0, 0.125]]
    """
    from . import FFD, Lattice

    shape = tuple(int(n) for n in record["shape"])
    if min(shape) < 2:
        raise ValueError(f"a Blender lattice with one point along an axis has no FFD lattice (points {shape})")
    rest = np.asarray(record["rest"], dtype=np.float64).reshape(shape + (3,))
    deformed = np.asarray(record["deformed"], dtype=np.float64).reshape(shape + (3,))
    matrix = np.asarray(record["matrix_world"], dtype=np.float64)
    linear, shift = matrix[:3, :3], matrix[:3, 3]
    world_rest = rest @ linear.T + shift
    origin = world_rest[0, 0, 0]
    steps = np.stack([world_rest[1, 0, 0], world_rest[0, 1, 0], world_rest[0, 0, 1]]) - origin  # rows: axes
    spacing = np.linalg.norm(steps, axis=1)
    if not np.all(spacing > 0):
        raise ValueError("the lattice's rest points coincide along an axis (a zero scale?)")
    # float32 data: a rotation to rounding is made exact by Lattice (nearest_rotation); beyond that, a sheared
    # lattice (an object under a non-uniformly scaled, rotated parent), which Lattice holds too
    lattice = Lattice(shape, spacing, origin=origin, rotation=(steps / spacing[:, None]).T, border="clamp")
    expected = lattice.control_points()
    if not np.allclose(expected, world_rest, atol=1e-5 * float(spacing.max()) + 1e-9):
        raise ValueError("the lattice's rest points are not a regular grid")
    lattice.offsets[...] = (deformed - rest) @ linear.T
    interpolation = tuple(str(kind) for kind in record["interpolation"])
    basis: Any = "bspline" if interpolation == ("bspline",) * 3 else interpolation
    outside, strength = bool(record.get("outside", False)), float(record.get("strength", 1.0))
    return FFD(lattice, basis=basis, border="clamp", outside=outside, strength=strength, weights=record.get("weights"))


def record_from_ffd(ffd: Any) -> dict[str, Any]:
    """A record (see :func:`lattice_record`) of the Blender lattice that deforms as ``ffd`` does.

    The lattice object's rest points are placed in a unit box (Blender's default lattice is
    ``[-0.5, 0.5]`` per axis) and its ``matrix_world`` scales, rotates and moves them onto
    the FFD's control points.

    Parameters
    ----------
    ffd : FFD
        A lattice FFD Blender can hold (see Raises).

    Returns
    -------
    dict
        The record, keys as :func:`lattice_record`'s.

    Raises
    ------
    ValueError
        If Blender's lattice cannot hold the FFD: an affine part, the ``"zero"`` border, the
        Bernstein basis, ``only_inside``, weights given as a mesh array name, or a sheared lattice.

    Examples
    --------
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((2, 3, 2), spacing=(1.0, 0.5, 2.0), border="clamp")
    >>> lat.offsets[1, 2, 1] = (0.0, 0.0, 0.4)  # the lattice is 2 long in z: 0.2 of the unit box
    >>> rec = record_from_ffd(FFD(lat, basis="linear", border="clamp"))
    >>> rec["shape"], rec["interpolation"], rec["rest"][0, 0, 0].tolist(), rec["deformed"][1, 2, 1].tolist()
    ((2, 3, 2), ('linear', 'linear', 'linear'), [-0.5, -0.5, -0.5], [0.5, 0.5, 0.7])
    >>> record_from_ffd(FFD(lat, basis="bernstein", border="clamp"))
    Traceback (most recent call last):
    ...
    ValueError: a Blender lattice cannot hold this FFD: its basis 'bernstein' is none of Blender's interpolations (...)
    """
    reasons = []
    if not np.array_equal(ffd.affine, np.eye(4)):
        reasons.append("it has an affine part (a Blender lattice has none: apply it to the object instead)")
    basis = ffd.basis if isinstance(ffd.basis, tuple) else (ffd.basis,) * 3
    unknown = [b for b in basis if b not in _TO_BLENDER]
    if unknown:
        reasons.append(f"its basis {unknown[0]!r} is none of Blender's interpolations {tuple(_TO_BLENDER)}")
    if ffd.border != "clamp":
        reasons.append(f"its border is {ffd.border!r} (Blender's lattice clamps at its ends: border='clamp')")
    if getattr(ffd, "only_inside", False):
        reasons.append("it deforms only inside its domain (only_inside=True)")
    weights = getattr(ffd, "weights", None)
    if isinstance(weights, str):
        reasons.append(f"its weights name a mesh array ({weights!r}): give the array itself")
    if getattr(ffd.lattice, "sheared", False):
        reasons.append("its lattice is sheared, and a Blender object's own transform has no shear")
    if reasons:
        raise ValueError("a Blender lattice cannot hold this FFD: " + "; ".join(reasons))
    lat = ffd.lattice
    shape = lat.shape
    idx = lat.indices().astype(np.float64)
    extent = np.array([n - 1 for n in shape], dtype=np.float64)
    rest = idx / extent - 0.5  # the unit box, Blender's default lattice
    linear = lat.rotation * (lat.spacing * extent)  # columns: axis * (length of the lattice along it)
    matrix = np.eye(4)
    matrix[:3, :3] = linear
    matrix[:3, 3] = lat.origin + linear @ np.full(3, 0.5)
    deformed = rest + lat.offsets @ np.linalg.inv(linear).T
    return {
        "shape": shape,
        "rest": rest,
        "deformed": deformed,
        "matrix_world": matrix,
        "interpolation": tuple(basis),
        "outside": bool(getattr(ffd, "outside", False)),
        "strength": float(getattr(ffd, "strength", 1.0)),
        "weights": None if weights is None else np.asarray(weights, dtype=np.float64),
    }
