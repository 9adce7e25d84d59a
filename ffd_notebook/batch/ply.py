"""Binary PLY for many copies of one triangle mesh: the header, faces and colours packed once.

Hand-written on purpose: VTK's PLY writer (``write_mesh``) takes ~100-200 ms for the 53k-vertex
face and plyfile ~700 ms (it writes list properties face by face), which made writing the
largest part of a batch sample. Every sample of a run shares the connectivity and colours, so
only the vertex coordinates change: packing them into a prepared NumPy record array is a few
milliseconds. Only triangle meshes with optional RGB/RGBA ``uint8`` colours take this path;
anything else goes through :func:`~ffd_notebook.io.write_mesh`. The files are standard binary
little-endian PLY (read back by VTK, PyVista, plyfile, MeshLab).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..io._atomic import atomic_open

__all__ = ["TrianglePly"]


class TrianglePly:
    """A writer for deformed copies of one triangle mesh (same faces and colours, new points).

    Use :meth:`for_mesh`, which returns ``None`` when the mesh is not a plain triangle mesh.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np, pyvista as pv
    >>> from ffd_notebook.io import read_mesh
    >>> mesh = pv.Sphere(theta_resolution=8, phi_resolution=8)
    >>> mesh.point_data.clear()
    >>> mesh.point_data["RGB"] = np.full((mesh.n_points, 3), (10, 200, 30), dtype=np.uint8)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "moved.ply"
    >>> TrianglePly.for_mesh(mesh).write(path, mesh.points * 2)
    >>> back = read_mesh(path)
    >>> bool(np.array_equal(back.points, mesh.points * 2)), back.point_data["RGB"][0].tolist()
    (True, [10, 200, 30])
    """

    def __init__(self, n_points: int, faces: NDArray[np.int64], colors: NDArray[np.uint8] | None) -> None:
        names = ("red", "green", "blue", "alpha")
        fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
        if colors is not None:
            fields += [(names[c], "u1") for c in range(colors.shape[1])]
        self._vertices = np.zeros(n_points, dtype=fields)
        if colors is not None:
            for c in range(colors.shape[1]):
                self._vertices[names[c]] = colors[:, c]
        face_rows = np.empty(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        face_rows["n"] = 3
        face_rows["i"] = faces
        self._faces = face_rows.tobytes()
        self._fields = fields

    def _header(self, n_points: int) -> bytes:
        props = "".join(f"property {'float' if t == '<f4' else 'uchar'} {name}\n" for name, t in self._fields)
        n_faces = len(self._faces) // 13
        return (
            "ply\nformat binary_little_endian 1.0\ncomment ffd_notebook batch\n"
            f"element vertex {n_points}\n{props}element face {n_faces}\n"
            "property list uchar int vertex_indices\nend_header\n"
        ).encode("ascii")

    @classmethod
    def for_mesh(cls, mesh: Any) -> TrianglePly | None:
        """A writer for ``mesh`` (a PyVista PolyData of triangles), or ``None`` if it is not one."""
        if type(mesh).__name__ != "PolyData" or not mesh.n_cells or mesh.n_verts or mesh.n_lines or mesh.n_strips:
            return None
        if not mesh.is_all_triangles:
            return None
        colors = None
        for name in ("RGBA", "RGB"):
            if name in mesh.point_data:
                colors = np.asarray(mesh.point_data[name])
                break
        if colors is not None and (colors.dtype != np.uint8 or colors.ndim != 2):
            return None
        faces = np.asarray(mesh.faces).reshape(-1, 4)[:, 1:]
        return cls(mesh.n_points, faces, colors)

    def write(self, path: str | os.PathLike[str], points: NDArray[np.float64]) -> None:
        """Write the mesh with new ``(N, 3)`` points (stored as float32), atomically."""
        vertices = self._vertices.copy()
        vertices["x"], vertices["y"], vertices["z"] = np.asarray(points, dtype=np.float32).T
        with atomic_open(path, "wb") as f:
            f.write(self._header(len(vertices)))
            f.write(vertices.tobytes())
            f.write(self._faces)
