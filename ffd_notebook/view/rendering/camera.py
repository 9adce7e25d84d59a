"""Camera placement for static figures: face a direction, fit the meshes tightly.

PyVista's ``reset_camera`` fits a bounding *sphere* around everything in the renderer (widgets'
boxes included), which leaves an elongated organ small in the frame. :func:`frame_camera` checks
every point against the perspective frustum of the active renderer instead.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

__all__ = ["frame_camera", "unit_vector", "view_direction"]


def unit_vector(vector: ArrayLike, what: str = "the direction") -> NDArray[np.float64]:
    """``vector`` scaled to length 1; a ValueError naming ``what`` if it is zero.

    Examples
    --------
    >>> unit_vector([0, 3, 4]).tolist()
    [0.0, 0.6, 0.8]
    """
    v = np.asarray(vector, dtype=np.float64).reshape(3)
    length = float(np.linalg.norm(v))
    if not length > 0:
        raise ValueError(f"{what} must not be zero")
    return v / length


def view_direction(normal: ArrayLike, elevation: float = 0.4) -> NDArray[np.float64]:
    """Where to look at a face from: along its normal, raised a little so the object's depth shows.

    For a cut, ``normal`` points to the side the cut removed, where the camera goes; it is raised
    by ``elevation`` times the world's up (z, or y for a nearly horizontal face).

    Parameters
    ----------
    normal : array_like
        The face's outward normal (3 values, any non-zero length).
    elevation : float, default 0.4
        How far to raise the direction towards the world's up, relative to the normal's unit length.

    Returns
    -------
    numpy.ndarray
        The unit direction from the face towards the camera, shape ``(3,)``.

    Examples
    --------
    >>> view_direction((0, 1, 0), elevation=0.0).tolist()
    [0.0, 1.0, 0.0]
    >>> bool(view_direction((1, 0, 0))[2] > 0)
    True
    """
    n = unit_vector(normal)
    up = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    return unit_vector(n + elevation * up)


def _renderer_aspect(plotter: pv.Plotter) -> float:
    x0, y0, x1, y1 = plotter.renderer.GetViewport()
    width, height = plotter.window_size
    return (x1 - x0) * width / max((y1 - y0) * height, 1e-9)


def frame_camera(
    plotter: pv.Plotter,
    points: ArrayLike,
    direction: ArrayLike,
    up: ArrayLike | None = None,
    margin: float = 1.04,
    top: float = 0.0,
) -> NDArray[np.float64]:
    """Look along ``-direction`` at ``points`` from as close as they all stay in the picture.

    Every point is checked against the perspective frustum of the active renderer (with its own
    aspect ratio, so subplots work); the camera moves back just far enough.

    Parameters
    ----------
    plotter : pyvista.Plotter
        Its active renderer's camera is set.
    points : array_like
        ``(N, 3)`` points to fit (e.g. the meshes on screen).
    direction : array_like
        From the points towards the camera (e.g. :func:`view_direction`).
    up : array_like, optional
        Screen-up direction. By default the points' narrower side across the view, pointing to the
        world's +z (or +y), so an elongated organ lies along the frame's long side.
    margin : float
        Blank border, as a factor on the picture's half-size.
    top : float
        Fraction of the picture's height kept free at the top (for a title).

    Returns
    -------
    numpy.ndarray
        The up vector used (pass it to other panels to keep them oriented alike).

    Examples
    --------
    >>> pl = pv.Plotter(off_screen=True, window_size=(400, 200))
    >>> up = frame_camera(pl, pv.Box().points * (2, 1, 1), direction=(0, 0, 1))
    >>> pl.camera_position.focal_point, up.round(6).tolist()
    ((0.0, 0.0, 0.0), [0.0, 1.0, 0.0])
    >>> _ = frame_camera(pl, pv.Box().points, direction=(0, 0, 1), top=0.2)   # room for a title
    >>> round(pl.camera_position.focal_point[1], 3) > 0   # looks above the box: it sits lower
    True
    >>> pl.close()
    """
    if not 0.0 <= top < 1.0:
        raise ValueError(f"top is a fraction of the picture's height in [0, 1), got {top}")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    d = unit_vector(direction)
    if up is None:
        q = pts - pts.mean(axis=0)
        q -= np.outer(q @ d, d)
        _, vectors = np.linalg.eigh(q.T @ q)  # ascending: ~d, the narrow side, the long side
        up = vectors[:, 1]
        world_up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
        if up @ world_up < 0:
            up = -up
    u = np.asarray(up, dtype=np.float64) - (np.asarray(up, dtype=np.float64) @ d) * d
    u = unit_vector(u)
    right = np.cross(u, d)
    x, y, z = pts @ right, pts @ u, pts @ d
    focal = (x.max() + x.min()) / 2 * right + (y.max() + y.min()) / 2 * u + (z.max() + z.min()) / 2 * d
    rel = pts - focal
    tan_v = np.tan(np.radians(plotter.camera.view_angle) / 2)
    tan_h = tan_v * _renderer_aspect(plotter)
    depth = rel @ d
    # a point at depth z (towards the camera) and across-distance s is in view if D - z >= s / tan.
    # Keeping a band of height `top` free: the view axis moves up by s0 = top * tan_v * D, and the
    # points must fit the lower band (half-height tan_v * (1 - top)); then the condition becomes
    # |y - top * tan_v * z| <= tan_v * (1 - top) * (D - z), exactly, for every depth.
    band = tan_v * (1.0 - top)
    vertical = np.abs(rel @ u - top * tan_v * depth) / band
    distance = float(np.max(depth + margin * np.maximum(np.abs(rel @ right) / tan_h, vertical)))
    focal = focal + top * tan_v * distance * u
    plotter.camera_position = [tuple(focal + distance * d), tuple(focal), tuple(u)]
    plotter.renderer.ResetCameraClippingRange()
    return u
