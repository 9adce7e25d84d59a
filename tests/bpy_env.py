"""Blender (the ``bpy`` module from PyPI) in a virtual environment of its own: :data:`reference_env.BLENDER`.

``bpy`` 4.5 pins NumPy < 2 while ffd_notebook runs on NumPy 2, so Blender cannot live in the test interpreter;
:mod:`reference_env` builds it once into the cache and runs scripts there (arrays through ``.npz`` files).
"""

from __future__ import annotations

from pathlib import Path

from reference_env import BLENDER


def bpy_python(*, log=None) -> Path:
    """Interpreter of the virtual environment holding Blender's ``bpy``, created on first use."""
    return BLENDER.python(log=log)


def run_blender(script: str, inputs: dict | None = None, *, workdir: Path, timeout: float = 300) -> dict:
    """Run ``script`` in Blender's Python and return the arrays it saved (see :meth:`reference_env.ReferenceEnv.run`).

    The script sees ``IN`` and ``save(**arrays)``; ffd_notebook's source tree is on its ``sys.path`` so that it can
    ``import ffd_notebook.blender``.
    """
    return BLENDER.run(script, inputs, workdir=workdir, timeout=timeout)
