import numpy as np
import pytest
import skimage.data
from PIL import Image

from ffd_notebook.errors import FileFormatError
from ffd_notebook.solidtex import as_rgb8, sliding_crops, volume_from_slices


def test_stack_of_real_image_crops_keeps_slice_order_and_roi():
    img = skimage.data.immunohistochemistry()
    crops = sliding_crops(img, 5, 32, step=(2, 1), start=(10, 20))
    vol = volume_from_slices(crops, roi=(4, 20, 0, 12))
    assert vol.shape == (5, 16, 12, 3) and vol.dtype == np.uint8
    for k in range(5):
        r, c = 10 + 2 * k + 4, 20 + k
        np.testing.assert_array_equal(vol[k], img[r : r + 16, c : c + 12])


def test_slices_from_files_and_mixed_formats(tmp_path):
    img = skimage.data.coffee()[:40, :50]
    paths = []
    for k in range(3):
        p = tmp_path / f"slice_{k:03d}.png"
        Image.fromarray(np.roll(img, k, axis=1)).save(p)
        paths.append(p)
    vol = volume_from_slices([*paths, str(paths[0])], roi=(slice(5, 25), slice(10, 40)))
    assert vol.shape == (4, 20, 30, 3)
    np.testing.assert_array_equal(vol[2], np.roll(img, 2, axis=1)[5:25, 10:40])
    np.testing.assert_array_equal(vol[3], vol[0])


def test_grey_float_and_rgba_slices_become_rgb8():
    grey = skimage.data.brick()[:8, :8]
    assert as_rgb8(grey).shape == (8, 8, 3)
    np.testing.assert_array_equal(as_rgb8(grey)[..., 1], grey)
    assert as_rgb8(np.full((2, 2), 0.5))[0, 0, 0] == 128
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 3] = 255
    assert as_rgb8(rgba).max() == 0


def test_bad_file_names_the_file(tmp_path):
    bad = tmp_path / "notes.png"
    bad.write_text("not an image")
    with pytest.raises(FileFormatError, match=r"notes\.png"):
        volume_from_slices([bad])


def test_bad_input_is_a_clear_value_error():
    with pytest.raises(ValueError, match="at least one"):
        volume_from_slices([])
    with pytest.raises(ValueError, match="slice 1 is 4x5"):
        volume_from_slices([np.zeros((4, 4, 3)), np.zeros((4, 5, 3))])
    with pytest.raises(ValueError, match="roi rows"):
        volume_from_slices([np.zeros((4, 4, 3))], roi=(0, 9, 0, 2))
    with pytest.raises(ValueError, match="expected a 2D"):
        volume_from_slices([np.zeros((4, 4, 2))])
    with pytest.raises(ValueError, match="do not fit"):
        sliding_crops(np.zeros((10, 10)), 5, 8, step=(1, 1))
