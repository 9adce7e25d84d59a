"""Pictures for the README, made from the package itself (offline, headless): PNGs, and a GIF of a lesson.

Run from the repository root::

    python docs/make_images.py

Each picture has its own function taking the output path; :func:`main` writes them all into
``docs/images/``. Writes are atomic (a temporary file in the same folder, then ``os.replace``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

IMAGES = Path(__file__).resolve().parent / "images"


def _save_png(pixels: np.ndarray, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".png", dir=path.parent)
    os.close(fd)
    try:
        Image.fromarray(pixels).save(tmp, format="png", optimize=True)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def solid_texture_image(path: str | Path, window_size: tuple[int, int] = (900, 400)) -> Path:
    """The frog liver with a synthesised solid texture, cut open: the cut face shows the interior.

    The texture is the organ's default, :class:`~ffd_notebook.solidtex.LazySolidTexture` at 256 voxels along the
    liver's box (synthesised voxel by voxel where the surface and the cut sample it), from the exemplar that
    :func:`~ffd_notebook.solidtex.exemplar_from_image` optimises from scikit-image's bundled
    immunohistochemistry image (a gland cut across: cells and nuclei), as in
    ``notebooks/05_solid_texture_liver.ipynb``.
    """
    import pyvista as pv
    import skimage.data

    import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
    from ffd_notebook.datasets import frog_liver
    from ffd_notebook.meshing.organ import tetrahedralize
    from ffd_notebook.solidtex import LazySolidTexture, exemplar_from_image
    from ffd_notebook.view import frame_camera, view_direction
    from ffd_notebook.view.solidtex import TexturedOrgan, add_cut

    exemplar = exemplar_from_image(skimage.data.immunohistochemistry()[340:404, 290:354], rng=0)
    grid = tetrahedralize(frog_liver(2500))
    organ = TexturedOrgan(grid, LazySolidTexture.fit(exemplar, grid.bounds, resolution=256, rng=0))

    normal = np.array([0.3, 1.0, 0.0])
    pl = pv.Plotter(off_screen=True, window_size=window_size)
    outside, face = add_cut(pl, organ, grid.center, normal)
    frame_camera(pl, np.vstack([outside.points, face.points]), view_direction(normal), margin=1.03)
    pixels = pl.screenshot(return_img=True)
    pl.close()
    _save_png(pixels, Path(path))
    return Path(path)


def editor_image(path: str | Path, window_size: tuple[int, int] = (900, 560)) -> Path:
    """The editor on its bundled sample face (its own colours): top layers sheared from code, one point dragged out."""
    import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
    from ffd_notebook.view.editor import Editor

    editor = Editor(off_screen=True, window_size=window_size)
    spacing = editor.lattice.spacing
    editor.lattice.offsets[:, 3:, :] += (0.6 * spacing[0], 0.0, 0.0)  # shear the top (+y is up), from code
    editor.update()
    editor.session.move_control_point((1, 2, 2), (-1.0 * spacing[0], 0.0, 0.0))  # as a drag or the panel would
    editor.session.select((1, 2, 2))
    pixels = editor.screenshot()
    editor.close()
    _save_png(pixels, Path(path))
    return Path(path)


def lesson_gif(path: str | Path, window_size: tuple[int, int] = (480, 330)) -> Path:
    """A lesson as an animation (issue 33): the bundled face's chin pulled out and two rows of control points
    pinched through each other, growing from rest while the camera turns a little (``editor.animate``)."""
    import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
    from ffd_notebook.view.editor import Editor

    editor = Editor(shape=(4, 5, 4), off_screen=True, window_size=window_size)
    s = editor.lattice.spacing
    offsets = editor.lattice.offsets
    offsets[0, 1, 3] = (-0.8 * s[0], 0.0, 0.3 * s[2])
    offsets[3, 1, 3] = (0.8 * s[0], 0.0, 0.3 * s[2])
    offsets[1:3, 2, 2:] += (0.0, 0.8 * s[1], 0.0)
    offsets[1:3, 3, 2:] -= (0.0, 0.8 * s[1], 0.0)
    editor.update()
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    editor.animate(target, frames=12, fps=6, orbit=30.0)  # written atomically
    editor.close()
    return target


def gp_image(path: str | Path, window_size: tuple[int, int] = (900, 320)) -> Path:
    """Random smooth deformation fields of Gaussian processes: the kernel width sets smoothness."""
    import pyvista as pv

    import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
    from ffd_notebook.gp import GaussianKernel, GaussianProcess, grid_points

    points = grid_points([-1, 1, -1, 1, -1, 1], 6)
    pl = pv.Plotter(off_screen=True, shape=(1, 3), window_size=window_size, border=False)
    for col, sigma in enumerate((0.5, 1.0, 2.0)):
        field = GaussianProcess(GaussianKernel(sigma=sigma, scale=0.25)).sample(points, 1, rng=3)[0]
        cloud = pv.PolyData(points)
        cloud["u"] = field
        cloud["|u|"] = np.linalg.norm(field, axis=1)
        pl.subplot(0, col)
        pl.add_mesh(
            cloud.glyph(orient="u", scale="|u|", factor=0.8), scalars="|u|", cmap="plasma", show_scalar_bar=False
        )
        pl.add_mesh(pv.Box((-1, 1, -1, 1, -1, 1)).outline(), color="grey")
        pl.add_text(f"sigma = {sigma}", font_size=11, color="black")
        pl.view_isometric()
        pl.camera.zoom(1.25)
    pl.set_background("white")
    pixels = pl.screenshot(return_img=True)
    pl.close()
    _save_png(pixels, Path(path))
    return Path(path)


def face_image(path: str | Path) -> Path:
    """A coloured 3D face from scikit-image's ``astronaut()`` photo: the landmarks over the photo, the mesh from
    the front and turned, and a smile pulled by two control points in the editor (as notebook 07 does)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pyvista as pv
    from skimage import data

    import ffd_notebook.view  # noqa: F401  (headless settings before any plotter)
    from ffd_notebook.face import face_from_photo, face_landmarks, face_triangles
    from ffd_notebook.view.editor import Editor

    photo = data.astronaut()
    marks, mesh = face_landmarks(photo), face_from_photo(photo)

    def render(azimuth: float) -> np.ndarray:
        pl = pv.Plotter(off_screen=True, window_size=(400, 440))
        pl.add_mesh(mesh, scalars="RGB", rgb=True)
        pl.view_xy()
        pl.camera.azimuth = azimuth
        pixels = pl.screenshot(return_img=True)
        pl.close()
        return pixels

    editor = Editor(mesh, shape=(7, 7, 5), window_size=(400, 440))
    rest = editor.lattice.control_points()
    for corner, outwards in ((61, -1.0), (291, 1.0)):  # the corners of the mouth, up and out
        near = mesh.points[corner]
        distance = np.linalg.norm(rest[..., :2] - near[:2], axis=-1) + 1e3 * (rest[..., 2] < near[2] - 5)
        editor.session.move_control_point(np.unravel_index(np.argmin(distance), editor.lattice.shape),
                                          (6.0 * outwards, 14.0, 0.0))  # fmt: skip
    editor.plotter.view_xy()
    smile = editor.screenshot()
    editor.close()

    fig, axes = plt.subplots(1, 4, figsize=(13, 3.9))
    axes[0].imshow(photo)
    axes[0].triplot(marks.points[:, 0] - 0.5, marks.points[:, 1] - 0.5, face_triangles(), lw=0.3, color="yellow")
    axes[0].set_xlim(150, 300)
    axes[0].set_ylim(195, 50)
    for ax, picture in zip(axes[1:], (render(0.0), render(-40.0), smile), strict=True):
        ax.imshow(picture[20:-20])
    titles = ("photo and 468 landmarks", f"coloured mesh ({mesh.n_points:,} vertices)", "turned",
              "a smile pulled by two control points")  # fmt: skip
    for ax, title in zip(axes, titles, strict=True):
        ax.set_title(title, fontsize=11)
        ax.axis("off")
    fig.subplots_adjust(left=0.01, right=0.99, top=0.9, bottom=0.01, wspace=0.05)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=80)
    plt.close(fig)
    _save_png(np.asarray(Image.open(buffer).convert("RGB")), Path(path))
    return Path(path)


def main() -> None:
    """Write every README picture into ``docs/images/``."""
    for made in (
        editor_image(IMAGES / "editor.png"),
        gp_image(IMAGES / "gp_fields.png"),
        solid_texture_image(IMAGES / "solid_texture.png"),
        face_image(IMAGES / "face_from_photo.png"),
        lesson_gif(IMAGES / "lesson.gif"),
    ):
        print(f"{made}: {made.stat().st_size / 1024:.0f} KB")


if __name__ == "__main__":
    main()
