"""A lighter copy of the mesh, drawn instead of it while a mouse button is held (level of detail).

With Mesa's software renderer, drawing the 53k-vertex face's 106k triangles is most of a frame at
any window size (17-28 ms of a bare 400x300 render against 4 ms for an 11k-triangle copy), and a
drag frame also recomputes the mesh's normals (6 ms) and uploads its points and normals again. The
browser view already renders at half size while a button is held (:mod:`..remote_view`); at that
size a triangle of the full mesh covers about a pixel, and a copy with about
:data:`INTERACTIVE_CELLS` triangles looks the same. ParaView and the VTK ``vtkLODActor`` do the same
while the user interacts; the choice here is by state (a button is held), not by a render-time
estimate, so frames are reproducible.

The copy's vertices are a subset of the mesh's (``vtkQuadricClustering`` with ``UseInputPoints``:
each cell of a grid keeps one of its own vertices), so the copy's deformed points, colours and field
values are the mesh's at those vertices: gathered before each render while interacting, never
computed. When the button is released the next render draws the full mesh (the sharp frame).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import NDArray

__all__ = ["INTERACTIVE_CELLS", "InteractiveProxy", "point_normals", "simplified"]

#: triangles of the copy drawn while a button is held (meshes with fewer than twice as many have none);
#: on the 53k face at a 400x300 drag frame, 10k differ from the full mesh by a mean 0.6 grey levels (20k: 0.4)
#: and render in ~9 ms against ~12 (full: 28)
INTERACTIVE_CELLS = 10_000

# triangles of a clustered surface per (surface area / bin edge^2): measured 2.4-2.5 on the face scan and
# PyVista's bunny; only the first guess of the bin size (a second pass corrects it)
_CELLS_PER_BIN_AREA = 2.5
_ID_ARRAY = "ffd_proxy_ids"


def point_normals(mesh: pv.PolyData) -> Any:
    """A ``vtkPolyDataNormals`` filter computing ``mesh``'s point normals, already run.

    The mesh's own faces say which way they face: no consistency reordering (PyVista's
    ``smooth_shading`` does that, 7x slower, again at every frame after a drag).

    Examples
    --------
    >>> normals = point_normals(pv.Sphere())
    >>> normals.GetOutput().GetPointData().GetNormals().GetNumberOfTuples() == pv.Sphere().n_points
    True
    """
    from vtkmodules.vtkFiltersCore import vtkPolyDataNormals

    normals = vtkPolyDataNormals()
    normals.SetInputData(mesh)
    normals.ComputePointNormalsOn()
    normals.ComputeCellNormalsOff()
    normals.SplittingOff()
    normals.ConsistencyOff()
    normals.AutoOrientNormalsOff()
    normals.Update()
    return normals


def _cluster(mesh: pv.PolyData, divisions: NDArray[np.int64]) -> pv.PolyData:
    from vtkmodules.vtkFiltersCore import vtkQuadricClustering

    clustering = vtkQuadricClustering()
    clustering.SetInputData(mesh)
    clustering.AutoAdjustNumberOfDivisionsOff()
    clustering.SetNumberOfDivisions(*(int(d) for d in divisions))
    clustering.UseInputPointsOn()  # each bin keeps one of its input vertices (with its point data)
    clustering.CopyCellDataOff()
    clustering.Update()
    return pv.wrap(clustering.GetOutput())


def simplified(mesh: pv.PolyData, cells: int | None = INTERACTIVE_CELLS) -> tuple[NDArray[np.int64], Any] | None:
    """Vertex ids and faces of a copy of ``mesh`` with about ``cells`` triangles, or None.

    None if ``cells`` is None or the mesh has fewer than twice as many cells (drawing it is
    cheap enough). The copy's vertices are ``mesh.points[ids]``; ``faces`` index them (a PyVista
    faces array). Bins are cubes whose edge is chosen from the surface area; a second pass
    corrects the edge if the first result has over 1.5x the wanted triangles.

    Examples
    --------
    >>> sphere = pv.Sphere(theta_resolution=400, phi_resolution=400)
    >>> ids, faces = simplified(sphere, cells=2000)
    >>> proxy = pv.PolyData(sphere.points[ids], faces=faces)
    >>> 1000 < proxy.n_cells <= 3000, bool(np.isin(proxy.points, sphere.points).all())
    (True, True)
    >>> simplified(pv.Sphere(), cells=2000) is None  # 1680 triangles: drawn as they are
    True
    """
    if cells is None or mesh.n_cells < 2 * cells or mesh.n_points == 0:
        return None
    work = pv.PolyData(mesh.points, faces=mesh.faces)
    if work.n_cells == 0:
        return None
    work.point_data[_ID_ARRAY] = np.arange(mesh.n_points, dtype=np.int64)
    extent = np.ptp(np.asarray(work.points, dtype=np.float64), axis=0)
    edge = np.sqrt(_CELLS_PER_BIN_AREA * work.area / cells)
    for _ in range(3):
        out = _cluster(work, np.maximum(1, np.ceil(extent / edge)).astype(np.int64))
        if out.n_cells <= 1.5 * cells:
            break
        edge *= np.sqrt(out.n_cells / cells)
    if out.n_cells == 0 or out.n_cells > 0.75 * work.n_cells:
        return None
    return np.asarray(out.point_data[_ID_ARRAY], dtype=np.int64), out.faces.copy()


class InteractiveProxy:
    """The copy of a plotted mesh shown instead of it while :attr:`interacting`.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Gets the copy's actor (hidden until a render while interacting).
    display : pyvista.PolyData
        The plotted mesh; its points and point arrays are copied from at each render while interacting.
    actor : vtkActor
        The plotted mesh's actor: the copy shares its property and mirrors its mapper's colouring.
    geometry : tuple
        ``(ids, faces)`` from :func:`simplified`.

    Examples
    --------
    >>> pl = pv.Plotter(off_screen=True, window_size=(64, 48))
    >>> mesh = pv.Sphere(theta_resolution=200, phi_resolution=200)
    >>> actor = pl.add_mesh(mesh)
    >>> proxy = InteractiveProxy(pl, mesh, actor, simplified(mesh, cells=2000))
    >>> proxy.interacting = True
    >>> mesh.points[:] *= 2.0
    >>> mesh.GetPoints().Modified()
    >>> pl.render_window.Render()
    >>> bool(proxy.actor.GetVisibility()), bool(actor.GetVisibility())
    (True, False)
    >>> np.allclose(proxy.mesh.points, mesh.points[proxy.ids])
    True
    >>> proxy.interacting = False
    >>> pl.render_window.Render()
    >>> bool(proxy.actor.GetVisibility()), bool(actor.GetVisibility())
    (False, True)
    >>> proxy.remove()
    >>> pl.close()
    """

    def __init__(self, plotter: pv.Plotter, display: pv.PolyData, actor: Any, geometry: tuple[Any, Any]) -> None:
        self.plotter, self.display, self.full = plotter, display, actor
        self.ids, faces = geometry
        self.mesh = pv.PolyData(np.asarray(display.points)[self.ids], faces=faces)
        self.normals = point_normals(self.mesh)
        self.actor = plotter.add_mesh(self.normals, pickable=False, reset_camera=False, render=False)
        self.actor.SetProperty(actor.GetProperty())
        self.actor.VisibilityOff()
        self._interacting = False
        self._swapped = False  # the copy stands in for the full mesh (since a render while interacting)
        self._full_visible = True
        self._stamps: dict[str, int] = {"points": display.GetPoints().GetMTime()}
        self._mapper_stamp = -1
        self._tag = plotter.renderer.AddObserver("StartEvent", lambda *_: self.before_render())

    @property
    def interacting(self) -> bool:
        """Whether renders draw the copy in the full mesh's place (from the next render on; off at once)."""
        return self._interacting

    @interacting.setter
    def interacting(self, value: bool) -> None:
        self._interacting = bool(value)
        if not self._interacting and self._swapped:
            self._swapped = False
            self.actor.VisibilityOff()
            self.full.SetVisibility(self._full_visible)

    def before_render(self) -> None:
        """Show the copy, brought up to date, while interacting.

        The full mesh's own visibility (set from code) is kept: the copy only ever shows in its place.
        """
        if not self._interacting:
            return
        if not self._swapped:
            self._swapped = True
            self._full_visible = bool(self.full.GetVisibility())
            self.full.VisibilityOff()
        self._copy_data()
        self._copy_coloring()
        self.actor.SetVisibility(self._full_visible)

    def _copy_data(self) -> None:
        """The plotted mesh's points and point arrays at the copy's vertices, where they changed."""
        points = self.display.GetPoints()
        if points.GetMTime() != self._stamps["points"]:
            self._stamps["points"] = points.GetMTime()
            self.mesh.points[:] = np.asarray(self.display.points)[self.ids]
            self.mesh.GetPoints().Modified()
        source = self.display.GetPointData()
        names = set(self.display.point_data.keys())
        for name in names:
            stamp = source.GetAbstractArray(name).GetMTime()
            if self._stamps.get(name) != stamp:
                self._stamps[name] = stamp
                self.mesh.point_data[name] = np.asarray(self.display.point_data[name])[self.ids]
        for name in set(self.mesh.point_data.keys()) - names:
            self.mesh.point_data.remove(name)
            self._stamps.pop(name, None)

    def _copy_coloring(self) -> None:
        """The full mapper's colouring (array, colour mode, lookup table, range), when it changed."""
        full = self.full.GetMapper()
        if full.GetMTime() == self._mapper_stamp:
            return
        self._mapper_stamp = full.GetMTime()
        mapper = self.actor.GetMapper()
        source = mapper.GetInputConnection(0, 0)
        mapper.ShallowCopy(full)
        mapper.SetInputConnection(source)

    def remove(self) -> None:
        """Take the copy out of the plotter (the full mesh shown again)."""
        self.plotter.renderer.RemoveObserver(self._tag)
        self.plotter.remove_actor(self.actor, reset_camera=False, render=False)
        if self._swapped:
            self.full.SetVisibility(self._full_visible)
