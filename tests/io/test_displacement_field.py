"""Displacement fields against SimpleITK: written fields are ITK's, loaded fields move points as ITK does."""

from __future__ import annotations

import numpy as np
import pytest
import SimpleITK as sitk

from ffd_notebook import FFD, Lattice
from ffd_notebook.errors import FileFormatError
from ffd_notebook.io import (
    DisplacementField,
    load_deformation,
    load_displacement_field,
    save_deformation,
    save_displacement_field,
)

ROTATED = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
REFERENCE = {"size": (9, 8, 7), "spacing": (1.1, 1.3, 0.9), "origin": (6.0, -1.0, 2.0), "direction": ROTATED.T}


def _ffd(seed: int = 0) -> FFD:
    lat = Lattice((6, 5, 7), (2.0, 3.0, 1.5), origin=(5.0, -3.0, 1.0), rotation=ROTATED)
    lat.offsets[...] = np.random.default_rng(seed).normal(0.0, 0.8, lat.offsets.shape)
    return FFD(lat, affine=np.array([[1.0, 0.1, 0, 0.5], [0, 1.0, 0, 0], [0, 0, 0.9, -1.0], [0, 0, 0, 1]]))


def _sitk_transform(path) -> sitk.Transform:
    return sitk.DisplacementFieldTransform(sitk.ReadImage(str(path), sitk.sitkVectorFloat64))


def _apply(transform: sitk.Transform, points: np.ndarray) -> np.ndarray:
    return np.array([transform.TransformPoint(tuple(float(v) for v in p)) for p in points])


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz", ".nrrd", ".mha"])
def test_written_field_is_the_ffd_at_voxel_centres(tmp_path, suffix):
    ffd = _ffd()
    path = tmp_path / f"warp{suffix}"
    save_displacement_field(path, ffd, REFERENCE)
    image = sitk.ReadImage(str(path))
    assert image.GetPixelID() == sitk.sitkVectorFloat64 and image.GetSize() == REFERENCE["size"]
    field = load_displacement_field(path)
    centres = field.grid_points()  # the file's own voxel centres (NIfTI keeps its geometry in float32)
    assert np.abs(_apply(_sitk_transform(path), centres) - ffd.deform(centres)).max() <= 1e-6
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no staging file left


@pytest.mark.parametrize("suffix", [".nii.gz", ".nrrd"])
def test_loaded_field_moves_points_as_simpleitk_everywhere(tmp_path, suffix):
    path = tmp_path / f"warp{suffix}"
    save_displacement_field(path, _ffd(1), REFERENCE)
    field = load_deformation(path)
    assert isinstance(field, DisplacementField)
    rng = np.random.default_rng(2)
    index = rng.random((4000, 3)) * (np.array(field.size) + 3) - 2  # inside, the half-voxel margin, beyond
    index[:200] = np.round(index[:200])  # exact voxel centres (on the buffer's edges, -0.5 and n - 0.5, rounding
    # decides: ITK and NumPy compute the index differently, so points there are left out, as for elastix #509)
    points = index @ (field.direction * field.spacing).T + field.origin
    reference = _apply(_sitk_transform(path), points)
    assert np.abs(field.deform(points) - reference).max() <= 1e-9
    assert np.abs(reference - points).max() > 0.1


def test_reference_grid_from_an_image_file_or_a_simpleitk_image(tmp_path):
    image = sitk.Image([5, 6, 4], sitk.sitkFloat32)
    image.SetSpacing((0.7, 0.8, 1.9))
    image.SetOrigin((3.0, 4.0, 5.0))
    image.SetDirection(ROTATED.ravel().tolist())
    sitk.WriteImage(image, str(tmp_path / "ref.nrrd"))
    ffd = _ffd(3)
    save_displacement_field(tmp_path / "a.mha", ffd, tmp_path / "ref.nrrd")
    save_displacement_field(tmp_path / "b.mha", ffd, image)
    a, b = load_displacement_field(tmp_path / "a.mha"), load_displacement_field(tmp_path / "b.mha")
    assert a.size == (5, 6, 4) and a.shape == (4, 6, 5) and np.allclose(a.vectors, b.vectors, rtol=0, atol=1e-12)
    assert np.allclose(a.direction, ROTATED) and np.allclose(a.origin, (3.0, 4.0, 5.0))
    save_deformation(tmp_path / "c.nrrd", a)  # a field on its own grid
    assert np.array_equal(load_displacement_field(tmp_path / "c.nrrd").vectors, a.vectors)


def test_bad_fields_are_refused_and_nothing_is_half_written(tmp_path):
    scalar = sitk.Image([4, 4, 4], sitk.sitkFloat32)
    sitk.WriteImage(scalar, str(tmp_path / "scalar.nii"))
    with pytest.raises(FileFormatError, match=r"scalar\.nii: expected a 3D image of 3-vectors"):
        load_deformation(tmp_path / "scalar.nii")
    (tmp_path / "junk.nrrd").write_bytes(b"NRRD0004\ntype: what\n\n")
    with pytest.raises(FileFormatError, match=r"junk\.nrrd: no 'dimension' field"):
        load_deformation(tmp_path / "junk.nrrd")
    save_displacement_field(tmp_path / "ok.nii", _ffd(), REFERENCE)
    before = (tmp_path / "ok.nii").read_bytes()
    with pytest.raises(ValueError, match="size"):
        save_displacement_field(tmp_path / "ok.nii", _ffd(), {"spacing": 1.0})
    with pytest.raises(ValueError, match="needs a voxel grid"):
        save_deformation(tmp_path / "ok.nii", _ffd())
    with pytest.raises(ValueError, match="not a lattice"):
        save_deformation(tmp_path / "x.tfm", load_displacement_field(tmp_path / "ok.nii"))
    assert (tmp_path / "ok.nii").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.nrrd", "ok.nii", "scalar.nii"]


