"""ITK's text transform files (``.tfm``, ``.txt``: "#Insight Transform File V1.0").

A file is a header line, then per transform a ``Transform: <type>`` line followed by
``Parameters: ...`` and ``FixedParameters: ...`` lines of numbers; other lines starting with ``#``
are comments (ITK writes ``#Transform <n>`` before each transform). A composite transform is a
``CompositeTransform_...`` entry with no parameters, followed by its children in order.
ITK's own reader is written in C++; this one is here so that a bad file gives a
:class:`~ffd_notebook.errors.FileFormatError` naming its line instead of a crash or a guess.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from ..errors import FileFormatError
from ._atomic import atomic_open
from ._text import end_line, parse_float, read_lines
from .itk_model import RawTransform

__all__ = ["HEADER", "read_itk_text", "write_itk_text"]

HEADER = "#Insight Transform File V1.0"
_KEYS = {"transform": "kind", "parameters": "parameters", "fixedparameters": "fixed"}


def read_itk_text(path: str | os.PathLike[str]) -> list[RawTransform]:
    """The transforms of an ITK text transform file, in file order.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.tfm"
    >>> _ = p.write_text(HEADER + "\\n#Transform 0\\nTransform: TranslationTransform_double_3_3\\n"
    ...                  "Parameters: 1 2 3\\nFixedParameters:\\n")
    >>> [(t.kind, t.parameters.tolist()) for t in read_itk_text(p)]
    [('TranslationTransform_double_3_3', [1.0, 2.0, 3.0])]
    """
    lines = read_lines(path)
    first = next((i for i, text in enumerate(lines) if text.strip()), None)
    if first is None or lines[first].strip() != HEADER:
        line = 1 if first is None else first + 1
        raise FileFormatError(path, line, f"expected the header line {HEADER!r}; not an ITK text transform file")
    out: list[RawTransform] = []
    fields: dict[str, tuple[int, str]] = {}
    for number, text in enumerate(lines[first + 1 :], start=first + 2):
        stripped = text.strip()
        if not stripped or stripped.startswith("#"):
            continue
        key, sep, value = stripped.partition(":")
        name = _KEYS.get(key.strip().lower()) if sep else None
        if name is None:
            raise FileFormatError(path, number, f"expected 'Transform:', 'Parameters:' or 'FixedParameters:', got "
                                  f"{stripped[:40]!r}")  # fmt: skip
        if name == "kind":
            if fields:
                out.append(_finish(path, fields))
            fields = {"kind": (number, value.strip())}
            continue
        if not fields:
            raise FileFormatError(path, number, f"'{key.strip()}:' before any 'Transform:' line")
        if name in fields:
            raise FileFormatError(path, number, f"second '{key.strip()}:' line for one transform "
                                  f"(the first is line {fields[name][0]})")  # fmt: skip
        fields[name] = (number, value)
    if fields:
        out.append(_finish(path, fields))
    if not out:
        raise FileFormatError(path, end_line(lines), "no 'Transform:' line: the file holds no transform")
    return out


def _numbers(path: str | os.PathLike[str], number: int, value: str, what: str) -> np.ndarray:
    return np.array([parse_float(path, number, token, what) for token in value.split()], dtype=np.float64)


def _finish(path: str | os.PathLike[str], fields: dict[str, tuple[int, str]]) -> RawTransform:
    kind_line, kind = fields["kind"]
    if not kind:
        raise FileFormatError(path, kind_line, "expected a transform type after 'Transform:'")
    params_line, params = fields.get("parameters", (kind_line, ""))
    fixed_line, fixed = fields.get("fixed", (kind_line, ""))
    return RawTransform(
        kind=kind,
        parameters=_numbers(path, params_line, params, "a parameter"),
        fixed=_numbers(path, fixed_line, fixed, "a fixed parameter"),
        where={"kind": kind_line, "parameters": params_line, "fixed": fixed_line},
    )


def _lines(transforms: list[RawTransform]) -> Iterator[str]:
    yield HEADER
    for index, raw in enumerate(transforms):
        yield f"#Transform {index}"
        yield f"Transform: {raw.kind}"
        if not raw.kind.startswith("CompositeTransform"):
            yield "Parameters: " + " ".join(repr(float(v)) for v in raw.parameters)
            yield "FixedParameters: " + " ".join(repr(float(v)) for v in raw.fixed)


def write_itk_text(path: str | os.PathLike[str], transforms: list[RawTransform]) -> None:
    """Write transforms as an ITK text file, atomically; numbers round-trip exactly (``repr``)."""
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        for line in _lines(transforms):
            f.write(line + "\n")
