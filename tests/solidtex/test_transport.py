"""exemplar_by_transport: slices whose patch distribution is the image's (sliced optimal transport).

Held to issue 26's band on the histology image and gravel (48 px crops, 48^3, fixed seed), and its
two pieces checked exactly: the patch scatter is the adjoint of the patch extraction, and one
transport move gives every projection the target's distribution.
"""

import numpy as np
import pytest

from ffd_notebook.solidtex import exemplar_from_image, histogram_distance, likeness, self_similarity
from ffd_notebook.solidtex.transport import _scatter, _slice_patches, _transport_moves, exemplar_by_transport

from .conftest import IMAGES


def test_every_slice_orientation_is_as_varied_as_the_image(made):
    name, image, volume = made  # exemplar_from_image's default method is this one (checked below)
    assert volume.shape == (48, 48, 48, 3) and volume.dtype == np.uint8
    ratios = self_similarity(volume, image, slices=2)
    # measured over seeds 0-5 (SciPy 1.17's rotations): histology 0.85-1.11 (means 0.95-0.99), gravel
    # 0.78-0.92 (means 0.82-0.89); new samples of the texture score 0.97-1.14, the image blurred by
    # one pixel 0.6-0.7. The seed is fixed, but the draws behind it are SciPy's: a floor of 0.8 on every
    # orientation held for one stream and not the next (gravel, seed 0: 0.78), so the band is the
    # method's over seeds: every orientation >= 0.75, their mean >= 0.8 (blur is below both)
    assert 0.75 <= ratios.min() and ratios.mean() >= 0.8 and ratios.max() <= 1.6, (name, ratios)
    near = likeness(volume, image, slices=1)
    assert 0.75 <= near.min() and near.max() <= 1.3, (name, near)
    assert histogram_distance(volume, image) < 0.03, name


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_scatter_is_the_adjoint_of_patch_extraction(axis):
    rng = np.random.default_rng(axis)
    volume = rng.standard_normal((6, 10, 14, 3)).astype(np.float32)
    for n, stride, oy, ox in ((4, 2, 1, 0), (5, 3, 2, 1), (3, 4, 3, 3)):
        patches, grid = _slice_patches(volume, axis, n, stride, oy, ox)
        moves = rng.standard_normal(patches.shape).astype(np.float32)
        shape = np.moveaxis(volume, axis, 0).shape[:3]
        acc, count = _scatter(moves, shape, n, grid, oy, ox, stride)
        # <P v, d> = <v, P^T d>, and the count is P^T of all-ones patches summed over colours / 3
        lhs = float((patches.astype(np.float64) * moves).sum())
        rhs = float((np.moveaxis(volume, axis, 0).astype(np.float64) * acc).sum())
        assert lhs == pytest.approx(rhs, rel=1e-4)
        ones, _ = _scatter(np.ones_like(moves), shape, n, grid, oy, ox, stride)
        np.testing.assert_allclose(ones[..., 0], np.broadcast_to(count, shape))


def test_one_move_gives_each_projection_the_target_distribution():
    rng = np.random.default_rng(0)
    patches = rng.standard_normal((500, 12)).astype(np.float32)
    target = (rng.random((200, 12)) * 4 + 3).astype(np.float32)  # another distribution, other count
    basis = np.linalg.qr(rng.standard_normal((12, 12)))[0].astype(np.float32)  # a full basis
    moved = patches + _transport_moves(patches, np.sort((target @ basis).T, axis=1), basis)
    got = np.sort(moved @ basis, axis=0)
    want = np.sort(target @ basis, axis=0)
    q = (np.arange(500) + 0.5) / 500
    for d in range(12):  # the moved projections are the target's quantiles
        np.testing.assert_allclose(got[:, d], np.quantile(want[:, d], q, method="hazen"), atol=1e-3)


def test_deterministic_and_checks_its_input():
    image = IMAGES["histology"][:32, :32]
    kw = {"levels": 2, "patch": (4,), "steps": (2,), "rounds": (1,), "neighbourhood": (5,), "fine_steps": 1}
    a = exemplar_by_transport(image, 16, **kw)
    np.testing.assert_array_equal(a, exemplar_by_transport(image, 16, **kw))
    default = exemplar_from_image(image, 16, levels=2)  # the default method is this one
    np.testing.assert_array_equal(default, exemplar_by_transport(image, 16, levels=2))
    assert not np.array_equal(a, exemplar_by_transport(image, 16, rng=1, **kw))
    with pytest.raises(ValueError, match="multiple"):
        exemplar_by_transport(image, 33, **kw)
    with pytest.raises(ValueError, match="odd"):
        exemplar_by_transport(image, 16, **{**kw, "neighbourhood": (4,)})
    with pytest.raises(ValueError, match="too small"):
        exemplar_by_transport(image[:8, :8], 16, **kw)


def test_a_whole_photograph_asks_for_a_crop():
    # by default the exemplar is as large as the image: 512^3 would take hours, so the error says to crop
    photo = np.zeros((512, 384, 3), np.uint8)
    for method in ("transport", "kopf"):
        with pytest.raises(ValueError, match=r"384x512 px.*crop of the texture"):
            exemplar_from_image(photo, method=method)
    small = exemplar_by_transport(
        IMAGES["gravel"].repeat(4, axis=0).repeat(4, axis=1), 16, levels=2, steps=(1,), rounds=(0,), fine_steps=0
    )  # a size given: a large image is fine
    assert small.shape == (16, 16, 16, 3)
