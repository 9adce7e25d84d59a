"""elastix parameter files (``TransformParameters.0.txt``): the syntax, read and written.

The rules are elastix's own (``itkParameterFileParser.cxx``): a file is lines of
``(Name value value ...)``; ``//`` starts a comment anywhere on a line (even inside quotes, as
elastix does); TABs count as spaces; values are separated by spaces, and double quotes delimit a
string value that may hold spaces (``"Compose"``, a file name); an empty value is dropped; a name
may appear once. elastix reads the values of a name as numbers or words as its components ask:
:class:`ParameterMap` keeps them as text with the line they came from, and converts on request
(:meth:`ParameterMap.numbers`, :meth:`ParameterMap.word`), so that an error names the line.

A parameter file and ITK's text transform files both end in ``.txt``: :func:`is_parameter_file`
tells them apart by content.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import FileFormatError
from ._atomic import atomic_open
from ._safety import read_bytes
from ._text import parse_float, read_lines

__all__ = ["Entry", "ParameterMap", "format_value", "is_parameter_file", "read_parameter_file",
           "write_parameter_file"]  # fmt: skip

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*", re.ASCII)
_SNIFF_BYTES = 4096


@dataclass(frozen=True)
class Entry:
    """One ``(Name values...)`` line: its 1-based line number and its values as text."""

    line: int
    values: tuple[str, ...]


def _strip(text: str) -> str:
    """A line as elastix sees it: TABs as spaces, no comment, no blanks around."""
    text = text.replace("\t", " ")
    cut = text.find("//")
    if cut >= 0:
        text = text[:cut]
    return text.strip(" ")


def _split(path: str | os.PathLike[str], number: int, body: str) -> tuple[str, tuple[str, ...]]:
    """Name and values of a line's inside (between the brackets), elastix's ``SplitLine``."""
    quotes = body.count('"')
    if quotes % 2:
        raise FileFormatError(path, number, 'an odd number of quotes ("): a string value is not closed')
    if quotes:  # quotes delimit values, blanks inside them stay (every other piece is quoted)
        pieces = []
        for index, part in enumerate(body.split('"')):
            pieces.extend([part] if index % 2 else part.split(" "))
    else:  # the long lines (TransformParameters): no quotes
        pieces = body.split(" ")
    name, values = pieces[0], tuple(p for p in pieces[1:] if p)
    if not _NAME.fullmatch(name):
        shown = name if len(name) <= 40 else name[:40] + "..."
        raise FileFormatError(
            path, number, f"expected a parameter name (letters, digits, '_') after '(', got {shown!r}"
        )
    if not values:
        raise FileFormatError(path, number, f"the parameter {name!r} has no value")
    return name, values


class ParameterMap:
    """The parameters of one elastix parameter file, by name, each with the line it was read from.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "TransformParameters.0.txt"
    >>> _ = path.write_text('(Transform "TranslationTransform") // a comment\\n(TransformParameters 1 2.5 -3)\\n')
    >>> params = read_parameter_file(path)
    >>> params.word("Transform"), params.numbers("TransformParameters").tolist()
    ('TranslationTransform', [1.0, 2.5, -3.0])
    >>> params.numbers("GridSize")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...TransformParameters.0.txt: no (GridSize ...) line; ...
    """

    def __init__(self, path: str | os.PathLike[str], entries: dict[str, Entry], end: int) -> None:
        self.path = os.fspath(path)
        self.entries = entries
        self.end = end  # the last line, where a missing parameter is reported

    def __contains__(self, name: str) -> bool:
        return name in self.entries

    def line(self, name: str) -> int | None:
        """The line a parameter was read from (``None`` if absent)."""
        entry = self.entries.get(name)
        return None if entry is None else entry.line

    def error(self, name: str | None, problem: str) -> FileFormatError:
        """A :class:`FileFormatError` at the line of ``name`` (the file alone if absent or ``None``)."""
        return FileFormatError(self.path, None if name is None else self.line(name), problem)

    def _entry(self, name: str, why: str) -> Entry:
        entry = self.entries.get(name)
        if entry is None:
            raise FileFormatError(self.path, None, f"no ({name} ...) line; {why}")
        return entry

    def values(self, name: str, *, why: str = "it is required here") -> tuple[str, ...]:
        """The values of ``name`` as text."""
        return self._entry(name, why).values

    def word(self, name: str, default: str | None = None, *, why: str = "it is required here") -> str:
        """The single value of ``name`` as text (``default`` if absent and a default is given)."""
        if default is not None and name not in self.entries:
            return default
        entry = self._entry(name, why)
        if len(entry.values) != 1:
            raise FileFormatError(self.path, entry.line, f"expected one value for {name}, got {len(entry.values)}")
        return entry.values[0]

    def flag(self, name: str, default: bool) -> bool:
        """A ``"true"``/``"false"`` value (elastix writes them quoted)."""
        if name not in self.entries:
            return default
        word = self.word(name)
        if word not in ("true", "false"):
            raise FileFormatError(self.path, self.line(name), f'expected {name} "true" or "false", got {word!r}')
        return word == "true"

    def numbers(self, name: str, count: int | None = None, *, why: str = "it is required here") -> np.ndarray:
        """The values of ``name`` as finite float64 numbers, ``count`` of them if given."""
        entry = self._entry(name, why)
        if count is not None and len(entry.values) != count:
            raise FileFormatError(self.path, entry.line, f"expected {count} numbers for {name}, got "
                                  f"{len(entry.values)}")  # fmt: skip
        try:  # fast path: NumPy's parser, then the strict one for the message if anything is off
            out = np.array(entry.values, dtype=np.float64)
            if np.isfinite(out).all() and all(_plain(v) for v in entry.values):
                return out
        except ValueError:
            pass
        return np.array([parse_float(self.path, entry.line, v, f"a number in {name}") for v in entry.values])

    def integers(self, name: str, count: int, *, low: int, high: int) -> list[int]:
        """``count`` integers of ``name`` in ``low..high``."""
        values = self.numbers(name, count)
        if np.any(values != np.round(values)) or np.any(values < low) or np.any(values > high):
            raise FileFormatError(self.path, self.line(name), f"expected {count} integers in {low}..{high} for "
                                  f"{name}, got {' '.join(self.values(name))}")  # fmt: skip
        return [int(v) for v in values]


_PLAIN = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]{1,5})?", re.ASCII)


def _plain(token: str) -> bool:
    return len(token) <= 400 and _PLAIN.fullmatch(token) is not None


def read_parameter_file(path: str | os.PathLike[str]) -> ParameterMap:
    """Parse an elastix parameter file (see the module docstring for the rules).

    Raises
    ------
    FileFormatError
        A line that is not ``(Name value ...)``, an unclosed quote, a name given twice, a file
        with no parameter at all; names the file and line.
    """
    lines = read_lines(path)
    entries: dict[str, Entry] = {}
    for number, raw in enumerate(lines, start=1):
        text = _strip(raw)
        if not text:
            continue
        if not (text.startswith("(") and text.endswith(")")):
            shown = text if len(text) <= 40 else text[:40] + "..."
            raise FileFormatError(path, number, f"expected a line '(Name value ...)' of an elastix parameter "
                                  f"file, got {shown!r}")  # fmt: skip
        name, values = _split(path, number, text[1:-1].strip(" "))
        if name in entries:
            raise FileFormatError(path, number, f"the parameter {name!r} is given twice (first on line "
                                  f"{entries[name].line})")  # fmt: skip
        entries[name] = Entry(number, values)
    if not entries:
        raise FileFormatError(path, None, "no '(Name value ...)' line: not an elastix parameter file")
    return ParameterMap(path, entries, len(lines))


def is_parameter_file(path: str | os.PathLike[str]) -> bool:
    """Whether a file reads as an elastix parameter file rather than an ITK text transform.

    By content: the first line that is not blank or a ``//`` comment starts with ``(``. Only the
    first few kilobytes are read.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.txt").write_text('// elastix\\n(Transform "BSplineTransform")\\n')
    >>> _ = (folder / "b.txt").write_text("#Insight Transform File V1.0\\n")
    >>> is_parameter_file(folder / "a.txt"), is_parameter_file(folder / "b.txt")
    (True, False)
    """
    head = read_bytes(path)[:_SNIFF_BYTES].decode("utf-8", errors="replace").lstrip("\ufeff")
    for raw in head.splitlines():
        text = _strip(raw)
        if text:
            return text.startswith("(")
    return False


def format_value(value: object) -> str:
    """A value as elastix writes it: strings quoted, floats in the shortest form that reads back exactly.

    Examples
    --------
    >>> [format_value(v) for v in ("Compose", 3, 0.1, True, -2.0)]
    ['"Compose"', '3', '0.1', '"true"', '-2']
    """
    if isinstance(value, bool):
        return '"true"' if value else '"false"'
    if isinstance(value, str):
        if '"' in value or "//" in value or "\n" in value or "\r" in value:
            raise ValueError(f"an elastix parameter file cannot hold the string {value!r} (quotes, '//' or a line end)")
        return f'"{value}"'
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    number = float(value)  # type: ignore[arg-type]
    if not np.isfinite(number):
        raise ValueError(f"an elastix parameter file cannot hold the number {number!r}")
    if number == int(number) and abs(number) < 2**53:
        return str(int(number))
    return repr(number)


def write_parameter_file(path: str | os.PathLike[str], entries: Iterable[tuple[str, Sequence[object]]]) -> None:
    """Write ``(Name values...)`` lines, atomically; numbers read back exactly (see :func:`format_value`)."""
    lines = []
    for name, values in entries:
        if not _NAME.fullmatch(name) or not len(values):
            raise ValueError(f"cannot write the parameter {name!r} with {len(values)} values")
        lines.append(f"({name} {' '.join(format_value(v) for v in values)})\n")
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.writelines(lines)
