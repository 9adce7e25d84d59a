"""The readers' file checks, defined in :mod:`ffd_notebook._util.file_access` (which ``images/`` imports too)."""

from __future__ import annotations

from .._util.file_access import MAX_FILE_BYTES, check_regular_file, open_regular, read_bytes

__all__ = ["MAX_FILE_BYTES", "check_regular_file", "open_regular", "read_bytes"]
