"""Displacement fields and reference grids go through the one image reader (issue 35 item 3).

Before, ``io/displacement_field.py`` called SimpleITK directly: a six-line ``.mha`` with ``NDims = -1`` made
``load_deformation`` spin for ever (ITK's MetaImage reader loops; ``read_image`` refused the same file), and a
field's ``ElementDataFile`` was read wherever it pointed. Now fields, and reference grids given as paths, are read
by :func:`~ffd_notebook.images.open_image` with its header checks, data-file rule and whole-or-nothing rule.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.images import warp_image
from ffd_notebook.io import load_deformation, load_displacement_field, sample_displacement_field

HOSTILE = "ObjectType = Image\nNDims = -1\nDimSize = 4 4 4\nElementNumberOfChannels = 3\nElementType = MET_DOUBLE\n" \
          "ElementDataFile = LOCAL\n"  # fmt: skip


def test_ndims_minus_one_is_refused_at_once(tmp_path):
    """In a child process with a deadline: on the code before, this call never returned."""
    path = tmp_path / "hostile.mha"
    path.write_text(HOSTILE)
    code = ("import sys\nfrom ffd_notebook.io import load_deformation\ntry:\n    load_deformation(sys.argv[1])\n"
            "except ValueError as exc:\n    print(type(exc).__name__, exc)\n")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[2])  # fmt: skip
    assert out.stdout.startswith("FileFormatError") and "NDims must be a whole number from 1 to 3" in out.stdout, (
        out.stdout + out.stderr[-2000:]
    )


def test_a_reference_grid_given_as_a_path_is_read_by_the_same_rules(tmp_path):
    path = tmp_path / "hostile.mha"
    path.write_text(HOSTILE)
    ffd = FFD(Lattice((4, 4, 4), 1.0))
    with pytest.raises(FileFormatError, match="NDims"):
        sample_displacement_field(ffd, path)
    with pytest.raises(FileFormatError, match="NDims"):
        warp_image(np.zeros((4, 4, 4), np.float32), ffd, reference=path, spacing=1.0)


def test_a_field_reads_its_data_file_only_inside_within(tmp_path):
    folder, outside = tmp_path / "folder", tmp_path / "outside"
    folder.mkdir()
    outside.mkdir()
    (outside / "secret.raw").write_bytes(np.full(4 * 4 * 4 * 3, 1234.5).tobytes())
    path = folder / "field.mha"
    path.write_text(HOSTILE.replace("-1", "3").replace("LOCAL", "../outside/secret.raw"))
    for read in (load_displacement_field, load_deformation):
        with pytest.raises(FileFormatError, match="outside the folder it may read from"):
            read(path, within=folder)
    assert np.all(load_displacement_field(path).vectors == 1234.5)  # a notebook reads what the header names
