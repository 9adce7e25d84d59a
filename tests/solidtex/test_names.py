"""The solidtex spelling: ``rng`` (an int or a Generator), ``color``; the old names warn and still work."""

import numpy as np
import pytest
import skimage.data

from ffd_notebook.solidtex import (
    LazyBlockTexture,
    LazySolidTexture,
    choose_block_size,
    color_histogram,
    colour_histogram,
    exemplar_from_image,
    neighbourhood_distance,
    seam_error,
    synthesize,
    synthesize_by_blocks,
)
from ffd_notebook.solidtex.seeding import integer_seed


@pytest.fixture(scope="module")
def image():
    return skimage.data.immunohistochemistry()[100:164, 100:164]


def test_colour_histogram_warns_and_equals_color_histogram(image):
    with pytest.warns(DeprecationWarning, match="use color_histogram"):
        old = colour_histogram(image, 4)
    np.testing.assert_array_equal(old, color_histogram(image, bins=4))


def test_synthesize_seed_warns_and_equals_rng(exemplar):
    with pytest.warns(DeprecationWarning, match=r"synthesize\(seed=...\) is deprecated: use rng=..."):
        old = synthesize(exemplar, 24, seed=3, progress=False)
    np.testing.assert_array_equal(old, synthesize(exemplar, 24, rng=3, progress=False))
    assert not np.array_equal(old, synthesize(exemplar, 24, rng=4, progress=False))
    with pytest.warns(DeprecationWarning, match=r"synthesize_by_blocks\(seed=...\) is deprecated: use rng=..."):
        old = synthesize_by_blocks(exemplar, 24, block=8, seed=3, progress=False)
    np.testing.assert_array_equal(old, synthesize_by_blocks(exemplar, 24, block=8, rng=3, progress=False))


def test_block_options_without_a_method_still_run_the_block_method(exemplar):
    # issue 31: synthesize's default is now the pyramid; synthesize(ex, n, seams="cut") (the old call) runs the block
    # method it meant, and says how to ask for it
    with pytest.warns(DeprecationWarning, match=r"synthesize\(block=..., seams=...\) runs the block method"):
        old = synthesize(exemplar, 24, block=8, seams="cut", progress=False)
    np.testing.assert_array_equal(old, synthesize(exemplar, 24, method="blocks", block=8, seams="cut", progress=False))
    np.testing.assert_array_equal(old, synthesize_by_blocks(exemplar, 24, block=8, seams="cut", progress=False))
    with pytest.raises(TypeError, match="no option block"):
        synthesize(exemplar, 24, method="pyramid", block=8)


def test_exemplar_from_image_seed_warns_and_equals_rng(image):
    kw = {"levels": 2, "neighbourhood": 5, "iterations": (1, 1), "method": "kopf"}
    with pytest.warns(DeprecationWarning, match=r"exemplar_from_image\(seed=...\)"):
        old = exemplar_from_image(image, 16, seed=2, **kw)
    np.testing.assert_array_equal(old, exemplar_from_image(image, 16, rng=2, **kw))


@pytest.mark.parametrize("cls, options", [(LazySolidTexture, {}), (LazyBlockTexture, {"block": 8})])
def test_lazy_fit_seed_warns_and_equals_rng(exemplar, cls, options):
    bounds, points = (0, 10, 0, 5, 0, 2), np.random.default_rng(0).uniform(0, 2, (200, 3))
    with pytest.warns(DeprecationWarning, match=rf"{cls.__name__}.fit\(seed=...\)"):
        old = cls.fit(exemplar, bounds, resolution=64, seed=7, **options)
    new = cls.fit(exemplar, bounds, resolution=64, rng=7, **options)
    assert old.seed == new.seed == 7
    np.testing.assert_array_equal(old.sample(points), new.sample(points))


def test_a_generator_works_where_an_int_does(exemplar):
    a = synthesize(exemplar, 24, rng=np.random.default_rng(5), progress=False)
    b = synthesize(exemplar, 24, rng=np.random.default_rng(5), progress=False)
    np.testing.assert_array_equal(a, b)
    # a Generator is drawn from: the same generator again gives other numbers
    gen = np.random.default_rng(1)
    first = neighbourhood_distance(exemplar, exemplar, n_queries=200, rng=gen)
    assert first != neighbourhood_distance(exemplar, exemplar, n_queries=200, rng=gen)
    assert neighbourhood_distance(exemplar, exemplar, n_queries=200, rng=1) == neighbourhood_distance(
        exemplar, exemplar, n_queries=200, rng=1
    )
    assert choose_block_size(exemplar, rng=np.random.default_rng(0)) in (8, 12, 16)


def test_lazy_texture_takes_a_generator_as_one_63_bit_root_seed(exemplar):
    tex = LazySolidTexture(exemplar, 64, rng=np.random.default_rng(11))
    assert tex.seed == integer_seed(np.random.default_rng(11))
    assert 2**32 <= tex.seed < 2**63  # a 63-bit draw (this one is large), hashed as is
    same = LazySolidTexture(exemplar, 64, rng=tex.seed, prepared=tex.prepared)
    points = np.random.default_rng(2).uniform(0, 64, (300, 3))
    np.testing.assert_array_equal(tex.sample(points), same.sample(points))
    with pytest.raises(TypeError):
        integer_seed(1.5)


def test_options_are_keyword_only(exemplar):
    with pytest.raises(TypeError):
        synthesize(exemplar, 24, 8)
    with pytest.raises(TypeError):
        LazySolidTexture(exemplar, 64, 1.0)
    with pytest.raises(TypeError):
        seam_error(exemplar, exemplar, 6, 2)
    with pytest.raises(TypeError):
        neighbourhood_distance(exemplar, exemplar, 5)
