"""Shared helpers of the text parsers: decoding, line splitting and strict number parsing.

Strict means ASCII only: Python's ``int``/``float``/``str.split`` also accept Arabic-Indic or
full-width digits, ``1_000``, ``nan``, NBSP or form feed as blanks, and ``int`` raises a plain
``ValueError`` past 4300 digits. Here fields are separated by spaces and TABs only
(:func:`split_fields`), numbers are ASCII decimal (:func:`parse_float`, :func:`parse_int`) and every
rejection is a :class:`FileFormatError` naming the file and line. Any reader of text formats
(.ffd, OBJ, PyGeM .prm, ...) should use these.
"""

from __future__ import annotations

import os
import re

from ..errors import FileFormatError
from ._safety import MAX_FILE_BYTES, read_bytes

__all__ = ["end_line", "parse_float", "parse_int", "read_lines", "read_text", "split_fields", "split_lines"]

# Plain ASCII decimal numbers only: float() would also take "nan", "inf", "1_000", "  1 ", "١٢".
# 4300 characters is CPython's int() limit; no number in a file needs more than a few dozen.
_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]{1,5})?", re.ASCII)
_INT = re.compile(r"[+-]?[0-9]{1,18}", re.ASCII)  # fits in int64
_LONG_INT = re.compile(r"[+-]?[0-9]+", re.ASCII)
_MAX_FLOAT_CHARS = 400
_BLANKS = re.compile(r"[ \t]+")


def read_text(path: str | os.PathLike[str], max_bytes: int = MAX_FILE_BYTES) -> str:
    """Read a whole text file as UTF-8 (a leading byte-order mark is dropped).

    Special files (FIFO, devices) and files over ``max_bytes`` are refused before reading
    (see :func:`~ffd_notebook.io._safety.read_bytes`).

    Raises
    ------
    FileFormatError
        If the bytes are not UTF-8 text; names the line of the first bad byte.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "bad.txt"
    >>> _ = p.write_bytes(b"ok\\n\\xff\\xfe")
    >>> read_text(p)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...bad.txt, line 2: not UTF-8 text (byte 0xff at column 1); expected ...
    """
    data = read_bytes(path, max_bytes)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line_start = data.rfind(b"\n", 0, exc.start) + 1
        line = data.count(b"\n", 0, exc.start) + 1
        column = exc.start - line_start + 1
        problem = f"not UTF-8 text (byte 0x{data[exc.start]:02x} at column {column}); expected a text file"
        raise FileFormatError(path, line, problem) from None
    return text[1:] if text.startswith("\ufeff") else text


def split_lines(text: str) -> list[str]:
    """Split on LF, CRLF or (if the file has no LF at all) CR; line ``i`` is physical line ``i + 1``."""
    if "\n" not in text and "\r" in text:
        return text.split("\r")
    lines = text.split("\n")
    if "\r" in text:
        lines = [line[:-1] if line.endswith("\r") else line for line in lines]
    return lines


def split_fields(text: str) -> list[str]:
    """Fields of a line separated by spaces and TABs only (``str.split`` also splits on NBSP, form feed...).

    Examples
    --------
    >>> split_fields(" 1\t2  3 ")
    ['1', '2', '3']
    >>> split_fields("1\u00a02")
    ['1\xa02']
    """
    stripped = text.strip(" \t")
    return _BLANKS.split(stripped) if stripped else []


def end_line(lines: list[str]) -> int:
    """Number of the last line of a file split by :func:`split_lines` (a final line end starts no line)."""
    return max(len(lines) - (1 if lines and lines[-1] == "" else 0), 1)


def read_lines(path: str | os.PathLike[str]) -> list[str]:
    """:func:`read_text` followed by :func:`split_lines`."""
    return split_lines(read_text(path))


def parse_float(path: str | os.PathLike[str], line: int, token: str, what: str = "a number") -> float:
    """Parse a finite decimal number or raise :class:`FileFormatError` saying what was expected.

    Examples
    --------
    >>> parse_float("x.ffd", 3, "-1.5e2")
    -150.0
    >>> parse_float("x.ffd", 3, "nan", "the spacing sx")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: x.ffd, line 3: expected the spacing sx (a finite number), got 'nan'
    """
    if len(token) <= _MAX_FLOAT_CHARS and _FLOAT.fullmatch(token):
        value = float(token)
        if value - value == 0.0:  # finite (1e999 overflows to inf)
            return value
    raise FileFormatError(path, line, f"expected {what} (a finite number), got {_show(token)}")


def parse_int(path: str | os.PathLike[str], line: int, token: str, what: str = "an integer") -> int:
    """Parse a decimal integer of at most 18 digits or raise :class:`FileFormatError` saying what was expected.

    Examples
    --------
    >>> parse_int("x.ffd", 7, "11")
    11
    >>> parse_int("x.ffd", 7, "11.5", "nx")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: x.ffd, line 7: expected nx (an integer), got '11.5'
    >>> parse_int("x.ffd", 7, "1" * 5000, "nx")
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: x.ffd, line 7: expected nx (an integer of at most 18 digits), got '111...'
    """
    if _INT.fullmatch(token):
        return int(token)
    kind = "an integer of at most 18 digits" if _LONG_INT.fullmatch(token) else "an integer"
    raise FileFormatError(path, line, f"expected {what} ({kind}), got {_show(token)}")


def _show(token: str, limit: int = 40) -> str:
    """Quote a token for an error message, shortened if long."""
    return repr(token if len(token) <= limit else token[:limit] + "...")
