"""Reference tools in virtual environments of their own, built once into a cache, and scripts run in them.

Some references pin libraries the package does not run on (Blender's ``bpy`` 4.5 wants NumPy < 2; ``antspyx`` and
``fslpy`` want NumPy 2.3 and SciPy 1.15) or are programs built from source (NiftyReg, from its PyPI source
distribution). Each lives in a virtual environment of its own in a cache folder outside the repository
(``$FFD_NOTEBOOK_CACHE`` or ``~/.cache/ffd_notebook``), keyed by what it holds:

- :meth:`ReferenceEnv.python` builds the environment on first use and returns its interpreter. The build runs
  under a file lock, at the environment's final path (a venv's scripts name their own path), and the environment
  counts as made only when a ``READY`` file is written after its check passed: an interrupted or concurrent build
  never leaves a half-made environment that looks ready.
- :meth:`ReferenceEnv.run` runs a Python script there, handing arrays both ways through ``.npz`` files, with
  ffd_notebook's source tree (the one this process imports) on its ``sys.path``.
- :meth:`ReferenceEnv.program` is a program the environment installed (NiftyReg's ``reg_f3d``...).

``python tests/reference_env.py build [NAME ...]`` builds them (all by default) from a shell: ``tests/run_all.sh``
starts it in the background first thing, so that the builds overlap the apt and pip steps.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


def cache_root() -> Path:
    """Folder holding the reference environments (``$FFD_NOTEBOOK_CACHE`` or ``~/.cache/ffd_notebook``)."""
    base = os.environ.get("FFD_NOTEBOOK_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "ffd_notebook")
    return Path(base)


def _run(cmd: list[str], log: Path, env: dict[str, str] | None = None) -> None:
    with open(log, "a") as out:
        out.write(f"$ {' '.join(cmd)}\n")
        out.flush()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, check=False, env=env)
    if done.returncode != 0:
        tail = log.read_text(errors="replace")[-4000:]
        raise RuntimeError(f"command failed ({done.returncode}): {' '.join(cmd)}\n{tail}")


def _child_env(extra: dict[str, str]) -> dict[str, str]:
    """The environment of a reference script: this one's without what would make it import this interpreter's
    packages, and the environment's own settings."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(extra)
    return env


# Registration tools on one thread: the machine's cores are shared, and ANTs' and NiftyReg's results then do not
# depend on how the work was split.
_ONE_THREAD = {"OMP_NUM_THREADS": "1", "ITK_GLOBAL_DEFAULT_NUMBER_OF_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


@dataclass(frozen=True)
class ReferenceEnv:
    """A virtual environment holding a reference tool, made once in the cache.

    Parameters
    ----------
    key : str
        Folder name in the cache; change it with the requirements so that a new version builds anew.
    requirements : tuple of str
        What ``pip install`` puts in it.
    check : str
        Python code run in the new environment; the environment is marked ready only when it succeeds.
    build_env : dict
        Extra environment variables for the install (NiftyReg's old ``CMakeLists.txt`` needs
        ``CMAKE_POLICY_VERSION_MINIMUM`` with CMake 4).
    programs : str
        Python expression, evaluated in the environment, of the folder holding the tool's programs.
    run_env : dict
        Extra environment variables for the scripts and programs run there.
    """

    key: str
    requirements: tuple[str, ...]
    check: str
    build_env: dict[str, str] = field(default_factory=dict)
    programs: str | None = None
    run_env: dict[str, str] = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        return cache_root() / self.key

    def python(self, *, log: Any = None) -> Path:
        """Interpreter of the environment, built first if it is not ready (waiting for a build under way)."""
        root = cache_root()
        root.mkdir(parents=True, exist_ok=True)
        venv, python = self.folder, self.folder / "bin" / "python"
        ready = venv / "READY"
        if ready.is_file():
            return python
        with open(root / f"{self.key}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if ready.is_file():  # built by another process while this one waited
                return python
            shutil.rmtree(venv, ignore_errors=True)
            logfile = root / f"{self.key}.log"
            logfile.write_text("")
            start = time.perf_counter()
            _run([sys.executable, "-m", "venv", str(venv)], logfile)
            env = {**os.environ, **self.build_env}
            pip = [str(python), "-m", "pip", "install", "-q", "--disable-pip-version-check"]
            _run([*pip, *self.requirements], logfile, env)
            _run([str(python), "-c", self.check], logfile)
            seconds = time.perf_counter() - start
            ready.write_text(f"{' '.join(self.requirements)} built in {seconds:.0f} s\n")
            if log is not None:
                log(f"{self.key} virtual environment built in {seconds:.0f} s at {venv}")
        return python

    def program(self, name: str) -> Path:
        """A program the environment installed (``NIFTYREG.program("reg_f3d")``), building the environment first."""
        if self.programs is None:
            raise ValueError(f"the {self.key} environment installs no programs")
        folder = self.folder / "PROGRAMS"
        if not folder.is_file():
            python = self.python()
            where = subprocess.run([str(python), "-c", f"print({self.programs})"], capture_output=True, text=True,
                                   check=True, env=_child_env(self.run_env)).stdout.strip()  # fmt: skip
            folder.write_text(where)
        path = Path(folder.read_text().strip()) / name
        if not path.is_file():
            raise FileNotFoundError(f"{self.key}: no program {name!r} in {path.parent}")
        return path

    def run(self, script: str, inputs: dict | None = None, *, workdir: Path, timeout: float = 300) -> dict:
        """Run ``script`` in the environment's Python and return the arrays it saved.

        The script sees ``IN`` (a dict of the ``inputs`` arrays, loaded from ``.npz``; JSON-able values go through
        ``IN["json"]``) and ``save(**arrays)`` to hand arrays back; ffd_notebook's source tree is on its
        ``sys.path``. A failing script raises ``RuntimeError`` with its output.
        """
        import numpy as np

        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        inputs = dict(inputs or {})
        meta = inputs.pop("json", None)
        np.savez(workdir / "in.npz", **{k: np.asarray(v) for k, v in inputs.items()})
        (workdir / "in.json").write_text(json.dumps(meta))
        out = workdir / "out.npz"
        if out.exists():
            out.unlink()
        import ffd_notebook  # the reference imports the same ffd_notebook as this process

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
        done = subprocess.run([str(self.python()), str(workdir / "script.py")], capture_output=True, text=True,
                              timeout=timeout, env=_child_env(self.run_env), cwd=workdir, check=False)  # fmt: skip
        if done.returncode != 0:
            raise RuntimeError(f"{self.key} script failed ({done.returncode}):\n{done.stdout[-3000:]}\n"
                               f"{done.stderr[-6000:]}")  # fmt: skip
        if not out.exists():
            return {}
        with np.load(out) as data:
            return {k: data[k] for k in data.files}

    def call(self, name: str, *args: str | os.PathLike[str], cwd: Path, timeout: float = 300) -> str:
        """Run one of the environment's programs; its output, or ``RuntimeError`` with it if it fails."""
        cmd = [str(self.program(name)), *[os.fspath(a) for a in args]]
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=_child_env(self.run_env),
                              cwd=cwd, check=False)  # fmt: skip
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout[-3000:]}\n"
                               f"{done.stderr[-3000:]}")  # fmt: skip
        return done.stdout + done.stderr


