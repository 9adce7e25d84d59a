"""Images and label maps in batch augmentation: warped with the mesh, kept together, replayable, on Dask.

The direction convention (``ffd_notebook.batch.sample``): the images are resampled through the
sample's transform ``T`` (ITK's pull-back) and the mesh is moved by ``T^-1``. The outside check:
a surface extracted from the warped label map (marching cubes) lies on the sample's mesh.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
import SimpleITK as sitk
from distributed import Client
from skimage.measure import marching_cubes

from ffd_notebook import FFD, load_ffd
from ffd_notebook.batch import RandomGP, RandomLattice, generate, local_cluster, read_manifest, replay
from ffd_notebook.errors import FileFormatError
from ffd_notebook.images import ImageGrid, read_image, write_image
from ffd_notebook.io import read_mesh

ROOT = Path(__file__).resolve().parents[2]
RADII = np.array([30.0, 22.0, 16.0])
CENTRE = np.array([12.0, -7.0, 40.0])
SPACING = (1.0, 1.2, 0.9)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> dict[str, Path]:
    """An ellipsoid mesh, its label map and a CT-like image of it, on an anisotropic grid away from the origin."""
    folder = tmp_path_factory.mktemp("scene")
    mesh = pv.ParametricEllipsoid(*RADII, u_res=80, v_res=80, w_res=80).clean().triangulate()
    mesh.points = mesh.points + CENTRE
    mesh.save(folder / "ellipsoid.vtp")
    size = tuple(int(s) for s in np.ceil(2 * (RADII + 12.0) / SPACING))
    grid = ImageGrid(size, SPACING, origin=CENTRE - RADII - 12.0)
    points = grid.physical_points()
    inside = (((points - CENTRE) / RADII) ** 2).sum(axis=1).reshape(grid.shape) < 1.0
    labels = inside.astype(np.uint8) * 5
    ct = np.where(inside, 60.0, -100.0) + 30.0 * np.sin(points[:, 0] / 7.0).reshape(grid.shape)
    write_image(folder / "labels.nii.gz", grid.to_sitk(sitk.GetImageFromArray(labels)))
    write_image(folder / "ct.nrrd", grid.to_sitk(sitk.GetImageFromArray(ct.astype(np.float32))))
    return {"mesh": folder / "ellipsoid.vtp", "labels": folder / "labels.nii.gz", "ct": folder / "ct.nrrd"}


def surface_of(label_map: sitk.Image, value: int) -> np.ndarray:
    """Physical points of the marching-cubes surface of one label."""
    grid = ImageGrid.of(label_map)
    volume = (sitk.GetArrayFromImage(label_map) == value).astype(np.float32)
    verts = marching_cubes(volume, level=0.5)[0]  # array order (k, j, i)
    index = np.column_stack([verts[:, ::-1], np.ones(len(verts))])
    return (index @ grid.index_to_physical().T)[:, :3]


def mean_distance(points: np.ndarray, mesh: pv.PolyData) -> float:
    return float(np.abs(pv.PolyData(points).compute_implicit_distance(mesh)["implicit_distance"]).mean())


MODEL = RandomLattice(num_control_points=6, max_displacement=9.0, locked_borders=1)


def test_warped_label_surface_lies_on_the_warped_mesh(tmp_path, scene):
    result = generate(scene["mesh"], MODEL, 3, tmp_path, image=scene["ct"], label_image=scene["labels"],
                      scheduler="sync", progress=False)  # fmt: skip
    voxel = min(SPACING)
    original = read_mesh(scene["mesh"])
    assert mean_distance(surface_of(read_image(scene["labels"]), 5), original) < 0.5 * voxel  # discretisation
    for row in result.rows:
        i = row["id"]
        assert row["image_file"] == f"meshes/image_{i:06d}.nrrd" and row["label_file"] == f"meshes/label_{i:06d}.nii.gz"
        labels = read_image(tmp_path / row["label_file"])
        assert ImageGrid.of(labels) == ImageGrid.of(read_image(scene["labels"]))
        assert set(np.unique(sitk.GetArrayViewFromImage(labels)).tolist()) == {0, 5}
        mesh = read_mesh(tmp_path / row["mesh_file"])
        surface = surface_of(labels, 5)
        assert mean_distance(surface, mesh) < voxel, f"sample {i}: the label map and the mesh drifted apart"
        # the other direction (mesh moved by T, as a run without images does) misses by several voxels
        forward = original.copy()
        forward.points = FFD(load_ffd(tmp_path / row["parameters_file"])).deform(original.points)
        assert mean_distance(surface, forward) > 1.5 * voxel
        image = sitk.GetArrayViewFromImage(read_image(tmp_path / row["image_file"]))
        assert image.dtype == np.float32 and image.max() > 60.0
    manifest = read_manifest(tmp_path)
    assert manifest["label_file"].tolist() == [f"meshes/label_{i:06d}.nii.gz" for i in range(3)]


def test_replay_rebuilds_images_and_mesh(tmp_path, scene):
    generate(scene["mesh"], MODEL, 2, tmp_path, image=scene["ct"], label_image=scene["labels"],
             image_interpolation="bspline", scheduler="sync", progress=False)  # fmt: skip
    for kind, ext in (("image", "nrrd"), ("label", "nii.gz")):
        written = sitk.GetArrayFromImage(read_image(tmp_path / "meshes" / f"{kind}_000001.{ext}"))
        np.testing.assert_array_equal(sitk.GetArrayFromImage(replay(tmp_path, 1, part=kind)), written)
    again = replay(tmp_path, 1)
    np.testing.assert_allclose(again.points, read_mesh(tmp_path / "meshes" / "sample_000001.ply").points, atol=1e-4)
    with pytest.raises(ValueError, match="part must be"):
        replay(tmp_path, 1, part="dose")
    # a resumed run with other images is refused; with the same ones it skips what is done
    with pytest.raises(ValueError, match="other settings"):
        generate(scene["mesh"], MODEL, 3, tmp_path, image=scene["ct"], scheduler="sync", progress=False)
    more = generate(scene["mesh"], MODEL, 3, tmp_path, image=scene["ct"], label_image=scene["labels"],
                    image_interpolation="bspline", scheduler="sync", progress=False)  # fmt: skip
    assert more.skipped == [0, 1] and more.made == [2]
    # a missing image file means the sample is not done: it is made again
    (tmp_path / "meshes" / "label_000002.nii.gz").unlink()
    redo = generate(scene["mesh"], MODEL, 3, tmp_path, image=scene["ct"], label_image=scene["labels"],
                    image_interpolation="bspline", scheduler="sync", progress=False)  # fmt: skip
    assert redo.made == [2]


def test_gp_model_with_a_label_map(tmp_path, scene):
    """A GP sample has no lattice: the image is warped point by point and the mesh inverted by differences."""
    model = RandomGP(kernel="gaussian", sigma=25.0, scale=2.5, rank=10, n_inducing=60)
    result = generate(scene["mesh"], model, 1, tmp_path, label_image=scene["labels"], scheduler="sync",
                      progress=False)  # fmt: skip
    row = result.rows[0]
    surface = surface_of(read_image(tmp_path / row["label_file"]), 5)
    assert mean_distance(surface, read_mesh(tmp_path / row["mesh_file"])) < min(SPACING)


def test_bad_image_fails_before_any_work(tmp_path, scene):
    bad = tmp_path / "bad.nii"
    bad.write_bytes(b"\0" * 400)
    with pytest.raises(FileFormatError, match=r"bad\.nii"):
        generate(scene["mesh"], MODEL, 2, tmp_path / "out", image=bad, scheduler="sync", progress=False)
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="image_interpolation"):
        generate(scene["mesh"], MODEL, 2, tmp_path / "out", image=scene["ct"], image_interpolation="cubic")


def test_command_line_and_cluster_write_the_same_files(tmp_path, scene):
    cli = [sys.executable, "-m", "ffd_notebook", "batch", str(scene["mesh"]), "--n", "2", "--out",
           str(tmp_path / "cli"), "--num-control-points", "6", "--max-displacement", "9", "--locked-borders", "1",
           "--image", str(scene["ct"]), "--label-image", str(scene["labels"]), "--scheduler", "sync",
           "--no-progress"]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(cli, capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    with local_cluster(2, dashboard_address=None) as cluster, Client(cluster) as client:
        generate(scene["mesh"], MODEL, 2, tmp_path / "dask", image=scene["ct"], label_image=scene["labels"],
                 client=client, progress=False)  # fmt: skip
    assert _files(tmp_path / "cli") == _files(tmp_path / "dask")
