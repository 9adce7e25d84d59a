"""One dtype policy for colours and intensities (issue 35 item 8), scikit-image's, at every entry point.

Before: ``synthesize_by_optimisation`` clipped a float exemplar in [0, 1] to {0, 1} and saturated a
uint16 one; ``exemplar_by_transport`` converted; ``Photo.of`` refused; a 16-bit photo file was
stretched by its own maximum. Now each entry point reads uint8 levels, uint16 (its whole range),
floats in [0, 1] the same way, and refuses floats outside [0, 1] with the range found.
"""

import io

import numpy as np
import pytest
import skimage.data
from PIL import Image
from skimage.util import img_as_ubyte

from ffd_notebook._util.colours import as_float, as_uint8
from ffd_notebook.errors import FileFormatError
from ffd_notebook.face.photo import Photo, decode_photo, is_photo, read_photo
from ffd_notebook.solidtex import (
    LazyBlockTexture,
    LazySolidTexture,
    SolidTexture,
    as_rgb8,
    color_histogram,
    exemplar_by_transport,
    exemplar_from_image,
    gradient_energy,
    self_similarity,
    synthesize,
    synthesize_by_blocks,
    synthesize_by_optimisation,
    volume_from_slices,
)

LEVELS = skimage.data.immunohistochemistry()[100:132, 100:132]  # uint8, 32 x 32 x 3


def _spellings(levels: np.ndarray) -> dict:
    """The same colours as uint8, uint16 (x 257: the 8 bits repeated) and floats in [0, 1]."""
    return {"uint8": levels, "uint16": levels.astype(np.uint16) * 257, "float": levels / 255.0}


def test_the_policy_is_scikit_images():
    values = np.array([0, 1, 127, 128, 254, 255], np.uint8)
    for name, spelled in _spellings(values).items():
        assert as_uint8(spelled).tolist() == values.tolist(), name
        np.testing.assert_allclose(as_float(spelled), values / 255.0, atol=1e-7)
    wide = np.array([0, 255, 256, 32768, 65535], np.uint16)
    assert as_uint8(wide).tolist() == img_as_ubyte(wide).tolist() == [0, 0, 1, 128, 255]  # its whole range
    assert as_uint8(np.array([True, False])).tolist() == [255, 0]
    assert as_uint8(np.array([3, 200])).dtype == np.uint8  # int64 0-255 levels (rng.integers, literals)
    assert as_uint8(np.array([1.0 + 1e-7, -1e-7])).tolist() == [255, 0]  # rounding, not a range
    with pytest.raises(ValueError, match=r"the mask: floating-point colours must be in \[0, 1\].*from 0 to 255"):
        as_uint8(np.array([0.0, 255.0]), "the mask")
    with pytest.raises(ValueError, match="NaN or infinite"):
        as_float(np.array([0.5, np.nan]))
    with pytest.raises(ValueError, match="int32 values from -5 to 300"):
        as_uint8(np.array([-5, 300], np.int32))
    with pytest.raises(ValueError, match="must be numbers"):
        as_uint8(np.array(["a"]))


def test_photos_read_every_spelling_alike():
    expected = Photo.of(LEVELS).rgb
    for name, spelled in _spellings(LEVELS).items():
        np.testing.assert_array_equal(Photo.of(spelled).rgb, expected, err_msg=name)
    with pytest.raises(ValueError, match=r"the photo \(a 32x32 array\): floating-point colours must be in \[0, 1\]"):
        Photo.of(LEVELS.astype(np.float32))  # 0-255 levels in a float array: refused, not clipped to white
    assert is_photo(LEVELS) and is_photo(LEVELS.astype(np.uint16)) and not is_photo(LEVELS / 255.0)


def _png(array: np.ndarray, **kwargs) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, **kwargs)
    return buffer.getvalue()


