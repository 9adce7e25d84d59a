"""Cutting a solid-textured organ open with a plane, deformed or not.

:class:`TexturedOrgan` holds a tetrahedral organ model, its densely textured outer surface and
the solid texture. :meth:`TexturedOrgan.cut` returns the two meshes to draw for a cutting plane:
the outer surface with the part in front of the plane removed, and the cut face (the plane's
section through the tetrahedra), whose colours are sampled from the texture at the *rest*
positions that the section interpolates from the tetrahedra's point data ``"rest"``. Deforming
the organ (:meth:`TexturedOrgan.deform`) only moves points, so the texture follows the tissue.

:func:`add_cut` draws one cut (or the intact organ) into a plotter or subplot, for static figures
(with :func:`~ffd_notebook.view.rendering.camera.frame_camera` to face the cut and fill the frame).
:class:`CutViewer` puts it in a PyVista plotter with a plane widget; dragging the plane recuts in
place (the actors are never re-created).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray
from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

from ...meshing.organ import REST, auto_subdivisions, organ_surface, rest_points, texture_surface
from ...solidtex.sampling import SolidTexture, TextureSampler  # noqa: F401  (SolidTexture: the doctests)
from ..rendering.camera import frame_camera, unit_vector, view_direction
from ..rendering.plotters import new_plotter
from ..serving.jupyter import forget_shown, keep_while_shown, release_views, show_changes, show_plotter
from ..serving.lifetime import Lifetime, weak_method

__all__ = ["CutViewer", "TexturedOrgan", "add_cut"]

#: colour of the line drawn around a cut face (dark liver brown: reads as an incision edge)
RIM_COLOUR = "#3d1a0c"


def _unit(normal: ArrayLike) -> NDArray[np.float64]:
    return unit_vector(normal, "the plane normal")


class TexturedOrgan:
    """A tetrahedral organ with a solid texture, ready to be deformed and cut.

    Parameters
    ----------
    grid : pyvista.UnstructuredGrid
        Linear tetrahedra with point data ``"rest"`` (see :func:`tetrahedralize`).
    texture : SolidTexture or LazySolidTexture
        Placed in the rest frame (e.g. ``LazySolidTexture.fit(exemplar, grid.bounds)``, the organ's
        default, or ``SolidTexture.fit(volume, grid.bounds)``). A
        :class:`~ffd_notebook.solidtex.LazySolidTexture` synthesises only the voxels that the surface
        and each cut face sample (with what they depend on), and keeps them for the next cut.
    subdivisions : int or "auto"
        Linear subdivisions of the outer surface before sampling (:func:`texture_surface`).
    face_subdivisions : int or "auto"
        Linear subdivisions of the cut face before sampling (its triangles are as large as the
        tetrahedra). ``"auto"`` (the default): chosen per cut, enough for a sample every two texture
        voxels along the long edges (99th percentile, at most 4; :func:`auto_subdivisions`): by the
        mean edge, the section's long thin triangles were sampled too sparsely and their corners'
        colours fanned out as streaks.

    Examples
    --------
    >>> from ffd_notebook.meshing.organ import tetrahedralize
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
        texture: TextureSampler,
        *,
        subdivisions: int | str = "auto",
        face_subdivisions: int | str = "auto",
    ) -> None:
        if REST not in grid.point_data:
            grid = grid.copy()
            grid.point_data[REST] = np.asarray(grid.points, dtype=np.float64)
        self.grid = grid
        self.texture = texture
        self.face_subdivisions = face_subdivisions if face_subdivisions == "auto" else int(face_subdivisions)
        self.surface = texture_surface(organ_surface(grid), texture, subdivisions)
        self._triangles = self.surface.regular_faces

    def deform(self, transform: Callable[[NDArray[np.float64]], ArrayLike] | None) -> None:
        """Move the organ to ``transform(rest)`` (e.g. ``FFD(lattice).deform``); ``None`` restores it.

        The outer surface's points are deformed individually (it is denser than the tetrahedra),
        so a smooth deformation stays smooth on screen.

        Parameters
        ----------
        transform : callable or None
            Maps ``(N, 3)`` rest positions to deformed positions; None puts the organ back at rest.

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> organ.deform(lambda rest: 2.0 * rest)
        >>> round(float(organ.grid.points[:, 0].max()), 3), round(float(organ.surface.points[:, 0].max()), 3)
        (0.985, 0.985)
        >>> organ.deform(None)
        >>> round(float(organ.grid.points[:, 0].max()), 3)
        0.492
        """
        for mesh in (self.grid, self.surface):
            rest = rest_points(mesh)
            mesh.points = rest.copy() if transform is None else np.asarray(transform(rest), dtype=np.float64)

    def cut_face(self, origin: ArrayLike, normal: ArrayLike) -> pv.PolyData:
        """The section of the tetrahedra by the plane, coloured from the texture at rest positions.

        Parameters
        ----------
        origin : array_like
            A point of the plane.
        normal : array_like
            The plane's normal (any non-zero length).

        Returns
        -------
        pyvista.PolyData
            Triangles in the plane with ``uint8`` point data ``"RGB"`` (no points if the plane misses the organ).

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> face = organ.cut_face((0, 0, 0), (1, 0, 0))
        >>> face.n_points > 0, float(abs(face.points[:, 0]).max()), face.point_data["RGB"].dtype.name
        (True, 0.0, 'uint8')
        """
        face = self.grid.slice(normal=_unit(normal), origin=np.asarray(origin, float), generate_triangles=True)
        if face.n_points == 0:
            return _empty_coloured()
        n = (
            auto_subdivisions(face, self.texture, samples_per_voxel=0.5, quantile=0.99)
            if self.face_subdivisions == "auto"
            else int(self.face_subdivisions)
        )
        if n:  # uniform: VTK's adaptive subdivision leaves T-junctions, cracks a rim would draw
            face = face.subdivide(n, subfilter="linear")
        face.point_data["RGB"] = self.texture.sample(face.point_data[REST])
        face.point_data.active_scalars_name = "RGB"
        return face

    def clipped_surface(self, origin: ArrayLike, normal: ArrayLike) -> pv.PolyData:
        """The outer surface behind the plane (the side ``normal`` points away from).

        Triangles wholly behind the plane are kept as they are (a NumPy selection); only the few
        that cross it go through VTK's clipper, which keeps a cut of a dense surface fast.

        Parameters
        ----------
        origin : array_like
            A point of the plane.
        normal : array_like
            The plane's normal, pointing to the side that is cut away.

        Returns
        -------
        pyvista.PolyData
            The kept surface with its ``"RGB"`` colours (no points if the plane is behind the whole organ).

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> kept = organ.clipped_surface((0, 0, 0), (1, 0, 0))
        >>> float(kept.points[:, 0].max()), kept.n_cells < organ.surface.n_cells
        (0.0, True)
        >>> organ.clipped_surface((1, 0, 0), (-1, 0, 0)).n_points
        0
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
        if sum(len(t) for t in pieces_tri) == 0:  # the plane is behind the whole organ
            return _empty_coloured()
        out = pv.PolyData.from_regular_faces(np.vstack(pieces_pts), np.vstack(pieces_tri))
        out.point_data["RGB"] = np.vstack(pieces_rgb)
        out.point_data.active_scalars_name = "RGB"
        return out

    def cut(self, origin: ArrayLike, normal: ArrayLike) -> tuple[pv.PolyData, pv.PolyData]:
        """``(outer surface behind the plane, cut face)`` for a plane through ``origin``.

        Parameters
        ----------
        origin : array_like
            A point of the plane.
        normal : array_like
            The plane's normal, pointing to the side that is cut away.

        Returns
        -------
        outside : pyvista.PolyData
            :meth:`clipped_surface`.
        face : pyvista.PolyData
            :meth:`cut_face`.

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> organ.deform(lambda rest: rest + (0.5, 0.0, 0.0))
        >>> outside, face = organ.cut((0.5, 0, 0), (1, 0, 0))
        >>> float(outside.points[:, 0].max()), bool(abs(face.points[:, 0] - 0.5).max() < 1e-6)
        (0.5, True)
        """
        return self.clipped_surface(origin, normal), self.cut_face(origin, normal)


def _empty_coloured() -> pv.PolyData:
    """A mesh with no points but an (empty) ``"RGB"`` array, so a plane missing the organ still draws."""
    empty = pv.PolyData()
    rgb = vtkUnsignedCharArray()  # PyVista refuses zero-length arrays; VTK's own array is fine
    rgb.SetNumberOfComponents(3)
    rgb.SetName("RGB")
    empty.GetPointData().AddArray(rgb)
    return empty


def _rim(face: pv.PolyData, normal: ArrayLike | None = None) -> pv.PolyData:
    """The boundary of a cut face: where the knife met the organ's surface.

    With ``normal`` (the side cut away, where the camera looks from), the line is lifted off the
    face by a thousandth of its size: drawn in the face's plane, its short segments lost the depth
    test to the face here and there and the rim showed as a broken line.
    """
    if face.n_cells == 0:
        return pv.PolyData()
    rim = face.extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False
    )
    if normal is not None and rim.n_points:
        rim.points = rim.points + 1e-3 * float(np.ptp(face.points, axis=0).max()) * _unit(normal)
    return rim


def add_cut(
    plotter: pv.Plotter,
    organ: TexturedOrgan,
    origin: ArrayLike | None = None,
    normal: ArrayLike | None = None,
    rim: bool = True,
    name: str = "organ",
) -> tuple[pv.PolyData, pv.PolyData]:
    """Draw ``organ`` cut by a plane (or whole, if ``normal`` is None) in the active (sub)plot.

    The outer surface is lit; the cut face is unlit, so it shows the texture's own colours whichever
    way it faces, with a dark rim where it meets the surface. The meshes are new ones: deforming or
    recutting the organ later does not change this picture.

    Parameters
    ----------
    plotter : pyvista.Plotter
    organ : TexturedOrgan
    origin, normal : array_like, optional
        The plane (``origin`` defaults to the organ's centre). The part ``normal`` points to is removed.
    rim : bool
        Draw the cut face's boundary.
    name : str
        Actor names are ``name + "-outside"``, ``"-cut"`` and ``"-rim"``.

    Returns
    -------
    (pyvista.PolyData, pyvista.PolyData)
        The outer surface and the cut face on screen (the face is empty for the whole organ).

    Examples
    --------
    >>> from ffd_notebook.meshing.organ import tetrahedralize
    >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
    >>> texture = SolidTexture.fit(np.full((4, 4, 4, 3), 120, np.uint8), grid.bounds)
    >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
    >>> pl = pv.Plotter(off_screen=True, window_size=(160, 120))
    >>> outside, face = add_cut(pl, organ, normal=(0, 0, 1))
    >>> sorted(pl.actors), face.n_cells > 0
    (['organ-cut', 'organ-outside', 'organ-rim'], True)
    >>> pl.close()
    """
    if normal is None:
        outside, face = organ.surface.copy(), _empty_coloured()
    else:
        origin = organ.grid.center if origin is None else origin
        outside, face = organ.cut(origin, normal)
    opts = {"scalars": "RGB", "rgb": True, "show_scalar_bar": False}
    # no smooth_shading: PyVista would draw a copy with normals, and in-place updates would not
    # reach the screen; the display surface is dense enough to look smooth with flat shading
    plotter.add_mesh(outside, name=f"{name}-outside", **opts)
    if face.n_cells:
        plotter.add_mesh(face, name=f"{name}-cut", lighting=False, **opts)
        if rim:
            plotter.add_mesh(_rim(face, normal), name=f"{name}-rim", color=RIM_COLOUR, line_width=2, lighting=False)
    return outside, face


class CutViewer:
    """A PyVista plotter showing a textured organ cut by a draggable plane.

    The plane widget's box is drawn faint and grey (it marks the reach of the plane, the organ is
    what matters) and the camera faces the cut face with the organ filling the picture
    (:meth:`look_at_cut`).

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
    outside, face, rim : pyvista.PolyData
        The meshes on screen; :meth:`update` replaces their contents in place.
    widget : vtkImplicitPlaneWidget
        The plane widget.

    Examples
    --------
    >>> from ffd_notebook.meshing.organ import tetrahedralize
    >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
    >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
    >>> viewer = CutViewer(TexturedOrgan(grid, texture, subdivisions=0), normal=(0, 1, 0), window_size=(64, 48))
    >>> viewer.face.n_cells > 0, float(viewer.outside.points[:, 1].max()), viewer.plotter.screenshot().shape
    (True, 0.0, (48, 64, 3))
    >>> viewer.close()
    """

    def __init__(
        self,
        organ: TexturedOrgan,
        plotter: pv.Plotter | None = None,
        *,
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
            else new_plotter(off_screen=True if off_screen is None else off_screen, window_size=window_size)
        )
        # released when the viewer is closed or collected: its browser views, and the plotter if it made it
        # (PyVista keeps every plotter until it is closed); the plane widget's callback refers to it weakly
        self.lifetime = Lifetime(self, functools.partial(release_views, self.plotter))
        if plotter is None:
            self.lifetime.add(self.plotter.close)
        self.origin = np.asarray(organ.grid.center if origin is None else origin, dtype=np.float64)
        self.normal = _unit(normal)
        self.outside, self.face = organ.cut(self.origin, self.normal)
        self.rim = _rim(self.face, self.normal)
        opts = {"scalars": "RGB", "rgb": True, "show_scalar_bar": False}
        self.plotter.add_mesh(self.outside, name="organ-outside", **opts)
        self.plotter.add_mesh(self.face, name="organ-cut", lighting=False, **opts)
        self.plotter.add_mesh(self.rim, name="organ-rim", color=RIM_COLOUR, line_width=2, lighting=False)
        self.widget = self.plotter.add_plane_widget(
            weak_method(self._on_plane),
            normal=self.normal,
            origin=self.origin,
            bounds=organ.grid.bounds,
            factor=1.05,
            color="#9a9a9a",
            interaction_event=interaction_event,
            outline_translation=False,
            outline_opacity=0.25,
            test_callback=False,
        )
        self._placed_bounds = tuple(organ.grid.bounds)
        self._style_widget()
        self.look_at_cut()

    def _style_widget(self) -> None:
        w = self.widget
        w.SetScaleEnabled(False)  # a stray drag on the box would resize it, not cut
        w.SetDiagonalRatio(0.15)  # a shorter normal arrow
        edges = w.GetEdgesProperty()  # the plane's trace on the box
        edges.SetColor(0.5, 0.5, 0.5)
        edges.SetOpacity(0.5)
        props = self.plotter.renderer.GetViewProps()
        for i in range(props.GetNumberOfItems()):
            actor = props.GetItemAsObject(i)
            if hasattr(actor, "GetProperty") and actor.GetProperty() is edges:
                actor.GetMapper().ScalarVisibilityOff()  # else VTK colours the trace red from scalars
        w.GetSelectedOutlineProperty().SetOpacity(0.4)

    def _on_plane(self, normal: ArrayLike, origin: ArrayLike) -> None:
        try:
            self.update(origin, normal)
        except Exception as exc:  # PyVista turns callback errors into warnings: say what failed
            import warnings

            warnings.warn(f"cutting plane update failed: {exc!r}", RuntimeWarning, stacklevel=2)

    def _sync_widget(self) -> None:
        """Put the widget on the current plane, around the organ where it is now (after a deformation)."""
        bounds = tuple(self.organ.grid.bounds)
        if bounds != self._placed_bounds:
            self.widget.PlaceWidget(bounds)
            self._placed_bounds = bounds
        if not np.allclose(self.widget.GetOrigin(), self.origin):
            self.widget.SetOrigin(*self.origin)
        if not np.allclose(self.widget.GetNormal(), self.normal):
            self.widget.SetNormal(*self.normal)

    def update(self, origin: ArrayLike | None = None, normal: ArrayLike | None = None) -> None:
        """Recut with a new plane (or the same plane after :meth:`TexturedOrgan.deform`).

        The widget follows a plane set here (it is not re-placed while the user drags it).

        Parameters
        ----------
        origin : array_like, optional
            A new point of the plane; the current one if omitted.
        normal : array_like, optional
            A new normal; the current one if omitted.

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> viewer = CutViewer(organ, window_size=(64, 48))
        >>> viewer.update(origin=(0.2, 0.0, 0.0))
        >>> round(float(viewer.face.points[:, 0].max()), 3), viewer.widget.GetOrigin()
        (0.2, (0.2, 0.0, 0.0))
        >>> viewer.close()
        """
        if origin is not None:
            self.origin = np.asarray(origin, dtype=np.float64)
        if normal is not None:
            self.normal = _unit(normal)
        outside, face = self.organ.cut(self.origin, self.normal)
        self.outside.copy_from(outside, deep=False)
        self.face.copy_from(face, deep=False)
        self.rim.copy_from(_rim(face, self.normal), deep=False)
        self._sync_widget()
        show_changes(self.plotter)

    def look_at_cut(self, elevation: float = 0.4, margin: float = 1.04) -> None:
        """Face the cut (from the side that was cut away), the organ filling the picture.

        The camera looks along :func:`~ffd_notebook.view.rendering.camera.view_direction` and is fitted to
        the organ's meshes with :func:`~ffd_notebook.view.rendering.camera.frame_camera`, not to the
        widget's box.

        Parameters
        ----------
        elevation : float, default 0.4
            How far the view direction is raised above the cut's normal (:func:`view_direction`).
        margin : float, default 1.04
            Room around the organ (1: the meshes touch the picture's border).

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> viewer = CutViewer(organ, window_size=(64, 48))
        >>> viewer.update(normal=(0, 0, 1))
        >>> viewer.look_at_cut(elevation=0.0)
        >>> position = np.asarray(viewer.plotter.camera.position)
        >>> bool(position[2] > 0 and abs(position[:2]).max() < 1e-6)
        True
        >>> viewer.close()
        """
        points = [np.asarray(m.points) for m in (self.outside, self.face) if m.n_cells]
        if not points:  # the plane cuts everything away: frame the whole organ
            points = [np.asarray(self.organ.surface.points)]
        frame_camera(self.plotter, np.vstack(points), view_direction(self.normal, elevation), margin=margin)
        show_changes(self.plotter)

    def show(self, **kwargs: Any) -> Any:
        """Show the viewer: in Jupyter the server-rendered trame view its plane widget needs.

        See :func:`ffd_notebook.view.serving.jupyter.show_plotter`; with the static backend, a picture.

        The picture is of the current cut: PyVista's static backend would otherwise show the
        picture of an earlier ``show``.

        The output showing it keeps the viewer alive until its cell runs again
        (:func:`~ffd_notebook.view.serving.jupyter.keep_while_shown`).

        Parameters
        ----------
        **kwargs
            Passed to ``plotter.show`` outside a kernel (or with a static backend).

        Returns
        -------
        object
            In a kernel, the trame view's widget; elsewhere what ``plotter.show`` returns (None, or the
            picture with ``return_img=True``).

        Examples
        --------
        Outside a kernel, the picture of the current cut:

        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.full((4, 4, 4, 3), 200, np.uint8), grid.bounds)
        >>> viewer = CutViewer(TexturedOrgan(grid, texture, subdivisions=0), window_size=(64, 48))
        >>> image = viewer.show(return_img=True, auto_close=False)
        >>> image.shape, bool(image.std() > 0)
        ((48, 64, 3), True)
        >>> viewer.close()
        """
        self.plotter.last_image = None
        shown = show_plotter(self.plotter, **kwargs)
        keep_while_shown(self)
        return shown

    def close(self) -> None:
        """Close the browser views and the plotter (if the viewer made it).

        A viewer nobody refers to any more (no variable, no output showing it) is closed the same way.

        Examples
        --------
        >>> from ffd_notebook.meshing.organ import tetrahedralize
        >>> grid = tetrahedralize(pv.Sphere(theta_resolution=10, phi_resolution=10), method="delaunay")
        >>> texture = SolidTexture.fit(np.random.default_rng(0).integers(0, 255, (8, 8, 8, 3), np.uint8), grid.bounds)
        >>> organ = TexturedOrgan(grid, texture, subdivisions=0)
        >>> viewer = CutViewer(organ, window_size=(64, 48))
        >>> viewer.close()
        >>> viewer.lifetime.alive
        False
        """
        forget_shown(self)
        self.lifetime.close()
