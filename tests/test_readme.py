"""The README's promises: two set-up commands, CI runs the test one, the engine example runs."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def setup_commands() -> list[str]:
    section = README.split("## Set up", 1)[1].split("\n## ", 1)[0]
    return [line.strip() for line in section.splitlines() if line.startswith("    ")]


def test_exactly_two_setup_commands_and_ci_runs_the_test_one():
    commands = setup_commands()
    assert len(commands) == 2, commands
    open_cmd, test_cmd = commands
    assert "python3 -m ffd_notebook" in open_cmd
    assert test_cmd == "bash tests/run_all.sh"
    ci = (ROOT / ".ci" / "run").read_text()
    assert "tests/run_all.sh" in ci


def test_the_open_command_knows_its_options():
    out = subprocess.run([sys.executable, "-m", "ffd_notebook", "--help"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    for option in ("--ffd", "--port", "--shape", "--basis", "--root"):
        assert option in out.stdout


def test_engine_example_runs():
    block = re.search(r"## The engine, from code\n\n```python\n(.*?)```", README, re.S).group(1)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["moved"].shape == (1000, 3)
    assert not namespace["folding"].any()


def test_pictures_exist():
    for path in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README):
        assert (ROOT / path).is_file(), path