def test_photo_files_of_16_bits_and_floats(tmp_path):
    grey = LEVELS[..., 0]
    dark = (grey // 4).astype(np.uint16) * 257  # a dark 16-bit photo: levels 0-63
    photo = decode_photo(_png(dark, format="PNG"), "dark.png")
    # scaled from the whole 16-bit range, as scikit-image does (it was stretched by its maximum: 63 became 255)
    np.testing.assert_array_equal(photo.rgb[..., 0], grey // 4)
    path = tmp_path / "unit.tif"
    path.write_bytes(_png((grey / 255.0).astype(np.float32), format="TIFF"))
    np.testing.assert_array_equal(read_photo(path)[..., 1], grey)
    path.write_bytes(_png(grey.astype(np.float32), format="TIFF"))  # floats in 0-255: no way to know
    with pytest.raises(FileFormatError, match=r"unit\.tif: F pixels: floating-point colours must be in \[0, 1\]"):
        read_photo(path)


def test_images_and_slices_read_every_spelling_alike():
    for name, spelled in _spellings(LEVELS).items():
        np.testing.assert_array_equal(as_rgb8(spelled), LEVELS, err_msg=name)
        np.testing.assert_array_equal(volume_from_slices([spelled, spelled]), np.stack([LEVELS] * 2), err_msg=name)
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\]"):
        as_rgb8(LEVELS.astype(float))


@pytest.mark.parametrize(
    "make",
    [
        lambda image: exemplar_by_transport(
            image, 16, levels=2, patch=(4,), steps=(2,), rounds=(1,), neighbourhood=(5,), fine_steps=1
        ),
        lambda image: exemplar_from_image(image, 16, levels=2, neighbourhood=5, iterations=(1, 1), method="kopf"),
    ],
    ids=["exemplar_by_transport", "exemplar_from_image kopf"],
)
def test_exemplars_from_every_spelling_of_an_image_are_the_same(make):
    made = {name: make(spelled) for name, spelled in _spellings(LEVELS).items()}
    np.testing.assert_array_equal(made["uint16"], made["uint8"])
    np.testing.assert_array_equal(made["float"], made["uint8"])
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\]"):
        make(LEVELS * 2.0)


EXEMPLAR = np.kron(np.random.default_rng(0).integers(0, 256, (4, 4, 4, 3)), np.ones((4, 4, 4, 1), int)).astype(np.uint8)
SYNTHESES = {
    "synthesize (pyramid)": lambda ex: synthesize(ex, 20, progress=False),
    "synthesize_by_optimisation": lambda ex: synthesize_by_optimisation(ex, 16, levels=2, iterations=1, progress=False),
    "synthesize_by_blocks": lambda ex: synthesize_by_blocks(ex, 20, block=8, progress=False),
    "LazySolidTexture": lambda ex: LazySolidTexture(ex, 12).volume(),
    "LazyBlockTexture": lambda ex: LazyBlockTexture(ex, 12, block=8).volume(),
    "SolidTexture": lambda ex: SolidTexture(ex).sample([[1.5, 2.0, 3.0], [7.0, 1.0, 0.5]]),
    "color_histogram": lambda ex: color_histogram(ex, bins=4),
    "gradient_energy": gradient_energy,
}


@pytest.mark.parametrize("name", sorted(SYNTHESES))
def test_every_solid_texture_entry_point_reads_every_spelling_alike(name):
    run = SYNTHESES[name]
    done = {spelling: run(spelled) for spelling, spelled in _spellings(EXEMPLAR).items()}
    for spelling in ("uint16", "float"):
        np.testing.assert_allclose(done[spelling], done["uint8"], rtol=1e-6, err_msg=f"{name}: {spelling}")
    with pytest.raises(ValueError, match=r"floating-point colours must be in \[0, 1\]"):
        run(EXEMPLAR.astype(np.float32))  # 0-255 levels in floats: the optimisation made them all white


def test_the_measures_read_every_spelling_alike():
    volume = synthesize(EXEMPLAR, 48, progress=False)
    expected = self_similarity(volume, LEVELS, slices=1)
    for spelling, spelled in _spellings(volume).items():
        measured = self_similarity(spelled, LEVELS / 255.0, slices=1)
        np.testing.assert_allclose(measured, expected, rtol=1e-5, err_msg=spelling)
