"""The code is ``ruff`` clean (the rules and line length in pyproject.toml), so CI keeps it that way.

Both the linter and the formatter's check run on the package, the tests and the benchmarks; a finding
fails with ruff's own report.
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _ruff(*args: str) -> subprocess.CompletedProcess:
    command = [shutil.which("ruff")] if shutil.which("ruff") else [sys.executable, "-m", "ruff"]
    return subprocess.run([*command, *args], cwd=REPO, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args", [("check", "."), ("format", "--check", ".")], ids=["lint", "format"])
def test_ruff_clean(args):
    result = _ruff(*args)
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_finds_a_problem(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import os\n")  # unused import: F401
    result = _ruff("check", "--no-cache", "--config", str(REPO / "pyproject.toml"), str(bad))
    assert result.returncode == 1 and "F401" in result.stdout
