"""The documentation site builds strictly and documents every public name.

The site (``docs/``) is built with ``sphinx-build -W --keep-going -n``: any warning fails, and every
cross-reference must resolve. The build runs on a copy of ``docs/`` and ``notebooks/`` in a temporary
folder, so the gallery's generated files never land in the repository.
"""

from __future__ import annotations

import importlib
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"


def _api_modules():
    sys.path.insert(0, str(DOCS))
    try:
        import api_modules
    finally:
        sys.path.remove(str(DOCS))
    return api_modules


def _packages() -> list[str]:
    root = REPO / "ffd_notebook"
    return sorted(
        ".".join(("ffd_notebook", *init.parent.relative_to(root).parts))
        for init in root.rglob("__init__.py")
        if "__pycache__" not in init.parts
    )


def test_every_package_is_public_or_internal():
    """A new package gets an API page by being listed; the test says which one is missing."""
    api = _api_modules()
    unlisted = []
    for package in _packages():
        parents = [package.rsplit(".", cut)[0] for cut in range(package.count(".") + 1)]
        if package not in api.PUBLIC and not any(p in api.INTERNAL for p in parents):
            unlisted.append(package)
    assert unlisted == [], f"list these in docs/api_modules.py (PUBLIC or INTERNAL): {unlisted}"
    for name in api.PUBLIC:
        assert hasattr(importlib.import_module(name), "__all__"), f"{name} has no __all__"


def _expected_pages(api) -> dict[str, str]:
    """Public name -> the page that documents it (the first public module exporting the object)."""
    pages: dict[str, str] = {}
    first: dict[int, str] = {}
    for module_name in api.PUBLIC:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            value = getattr(module, name)
            qualified = f"{module_name}.{name}"
            if callable(value) and id(value) in first:
                pages[qualified] = first[id(value)]
            else:
                pages[qualified] = qualified
                if callable(value):
                    first[id(value)] = qualified
    return pages


@pytest.mark.slow
def test_site_builds_strictly_and_documents_every_public_name(tmp_path: Path):
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("_build", "auto_examples", "api", "*.ipynb"))
    shutil.copytree(REPO / "notebooks", tmp_path / "notebooks", ignore=shutil.ignore_patterns(".ipynb_checkpoints"))
    out = tmp_path / "html"
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    env["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    env["MPLBACKEND"] = "Agg"
    started = time.perf_counter()
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html", str(source), str(out)],
        capture_output=True, text=True, env=env, timeout=1500,
    )  # fmt: skip
    seconds = time.perf_counter() - started
    assert build.returncode == 0, f"the site's build failed or warned:\n{build.stderr[-6000:]}"
    assert "WARNING" not in build.stderr and "ERROR" not in build.stderr, build.stderr[-6000:]

    pages = sorted(out.rglob("*.html"))
    gallery = sorted((out / "auto_examples").glob("plot_*.html"))
    pictures = [p for p in sorted((out / "_images").glob("sphx_glr_plot_*")) if p.suffix in (".png", ".gif")
                and not p.stem.endswith("_thumb")]  # fmt: skip
    print(
        f"\nsite built in {seconds:.0f} s: {len(pages)} pages, {len(gallery)} gallery examples, "
        f"{len(pictures)} pictures"
    )
    assert len(gallery) >= 6 and len(pictures) >= len(gallery), (gallery, pictures)
    # the animation's page shows the GIF the example wrote (issue 33), moving: its frames are all there
    animated = [p for p in pictures if p.name.startswith("sphx_glr_plot_animation") and p.suffix == ".gif"]
    assert animated and Image.open(animated[0]).n_frames > 1, pictures

    api = _api_modules()
    missing = [name for name, page in _expected_pages(api).items()
               if not (out / "api" / "generated" / f"{page}.html").is_file()]  # fmt: skip
    assert missing == [], f"public names without an API page: {missing}"
    for module in api.PUBLIC:
        assert (out / "api" / f"{module}.html").is_file()
    for notebook in (REPO / "notebooks").glob("*.ipynb"):
        assert (out / "tutorials" / f"{notebook.stem}.html").is_file(), notebook.name
