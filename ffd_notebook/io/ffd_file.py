"""Read and write .ffd lattice files (the format of the FFD platform; see docs/ffd-format.md).

A file is a sequence of ``#name#`` sections; names are matched after trimming spaces, ignoring
case. :func:`load_ffd` keeps what a :class:`~ffd_notebook.Lattice` has no field for in
``lattice.metadata``, so that ``save_ffd(load_ffd(f))`` writes the same values back:

``metadata["placement"]``
    ``None`` if the file has no ``#quaternion ...#`` section (the lattice then rests at origin
    (0, 0, 0), axis-aligned; see :func:`~ffd_notebook.io.place_at_mesh_minimum`), else a dict of
    the seven values ``qf, qb, qc, qd, qx, qy, qz`` as read.
``metadata["one_to_one"]``
    The integer of the ``#one to one#`` section (meaning unknown), ``None`` if absent.
``metadata["ffd_extra_sections"]``
    Sections this reader does not know, in file order: dicts with the ``header`` text, the raw
    ``lines`` and ``after``, the known section they followed (so a save puts them back there).

This package adds one section, written last and only for a lattice whose
:attr:`~ffd_notebook.Lattice.border` is not the format's own rule: ``#border#`` holding the word
``clamp`` (control points beyond the lattice are copies of the border ones). A file without it
means ``zero``, the FFD platform's formula.

And three sections for the options of an FFD on the lattice that Blender's lattice has (written by
:func:`~ffd_notebook.io.save_deformation`, read by :func:`~ffd_notebook.io.load_deformation`; kept
in ``lattice.metadata["ffd_options"]``, a dict with the keys present, so that ``save_ffd(load_ffd(f))``
keeps them), each written only when it is not the default:

``#interpolation#``
    Three words, the basis of each axis (``linear``, ``cardinal``, ``catmull-rom``, ``bspline``;
    key ``"basis"``, a tuple). Without it: the cubic B-spline on every axis.
``#outside#``
    ``true``: only the surface control points are free, the inner ones follow them (key ``"outside"``).
``#strength#``
    One number scaling the displacement (key ``"strength"``; 1 without it).

Older readers keep these as unknown sections; files without them load as before.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..errors import FileFormatError
from ..ffd.interpolation import LATTICE_INTERPOLATIONS
from ..ffd.lattice import Lattice
from ..ffd.support import BORDERS, Border
from ._atomic import atomic_open
from ._text import end_line, parse_float, parse_int, read_lines, split_fields
from .placement import quaternion_to_rotation, rotation_to_quaternion

__all__ = ["load_ffd", "save_ffd"]

# canonical header of each known section, in the order files have them
_HEADERS = {
    "dimension": "dimension",
    "one to one": "one to one",
    "control grid size": "control grid size",
    "control grid spacing": "control grid spacing",
    "offsets": "offsets of the control points",
    "quaternion": "quaternion qf,qb,qc,qd,qx,qy,qz",
    "border": "border",
    "interpolation": "interpolation",
    "outside": "outside",
    "strength": "strength",
}
_QUATERNION_FIELDS = ("qf", "qb", "qc", "qd", "qx", "qy", "qz")


@dataclass
class _Section:
    header: str  # the name between the two '#', as written
    line: int  # 1-based line of the header
    lines: list[tuple[int, str]] = field(default_factory=list)  # (line number, text) of the body


def _key(header: str) -> str | None:
    """The known section a header names (loosely: spaces trimmed, case ignored), or None."""
    name = " ".join(split_fields(header)).lower()
    if name.startswith("quaternion"):
        return "quaternion"
    if name.startswith("offsets"):
        return "offsets"
    return name if name in _HEADERS else None


def _split_sections(path: str | os.PathLike[str], lines: list[str]) -> list[_Section]:
    sections: list[_Section] = []
    for number, text in enumerate(lines, start=1):
        stripped = text.strip(" \t")  # only spaces and TABs are blanks (see _text)
        if len(stripped) >= 2 and stripped[0] == "#" and stripped[-1] == "#":
            if not stripped[1:-1].strip(" \t"):
                raise FileFormatError(path, number, "empty section header '##'; expected a name like #dimension#")
            sections.append(_Section(stripped[1:-1], number))
        elif sections:
            sections[-1].lines.append((number, text))
        elif stripped:
            raise FileFormatError(path, number, f"expected a section header like #dimension#, got {text[:40]!r}")
    if not sections:
        raise FileFormatError(path, end_line(lines), "no sections: expected a .ffd file starting with #dimension#")
    return sections


def _tokens(section: _Section) -> list[tuple[int, str]]:
    return [(number, tok) for number, text in section.lines for tok in split_fields(text)]


def _last_line(section: _Section) -> int:
    body = [number for number, text in section.lines if text.strip(" \t")]
    return body[-1] if body else section.line


def _numbers(path, section: _Section, names: tuple[str, ...], parse) -> list:
    """Exactly ``len(names)`` numbers from a section (any layout of whitespace and lines)."""
    tokens = _tokens(section)
    if len(tokens) != len(names):
        where = tokens[len(names)][0] if len(tokens) > len(names) else _last_line(section)
        expected = ", ".join(names)
        raise FileFormatError(
            path, where, f"section #{section.header}# must hold {len(names)} numbers ({expected}), found {len(tokens)}"
        )
    return [parse(path, number, tok, name) for (number, tok), name in zip(tokens, names, strict=True)]


def _parse_entry(path, number: int, entry: str, index: tuple[int, int, int]) -> tuple[float, float, float]:
    parts = split_fields(entry)
    if len(parts) != 3:
        raise FileFormatError(path, number, f"expected 'dx dy dz' for control point {index}, got {entry.strip()!r}")
    what = f"an offset of control point {index}"
    return tuple(parse_float(path, number, p, what) for p in parts)  # type: ignore[return-value]


def _parse_row(path, number: int, text: str, i: int, j: int, nz: int) -> list[tuple[float, float, float]]:
    """One line of the offsets block: ``nz`` entries ``dx dy dz``, each followed by a TAB."""
    if "\t" in text:
        entries = text.split("\t")
        while entries and not entries[-1].strip(" "):  # trailing TAB (or none: both occur)
            entries.pop()
    else:  # a writer that separates entries with spaces: group the numbers by three
        parts = split_fields(text)
        entries = [" ".join(parts[n : n + 3]) for n in range(0, len(parts), 3)]
    if len(entries) != nz:
        raise FileFormatError(path, number, f"expected nz={nz} entries 'dx dy dz' for x index {i}, y index {j}, "
                              f"found {len(entries)}")  # fmt: skip
    return [_parse_entry(path, number, entry, (i, j, k)) for k, entry in enumerate(entries)]


def _parse_offsets(path, section: _Section, shape: tuple[int, int, int]) -> np.ndarray:
    nx, ny, nz = shape
    blocks: list[list[tuple[int, str]]] = [[]]
    for number, text in section.lines:
        if text.strip(" \t"):
            blocks[-1].append((number, text))
        elif blocks[-1]:
            blocks.append([])
    if not blocks[-1]:
        blocks.pop()
    rows = [row for block in blocks for row in block]
    if len(blocks) == 1 and nx > 1 and len(rows) == nx * ny:  # no empty lines between blocks
        blocks = [rows[i * ny : (i + 1) * ny] for i in range(nx)]
    if len(blocks) != nx or any(len(b) != ny for b in blocks):
        for i, block in enumerate(blocks):
            if i >= nx:
                raise FileFormatError(path, block[0][0], f"expected nx={nx} blocks of ny={ny} lines, found more")
            if len(block) != ny:
                where = block[ny][0] if len(block) > ny else block[-1][0]
                raise FileFormatError(path, where, f"block {i + 1} of the offsets (x index {i}) has {len(block)} "
                                      f"lines, expected ny={ny}")  # fmt: skip
        raise FileFormatError(path, _last_line(section), f"expected nx={nx} blocks of ny={ny} lines (one per y "
                              f"index) in the offsets, found {len(blocks)} blocks")  # fmt: skip
    values = [_parse_row(path, number, text, i, j, nz) for i, block in enumerate(blocks)
              for j, (number, text) in enumerate(block)]  # fmt: skip
    return np.array(values, dtype=np.float64).reshape(nx, ny, nz, 3)


def _index_sections(path, sections: list[_Section], end: int) -> dict[str, _Section]:
    known: dict[str, _Section] = {}
    for sec in sections:
        key = _key(sec.header)
        if key is not None:
            if key in known:
                raise FileFormatError(path, sec.line, f"section #{sec.header}# appears twice "
                                      f"(first on line {known[key].line})")  # fmt: skip
            known[key] = sec
    if not known:
        first = sections[0]
        raise FileFormatError(path, first.line, f"not a .ffd file: expected sections like #dimension# and "
                              f"#control grid size#, found none (first header: #{first.header[:40]}#)")  # fmt: skip
    for key in ("control grid size", "control grid spacing", "offsets"):
        if key not in known:
            raise FileFormatError(path, end, f"missing section #{_HEADERS[key]}# (reached the end of the file)")
    return known


def _extra_sections(sections: list[_Section]) -> list[dict[str, Any]]:
    extra, after = [], None
    for sec in sections:
        key = _key(sec.header)
        if key is not None:
            after = key
            continue
        body = [text for _, text in sec.lines]
        while body and not body[-1].strip(" \t"):
            body.pop()
        extra.append({"header": sec.header, "after": after, "lines": body})
    return extra


def load_ffd(path: str | os.PathLike[str]) -> Lattice:
    """Read a .ffd lattice file.

    Parameters
    ----------
    path : str or path-like
        The file. LF or CRLF line ends, with or without trailing TABs.

    Returns
    -------
    Lattice
        Shape, spacing and offsets from the file, placed by its ``#quaternion ...#`` section if it
        has one (else at origin (0, 0, 0), axis-aligned). The module docstring lists the
        ``metadata`` kept for a round trip.

    Raises
    ------
    FileFormatError
        For anything malformed; the message names the file, the line and what was expected.
    FileNotFoundError
        If there is no such file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "tiny.ffd"
    >>> _ = path.write_text("#dimension#\\n3\\n#control grid size#\\n2\\n2\\n2\\n#control grid spacing#\\n1\\n1\\n1\\n"
    ...     "#offsets of the control points#\\n0 0 0\\t0 0 0.5\\t\\n0 0 0\\t0 0 0\\t\\n\\n"
    ...     "1.5 0 0\\t0 0 0\\t\\n0 0 0\\t0 -2 0\\t\\n\\n")
    >>> lat = load_ffd(path)
    >>> lat.shape, lat.offsets[0, 0, 1].tolist(), lat.offsets[1, 1, 1].tolist()
    ((2, 2, 2), [0.0, 0.0, 0.5], [0.0, -2.0, 0.0])
    >>> lat.metadata["placement"] is None
    True
    """
    lines = read_lines(path)
    sections = _split_sections(path, lines)
    known = _index_sections(path, sections, end_line(lines))
    if "dimension" in known:
        (dim,) = _numbers(path, known["dimension"], ("the dimension",), parse_int)
        if dim != 3:
            raise FileFormatError(path, _last_line(known["dimension"]), f"expected dimension 3, got {dim}")
    size_sec = known["control grid size"]
    shape = tuple(_numbers(path, size_sec, ("nx", "ny", "nz"), parse_int))
    if min(shape) < 2:
        raise FileFormatError(path, _last_line(size_sec), f"expected at least 2 control points per axis, got {shape}")
    spacing_sec = known["control grid spacing"]
    spacing = _numbers(path, spacing_sec, ("sx", "sy", "sz"), parse_float)
    if min(spacing) <= 0:
        raise FileFormatError(path, _last_line(spacing_sec), f"expected positive spacings, got {spacing}")
    offsets = _parse_offsets(path, known["offsets"], shape)
    placement = None
    origin, rotation = np.zeros(3), np.eye(3)
    if "quaternion" in known:
        values = _numbers(path, known["quaternion"], _QUATERNION_FIELDS, parse_float)
        placement = dict(zip(_QUATERNION_FIELDS, values, strict=True))
        norm2 = placement["qb"] ** 2 + placement["qc"] ** 2 + placement["qd"] ** 2
        if norm2 > 1.0001:
            raise FileFormatError(path, _last_line(known["quaternion"]), f"expected a unit quaternion "
                                  f"(qb^2 + qc^2 + qd^2 <= 1), got {norm2:.6g}")  # fmt: skip
        if placement["qf"] not in (1.0, -1.0):
            qf_line = _tokens(known["quaternion"])[0][0]
            raise FileFormatError(path, qf_line, f"expected qf (qfac) to be 1 or -1, got {placement['qf']!r}")
        origin, rotation = _placement_pose(placement)
    one_to_one = None
    if "one to one" in known:
        (one_to_one,) = _numbers(path, known["one to one"], ("the one-to-one flag",), parse_int)
    border = _parse_border(path, known["border"]) if "border" in known else "zero"
    options = _parse_options(path, known)
    lattice = Lattice(shape, spacing, origin=origin, rotation=rotation, offsets=offsets, border=border)
    _check_finite(path, lattice, spacing_sec, known["offsets"])
    lattice.metadata.update(placement=placement, one_to_one=one_to_one, ffd_extra_sections=_extra_sections(sections))
    if options:
        lattice.metadata["ffd_options"] = options
    return lattice


def _words(section: _Section) -> list[str]:
    return [tok.lower() for _, tok in _tokens(section)]


def _parse_options(path, known: dict[str, _Section]) -> dict[str, Any]:
    """The FFD options of the ``#interpolation#``, ``#outside#`` and ``#strength#`` sections present."""
    options: dict[str, Any] = {}
    if "interpolation" in known:
        section = known["interpolation"]
        words = _words(section)
        if len(words) != 3 or any(w not in LATTICE_INTERPOLATIONS for w in words):
            raise FileFormatError(path, _last_line(section), f"section #{section.header}# must hold three words, "
                                  f"one per axis, each one of {', '.join(LATTICE_INTERPOLATIONS)}; got "
                                  f"{' '.join(words)[:60]!r}")  # fmt: skip
        options["basis"] = tuple(words)
    if "outside" in known:
        section = known["outside"]
        words = _words(section)
        if words not in (["true"], ["false"]):
            raise FileFormatError(path, _last_line(section), f"section #{section.header}# must hold one word, "
                                  f"'true' or 'false', got {' '.join(words)[:40]!r}")  # fmt: skip
        options["outside"] = words == ["true"]
    if "strength" in known:
        section = known["strength"]
        (strength,) = _numbers(path, section, ("the strength",), parse_float)
        if not np.isfinite(strength):
            raise FileFormatError(path, _last_line(section), f"expected a finite strength, got {strength!r}")
        options["strength"] = strength
    return options


