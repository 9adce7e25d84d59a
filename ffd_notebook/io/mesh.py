"""Read and write meshes: OBJ and PLY with this package's readers, STL and VTK formats through PyVista.

Reading takes untrusted files: only the formats below are read, each file is checked to be a
regular file under the size limit (:mod:`._safety`) before anything opens it, and no mesh
reaches VTK before its sizes and connectivity are checked:

* ``.obj`` -- :mod:`.obj` (NumPy), indices checked;
* ``.ply`` -- :mod:`.ply` (NumPy): VTK's PLY reader crashes on hostile headers (see there why
  neither ``plyfile`` nor ``meshio``);
* ``.stl``, ``.vtk`` (legacy), ``.vtp``, ``.vtu`` -- VTK's readers, which survived the fuzzing of
  tests/io/test_fuzz_readers.py, behind :mod:`.mesh_checks`: header counts checked against the
  file size before reading, cells and points checked after.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pyvista as pv

from ..errors import FileFormatError
from . import MESH_SUFFIXES
from ._atomic import atomic_path
from ._safety import MAX_FILE_BYTES, read_bytes
from .mesh_checks import check_cells, check_header_counts
from .obj import read_obj, write_obj
from .ply import read_ply

__all__ = ["read_mesh", "write_mesh"]

#: Extensions :func:`read_mesh` reads (lower case).
_HEADER_BYTES = 1 << 20  # XML headers: counts are looked for in the first MiB
READ_TIMEOUT = 300  # seconds VTK's reader may take in its child process


def _pyvista_read(path: Path) -> pv.DataSet:
    """Read a file VTK can read, without letting VTK parse it in this process (see :mod:`._vtk_child`)."""
    suffix = path.suffix.lower()
    data = read_bytes(path, MAX_FILE_BYTES)
    check_header_counts(path, data[: len(data) if suffix == ".vtk" else _HEADER_BYTES], len(data), suffix)
    with tempfile.TemporaryDirectory(prefix="ffd-notebook-read-") as folder:
        source = Path(folder) / f"in{suffix}"  # a copy: the child reads exactly the bytes checked here
        source.write_bytes(data)
        del data
        problem = _run_child(path, source, Path(folder) / "out", suffix)
        if problem is not None:
            raise FileFormatError(path, None, f"VTK could not read a mesh from it ({problem})")
        (converted,) = Path(folder).glob("out.vt[pu]")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with pv.vtk_verbosity("off"), pv.VtkErrorCatcher(send_to_logging=False) as catcher:
                mesh = pv.read(converted)  # written by VTK's own writer just now: raw arrays
    failures = [str(e) for e in catcher.error_events] + [str(w.message) for w in caught if "error" in str(w.message)]
    if failures or mesh.n_points == 0:
        detail = failures[0].strip().splitlines()[-1].strip(' \t"')[:200] if failures else "no points"
        raise FileFormatError(path, None, f"VTK could not read a mesh from it ({detail})")
    check_cells(path, mesh)
    return mesh


def _run_child(path: Path, source: Path, target: Path, suffix: str) -> str | None:
    """Run VTK's reader in a child process; what went wrong, or None."""
    command = [sys.executable, str(Path(__file__).with_name("_vtk_child.py")), str(source), str(target), suffix]
    try:
        done = subprocess.run(command, capture_output=True, timeout=READ_TIMEOUT, check=False)
    except subprocess.TimeoutExpired:
        return f"VTK's reader took more than {READ_TIMEOUT} s"
    if done.returncode < 0:
        return f"VTK's reader crashed on it (signal {-done.returncode})"
    if done.returncode != 0:
        message = done.stderr.decode("utf-8", "replace").strip().splitlines()
        return message[-1][:200] if message else f"VTK's reader failed (exit status {done.returncode})"
    return None


