"""The session's image in the scene: three orthogonal slice planes whose pixels follow the drags.

Each slice is one textured quadrilateral through the slice's corner voxel centres (at rest: the
image is resampled onto its own grid, ITK's convention). Its texture holds the warped values, a
grey image mapped through the window (level +- width / 2) to 0..255, a colour image as it is: four
vertices per slice, so the planes add next to nothing to a render (a plane of one coloured vertex
per voxel doubled the render time of the 53k-vertex face with a 192^3 image under software
rendering). Just before each render (an observer of the render window's start), the session's
slices are brought up to date and only the pixels re-read since the last frame
(:meth:`~..session.image.SessionImage.take_unshown`) are written into the textures, in place: a
drag's mouse events between two frames cost one update. No actor is created or removed while
dragging.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyvista as pv
from numpy.typing import NDArray

__all__ = ["TEXELS", "ImageSlices", "to_texels"]

TEXELS = "texels"  # the point-data array of a slice's texture image


def to_texels(values: NDArray, window: tuple[float, float] | None) -> NDArray[np.uint8]:
    """What a slice's texture holds for ``values``: grey values through the window to 0..255, colours clipped.

    Examples
    --------
    >>> to_texels(np.array([[-10.0, 0.0, 5.0, 99.0]]), (0.0, 10.0)).tolist()
    [[0, 128, 255, 255]]
    """
    if window is None:
        return np.clip(values, 0, 255).astype(np.uint8)
    level, width = window
    scaled = (np.asarray(values, dtype=np.float32) - np.float32(level - width / 2.0)) * np.float32(255.0 / width)
    return np.clip(np.rint(scaled), 0, 255).astype(np.uint8)


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
        self.planes: dict[int, pv.PolyData] = {}
        self.textures: dict[int, pv.ImageData] = {}
        self.actors: dict[int, Any] = {}
        self._texture_objects: dict[int, pv.Texture] = {}
        self._window = image.window
        slices = image.slices
        for axis in slices.axes:
            self._add(axis)
        image.take_unshown()  # the textures were made from the current values
        window = plotter.render_window
        self._observer = window.AddObserver("StartEvent", lambda *_: self.update()) if window is not None else None

    def _corners(self, axis: int) -> NDArray[np.float64]:
        slices = self.image.slices
        rows, cols = slices.values[axis].shape[:2]
        grid = slices.slice_points(axis).reshape(rows, cols, 3)
        return np.array([grid[0, 0], grid[0, -1], grid[-1, -1], grid[-1, 0]])

    def _add(self, axis: int) -> None:
        values = self.image.slices.values[axis]
        rows, cols = values.shape[:2]
        plane = pv.PolyData(self._corners(axis), faces=[4, 0, 1, 2, 3])
        s0, s1, t0, t1 = 0.5 / cols, 1.0 - 0.5 / cols, 0.5 / rows, 1.0 - 0.5 / rows  # texel centres at the corners
        plane.active_texture_coordinates = np.array([[s0, t0], [s1, t0], [s1, t1], [s0, t1]])
        texels = pv.ImageData(dimensions=(cols, rows, 1))
        texels.point_data[TEXELS] = self._texels(values).reshape(rows * cols, *values.shape[2:])
        texture = pv.Texture(texels)
        texture.interpolate = False
        self.planes[axis], self.textures[axis] = plane, texels
        self.actors[axis] = self.plotter.add_mesh(plane, texture=texture, lighting=False, reset_camera=False,
                                                  render=False)  # fmt: skip
        self._texture_objects[axis] = texture

    def _texels(self, values: NDArray) -> NDArray[np.uint8]:
        return to_texels(values, self.image.window)

    def update(self, rebuild: bool = False) -> None:
        """Write the pixels re-read since the last update into the textures; move the planes if the slices moved."""
        slices = self.image.slices
        unshown = self.image.take_unshown()
        window_changed = self.image.window != self._window
        self._window = self.image.window
        for axis in slices.axes:
            if rebuild:
                self.planes[axis].points[:] = self._corners(axis)
                self.planes[axis].GetPoints().Modified()
            region = unshown.get(axis)
            values = slices.values[axis]
            shown = self.textures[axis].point_data[TEXELS]  # a view of the VTK array
            if window_changed or (region is not None and region.all()):
                shown[...] = self._texels(values).reshape(shown.shape)
            elif region is not None and region.any():
                where = np.flatnonzero(region.ravel())
                shown[where] = self._texels(values.reshape(-1, *values.shape[2:])[where])
            else:
                continue
            self.textures[axis].point_data.GetArray(TEXELS).Modified()
            self._texture_objects[axis].Modified()

    def shown_values(self, axis: int) -> NDArray[np.uint8]:
        """The texels of a slice (what the renderer draws), in the slice array's shape."""
        values = self.image.slices.values[axis]
        return np.asarray(self.textures[axis].point_data[TEXELS]).reshape(values.shape)

    def remove(self) -> None:
        """Remove the slice actors and stop following renders."""
        if self._observer is not None and self.plotter.render_window is not None:
            self.plotter.render_window.RemoveObserver(self._observer)
        self._observer = None
        for actor in self.actors.values():
            self.plotter.remove_actor(actor, reset_camera=False, render=False)
        self.actors.clear()
        self.planes.clear()
        self.textures.clear()
