"""PyGeM's FFD parameter files (``.prm``): ``load_prm`` and ``save_prm``.

What PyGeM does with one (``pygem/ffd.py``, read for this module; checked against its test data):
an INI file whose ``[Box info]`` gives ``n control points x|y|z``, ``box length x|y|z``,
``box origin x|y|z`` and ``rotation angle x|y|z`` (degrees); ``[Parameters weights]`` gives
``parameter x|y|z``, one ``i j k weight`` line per control point (a missing line is a zero). The
box is rotated about its origin by ``R = Rx(ax) @ Ry(ay) @ Rz(az)``; a point's box coordinates
``s = R^T (x - origin) / length`` are deformed by the Bernstein sum of the weights, so control
point (i, j, k) moves by ``R @ (weight * length)`` in world units; only points with ``s`` in
``[0, 1]^3`` move. As a lattice: ``shape = n``, ``spacing = length / (n - 1)``,
``origin = box origin``, ``rotation = R``, and ``FFD(lattice, "bernstein", only_inside=True)``
reproduces PyGeM.

The parser is hand-written (not ``configparser``) so that every error names its line and numbers
are read strictly (no ``nan``, no ``1_000``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FileFormatError
from ..ffd.lattice import Lattice
from ._atomic import atomic_open
from ._text import end_line, parse_float, parse_int, read_lines

__all__ = ["load_prm", "rotation_from_angles", "save_prm"]

_AXES = "xyz"
_BOX = {f"{what} {a}": (what, i) for what in ("n control points", "box length", "box origin", "rotation angle")
        for i, a in enumerate(_AXES)}  # fmt: skip
_WEIGHTS = {f"parameter {a}": i for i, a in enumerate(_AXES)}
_MAX_POINTS = 2**21


def rotation_from_angles(angles_deg: np.ndarray) -> np.ndarray:
    """PyGeM's box rotation ``Rx @ Ry @ Rz`` from angles about x, y, z in degrees.

    Built as PyGeM builds it (``pygem.utils.angles2matrix``), product in the same order, so the
    matrix is the same to the last bit.

    Examples
    --------
    >>> rotation_from_angles(np.array([0.0, 0.0, 90.0])).round(12).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    factors = []
    for axis in (0, 1, 2):  # Rx, Ry, Rz: the product Rx @ Ry @ Rz, left to right
        angle = float(np.radians(angles_deg[axis]))
        if not angle:
            continue
        c, s = math.cos(angle), math.sin(angle)
        m = np.eye(3)
        p, q = [(1, 2), (0, 2), (0, 1)][axis]
        m[p, p], m[q, q] = c, c
        m[p, q], m[q, p] = (-s, s) if axis != 1 else (s, -s)
        factors.append(m)
    out = np.eye(3)
    for i, m in enumerate(factors):
        out = m if i == 0 else out @ m
    return out


_Entries = dict[tuple[str, str], tuple[int, list[tuple[int, str]]]]


def _entries(path: str | os.PathLike[str], lines: list[str]) -> _Entries:
    """``(section, key) -> (line, value lines)`` with INI rules: comments, continuation lines.

    Each section's header is entered too, as key ``""``, for where a missing key is reported.
    """
    section = None
    entries: _Entries = {}
    current: list[tuple[int, str]] | None = None
    for number, text in enumerate(lines, start=1):
        stripped = text.strip()
        if not stripped or stripped[0] in "#;":
            current = None
            continue
        if text[0] in " \t" and current is not None:  # continuation of the value above
            current.append((number, stripped))
            continue
        if stripped.startswith("["):
            if not stripped.endswith("]"):
                raise FileFormatError(path, number, f"expected a section header like [Box info], got {stripped[:40]!r}")
            section, current = " ".join(stripped[1:-1].split()).lower(), None
            entries.setdefault((section, ""), (number, []))
            continue
        cut = min((i for i in (stripped.find(":"), stripped.find("=")) if i >= 0), default=-1)
        if cut < 0 or section is None:
            what = "'key: value'" if section is not None else "a section header like [Box info]"
            raise FileFormatError(path, number, f"expected {what}, got {stripped[:40]!r}")
        key = " ".join(stripped[:cut].split()).lower()
        if (section, key) in entries:
            raise FileFormatError(path, number, f"{key!r} given twice (first on line {entries[section, key][0]})")
        value = stripped[cut + 1 :].strip()
        current = [(number, value)] if value else []
        entries[section, key] = (number, current)
    return entries