def _check_finite(path, lattice: Lattice, spacing_sec: _Section, offsets_sec: _Section) -> None:
    """Reject a lattice whose numbers are finite but whose control points are not (``1e308 * 10``).

    The FFD divides by the spacing, so its inverse must be finite too (no subnormal spacing).
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # the overflow is what is checked
        inverse, rest, deformed = 1.0 / lattice.spacing, lattice.control_points(), lattice.control_points(deformed=True)
    if not (np.isfinite(inverse).all() and np.isfinite(rest).all()):
        raise FileFormatError(path, _last_line(spacing_sec), f"the spacing {lattice.spacing.tolist()} puts control "
                              "points beyond the range of floating-point numbers")  # fmt: skip
    bad = np.argwhere(~np.isfinite(deformed).all(axis=-1))
    if len(bad):
        index = tuple(int(i) for i in bad[0])
        raise FileFormatError(path, offsets_sec.line, f"control point {index} plus its offset is beyond the range "
                              "of floating-point numbers")  # fmt: skip


def _parse_border(path, section: _Section) -> Border:
    words = [tok.lower() for _, tok in _tokens(section)]
    if len(words) != 1 or words[0] not in BORDERS:
        raise FileFormatError(path, _last_line(section), f"section #{section.header}# must hold one word, "
                              f"'zero' or 'clamp', got {' '.join(words)[:40]!r}")  # fmt: skip
    return cast(Border, words[0])  # checked: one of BORDERS


def _placement_pose(placement: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    rotation = quaternion_to_rotation(placement["qf"], placement["qb"], placement["qc"], placement["qd"])
    return np.array([placement["qx"], placement["qy"], placement["qz"]], dtype=np.float64), rotation


def _placement_values(lattice: Lattice) -> dict[str, float]:
    """Quaternion values for the lattice: the loaded ones if they still describe it exactly."""
    stored = lattice.metadata.get("placement")
    if isinstance(stored, dict) and set(stored) == set(_QUATERNION_FIELDS):
        origin, rotation = _placement_pose(stored)
        if np.array_equal(origin, lattice.origin) and np.array_equal(rotation, lattice.rotation):
            return {k: float(stored[k]) for k in _QUATERNION_FIELDS}
    qf, qb, qc, qd = rotation_to_quaternion(lattice.rotation)
    qx, qy, qz = (float(v) for v in lattice.origin)
    return dict(zip(_QUATERNION_FIELDS, (qf, qb, qc, qd, qx, qy, qz), strict=True))


def _section_lines(lattice: Lattice, key: str, placement: bool) -> Iterable[str] | None:
    """Body lines of a known section, or None if it is not written."""
    if key == "dimension":
        return ["3"]
    if key == "one to one":
        value = lattice.metadata.get("one_to_one", 1)
        return None if value is None else [str(int(value))]
    if key == "control grid size":
        return [str(n) for n in lattice.shape]
    if key == "control grid spacing":
        return [repr(float(s)) for s in lattice.spacing]
    if key == "offsets":
        return _offset_lines(lattice.offsets)
    if key == "quaternion" and placement:
        return ["\t".join(repr(v) for v in _placement_values(lattice).values())]
    if key == "border" and lattice.border != "zero":
        return [lattice.border]
    options = lattice.metadata.get("ffd_options") or {}
    if key == "interpolation" and options.get("basis", ("bspline",) * 3) != ("bspline",) * 3:
        return [str(b) for b in options["basis"]]
    if key == "outside" and options.get("outside"):
        return ["true"]
    if key == "strength" and options.get("strength", 1.0) != 1.0:
        return [repr(float(options["strength"]))]
    return None


def _offset_lines(offsets: np.ndarray) -> Iterator[str]:
    for block in offsets.tolist():
        for row in block:
            yield "".join(f"{dx!r} {dy!r} {dz!r}\t" for dx, dy, dz in row)
        yield ""


def save_ffd(path: str | os.PathLike[str], lattice: Lattice, placement: bool | None = None) -> None:
    """Write a lattice as a .ffd file, atomically (a temporary file in the same folder, then rename).

    Numbers are written with ``repr``, so :func:`load_ffd` reads back bit-identical values.

    Parameters
    ----------
    path : str or path-like
        Destination; an existing file is replaced only once the new one is complete.
    lattice : Lattice
        The lattice. Its ``metadata`` (see the module docstring) is written back: the
        ``#one to one#`` value (1 if unknown), unknown sections in their place, and the quaternion
        values as loaded if they still describe the lattice's origin and rotation exactly.
    placement : bool, optional
        Write the ``#quaternion ...#`` section. By default it is written unless the lattice is at
        origin (0, 0, 0), axis-aligned, and was not loaded with one.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from ffd_notebook import Lattice
    >>> lat = Lattice((3, 2, 2), spacing=(1.0, 2.0, 0.5), origin=(1, 2, 3), rotation=np.diag([1.0, -1, -1]))
    >>> lat.offsets[2, 1, 0] = (0.1, 1 / 3, -2e-9)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "lattice.ffd"
    >>> save_ffd(path, lat)
    >>> load_ffd(path) == lat
    True
    >>> path.read_text().splitlines()[-1]
    '1.0\\t1.0\\t0.0\\t0.0\\t1.0\\t2.0\\t3.0'
    """
    if not isinstance(lattice, Lattice):
        raise TypeError(f"expected a Lattice, got {type(lattice).__name__}")
    for name in ("offsets", "spacing", "origin"):
        if not np.isfinite(getattr(lattice, name)).all():
            raise ValueError(f"cannot save a lattice whose {name} contain NaN or infinite values")
    if lattice.sheared:
        raise ValueError("the lattice is sheared (its axes are not orthogonal): a .ffd file places its lattice by a "
                         "rotation (the #quaternion# section), which cannot hold a shear")  # fmt: skip
    if placement is None:
        at_rest = not lattice.origin.any() and np.array_equal(lattice.rotation, np.eye(3))
        placement = lattice.metadata.get("placement") is not None or not at_rest
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as f:
        for line in _file_lines(lattice, placement):
            f.write(line + "\n")


def _file_lines(lattice: Lattice, placement: bool) -> Iterator[str]:
    """Lines of the file: known sections in the usual order, unknown ones where they were."""
    extra: dict[str | None, list[dict[str, Any]]] = {}
    for sec in lattice.metadata.get("ffd_extra_sections") or []:
        slot = sec.get("after")
        extra.setdefault(slot if slot is None or slot in _HEADERS else "quaternion", []).append(sec)
    for key in (None, *_HEADERS):
        body = None if key is None else _section_lines(lattice, key, placement)
        if body is not None:
            yield f"#{_HEADERS[key]}#"  # type: ignore[index]
            yield from body
        for sec in extra.get(key, []):
            yield f"#{sec['header']}#"
            yield from (str(line) for line in sec["lines"])