#: Blender 4.5 (``bpy`` from PyPI; it pins NumPy < 2).
BLENDER = ReferenceEnv(
    "bpy-4.5", ("bpy==4.5.*",), "import bpy, numpy; print(bpy.app.version_string, numpy.__version__)"
)
#: NiftyReg built from its PyPI source distribution (about 3 minutes on 2 cores): reg_aladin, reg_f3d,
#: reg_resample, reg_transform in ``niftyreg.bin_path``.
NIFTYREG = ReferenceEnv(
    "niftyreg-1.5.70",
    ("niftyreg==1.5.70rc1",),
    "import niftyreg, subprocess; subprocess.run([str(niftyreg.bin_path / 'reg_f3d'), '--version'], check=True)",
    build_env={"CMAKE_POLICY_VERSION_MINIMUM": "3.5"},
    programs="__import__('niftyreg').bin_path",
    run_env=_ONE_THREAD,
)
#: ANTs (``antspyx``) and FSL's own Python library ``fslpy`` (it reads and evaluates FNIRT files as FSLeyes does);
#: both pin NumPy 2.3 / SciPy 1.15.
ANTS_FSL = ReferenceEnv(
    "ants-fsl-0.6.3-3.29.1",
    ("antspyx==0.6.3", "fslpy==3.29.1"),
    "import ants, fsl.transform.fnirt, numpy; print(ants.__version__, numpy.__version__)",
    run_env=_ONE_THREAD,
)
ENVIRONMENTS = {"blender": BLENDER, "niftyreg": NIFTYREG, "ants-fsl": ANTS_FSL}


def main(argv: list[str]) -> int:
    if not argv or argv[0] != "build" or any(name not in ENVIRONMENTS for name in argv[1:]):
        print(f"usage: python {Path(__file__).name} build [{' | '.join(ENVIRONMENTS)} ...]", file=sys.stderr)
        return 2
    failed = 0
    for name in argv[1:] or list(ENVIRONMENTS):
        try:
            ENVIRONMENTS[name].python(log=print)
            print(f"{name}: ready at {ENVIRONMENTS[name].folder}", flush=True)
        except Exception as exc:  # each build on its own: the tests that need a failed one report it
            failed += 1
            print(f"{name}: build failed: {exc}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
