"""The deformation as an animation: a GIF or MP4 of a mesh going from rest to a deformation, or through saved states.

:func:`animate` (``ffd_notebook.animate``) and :meth:`Editor.animate <ffd_notebook.view.editor.editor.Editor.animate>`
draw the frames in an editor scene of their own (off-screen, the editor's look: the mesh with its colours or a
field, the lattice's lines and spheres), so a frame is what the editor would show and the editor itself is not
touched while it records. Between rest and the first deformation a frame shows ``rest + t * (deformed - rest)``
(the editor's blend: :meth:`~.session.EditingSession.set_blend`); between two saved states, which must share
their lattice and options (only the offsets differ: states of one editing session), the offsets in between,
which is the same linear path of every point. The camera stays where it is given (by default it frames every
state) or orbits around the mesh's centre.

Frames go through PyVista's own movie writing (:meth:`pyvista.Plotter.open_gif`, :meth:`~pyvista.Plotter.open_movie`:
imageio, with the ffmpeg that the ``imageio-ffmpeg`` wheel ships for MP4), into a temporary file in the target's
folder renamed over it at the end: a failed recording leaves any earlier file as it was. :class:`Recording`
writes one frame per step, so a front-end shows a progress bar and keeps answering between frames.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._util.paths import StrPath
from ...ffd.basis import BasisName
from ...ffd.deform import FFD
from ...io._atomic import atomic_path
from ..rendering.camera import frame_camera
from .meshes import PYVISTA_MESH_IO, surface_of
from .scene.scene import FRONT, EditorScene
from .session.lattices import copy_ffd
from .session.session import EditingSession

__all__ = ["ANIMATION_SUFFIXES", "MOVIE_SUFFIXES", "Recording", "animate", "frame_poses"]

#: movie files written by ffmpeg (imageio-ffmpeg)
MOVIE_SUFFIXES = (".mp4", ".mov", ".mkv", ".avi", ".webm")
#: what :func:`animate` writes, by the path's extension
ANIMATION_SUFFIXES = (".gif", *MOVIE_SUFFIXES)


def frame_poses(frames: int, states: int) -> list[tuple[int, float]]:
    """Where each of ``frames`` frames is on the way from rest through ``states`` states: ``(segment, u)``.

    Segment 0 goes from rest to the first state, segment ``k`` from state ``k - 1`` to state ``k`` (0-based); ``u`` in
    [0, 1] is how far along. The first frame is at rest, the last at the last state, the others evenly between.

    Examples
    --------
    >>> frame_poses(3, 1)
    [(0, 0.0), (0, 0.5), (0, 1.0)]
    >>> frame_poses(5, 2)
    [(0, 0.0), (0, 0.5), (1, 0.0), (1, 0.5), (1, 1.0)]
    """
    if frames < 2:
        raise ValueError(f"an animation needs at least 2 frames, got {frames}")
    poses = []
    for f in range(frames):
        s = f * states / (frames - 1)
        segment = min(int(s), states - 1)
        poses.append((segment, 1.0 if f == frames - 1 else s - segment))
    return poses


def _states(deformations: Any) -> list[FFD]:
    """The FFDs to go through (one FFD or a sequence), checked: those after the first only differ in offsets."""
    states = [deformations] if isinstance(deformations, FFD) else list(deformations)
    if not states or not all(isinstance(s, FFD) for s in states):
        raise TypeError("animate takes an FFD or a sequence of FFDs (the states to go through)")
    first = states[0]
    for state in states[1:]:
        a, b = first.lattice, state.lattice
        same = (a.shape == b.shape and np.array_equal(a.spacing, b.spacing) and np.array_equal(a.origin, b.origin)
                and np.array_equal(a.rotation, b.rotation) and first.basis == state.basis
                and first.border == state.border and np.array_equal(first.affine, state.affine)
                and first.strength == state.strength and first.only_inside == state.only_inside
                and first.outside == state.outside)  # fmt: skip
        if not same:
            raise ValueError("the states of an animation must share their lattice and options (only the offsets "
                             "may differ, as in one editing session): make one animation per lattice")  # fmt: skip
    return [copy_ffd(s) for s in states]


def _camera(plotter: Any, camera: Any) -> None:
    """Put ``camera`` (a :class:`pyvista.Camera`, or ``(position, focal point, view up)``) on the plotter."""
    if hasattr(camera, "position") and hasattr(camera, "focal_point"):
        plotter.camera.position, plotter.camera.focal_point = camera.position, camera.focal_point
        plotter.camera.up = camera.up
        plotter.camera.view_angle = camera.view_angle
        plotter.camera.parallel_projection = camera.parallel_projection
        plotter.camera.parallel_scale = camera.parallel_scale
        plotter.camera.clipping_range = camera.clipping_range
    else:
        plotter.camera_position = camera


class Recording:
    """An animation being written, one frame per step (:func:`animate` runs it to the end).

    Parameters are those of :func:`animate`; ``points_shown`` is the editor's choice of control points drawn.

    Examples
    --------
    >>> import os, tempfile
    >>> import pyvista as pv
    >>> from ffd_notebook import FFD, Lattice
    >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
    >>> lattice = Lattice.around(sphere, (4, 4, 4), border="clamp")
    >>> lattice.offsets[3, 3, 3] = (0.0, 0.0, 0.5)
    >>> recording = Recording(sphere, FFD(lattice), frames=3, window_size=(64, 48))
    >>> path = os.path.join(tempfile.mkdtemp(), "bulge.gif")
    >>> list(recording.write(path))
    [1, 2, 3]
    >>> os.path.exists(path)
    True
    """

    def __init__(
        self,
        mesh: Any,
        deformations: FFD | Sequence[FFD],
        *,
        frames: int = 24,
        fps: float = 12.0,
        orbit: float | bool = False,
        lattice: bool = True,
        window_size: tuple[int, int] = (640, 480),
        camera: Any = None,
        field: str | None = None,
        colors: bool = True,
        points_shown: str = "auto",
    ) -> None:
        self.states = _states(deformations)
        self.poses = frame_poses(int(frames), len(self.states))
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.fps = float(fps)
        self.orbit = 360.0 if orbit is True else float(orbit or 0.0)
        surface = surface_of(mesh)
        first = self.states[0]
        basis: BasisName = "bernstein" if first.basis == "bernstein" else "bspline"  # (its own options below)
        self.session = EditingSession(surface, mesh_io=PYVISTA_MESH_IO, lattice=first.lattice.copy(), basis=basis)
        self.session.swap_ffd(copy_ffd(first), label="animation", source="given")
        self.session.set_field(field)
        self.session.colors_shown = bool(colors)
        self.session.points_shown = points_shown
        self.session.messages.clear()
        width, height = (int(v) // 2 * 2 for v in window_size)  # even: the yuv420p pixels of movies need it
        self.scene = EditorScene(self.session, on_start=_ignore, on_move=_ignore, on_end=_ignore,
                                 window_size=(width, height), off_screen=True, interactive_cells=None)  # fmt: skip
        self.scene.auto_render = False  # one render a frame, when it is written
        if not lattice:
            assert self.scene.lattice_actor is not None  # built with the scene
            self.scene.lattice_actor.set_visible(False)
        if camera is not None:
            _camera(self.scene.plotter, camera)
        else:  # every state in the picture
            shown = [self.session.rest_points, self.session.control_points()]
            for state in self.states:
                shown += [
                    state.deform(self.session.rest_points),
                    state.lattice.control_points(deformed=True).reshape(-1, 3),
                ]
            frame_camera(self.scene.plotter, np.vstack(shown), direction=FRONT, up=(0.0, 1.0, 0.0))

    def __len__(self) -> int:
        return len(self.poses)

    def pose(self, index: int) -> None:
        """Show frame ``index`` (mesh, lattice, field) in the recording's scene."""
        segment, u = self.poses[index]
        session = self.session
        if segment == 0:
            offsets = self.states[0].lattice.offsets
            if not np.array_equal(session.lattice.offsets, offsets):
                session.lattice.offsets[...] = offsets
                session.update()
            session.set_blend(u)
            return
        a, b = self.states[segment - 1].lattice.offsets, self.states[segment].lattice.offsets
        session.lattice.offsets[...] = b if u == 1.0 else a + u * (b - a)
        session.update()

    def frame(self, index: int) -> NDArray[np.uint8]:
        """Frame ``index`` as an ``(height, width, 3)`` image (the camera as it is for that frame)."""
        self.pose(index)
        return self.scene.screenshot()

    def write(self, path: StrPath, progress: Callable[[int, int], None] | None = None) -> Iterator[int]:
        """Write the animation to ``path`` (``.gif``, or a movie: :data:`MOVIE_SUFFIXES`), a frame per step: yields
        the number of frames written so far. The file appears, whole, when the last frame is written."""
        target = Path(path)
        suffix = target.suffix.lower()
        if suffix not in ANIMATION_SUFFIXES:
            raise ValueError(f"{os.fspath(path)!r}: an animation is one of {', '.join(ANIMATION_SUFFIXES)}")
        plotter = self.scene.plotter
        with atomic_path(target) as temporary:  # (the package's atomic writes: same folder, fsync, rename)
            written = False
            try:
                if suffix == ".gif":  # (Pillow gives each frame its palette: 50-120 ms a 640x480 frame, as a render)
                    plotter.open_gif(temporary, loop=0, fps=self.fps)
                else:  # even sizes for the yuv420p pixels players read; no resizing to blocks of 16
                    plotter.open_movie(temporary, framerate=self.fps, quality=7, macro_block_size=2)
                step = self.orbit / len(self) if self.orbit else 0.0
                for index in range(len(self)):
                    plotter.mwriter.append_data(self.frame(index))
                    if step:
                        plotter.camera.Azimuth(step)
                    if progress is not None:
                        progress(index + 1, len(self))
                    yield index + 1
                plotter.mwriter.close()
                written = True
            finally:
                if not written and plotter.mwriter is not None:
                    try:  # (a GIF writer writes its frames when closed: close it before the file goes)
                        plotter.mwriter.close()
                    except Exception:
                        pass
                plotter.mwriter = None  # closed: the plotter must not close it again
                # open_gif registered the temporary file for sphinx-gallery's PyVista scraper (which moves a plotter's
                # GIF into the gallery): the file written, or none
                plotter._gif_filename = None
        if suffix == ".gif":
            plotter._gif_filename = target.resolve()

    def run(self, path: StrPath, progress: Callable[[int, int], None] | None = None) -> Path:
        """Write every frame to ``path`` (see :meth:`write`), then release the plotter; returns the path."""
        try:
            for _ in self.write(path, progress):
                pass
        finally:
            self.close()
        return Path(path)

    def close(self) -> None:
        """Release the recording's plotter."""
        self.scene.close()
        self.session.close()


