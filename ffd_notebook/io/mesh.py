"""Read and write meshes of any format: OBJ through :mod:`.obj`, the rest through PyVista."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pyvista as pv

from ..errors import FileFormatError
from ._atomic import atomic_path
from .obj import read_obj, write_obj

__all__ = ["read_mesh", "write_mesh"]


def _pyvista_read(path: Path) -> pv.DataSet:
    """``pyvista.read`` with VTK's silent failures (an empty mesh plus a log line) made errors."""
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with pv.vtk_verbosity("off"), pv.VtkErrorCatcher(send_to_logging=False) as catcher:
                mesh = pv.read(path)
    except Exception as exc:  # PyVista raises OSError, ValueError, KeyError... for what it cannot read
        raise FileFormatError(path, None, f"not a mesh file PyVista can read ({type(exc).__name__}: {exc})") from exc
    failures = [str(e) for e in catcher.error_events] + [str(w.message) for w in caught if "error" in str(w.message)]
    if isinstance(mesh, pv.MultiBlock):
        mesh = mesh.combine() if len(mesh) else None
    if not isinstance(mesh, pv.DataSet) or failures or mesh.n_points == 0:
        detail = failures[0].strip().splitlines()[0] if failures else "no points"
        raise FileFormatError(path, None, f"PyVista's reader could not read a mesh from it ({detail})")
    return mesh


def read_mesh(path: str | os.PathLike[str]) -> pv.DataSet:
    """Read a mesh, choosing the reader by extension.

    ``.obj`` goes through :func:`~ffd_notebook.io.read_obj` (vertex order and colours kept);
    everything else through :func:`pyvista.read` (PLY, STL, VTK/VTP/VTU, ...). Colours stay point
    data: a PLY with RGBA colours gets an ``"RGB"`` array too (the active scalars), like OBJ.

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
    ffd_notebook.errors.FileFormatError: ...sphere.xyz: not a mesh file PyVista can read (...)
    """
    path = Path(path)
    if path.suffix.lower() == ".obj":
        return read_obj(path)
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