def read_mesh(path: str | os.PathLike[str]) -> pv.DataSet:
    """Read a mesh, choosing the reader by extension (one of :data:`MESH_SUFFIXES`).

    ``.obj`` goes through :func:`~ffd_notebook.io.read_obj` (vertex order and colours kept),
    ``.ply`` through :func:`~ffd_notebook.io.ply.read_ply`, STL and VTK formats through
    :func:`pyvista.read` with the checks of :mod:`.mesh_checks` (see the module docstring). Colours
    stay point data: a PLY with RGBA colours gets an ``"RGB"`` array too (the active scalars), like OBJ.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    pyvista.DataSet
        Usually a :class:`pyvista.PolyData`.

    Raises
    ------
    FileFormatError
        If the file is malformed, empty or of a format no reader knows; it names the file.
    FileNotFoundError
        If there is no such file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import pyvista as pv
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "sphere.ply"
    >>> write_mesh(path, pv.Sphere(theta_resolution=8, phi_resolution=8))
    >>> read_mesh(path).n_points
    50
    >>> _ = path.with_suffix(".xyz").write_text("not a mesh")
    >>> read_mesh(path.with_suffix(".xyz"))
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...sphere.xyz: unsupported mesh format '.xyz': expected one of .obj, ...
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise FileFormatError(path, None, f"unsupported mesh format {suffix or '(no extension)'!r}: expected one of "
                              f"{', '.join(MESH_SUFFIXES)}")  # fmt: skip
    if suffix == ".obj":
        return read_obj(path)
    if suffix == ".ply":
        return read_ply(path)
    mesh = _pyvista_read(path)
    if "RGB" not in mesh.point_data and "RGBA" in mesh.point_data:
        rgba = np.asarray(mesh.point_data["RGBA"])
        if rgba.ndim == 2 and rgba.shape[1] == 4:
            mesh.point_data["RGB"] = np.ascontiguousarray(rgba[:, :3])
            mesh.point_data.active_scalars_name = "RGB"
    return mesh


def _ply_texture(mesh: pv.DataSet) -> np.ndarray | None:
    """The colours PyVista's PLY writer should store (it only writes them when asked)."""
    for name in ("RGBA", "RGB"):
        if name in mesh.point_data:
            colors = np.asarray(mesh.point_data[name])
            if colors.dtype != np.uint8:
                scale = 255.0 if colors.max(initial=0) <= 1.0 else 1.0
                colors = np.clip(np.rint(colors * scale), 0, 255).astype(np.uint8)
            return colors
    return None


def write_mesh(path: str | os.PathLike[str], mesh: pv.DataSet) -> None:
    """Write a mesh, choosing the writer by extension, atomically (temporary file, then rename).

    ``.obj`` goes through :func:`~ffd_notebook.io.write_obj`; everything else through
    ``mesh.save``. PLY files get the ``"RGBA"`` or ``"RGB"`` point data as vertex colours
    (PyVista's PLY writer only writes colours passed as ``texture``).

    Parameters
    ----------
    path : str or path-like
        Destination; an existing file is replaced only once the new one is complete.
    mesh : pyvista.DataSet
        The mesh.

    Raises
    ------
    ValueError
        If PyVista has no writer for the extension (the old file is then untouched).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np, pyvista as pv
    >>> mesh = pv.Sphere(theta_resolution=8, phi_resolution=8)
    >>> mesh.point_data["RGB"] = np.full((mesh.n_points, 3), (200, 30, 10), dtype=np.uint8)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "red.ply"
    >>> write_mesh(path, mesh)
    >>> read_mesh(path).point_data["RGB"][0].tolist()
    [200, 30, 10]
    """
    path = Path(path)
    if path.suffix.lower() == ".obj":
        write_obj(path, mesh)
        return
    if not isinstance(mesh, pv.DataSet):
        raise TypeError(f"expected a PyVista mesh, got {type(mesh).__name__}")
    kwargs = {}
    if path.suffix.lower() == ".ply":
        kwargs["texture"] = _ply_texture(mesh)
    with atomic_path(path) as tmp:
        mesh.save(tmp, **kwargs)
