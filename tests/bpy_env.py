"""Blender (the ``bpy`` module from PyPI) in a virtual environment of its own, and scripts run in it.

``bpy`` 4.5 pins NumPy < 2 while ffd_notebook runs on NumPy 2, so Blender cannot live in the test interpreter.
:func:`bpy_python` creates (once) a virtual environment in a cache folder outside the repository, keyed by the
bpy version, and returns its interpreter; :func:`run_blender` runs a script there with ffd_notebook's source
tree (the one this process imports) on ``sys.path`` and exchanges arrays through ``.npz`` files.

The environment is built next to its final place and renamed into it when complete, under a file lock, so an
interrupted or concurrent build never leaves a half-made environment that looks ready.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

BPY_SPEC = "bpy==4.5.*"
BPY_KEY = "bpy-4.5"


def cache_root() -> Path:
    """Folder holding the Blender virtual environments (``$FFD_NOTEBOOK_CACHE`` or ``~/.cache/ffd_notebook``)."""
    base = os.environ.get("FFD_NOTEBOOK_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "ffd_notebook")
    return Path(base)


def _venv_python(venv: Path) -> Path:
    return venv / "bin" / "python"


def _run(cmd: list[str], log: Path) -> None:
    with open(log, "a") as out:
        out.write(f"$ {' '.join(cmd)}\n")
        out.flush()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, check=False)
    if done.returncode != 0:
        tail = log.read_text(errors="replace")[-4000:]
        raise RuntimeError(f"command failed ({done.returncode}): {' '.join(cmd)}\n{tail}")


def bpy_python(*, log=None) -> Path:
    """Interpreter of the virtual environment holding Blender's ``bpy``, created on first use.

    Returns
    -------
    Path
        ``<cache>/bpy-4.5/bin/python``; ``import bpy`` works in it.
    """
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    venv = root / BPY_KEY
    ready = venv / "READY"
    if ready.is_file():
        return _venv_python(venv)
    with open(root / f"{BPY_KEY}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if ready.is_file():
            return _venv_python(venv)
        building = root / f"{BPY_KEY}.building"
        shutil.rmtree(building, ignore_errors=True)
        shutil.rmtree(venv, ignore_errors=True)
        logfile = root / f"{BPY_KEY}.log"
        logfile.write_text("")
        start = time.perf_counter()
        # Built at its final path (a venv's scripts name their own path), marked READY only when bpy imports.
        _run([sys.executable, "-m", "venv", str(venv)], logfile)
        py = str(_venv_python(venv))
        _run([py, "-m", "pip", "install", "-q", "--disable-pip-version-check", BPY_SPEC], logfile)
        _run([py, "-c", "import bpy, numpy; print(bpy.app.version_string, numpy.__version__)"], logfile)
        ready.write_text(f"{BPY_SPEC} built in {time.perf_counter() - start:.0f} s\n")
        if log is not None:
            log(f"bpy virtual environment built in {time.perf_counter() - start:.0f} s at {venv}")
    return _venv_python(venv)


def run_blender(script: str, inputs: dict | None = None, *, workdir: Path, timeout: float = 300) -> dict:
    """Run ``script`` in Blender's Python and return the arrays it saved.

    The script sees ``IN`` (a dict of the ``inputs`` arrays, loaded from ``.npz``; JSON-able values go
    through ``IN["json"]``) and ``save(**arrays)`` to hand arrays back; ffd_notebook's source tree is on its
    ``sys.path`` so that it can ``import ffd_notebook.blender``.
    """
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    inputs = dict(inputs or {})
    meta = inputs.pop("json", None)
    np.savez(workdir / "in.npz", **{k: np.asarray(v) for k, v in inputs.items()})
    (workdir / "in.json").write_text(json.dumps(meta))
    out = workdir / "out.npz"
    if out.exists():
        out.unlink()
    import ffd_notebook  # Blender imports the same ffd_notebook as this process

    source = Path(os.path.abspath(ffd_notebook.__file__)).parents[1]
    prelude = (
        "import sys, json, numpy as np\n"
        f"sys.path.insert(0, {str(source)!r})\n"
        f"_d = np.load({str(workdir / 'in.npz')!r})\n"
        "IN = {k: _d[k] for k in _d.files}\n"
        f"IN['json'] = json.loads(open({str(workdir / 'in.json')!r}).read())\n"
        f"def save(**arrays):\n    np.savez({str(out)!r}, **arrays)\n"
    )
    (workdir / "script.py").write_text(prelude + script)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    done = subprocess.run(
        [str(bpy_python()), str(workdir / "script.py")],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=workdir,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"Blender script failed ({done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-6000:]}")
    if not out.exists():
        return {}
    with np.load(out) as data:
        return {k: data[k] for k in data.files}