def _ignore(*_: Any) -> None:
    """The recording's scene is never dragged."""


def animate(
    mesh: Any,
    deformations: FFD | Sequence[FFD],
    path: StrPath,
    *,
    frames: int = 24,
    fps: float = 12.0,
    orbit: float | bool = False,
    lattice: bool = True,
    window_size: tuple[int, int] = (640, 480),
    camera: Any = None,
    field: str | None = None,
    colors: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Write a GIF or MP4 of ``mesh`` going from rest to a deformation, or through saved states.

    Parameters
    ----------
    mesh : pyvista.DataSet or path
        The rest mesh (its surface), or a mesh file.
    deformations : FFD or sequence of FFD
        Where it goes: one FFD (from rest to it), or states to go through in turn (from rest to the first, then
        on to each next one). States after the first must share its lattice and options: only the offsets differ.
    path : str or path-like
        ``.gif``, or a movie (``.mp4``, ``.mov``, ``.mkv``, ``.avi``, ``.webm``); written whole or not at all.
    frames : int, default 24
        Frames in all, the first at rest and the last at the last state.
    fps : float, default 12
        Frames a second.
    orbit : float or bool, default False
        Turn the camera around the mesh by this many degrees over the animation (True: a whole turn).
    lattice : bool, default True
        Draw the lattice (its lines and control points, moving with the frames).
    window_size : tuple of int, default (640, 480)
        The frames' size in pixels (width, height), made even (movies need it).
    camera : pyvista.Camera or tuple, optional
        Where the camera is (``plotter.camera`` or a ``camera_position``); by default it frames every state.
    field : {None, "displacement", "jacobian"}, optional
        Colour the mesh by how far each point moved, or where the deformation folds (as the editor does).
    colors : bool, default True
        Show the mesh's own per-vertex colours (when no field is shown).
    progress : callable, optional
        ``progress(done, total)`` after each frame.

    Returns
    -------
    pathlib.Path
        The file written.

    Examples
    --------
    >>> import os, tempfile
    >>> import imageio.v3 as iio
    >>> import pyvista as pv
    >>> import ffd_notebook as fn
    >>> sphere = pv.Sphere(theta_resolution=12, phi_resolution=12)
    >>> lattice = fn.Lattice.around(sphere, (4, 4, 4), border="clamp")
    >>> lattice.offsets[3, 3, 3] = (0.0, 0.0, 0.5)
    >>> path = fn.animate(sphere, fn.FFD(lattice), os.path.join(tempfile.mkdtemp(), "bulge.gif"), frames=6,
    ...                   window_size=(80, 60))
    >>> iio.imread(path).shape  # frames, height, width, RGB
    (6, 60, 80, 3)
    """
    recording = Recording(mesh, deformations, frames=frames, fps=fps, orbit=orbit, lattice=lattice,
                          window_size=window_size, camera=camera, field=field, colors=colors)  # fmt: skip
    return recording.run(path, progress)
