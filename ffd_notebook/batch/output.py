"""The output folder of a batch run: meshes, parameters, per-sample records and the manifest.

Layout of ``out/``::

    run.json                 the run's settings (mesh, model spec, seed, fold rule, format)
    manifest.csv             one row per finished sample, by id (rebuilt from records/)
    meshes/sample_000012.ply the deformed mesh
    meshes/image_000012.EXT  with images: the image and the label map warped by the same sample, in the
    meshes/label_000012.EXT  input images' own formats (EXT: their extensions, e.g. nii.gz)
    parameters/sample_000012.ffd (lattice models) or .txt (GP coefficients, one per line)
    records/sample_000012.json   the sample's manifest row, written last: the sample is done

Every file is written atomically (temporary file, then rename), so a killed run leaves whole
files only; a sample counts as done when its record and its mesh exist.
"""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from ..io._atomic import atomic_open
from ..io._text import parse_float, read_lines

__all__ = [
    "COLUMNS",
    "IMAGE_COLUMNS",
    "MESH_OUTPUT_FORMATS",
    "Layout",
    "read_manifest",
    "read_parameters_txt",
    "write_parameters_txt",
]

MESH_OUTPUT_FORMATS = ("ply", "vtp", "obj")
COLUMNS = (
    "id",
    "seed",
    "source_mesh",
    "mesh_file",
    "parameters_file",
    "min_det_j",
    "max_displacement",
    "redraws",
    "scale_downs",
    "scale",
)
IMAGE_COLUMNS = {"image": "image_file", "label": "label_file"}  # in the manifest of a run with images


class Layout:
    """Paths inside an output folder.

    ``images`` maps ``"image"`` / ``"label"`` to the extension of the warped files (the input
    image's, such as ``".nii.gz"``) for a run with images.
    """

    def __init__(self, out: str | os.PathLike[str], fmt: str = "ply", images: dict[str, str] | None = None) -> None:
        self.root = Path(out)
        self.format = fmt
        self.images = dict(images or {})
        self.run_file = self.root / "run.json"
        self.manifest = self.root / "manifest.csv"

    def mesh(self, index: int) -> Path:
        return self.root / "meshes" / f"sample_{index:06d}.{self.format}"

    def image(self, kind: str, index: int) -> Path:
        """The warped ``"image"`` or ``"label"`` map of sample ``index``, beside its mesh."""
        return self.root / "meshes" / f"{kind}_{index:06d}{self.images[kind]}"

    def parameters(self, index: int, suffix: str) -> Path:
        return self.root / "parameters" / f"sample_{index:06d}{suffix}"

    def record(self, index: int) -> Path:
        return self.root / "records" / f"sample_{index:06d}.json"

    def make(self) -> None:
        for sub in ("meshes", "parameters", "records"):
            (self.root / sub).mkdir(parents=True, exist_ok=True)

    # ------------------------------------------------------------------ run settings
    def claim(self, settings: dict[str, Any]) -> None:
        """Write ``run.json``, or check that an earlier run in this folder had the same settings."""
        if self.run_file.exists():
            try:
                old = json.loads(self.run_file.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise FileFormatError(self.run_file, None, f"not a run settings file ({exc})") from None
            if old != settings:
                changed = sorted(k for k in set(old) | set(settings) if old.get(k) != settings.get(k))
                raise ValueError(
                    f"{self.root} holds a run with other settings (different {', '.join(changed)}); "
                    "use another output folder to start a new run"
                )
            return
        self.make()
        with atomic_open(self.run_file, "w", encoding="utf-8") as f:
            json.dump(settings, f, indent=1, sort_keys=True)

    def settings(self) -> dict[str, Any]:
        """The settings in ``run.json``."""
        if not self.run_file.is_file():
            raise FileNotFoundError(f"{self.root} is not a batch output folder: no run.json")
        return json.loads(self.run_file.read_text(encoding="utf-8"))

    # ------------------------------------------------------------------ records
    def done(self, index: int) -> bool:
        files = [self.record(index), self.mesh(index), *(self.image(kind, index) for kind in self.images)]
        return all(f.is_file() for f in files)

    def write_record(self, row: dict[str, Any]) -> None:
        with atomic_open(self.record(int(row["id"])), "w", encoding="utf-8") as f:
            json.dump(row, f)

    def records(self) -> list[dict[str, Any]]:
        """Every finished sample's row, by id."""
        rows = []
        for path in sorted((self.root / "records").glob("sample_*.json")):
            try:
                row = json.loads(path.read_text(encoding="utf-8"))
            except ValueError:
                continue  # cannot happen with atomic writes; such a sample is simply redone
            columns = set(COLUMNS) | {IMAGE_COLUMNS[kind] for kind in self.images}
            if isinstance(row, dict) and columns <= set(row) and self.done(int(row["id"])):
                rows.append(row)
        return rows

    def write_manifest(self) -> list[dict[str, Any]]:
        """Rebuild ``manifest.csv`` from the records (atomically); returns the rows."""
        rows = self.records()
        buffer = io.StringIO()
        columns = COLUMNS + tuple(IMAGE_COLUMNS[kind] for kind in self.images)
        writer = csv.DictWriter(buffer, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
        with atomic_open(self.manifest, "w", encoding="utf-8", newline="") as f:
            f.write(buffer.getvalue())
        return rows


def read_manifest(out: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The manifest of an output folder as columns (NumPy arrays; numbers parsed).

    Parameters
    ----------
    out : str or os.PathLike
        An output folder (holding ``manifest.csv``).

    Returns
    -------
    dict of numpy.ndarray
        Column name -> values, one per finished sample.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "manifest.csv").write_text("id,min_det_j\\n0,0.5\\n1,0.25\\n")
    >>> read_manifest(folder)["min_det_j"].tolist()
    [0.5, 0.25]
    """
    path = Path(out) / "manifest.csv"
    with open(path, encoding="utf-8", newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return {name: np.array([]) for name in COLUMNS}
    columns: dict[str, np.ndarray] = {}
    for name in rows[0]:
        values = [r[name] for r in rows]
        for kind in (int, float):
            try:
                columns[name] = np.array([kind(v) for v in values])
                break
            except ValueError:
                continue
        else:
            columns[name] = np.array(values)
    return columns


def write_parameters_txt(path: Path, coefficients: np.ndarray) -> None:
    """Coefficients, one per line, written with ``repr`` (read back bit-identical)."""
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(f"{float(c)!r}\n" for c in coefficients)


def read_parameters_txt(path: Path, expected: int) -> np.ndarray:
    """Coefficients written by :func:`write_parameters_txt`; a malformed file names the line."""
    lines = [line.strip() for line in read_lines(path)]
    values = [parse_float(path, i + 1, line, "a coefficient") for i, line in enumerate(lines) if line]
    if len(values) != expected:
        raise FileFormatError(path, None, f"expected {expected} coefficients, got {len(values)}")
    return np.array(values)
