"""Blender, run for real: a virtual environment with ``bpy`` 4.5 made once (see ``tests/bpy_env.py``)."""

from __future__ import annotations

import pytest
from bpy_env import bpy_python, run_blender


@pytest.fixture(scope="session")
def blender(tmp_path_factory):
    """``blender(script, inputs) -> dict of arrays``: run a script in Blender's Python (see ``run_blender``)."""
    bpy_python()  # builds the environment on first use (about a minute with a warm pip cache)
    counter = iter(range(1_000_000))

    def run(script: str, inputs: dict | None = None, *, timeout: float = 600) -> dict:
        workdir = tmp_path_factory.mktemp(f"blender{next(counter)}")
        return run_blender(script, inputs, workdir=workdir, timeout=timeout)

    return run
