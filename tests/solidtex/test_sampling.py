import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffd_notebook.solidtex import SolidTexture


def _linear_volume():
    # colour channels are linear functions of x, y, z: trilinear sampling reproduces them exactly
    z, y, x = np.meshgrid(np.arange(10), np.arange(12), np.arange(14), indexing="ij")
    return np.stack([10 * x + 5, 10 * y + 3, 20 * z + 1], axis=-1).astype(np.uint8)


@settings(max_examples=30, deadline=None)
@given(
    st.floats(0.1, 3.0),
    st.tuples(*[st.floats(-5, 5)] * 3),
    st.lists(st.tuples(st.floats(0, 13), st.floats(0, 11), st.floats(0, 9)), min_size=1, max_size=20),
)
def test_trilinear_sampling_is_exact_for_linear_colours(spacing, origin, ijk):
    tex = SolidTexture(_linear_volume(), spacing=spacing, origin=origin)
    ijk = np.array(ijk)
    points = np.array(origin) + ijk * spacing
    want = np.column_stack([10 * ijk[:, 0] + 5, 10 * ijk[:, 1] + 3, 20 * ijk[:, 2] + 1])
    np.testing.assert_allclose(tex.sample(points), np.rint(want), atol=1)


def test_fit_covers_a_box_with_cubic_voxels_and_mirrors_outside():
    vol = _linear_volume()
    tex = SolidTexture.fit(vol, (-1, 1, 0, 4, 10, 11), margin=0.0)
    b = tex.bounds.reshape(3, 2)
    assert tex.spacing == pytest.approx(4 / 12)
    np.testing.assert_allclose(b.mean(axis=1), [0, 2, 10.5])
    inside = tex.sample([[0, 2, 10.5]])
    assert inside.shape == (1, 3) and inside.dtype == np.uint8
    # beyond the last voxel the texture is reflected, not clamped or black
    edge_x = b[0, 1]
    out = tex.sample([[edge_x + 2 * tex.spacing, 2, 10.5], [edge_x - 2 * tex.spacing, 2, 10.5]])
    np.testing.assert_array_equal(out[0], out[1])
    with pytest.raises(ValueError, match="Z, Y, X, 3"):
        SolidTexture(np.zeros((4, 4, 4)))
