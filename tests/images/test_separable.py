"""The separable evaluation of an FFD on an aligned grid equals ``FFD.deform`` point by point."""

from __future__ import annotations

import numpy as np
import pytest
from image_testing import awkward_grid

from ffd_notebook import FFD, Lattice
from ffd_notebook.images import ImageGrid
from ffd_notebook.images.sample import IndexSampler
from ffd_notebook.images.separable import GridFFDSampler, index_sampler

# a grid whose index axes are the lattice's y, -x and z: a permutation with a flip
PERMUTED = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]


@pytest.mark.parametrize(
    ("basis", "border", "direction", "affine"),
    [
        ("bspline", "zero", None, False),
        ("bspline", "clamp", None, True),
        ("bspline", "zero", PERMUTED, True),
        ("bernstein", "zero", PERMUTED, False),
    ],
)
@pytest.mark.parametrize("dim", [3, 2])
def test_separable_equals_point_by_point(basis, border, direction, affine, dim):
    rng = np.random.default_rng(11)
    if dim == 2:
        direction = None if direction is None else np.array(direction)[:2, :2]
    reference = ImageGrid((23, 17, 9)[:dim], spacing=(0.7, 1.1, 1.9)[:dim], origin=(4.0, -8.0, 3.0)[:dim],
                          direction=direction)  # fmt: skip
    source = awkward_grid((20, 18, 11)[:dim])
    lo, hi = reference.bounds()
    lat = Lattice.around(np.array([lo - 2.0, hi + 2.0]), shape=(6, 5, 7), basis=basis, border=border)
    lat.offsets[...] = rng.normal(scale=1.5, size=lat.offsets.shape)
    matrix = np.eye(4)
    if affine:
        matrix[:3, :3] += rng.normal(scale=0.05, size=(3, 3))
        matrix[:3, 3] = (1.0, -2.0, 0.5)
    ffd = FFD(lat, basis=basis, affine=matrix)
    fast = index_sampler(ffd, reference, source)
    assert isinstance(fast, GridFFDSampler)
    slow = IndexSampler(ffd, reference, source)
    rows = reference.shape[0]
    for start, stop in ((0, 2), (rows // 2, rows // 2 + 3), (rows - 1, rows)):
        np.testing.assert_allclose(fast.rows(start, stop), slow.rows(start, stop), rtol=0, atol=1e-9)


def test_turned_lattice_or_only_inside_goes_point_by_point():
    reference = ImageGrid((10, 10, 10))
    lat = Lattice((5, 5, 5), 3.0, origin=(-3.0, -3.0, -3.0))
    assert isinstance(index_sampler(FFD(lat), reference, reference), GridFFDSampler)
    assert type(index_sampler(FFD(lat, only_inside=True), reference, reference)) is IndexSampler
    c, s = np.cos(0.01), np.sin(0.01)
    turned = Lattice((5, 5, 5), 3.0, origin=(-3.0, -3.0, -3.0), rotation=[[c, -s, 0], [s, c, 0], [0, 0, 1]])
    assert type(index_sampler(FFD(turned), reference, reference)) is IndexSampler