@pytest.mark.parametrize("only_inside", [False, True])
def test_fields_of_ffds_on_grids_along_their_lattice_are_sampled_axis_by_axis(only_inside):
    from ffd_notebook.io import sample_displacement_field

    ffd = _ffd(4)
    ffd.only_inside = only_inside
    # along the lattice (the fast path), no voxel on the domain's faces (u = 1 or n - 2: rounding decides there)
    grid = dict(REFERENCE, direction=ffd.lattice.rotation, size=(23, 19, 17), origin=(6.013, -1.029, 2.007))
    fast = sample_displacement_field(ffd, grid)
    slow = sample_displacement_field(ffd.deform, grid)  # a plain callable: every voxel centre through deform()
    assert np.abs(fast.vectors - slow.vectors).max() < 1e-9
    assert np.abs(slow.vectors).max() > 0.5


def test_batch_lattice_files_refuse_a_field(tmp_path):
    from ffd_notebook.batch.files import LatticeFiles

    save_displacement_field(tmp_path / "warp.nrrd", _ffd(), REFERENCE)
    with pytest.raises(ValueError, match=r"warp\.nrrd: a displacement field is not a lattice; fit one first"):
        LatticeFiles([tmp_path / "warp.nrrd"])


# ---------------------------------------------------------------------------------------- one array layout
@pytest.mark.parametrize("size", [(4, 4, 4), (5, 3, 4)], ids=["cube", "box"])
def test_vectors_are_in_simpleitk_array_order(size):
    """``vectors[k, j, i]`` is voxel (i, j, k)'s, as ``sitk.GetArrayFromImage`` gives it: a field built from that
    array (even on a cube, where a transposed layout would go unnoticed by its shape) moves points as SimpleITK."""
    rng = np.random.default_rng(5)
    array = rng.normal(0.0, 0.7, (*size[::-1], 3))
    image = sitk.GetImageFromArray(array, isVector=True)
    image.SetSpacing((1.2, 0.9, 1.5))
    image.SetOrigin((2.0, -3.0, 1.0))
    image.SetDirection(ROTATED.ravel().tolist())
    from_array = DisplacementField(array, image.GetSpacing(), image.GetOrigin(), ROTATED)
    from_image = DisplacementField.from_sitk(image)
    assert np.array_equal(from_array.vectors, from_image.vectors) and from_array.grid == from_image.grid
    assert from_image.size == size and from_image.shape == size[::-1]
    points = from_image.grid_points()
    assert np.allclose(points[1] - points[0], ROTATED[:, 0] * 1.2)  # i fastest, as vectors.reshape(-1, 3)
    assert np.allclose(from_image.deform(points), points + array.reshape(-1, 3), rtol=0, atol=1e-12)
    inside = points[:: max(1, len(points) // 40)] + rng.normal(0.0, 0.3, (len(points[:: max(1, len(points) // 40)]), 3))
    expected = _apply(sitk.DisplacementFieldTransform(sitk.Cast(image, sitk.sitkVectorFloat64)), inside)
    assert np.abs(from_image.deform(inside) - expected).max() < 1e-9
    back = from_image.to_sitk()
    assert np.array_equal(sitk.GetArrayFromImage(back), array) and back.GetDirection() == image.GetDirection()


def test_a_field_refuses_a_vector_image_that_is_not_one():
    with pytest.raises(ValueError, match="3D image of 3-vectors"):
        DisplacementField.from_sitk(sitk.GetImageFromArray(np.zeros((3, 4, 2)), isVector=True))
    with pytest.raises(ValueError, match=r"\(nz, ny, nx, 3\)"):
        DisplacementField(np.zeros((3, 4, 5)))


def test_the_field_reads_its_vectors_with_the_images_interpolator():
    """One linear interpolator for images and fields: the field's displacement is warp_image of its vectors."""
    from ffd_notebook.images import warp_image

    rng = np.random.default_rng(5)
    field = DisplacementField(rng.normal(size=(5, 6, 7, 3)), spacing=(1.0, 1.5, 0.5), origin=(2.0, -1.0, 0.0))
    index = rng.random((500, 3)) * (np.array(field.size) + 2) - 1.5  # inside, the half-voxel margin, beyond
    points = index @ (field.direction * field.spacing).T + field.origin

    class Points:  # T of a 1 x 1 x 500 grid: the points themselves
        def deform(self, grid_points):
            return points

    read = warp_image(field.vectors, Points(), reference={"size": (500, 1, 1)}, spacing=field.spacing,
                      origin=field.origin)  # fmt: skip
    np.testing.assert_array_equal(field.displacement(points), read.reshape(-1, 3))
    far = field.displacement([[1e300, 0.0, 0.0], [-1e300, 1e300, 0.0]])  # indices beyond any integer: outside
    assert far.tolist() == [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    field.vectors = field.vectors * 2.0  # a new array: read again
    np.testing.assert_allclose(field.displacement(points), 2.0 * read.reshape(-1, 3), rtol=1e-15)