def _missing(path, entries: _Entries, key: str, section: str, end: int) -> FileFormatError:
    line = entries.get((section, ""), (end, []))[0]
    return FileFormatError(path, line, f"missing {key!r} in [{section}]; expected a PyGeM FFD parameter file")


def _one_value(path, entries: _Entries, key: str, section: str, end: int) -> tuple[int, str]:
    if (section, key) not in entries:
        raise _missing(path, entries, key, section, end)
    number, values = entries[section, key]
    if len(values) != 1 or len(values[0][1].split()) != 1:
        raise FileFormatError(path, number, f"expected one number after {key!r}")
    return values[0]


def _weights(path, entries: _Entries, key: str, shape: tuple[int, int, int], end: int) -> np.ndarray:
    if ("parameters weights", key) not in entries:
        raise _missing(path, entries, key, "parameters weights", end)
    out = np.zeros(shape)
    seen: dict[tuple[int, int, int], int] = {}
    for number, text in entries["parameters weights", key][1]:
        tokens = text.split()
        if len(tokens) != 4:
            raise FileFormatError(path, number, f"expected 'i j k weight' (4 numbers), got {text[:40]!r}")
        ijk = tuple(parse_int(path, number, t, f"the {a} index") for t, a in zip(tokens[:3], _AXES, strict=True))
        if any(not 0 <= v < n for v, n in zip(ijk, shape, strict=True)):
            raise FileFormatError(path, number, f"control point {ijk} is outside the {shape} grid")
        if ijk in seen:
            raise FileFormatError(path, number, f"control point {ijk} given twice (first on line {seen[ijk]})")
        seen[ijk] = number  # type: ignore[index]
        out[ijk] = parse_float(path, number, tokens[3], "the weight")
    return out


def load_prm(path: str | os.PathLike[str]) -> Lattice:
    """Read a PyGeM FFD parameter file as a lattice for the Bernstein basis.

    ``FFD(load_prm(path), "bernstein", only_inside=True).deform(points)`` is PyGeM's
    ``FFD.__call__`` on the same file. The file's box length, angles and weights are kept in
    ``lattice.metadata["prm"]`` so that :func:`save_prm` writes them back unchanged.

    Parameters
    ----------
    path : str or os.PathLike
        A PyGeM parameter file.

    Returns
    -------
    Lattice
        The box as a lattice (spacing = box length / (n - 1), rotation from PyGeM's angles).

    Raises
    ------
    FileFormatError
        Missing or malformed entries; names the file and line.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "box.prm"
    >>> save_prm(p, Lattice((2, 3, 2), spacing=(2.0, 1.0, 4.0), origin=(1.0, 0.0, 0.0)))
    >>> lat = load_prm(p)
    >>> lat.shape, lat.spacing.tolist(), lat.metadata["prm"]["box_length"].tolist()
    ((2, 3, 2), [2.0, 1.0, 4.0], [2.0, 2.0, 4.0])
    """
    lines = read_lines(path)
    end = end_line(lines)
    entries = _entries(path, lines)
    box: dict[str, list[float]] = {what: [0.0, 0.0, 0.0] for what, _ in _BOX.values()}
    counts = []
    for key, (what, axis) in _BOX.items():
        number, token = _one_value(path, entries, key, "box info", end)
        if what == "n control points":
            n = parse_int(path, number, token, key)
            if n < 2:
                raise FileFormatError(path, number, f"expected at least 2 control points per axis, got {n}")
            counts.append(n)
            box[what][axis] = n
        else:
            box[what][axis] = parse_float(path, number, token, key)
            if what == "box length" and box[what][axis] <= 0:
                raise FileFormatError(path, number, f"expected a positive {key}, got {token!r}")
    shape = (counts[0], counts[1], counts[2])
    if math.prod(shape) > _MAX_POINTS:
        number = entries["box info", "n control points z"][0]
        raise FileFormatError(path, number, f"{shape} is more than {_MAX_POINTS} control points")
    weights = np.stack([_weights(path, entries, key, shape, end) for key in _WEIGHTS], axis=-1)
    length, angles = np.array(box["box length"]), np.array(box["rotation angle"])
    rotation = rotation_from_angles(angles)
    spacing = length / (np.array(shape) - 1.0)
    lattice = Lattice(shape, spacing, box["box origin"], rotation, (weights * length) @ rotation.T)
    lattice.metadata["prm"] = {"box_length": length, "rotation_angles": angles, "weights": weights}
    return lattice


