"""The session's image in the scene: three orthogonal slice planes whose pixels follow the drags.

Each slice is a :class:`pyvista.StructuredGrid` through the slice's voxel centres (at rest: the
image is resampled onto its own grid, ITK's convention), coloured by the warped values: a grey
image through a lookup table spanning the window (level +- width / 2), a colour image directly.
Just before each render (an observer of the render window's start), the session's slices are
brought up to date and only the pixels re-read since the last frame
(:meth:`~..session.image.SessionImage.take_unshown`) are copied into the plotted arrays, in place:
a drag's mouse events between two frames cost one update. No actor is created or removed while
dragging.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyvista as pv

__all__ = ["VALUES", "ImageSlices"]

VALUES = "image"  # the point-data array of a slice plane


class ImageSlices:
    """The slice actors of one :class:`~..session.image.SessionImage`.

    Parameters
    ----------
    plotter : pyvista.Plotter
    image : SessionImage
        The session's image (loaded).
    """

    def __init__(self, plotter: pv.Plotter, image: Any) -> None:
        self.plotter = plotter
        self.image = image
        self.planes: dict[int, pv.StructuredGrid] = {}
        self.actors: dict[int, Any] = {}
        slices = image.slices
        for axis in slices.axes:
            self._add(axis)
        image.take_unshown()  # the planes were made from the current values
        window = plotter.render_window
        self._observer = window.AddObserver("StartEvent", lambda *_: self.update()) if window is not None else None

    def _add(self, axis: int) -> None:
        slices = self.image.slices
        rows, cols = slices.values[axis].shape[:2]
        plane = pv.StructuredGrid()
        plane.points = slices.slice_points(axis)  # C order over (rows, cols): VTK's first index is the column
        plane.dimensions = (cols, rows, 1)
        plane.point_data[VALUES] = self._flat(axis)
        self.planes[axis] = plane
        grey = self.image.window is not None
        kwargs: dict[str, Any] = {"cmap": "gray", "clim": self._clim()} if grey else {"rgb": True}
        self.actors[axis] = self.plotter.add_mesh(plane, scalars=VALUES, show_scalar_bar=False, lighting=False,
                                                  reset_camera=False, render=False, **kwargs)  # fmt: skip

    def _flat(self, axis: int) -> np.ndarray:
        values = self.image.slices.values[axis]
        flat = values.reshape(values.shape[0] * values.shape[1], *values.shape[2:])
        return flat.astype(np.float32) if self.image.window is not None else flat.astype(np.uint8)

    def _clim(self) -> tuple[float, float]:
        level, width = self.image.window
        return level - width / 2.0, level + width / 2.0

    def update(self, rebuild: bool = False) -> None:
        """Copy the pixels re-read since the last update into the planes; move the planes if the slices moved."""
        slices = self.image.slices
        unshown = self.image.take_unshown()
        for axis in slices.axes:
            plane = self.planes[axis]
            if rebuild:
                plane.points[:] = slices.slice_points(axis)
                plane.GetPoints().Modified()
            region = unshown.get(axis)
            if region is None or not region.any():
                continue
            shown = plane.point_data[VALUES]  # a view of the VTK array
            values = slices.values[axis]
            if region.all():
                shown[...] = self._flat(axis)
            else:
                where = np.flatnonzero(region.ravel())
                shown[where] = values.reshape(-1, *values.shape[2:])[where]
            plane.point_data.GetArray(VALUES).Modified()
        if self.image.window is not None:
            for actor in self.actors.values():
                actor.mapper.scalar_range = self._clim()

    def shown_values(self, axis: int) -> np.ndarray:
        """The plotted values of a slice (what the renderer draws), in the slice array's shape."""
        values = self.image.slices.values[axis]
        return np.asarray(self.planes[axis].point_data[VALUES]).reshape(values.shape)

    def remove(self) -> None:
        """Remove the slice actors and stop following renders."""
        if self._observer is not None and self.plotter.render_window is not None:
            self.plotter.render_window.RemoveObserver(self._observer)
        self._observer = None
        for actor in self.actors.values():
            self.plotter.remove_actor(actor, reset_camera=False, render=False)
        self.actors.clear()
        self.planes.clear()
