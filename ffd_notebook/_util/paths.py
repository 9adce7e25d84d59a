"""The type of a file-name argument, defined once."""

from __future__ import annotations

import os
from typing import TypeAlias

__all__ = ["StrPath"]

#: A file name as the package's functions take it: a ``str`` or any ``os.PathLike`` of one (``pathlib.Path``).
StrPath: TypeAlias = str | os.PathLike[str]
