"""Cutting a solid-textured organ open with a plane, deformed or not.

:class:`TexturedOrgan` holds a tetrahedral organ model, its densely textured outer surface and
the solid texture. :meth:`TexturedOrgan.cut` returns the two meshes to draw for a cutting plane:
the outer surface with the part in front of the plane removed, and the cut face (the plane's
section through the tetrahedra), whose colours are sampled from the texture at the *rest*
positions that the section interpolates from the tetrahedra's point data ``"rest"``. Deforming
the organ (:meth:`TexturedOrgan.deform`) only moves points, so the texture follows the tissue.

:class:`CutViewer` puts it in a PyVista plotter with a plane widget; dragging the plane recuts
in place (the actors are never re-created).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ..solidtex.sampling import SolidTexture
from .organ import REST, organ_surface, rest_points, texture_surface

__all__ = ["CutViewer", "TexturedOrgan"]


def _unit(normal: ArrayLike) -> NDArray[np.float64]:
    n = np.asarray(normal, dtype=np.float64).reshape(3)
    length = float(np.linalg.norm(n))
    if not length > 0:
        raise ValueError("the plane normal must not be zero")
    return n / length


class TexturedOrgan:
    """A tetrahedral organ with a solid texture, ready to be deformed and cut.

    Parameters
    ----------
    grid : pyvista.UnstructuredGrid
        Linear tetrahedra with point data ``"rest"`` (see :func:`tetrahedralize`).
    texture : SolidTexture
        Placed in the rest frame (e.g. ``SolidTexture.fit(volume, grid.bounds)``).
    subdivisions : int or "auto"
        Linear subdivisions of the outer surface before sampling (:func:`texture_surface`).
    face_subdivisions : int
        Linear subdivisions of the cut face before sampling (its triangles are as large as the
        tetrahedra; two subdivisions give ~16 samples per triangle).

    Examples
    --------
    >>> from ffd_notebook.view.organ import tetrahedralize
    >>> grid = tetrahedralize(pv.Sphere(theta_resolution=12, phi_resolution=12), method="delaunay")
    >>> tex = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3)).astype(np.uint8), grid.bounds)
    >>> organ = TexturedOrgan(grid, tex, subdivisions=1)
    >>> outside, face = organ.cut(origin=(0, 0, 0), normal=(1, 0, 0))
    >>> face.n_points > 0, bool(outside.points[:, 0].max() <= 1e-6), face.point_data["RGB"].dtype.name
    (True, True, 'uint8')
    """

    def __init__(
        self,
        grid: pv.UnstructuredGrid,
        texture: SolidTexture,
        subdivisions: int | str = "auto",
        face_subdivisions: int = 2,
    ) -> None:
        if REST not in grid.point_data:
            grid = grid.copy()
            grid.point_data[REST] = np.asarray(grid.points, dtype=np.float64)
        self.grid = grid
        self.texture = texture
        self.face_subdivisions = int(face_subdivisions)
        self.surface = texture_surface(organ_surface(grid), texture, subdivisions)
        self._triangles = self.surface.regular_faces

    def deform(self, transform: Callable[[NDArray[np.float64]], ArrayLike] | None) -> None:
        """Move the organ to ``transform(rest)`` (e.g. ``FFD(lattice).deform``); ``None`` restores it.

        The outer surface's points are deformed individually (it is denser than the tetrahedra),
        so a smooth deformation stays smooth on screen.
        """
        for mesh in (self.grid, self.surface):
            rest = rest_points(mesh)
            mesh.points = rest.copy() if transform is None else np.asarray(transform(rest), dtype=np.float64)

    def cut_face(self, origin: ArrayLike, normal: ArrayLike) -> pv.PolyData:
        """The section of the tetrahedra by the plane, coloured from the texture at rest positions."""
        face = self.grid.slice(normal=_unit(normal), origin=np.asarray(origin, float), generate_triangles=True)
        if face.n_points == 0:
            return _empty_coloured()
        if self.face_subdivisions:
            face = face.subdivide(self.face_subdivisions, subfilter="linear")
        face.point_data["RGB"] = self.texture.sample(face.point_data[REST])
        face.point_data.active_scalars_name = "RGB"
        return face

    def clipped_surface(self, origin: ArrayLike, normal: ArrayLike) -> pv.PolyData:
        """The outer surface behind the plane (the side ``normal`` points away from).

        Triangles wholly behind the plane are kept as they are (a NumPy selection); only the few
        that cross it go through VTK's clipper, which keeps a cut of a dense surface fast.
        """
        n = _unit(normal)
        points = np.asarray(self.surface.points)
        rgb = np.asarray(self.surface.point_data["RGB"])
        behind = (points - np.asarray(origin, float)) @ n <= 0
        tri = self._triangles
        inside = behind[tri]
        whole = inside.all(axis=1)
        crossing = tri[inside.any(axis=1) & ~whole]
        # keep only the points the whole triangles use (a mask and a cumulative sum: no sorting)
        used = np.zeros(len(points), dtype=bool)
        used[tri[whole]] = True
        new_index = np.cumsum(used) - 1
        n_kept = int(used.sum())
        pieces_pts, pieces_tri, pieces_rgb = [points[used]], [new_index[tri[whole]]], [rgb[used]]
        if len(crossing):
            ids, local = np.unique(crossing, return_inverse=True)
            part = pv.PolyData.from_regular_faces(points[ids], local.reshape(-1, 3))
            part.point_data["RGB"] = rgb[ids]
            part.point_data["side"] = (points[ids] - np.asarray(origin, float)) @ n
            kept = part.clip_scalar(scalars="side", value=0.0, invert=True).triangulate()
            if kept.n_cells:
                pieces_tri.append(kept.regular_faces + n_kept)
                pieces_pts.append(np.asarray(kept.points))
                pieces_rgb.append(np.asarray(kept.point_data["RGB"]))
        out = pv.PolyData.from_regular_faces(np.vstack(pieces_pts), np.vstack(pieces_tri))
        out.point_data["RGB"] = np.vstack(pieces_rgb)
        out.point_data.active_scalars_name = "RGB"
        return out

    def cut(self, origin: ArrayLike, normal: ArrayLike) -> tuple[pv.PolyData, pv.PolyData]:
        """``(outer surface behind the plane, cut face)`` for a plane through ``origin``."""
        return self.clipped_surface(origin, normal), self.cut_face(origin, normal)


def _empty_coloured() -> pv.PolyData:
    empty = pv.PolyData()
    empty.point_data["RGB"] = np.zeros((0, 3), np.uint8)
    return empty


class CutViewer:
    """A PyVista plotter showing a textured organ cut by a draggable plane.

    Parameters
    ----------
    organ : TexturedOrgan
        What to show.
    plotter : pyvista.Plotter, optional
        Draw into this plotter (a new one if omitted: off-screen on headless machines).
    origin, normal : array_like, optional
        Initial plane (default: through the organ's centre, normal along x).
    interaction_event : str
        When the widget calls back: ``"always"`` recuts while dragging, ``"end"`` on release.
    window_size : (int, int)
        Size of a new plotter.
    off_screen : bool, optional
        For a new plotter; off-screen by default, as the notebook backends (trame, static) and
        headless machines want it.

    Attributes
    ----------
    outside, face : pyvista.PolyData
        The meshes on screen; :meth:`update` replaces their contents in place.
    """

    def __init__(
        self,
        organ: TexturedOrgan,
        plotter: pv.Plotter | None = None,
        origin: ArrayLike | None = None,
        normal: ArrayLike = (1.0, 0.0, 0.0),
        interaction_event: str = "always",
        window_size: tuple[int, int] = (600, 400),
        off_screen: bool | None = None,
    ) -> None:
        self.organ = organ
        self.plotter = (
            plotter
            if plotter is not None
            else pv.Plotter(off_screen=True if off_screen is None else off_screen, window_size=window_size)
        )
        self.origin = np.asarray(organ.grid.center if origin is None else origin, dtype=np.float64)
        self.normal = _unit(normal)
        self.outside, self.face = organ.cut(self.origin, self.normal)
        opts = {"scalars": "RGB", "rgb": True, "show_scalar_bar": False}
        # no smooth_shading: PyVista would draw a copy with normals, and in-place updates would not
        # reach the screen; the display surface is dense enough to look smooth with flat shading
        self.plotter.add_mesh(self.outside, name="organ-outside", **opts)
        # a cut is flat: unlit, it shows the texture's own colours whichever way it faces
        self.plotter.add_mesh(self.face, name="organ-cut", lighting=False, **opts)
        self.widget = self.plotter.add_plane_widget(
            self._on_plane,
            normal=self.normal,
            origin=self.origin,
            bounds=organ.grid.bounds,
            interaction_event=interaction_event,
            outline_translation=False,
        )

    def _on_plane(self, normal, origin) -> None:
        try:
            self.update(origin, normal)
        except Exception as exc:  # PyVista turns callback errors into warnings: say what failed
            import warnings

            warnings.warn(f"cutting plane update failed: {exc!r}", RuntimeWarning, stacklevel=2)

    def update(self, origin: ArrayLike | None = None, normal: ArrayLike | None = None) -> None:
        """Recut with a new plane (or the same plane after :meth:`TexturedOrgan.deform`)."""
        if origin is not None:
            self.origin = np.asarray(origin, dtype=np.float64)
        if normal is not None:
            self.normal = _unit(normal)
        outside, face = self.organ.cut(self.origin, self.normal)
        self.outside.copy_from(outside, deep=False)
        self.face.copy_from(face, deep=False)
        self.plotter.render()

    def look_at_cut(self, distance: float = 1.5, elevation: float = 0.35) -> None:
        """Put the camera in front of the cut face (on the side that was cut away)."""
        size = float(np.linalg.norm(np.ptp(np.asarray(self.organ.grid.bounds).reshape(3, 2), axis=1)))
        up = np.array([0.0, 0.0, 1.0]) if abs(self.normal[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
        direction = self.normal + elevation * up
        eye = self.origin + distance * size * direction / np.linalg.norm(direction)
        self.plotter.camera_position = [tuple(eye), tuple(self.origin), tuple(up)]
        self.plotter.render()

    def show(self, **kwargs):
        """Show the plotter (in a notebook: the interactive trame view, or a picture when static)."""
        return self.plotter.show(**kwargs)
