"""The deformation as an animation: GIF and MP4 files of frames that are what the editor shows.

Small meshes and frames (a sphere, 160x120): the frames are compared with the editor's own screenshots at rest,
at the deformation and at a saved state; files are read back with imageio (GIF through Pillow, MP4 through the
ffmpeg of imageio-ffmpeg). The 53k-face timing is a benchmark (tests/benchmarks/bench_animation.py).
"""

from __future__ import annotations

import imageio.v2 as iio2
import imageio.v3 as iio
import numpy as np
import pytest
import pyvista as pv
from editor_testing import colored_sphere

import ffd_notebook as fn
from ffd_notebook.view.editor import Editor
from ffd_notebook.view.editor.animation import Recording, frame_poses
from ffd_notebook.view.editor.session.lattices import copy_ffd

SIZE = (160, 120)


def close_pictures(a: np.ndarray, b: np.ndarray) -> bool:
    """The same picture up to a GIF's palette: a small mean difference and hardly a pixel far off."""
    diff = np.abs(a.astype(np.int16) - b.astype(np.int16)).max(axis=-1)
    return a.shape == b.shape and diff.mean() < 2.0 and (diff > 40).mean() < 0.002


@pytest.fixture
def editor():
    editor = Editor(colored_sphere(16), shape=(4, 4, 4), window_size=SIZE)
    yield editor
    editor.close()


def deform(editor: Editor, amount: float = 0.6) -> None:
    """An edit from code (no control point selected: the editor's screenshot has no highlighted sphere)."""
    editor.lattice.offsets[3, 3, :] += (0.0, amount, 0.0)
    editor.lattice.offsets[0, 1, 2] = (-amount, 0.0, 0.0)
    editor.update()


def test_the_first_frame_is_the_rest_and_the_last_the_deformation(editor, tmp_path):
    rest = editor.screenshot()
    deform(editor)
    deformed = editor.screenshot()
    path = editor.animate(tmp_path / "lesson.gif", frames=5, fps=10)
    frames = iio.imread(path)
    assert frames.shape == (5, SIZE[1], SIZE[0], 3)
    assert close_pictures(frames[0], rest) and close_pictures(frames[-1], deformed)
    assert not close_pictures(frames[2], rest) and not close_pictures(frames[2], deformed)  # on its way
    assert iio.immeta(path)["duration"] == pytest.approx(100, abs=1)  # ms a frame: 10 frames a second
    assert editor.session.blend == 1.0 and len(editor.session.history) == 1  # the editor was not touched


def test_a_movie_opens_with_imageio_and_orbits(editor, tmp_path):
    deform(editor)
    path = editor.animate(tmp_path / "lesson.mp4", frames=6, fps=8, orbit=True)
    reader = iio2.get_reader(path)
    try:
        assert reader.count_frames() == 6 and reader.get_meta_data()["fps"] == pytest.approx(8)
        frames = [frame for frame in reader]
    finally:
        reader.close()
    assert frames[0].shape == (SIZE[1], SIZE[0], 3)
    still = iio.imread(editor.animate(tmp_path / "still.gif", frames=6))
    # lossy frames: the first is the rest seen from the editor's camera, the last from half a turn... further on
    assert np.abs(frames[0].astype(int) - still[0].astype(int)).mean() < 8
    assert np.abs(frames[-1].astype(int) - still[-1].astype(int)).mean() > 8


def test_through_saved_states(editor, tmp_path):
    """States saved along a lesson: the animation passes through each of them exactly."""
    deform(editor, 0.3)
    first, first_shot = copy_ffd(editor.session.ffd), editor.screenshot()
    deform(editor, 0.5)
    second, last_shot = copy_ffd(editor.session.ffd), editor.screenshot()
    frames = iio.imread(editor.animate(tmp_path / "states.gif", frames=5, states=[first, second]))
    assert frame_poses(5, 2)[2] == (1, 0.0)
    assert close_pictures(frames[2], first_shot) and close_pictures(frames[-1], last_shot)
    other = fn.FFD(fn.Lattice.around(editor.mesh, (5, 4, 4), border="clamp"))
    with pytest.raises(ValueError, match="share their lattice and options"):
        editor.animate(tmp_path / "bad.gif", states=[first, other])


def test_without_the_lattice_and_from_code_without_an_editor(tmp_path):
    sphere = pv.Sphere(theta_resolution=16, phi_resolution=16)
    lattice = fn.Lattice.around(sphere, (4, 4, 4), border="clamp")
    lattice.offsets[3, 3, 3] = (0.0, 0.0, 0.8)
    path = fn.animate(sphere, fn.FFD(lattice), tmp_path / "bare.gif", frames=3, lattice=False, window_size=SIZE)
    bare = iio.imread(path)
    drawn = iio.imread(fn.animate(sphere, fn.FFD(lattice), tmp_path / "drawn.gif", frames=3, window_size=SIZE))
    blue = np.array([65, 105, 225])  # the spheres' colour (royalblue)
    near_blue = lambda frames: (np.abs(frames.astype(int) - blue).max(axis=-1) < 30).sum()  # noqa: E731
    assert near_blue(drawn) > 50 and near_blue(bare) == 0


def test_a_failed_recording_leaves_the_old_file(editor, tmp_path):
    deform(editor)
    path = editor.animate(tmp_path / "lesson.gif", frames=3)
    before = path.read_bytes()

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        editor.animate(path, frames=4, progress=stop)
    assert path.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["lesson.gif"]
    with pytest.raises(ValueError, match=r"an animation is one of \.gif, \.mp4"):
        editor.animate(tmp_path / "lesson.png")
    with pytest.raises(ValueError, match="at least 2 frames"):
        Recording(editor.mesh, editor.session.ffd, frames=1)
