"""The exemplar most solidtex tests grow volumes from: 32 stacked crops of a real histology image."""

import pytest
import skimage.data

from ffd_notebook.solidtex import sliding_crops, volume_from_slices


@pytest.fixture(scope="session")
def exemplar():
    img = skimage.data.immunohistochemistry()
    return volume_from_slices(sliding_crops(img, 32, 32, step=(1, 1), start=(100, 100)))