def _matches(lattice: Lattice, stored: dict) -> bool:
    """Whether ``stored`` (a loaded file's values) still describes ``lattice`` bit for bit."""
    try:
        length, angles, weights = (np.asarray(stored[k], dtype=np.float64) for k in
                                   ("box_length", "rotation_angles", "weights"))  # fmt: skip
    except (KeyError, TypeError, ValueError):
        return False
    if weights.shape != lattice.shape + (3,) or length.shape != (3,) or angles.shape != (3,):
        return False
    rotation = rotation_from_angles(angles)
    return (
        np.array_equal(length / (np.array(lattice.shape) - 1.0), lattice.spacing)
        and np.array_equal(rotation, lattice.rotation)
        and np.array_equal((weights * length) @ rotation.T, lattice.offsets)
    )


def prm_values(lattice: Lattice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Box length, rotation angles (degrees) and normalised weights that describe ``lattice``.

    The loaded file's values if they still describe it exactly, else computed (rotation angles
    from the matrix: exact to rounding, not to the bit).
    """
    stored = lattice.metadata.get("prm")
    if isinstance(stored, dict) and _matches(lattice, stored):
        return (np.asarray(stored[k], dtype=np.float64) for k in ("box_length", "rotation_angles", "weights"))  # type: ignore[return-value]
    if lattice.sheared:
        raise ValueError("the lattice is sheared (its axes are not orthogonal): a PyGeM box is a rotated box")
    if np.linalg.det(lattice.rotation) < 0:
        raise ValueError("the lattice's rotation is a reflection: a PyGeM box has rotation angles only")
    length = lattice.spacing * (np.array(lattice.shape) - 1.0)
    angles = Rotation.from_matrix(lattice.rotation).as_euler("XYZ", degrees=True)  # intrinsic: Rx @ Ry @ Rz
    weights = (lattice.offsets @ lattice.rotation) / length
    return length, angles, weights


def _file_lines(lattice: Lattice) -> Iterator[str]:
    length, angles, weights = prm_values(lattice)
    yield "\n[Box info]"
    yield "# The FFD box (written by ffd_notebook in PyGeM's format; see pygem.FFD.read_parameters)."
    for a, n in zip(_AXES, lattice.shape, strict=True):
        yield f"n control points {a}: {n}"
    for what, values in (("box length", length), ("box origin", lattice.origin), ("rotation angle", angles)):
        for a, v in zip(_AXES, values, strict=True):
            yield f"{what} {a}: {float(v)!r}"
    yield "\n\n[Parameters weights]"
    yield "# | x index | y index | z index | weight |: control point displacements normalised by the box length."
    indices = np.indices(lattice.shape).reshape(3, -1).T.tolist()
    for axis, a in enumerate(_AXES):
        yield f"\n# parameter {a}: displacements along {a}, divided by the box length {a}."
        column = weights[..., axis].ravel().tolist()
        rows = [f"{i}   {j}   {k}   {w!r}" for (i, j, k), w in zip(indices, column, strict=True)]
        yield f"parameter {a}: " + rows[0]
        yield from ("             " + row for row in rows[1:])


def save_prm(path: str | os.PathLike[str], lattice: Lattice) -> None:
    """Write a lattice as a PyGeM FFD parameter file, atomically; PyGeM's reader takes it.

    Every weight line is written (also the zeros, as PyGeM does). ``FFD(lattice, "bernstein",
    only_inside=True)`` is what the file means.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.prm`` file to write.
    lattice : Lattice
        The box; its rotation must not be a reflection.

    Raises
    ------
    ValueError
        If the lattice's rotation is a reflection (a PyGeM box has none).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> lat = Lattice((2, 2, 2), 1.0)
    >>> lat.offsets[1, 1, 1] = (0.0, 0.0, 0.5)
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "box.prm"
    >>> save_prm(p, lat)
    >>> load_prm(p) == lat
    True
    """
    lines = list(_file_lines(lattice))  # fails before the file is touched
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
