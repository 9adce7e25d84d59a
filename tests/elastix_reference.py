"""itk-elastix as the outside reference: small real registrations, and transformix on points.

``itk`` takes ~25 s to import here (it loads every wrapped module), so tests use these through
session fixtures (``tests/io/test_elastix.py``). transformix writes its ``OutputPoint`` values in
fixed notation with 6 decimals (``elxTransformBase.hxx``: ``std::fixed``), so a comparison can be
exact to 5e-7 at best.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

#: transformix's output precision (6 decimals)
TRANSFORMIX_ROUNDING = 5e-7


def _itk():
    import itk

    return itk


def blobs(shape: tuple[int, int, int], centres: list[tuple[float, float, float]]) -> np.ndarray:
    """A smooth test volume (z, y, x array order) of Gaussian blobs at index-space ``centres`` (x, y, z)."""
    z, y, x = np.mgrid[0 : shape[2], 0 : shape[1], 0 : shape[0]].astype(np.float32)
    out = np.zeros(z.shape, np.float32)
    for k, (cx, cy, cz) in enumerate(centres):
        out += np.exp(-((x - cx) ** 2 / 30 + (y - cy) ** 2 / 40 + (z - cz) ** 2 / 20)).astype(np.float32) / (k + 1)
    return out


def register(folder: Path, *, affine: bool, spacing, origin, direction, grid_spacing: float, iterations: int = 20):
    """Run elastix (affine then B-spline, or B-spline alone) on two small volumes; return the last file's path."""
    itk = _itk()
    folder.mkdir(parents=True, exist_ok=True)
    shape = (18, 22, 20)
    images = []
    for centres in ([(9, 11, 10), (5, 6, 4)], [(10, 12, 9), (6, 6, 5)]):
        image = itk.image_from_array(blobs(shape, centres))
        image.SetSpacing([float(s) for s in spacing])
        image.SetOrigin([float(o) for o in origin])
        image.SetDirection(itk.matrix_from_array(np.asarray(direction, dtype=np.float64)))
        images.append(image)
    params = itk.ParameterObject.New()
    if affine:
        params.AddParameterMap(params.GetDefaultParameterMap("affine", 1))
    params.AddParameterMap(params.GetDefaultParameterMap("bspline", 1, float(grid_spacing)))
    for i in range(params.GetNumberOfParameterMaps()):
        params.SetParameter(i, "MaximumNumberOfIterations", str(iterations))
        params.SetParameter(i, "WriteResultImage", "false")
    itk.elastix_registration_method(images[0], images[1], parameter_object=params, output_directory=str(folder),
                                    log_to_console=False)  # fmt: skip
    return folder / f"TransformParameters.{params.GetNumberOfParameterMaps() - 1}.txt"


def transformix_points(parameter_file: str | os.PathLike[str], points: np.ndarray, workdir: Path) -> np.ndarray:
    """transformix's ``OutputPoint`` for physical ``points`` under a parameter file (read from disk, chain and all)."""
    itk = _itk()
    workdir.mkdir(parents=True, exist_ok=True)
    listing = workdir / "inputpoints.txt"
    with listing.open("w") as f:
        f.write(f"point\n{len(points)}\n")
        for p in points:
            f.write(" ".join(repr(float(v)) for v in p) + "\n")
    flt = itk.TransformixFilter[itk.Image[itk.F, 3]].New()
    flt.SetMovingImage(itk.image_from_array(np.zeros((4, 4, 4), np.float32)))
    flt.SetTransformParameterFileName(os.fspath(parameter_file))
    flt.SetFixedPointSetFileName(os.fspath(listing))
    flt.SetOutputDirectory(os.fspath(workdir))
    flt.SetLogToConsole(False)
    flt.Update()
    out = []
    for line in (workdir / "outputpoints.txt").read_text().splitlines():
        inside = line.split("OutputPoint = [", 1)[1].split("]", 1)[0]
        out.append([float(v) for v in inside.split()])
    return np.array(out)
