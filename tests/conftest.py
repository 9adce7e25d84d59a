"""Fixtures shared by every test folder."""

from __future__ import annotations

from pathlib import Path

import pytest

# tests/ -> repo root -> the folder holding both the repo and shared/
SHARED_DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of the shared test data (``../shared/data`` next to the repository; never copied into it)."""
    if not SHARED_DATA.is_dir():
        pytest.fail(
            f"shared test data not found at {SHARED_DATA}: these tests need the project's shared/data folder "
            "next to the repository (../shared/data relative to the repository root)",
            pytrace=False,
        )
    return SHARED_DATA
