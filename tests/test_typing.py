"""Tools can see the API: lazy names declared statically, ``py.typed`` shipped, mypy clean.

The checker is mypy, at the strictness configured in ``pyproject.toml`` (``[tool.mypy]``: mypy's
defaults plus strict equality, no implicit Optional, unused ignores reported; PyVista, VTK, trame and
the other untyped or loosely typed libraries taken as ``Any``).
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "ffd_notebook"


def _lazy_tables() -> dict[Path, tuple[dict[str, str], dict[str, str]]]:
    """For each module with a ``_LAZY`` table: (the table, the names its TYPE_CHECKING block imports -> module)."""
    found = {}
    for path in sorted(PACKAGE.rglob("__init__.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        table: dict[str, str] = {}
        declared: dict[str, str] = {}
        package = ".".join(("ffd_notebook", *path.parent.relative_to(PACKAGE).parts))
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "_LAZY" for t in node.targets):
                table = ast.literal_eval(node.value)
            if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
                for imp in node.body:
                    assert isinstance(imp, ast.ImportFrom), ast.dump(imp)
                    base = package.split(".")
                    base = base[: len(base) - imp.level + 1] if imp.level else []
                    module = ".".join([*base, *([imp.module] if imp.module else [])])
                    declared.update({alias.name: module for alias in imp.names})
        if table:
            found[path] = (table, declared)
    return found


def test_lazy_names_are_declared_for_type_checkers():
    """Every lazily imported name is imported under TYPE_CHECKING too, from a module that has it."""
    import importlib

    tables = _lazy_tables()
    assert PACKAGE / "__init__.py" in tables
    for path, (table, declared) in tables.items():
        assert set(declared) == set(table), (
            f"{path}: TYPE_CHECKING imports {sorted(declared)}, _LAZY has {sorted(table)}"
        )
        for name, module in declared.items():
            lazy = getattr(importlib.import_module(table[name]), name)
            assert getattr(importlib.import_module(module), name) is lazy, (path, name)


def _mypy(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, "-m", "mypy", *args], cwd=cwd, env=env, capture_output=True, text=True)


@pytest.mark.slow
def test_mypy_finds_no_error_in_the_package(tmp_path: Path):
    result = _mypy("--cache-dir", str(tmp_path / "cache"), "--config-file", str(REPO / "pyproject.toml"), cwd=REPO)
    assert result.returncode == 0, result.stdout[-8000:] + result.stderr[-2000:]
    assert "Success: no issues found" in result.stdout


@pytest.mark.slow
def test_public_names_are_typed_for_a_user(tmp_path: Path):
    """What an IDE shows a user: the lazy top-level names have their real types, not Any."""
    script = tmp_path / "use.py"
    script.write_text(
        "import ffd_notebook\n"
        "import ffd_notebook.batch\n"
        "reveal_type(ffd_notebook.edit)\n"
        "reveal_type(ffd_notebook.load_deformation)\n"
        "reveal_type(ffd_notebook.read_mesh)\n"
        "reveal_type(ffd_notebook.batch.generate)\n"
        "ffd_notebook.FFD(ffd_notebook.Lattice((4, 4, 4), 1.0), border='clmap')\n",
        encoding="utf-8",
    )
    result = _mypy("--cache-dir", str(tmp_path / "cache"), "--follow-imports=silent", str(script), cwd=tmp_path)
    revealed = [line for line in result.stdout.splitlines() if "Revealed type" in line]
    assert len(revealed) == 4, result.stdout
    for line in revealed:
        assert "def" in line and '"Any"' not in line, line
    assert "edit" in revealed[0] and "Editor" in revealed[0], revealed[0]
    assert "FFD" in revealed[1], revealed[1]
    # a choice typed as a Literal: a misspelt border is an error before anything runs
    assert any("clmap" in line and "error" in line for line in result.stdout.splitlines()), result.stdout


@pytest.mark.slow
def test_the_wheel_ships_py_typed(tmp_path: Path):
    source = tmp_path / "src"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, source / name)
    shutil.copytree(PACKAGE, source / "ffd_notebook", ignore=shutil.ignore_patterns("__pycache__"))
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), "."],
        cwd=source, capture_output=True, text=True,
    )  # fmt: skip
    assert build.returncode == 0, build.stderr[-3000:]
    (wheel,) = tmp_path.glob("ffd_notebook-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "ffd_notebook/py.typed" in names
    assert "ffd_notebook/__init__.py" in names
