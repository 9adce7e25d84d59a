"""Fixtures shared by every test folder."""

from __future__ import annotations

from pathlib import Path

import pytest
import registration_reference

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


@pytest.fixture(scope="session")
def niftyreg_run(tmp_path_factory):
    """reg_aladin + reg_f3d -aff on a real MRI pair, and what reg_resample and reg_transform make of the grid
    (``tests/registration_reference.py``; once per session, a few seconds)."""
    return registration_reference.run_niftyreg(tmp_path_factory.mktemp("niftyreg"))


@pytest.fixture(scope="session")
def ants_run(tmp_path_factory):
    """ANTs SyN on the MRI pair (separate files and a composite .h5), applied by ants.apply_transforms."""
    return registration_reference.run_ants(tmp_path_factory.mktemp("ants"), tmp_path_factory.mktemp("ants_script"))


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
