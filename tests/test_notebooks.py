"""Execute every tutorial notebook headless, the way CI and ``nbconvert --execute`` do.

Each notebook runs with nbclient in a fresh ``python3`` kernel whose working directory is a
temporary copy of ``notebooks/`` (so files a notebook writes never land in the repository), with
``PYVISTA_JUPYTER_BACKEND=static`` so that plots become PNG outputs instead of trame views.
"""

from __future__ import annotations

import base64
import io
import os
import shutil
from pathlib import Path

import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = REPO / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
TIMEOUT_S = 600


def _outputs(nb):
    for index, cell in enumerate(nb.cells):
        for output in cell.get("outputs", []):
            yield index, output


def _png_images(nb) -> list[np.ndarray]:
    images = []
    for _, output in _outputs(nb):
        data = output.get("data", {})
        if "image/png" in data:
            images.append(np.asarray(Image.open(io.BytesIO(base64.b64decode(data["image/png"])))))
    return images


def test_tutorials_are_present():
    names = {p.name for p in NOTEBOOKS}
    assert {"01_quickstart.ipynb", "02_ffd_files.ipynb", "03_bspline_basics.ipynb"} <= names


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_executes(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    work = tmp_path / "notebooks"
    shutil.copytree(NOTEBOOK_DIR, work, ignore=shutil.ignore_patterns(".ipynb_checkpoints"))
    # the kernel inherits this process's environment
    monkeypatch.setenv("PYVISTA_JUPYTER_BACKEND", "static")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    monkeypatch.setenv("JUPYTER_RUNTIME_DIR", str(tmp_path / "runtime"))
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    monkeypatch.delenv("FFD_NOTEBOOK_TRACE", raising=False)

    nb = nbformat.read(work / path.name, as_version=4)
    client = NotebookClient(
        nb, timeout=TIMEOUT_S, kernel_name="python3", allow_errors=True, resources={"metadata": {"path": str(work)}}
    )
    client.execute()

    errors = [
        f"cell {i}: {o.get('ename')}: {o.get('evalue')}" for i, o in _outputs(nb) if o.get("output_type") == "error"
    ]
    tracebacks = [
        f"cell {i}: {o.get('text', '')[-500:]}"
        for i, o in _outputs(nb)
        if o.get("name") == "stderr" and "Traceback" in o.get("text", "")
    ]
    assert not errors + tracebacks, "\n".join(errors + tracebacks)
    unrun = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and c.source.strip() and not c.execution_count]
    assert not unrun, f"code cells that did not run: {unrun}"

    images = _png_images(nb)
    assert images, f"{path.name} produced no image/png output"
    # a picture, not a blank canvas: every image has some contrast
    for image in images:
        assert image.size and np.ptp(image[..., :3] if image.ndim == 3 else image) > 30
