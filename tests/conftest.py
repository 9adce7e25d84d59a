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


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Doctests that run only inside Blender (their examples ``import bpy``: ffd_notebook.blender's Blender side)
    are left out where ``bpy`` is not importable; ``tests/blender/test_blender_doctests.py`` runs them in
    Blender's own Python instead, so they still run for real."""
    import importlib.util

    from _pytest.doctest import DoctestItem

    if importlib.util.find_spec("bpy") is not None:
        return
    kept, left_out = [], []
    for item in items:
        blender_only = isinstance(item, DoctestItem) and any(
            "import bpy" in example.source for example in (item.dtest.examples if item.dtest else [])
        )
        (left_out if blender_only else kept).append(item)
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        items[:] = kept
