"""Exemplars the solidtex tests grow volumes from.

* ``exemplar``: 32 stacked crops of a real histology image (a sheared extrusion, cheap);
* ``made``: per texture (histology, gravel), a 48 px crop and ``exemplar_from_image`` of it with the
  defaults and a fixed seed (48^3, the image's own size), shared by the exemplar and synthesis tests.
"""

import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import exemplar_from_image, sliding_crops, volume_from_slices

SIDE = 48
IMAGES = {
    "histology": skimage.data.immunohistochemistry()[100 : 100 + SIDE, 100 : 100 + SIDE],
    "gravel": np.repeat(skimage.data.gravel()[100 : 100 + SIDE, 100 : 100 + SIDE, None], 3, axis=2),
}
_MADE: dict = {}


@pytest.fixture(scope="session")
def exemplar():
    img = skimage.data.immunohistochemistry()
    return volume_from_slices(sliding_crops(img, 32, 32, step=(1, 1), start=(100, 100)))


@pytest.fixture(scope="session", params=sorted(IMAGES))
def made(request):
    if request.param not in _MADE:
        image = IMAGES[request.param]
        _MADE[request.param] = (request.param, image, exemplar_from_image(image, rng=0))
    return _MADE[request.param]


@pytest.fixture(scope="session")
def images():
    """The crops ``made`` starts from, by texture name."""
    return IMAGES
