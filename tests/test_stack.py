"""LayerStack: validation rules, flatten/render against hand-computed pixels, disparity maps."""

import numpy as np
import pytest

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo.stack import over


def _two_layer_stack():
    # 1x3 frame. Back layer (d=0): opaque blue. Front layer (d=2): half-transparent red on the middle pixel only.
    rgba = np.zeros((2, 1, 3, 4), np.float32)
    rgba[0, ..., 2] = 1.0
    rgba[0, ..., 3] = 1.0
    rgba[1, 0, 1] = [0.5, 0.0, 0.0, 0.5]  # premultiplied red at alpha 0.5
    return LayerStack(rgba, [0.0, 2.0], Camera.from_positions([0, 1, 2], reference=1))


class TestValidation:
    def good(self):
        return np.zeros((2, 3, 4, 4), np.float32), np.array([0.0, 1.0])

    def test_accepts_a_valid_stack_and_stores_float32(self):
        rgba, d = self.good()
        s = LayerStack(rgba.astype(np.float64), d)
        assert s.rgba.dtype == np.float32 and s.shape == (2, 3, 4)

    @pytest.mark.parametrize("shape", [(3, 4, 4), (2, 3, 4, 3), (0, 3, 4, 4), (2, 0, 4, 4)])
    def test_rejects_bad_shapes(self, shape):
        with pytest.raises(VfxStereoError):
            LayerStack(np.zeros(shape, np.float32), np.arange(shape[0] if len(shape) == 4 else 1, dtype=float))

    def test_rejects_integer_dtype(self):
        with pytest.raises(VfxStereoError, match="floating"):
            LayerStack(np.zeros((2, 3, 4, 4), np.uint8), [0, 1])

    def test_rejects_wrong_number_of_disparities(self):
        rgba, _ = self.good()
        with pytest.raises(VfxStereoError, match="disparities"):
            LayerStack(rgba, [0.0, 1.0, 2.0])

    @pytest.mark.parametrize("d", [[1.0, 1.0], [2.0, 1.0], [0.0, np.nan]])
    def test_rejects_disparities_not_strictly_increasing_or_not_finite(self, d):
        rgba, _ = self.good()
        with pytest.raises(VfxStereoError):
            LayerStack(rgba, d)

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_rejects_non_finite_values(self, bad):
        rgba, d = self.good()
        rgba[1, 2, 3, 0] = bad
        with pytest.raises(VfxStereoError, match="NaN or infinite"):
            LayerStack(rgba, d)

    @pytest.mark.parametrize("a", [-0.1, 1.1])
    def test_rejects_alpha_outside_unit_interval(self, a):
        rgba, d = self.good()
        rgba[0, 0, 0, 3] = a
        with pytest.raises(VfxStereoError, match="alpha"):
            LayerStack(rgba, d)

    def test_rejects_colour_above_alpha(self):
        rgba, d = self.good()
        rgba[0, 0, 0] = [0.6, 0.0, 0.0, 0.5]
        with pytest.raises(VfxStereoError, match="premultiplied"):
            LayerStack(rgba, d)

    def test_rejects_negative_colour(self):
        rgba, d = self.good()
        rgba[0, 0, 0] = [-0.5, 0.0, 0.0, 1.0]
        with pytest.raises(VfxStereoError, match="negative"):
            LayerStack(rgba, d)

    def test_tolerance_admits_half_float_rounding(self):
        rgba, d = self.good()
        rgba[0, 0, 0] = [0.5 + 1e-4, 0.0, 0.0, 0.5]
        LayerStack(rgba, d)

    def test_white_admits_hdr_colour(self):
        rgba, d = self.good()
        rgba[0, 0, 0] = [2.0, 0.0, 0.0, 0.5]  # straight colour 4.0
        with pytest.raises(VfxStereoError):
            LayerStack(rgba, d)
        LayerStack(rgba, d, white=4.0)


def test_over_is_the_premultiplied_porter_duff_operator():
    fg = np.array([0.5, 0.0, 0.0, 0.5], np.float32)
    bg = np.array([0.0, 0.0, 1.0, 1.0], np.float32)
    np.testing.assert_allclose(over(fg, bg), [0.5, 0.0, 0.5, 1.0])


def test_eq6_flatten_hand_computed_pixels():
    out = _two_layer_stack().flatten()
    np.testing.assert_allclose(out[0, 0], [0, 0, 1, 1])
    np.testing.assert_allclose(out[0, 1], [0.5, 0, 0.5, 1])  # red 0.5 over blue
    np.testing.assert_allclose(out[0, 2], [0, 0, 1, 1])


def test_flatten_puts_the_largest_disparity_on_top():
    rgba = np.zeros((2, 1, 1, 4), np.float32)
    rgba[0, 0, 0] = [1, 0, 0, 1]
    rgba[1, 0, 0] = [0, 1, 0, 1]
    assert LayerStack(rgba, [1.0, 3.0]).flatten()[0, 0, 1] == 1.0
    assert LayerStack(rgba[::-1].copy(), [1.0, 3.0]).flatten()[0, 0, 0] == 1.0


def test_render_shifts_each_layer_by_d_times_offset():
    s = _two_layer_stack()
    # Position 1.5 (offset +0.5): the d=2 layer moves 1 column left, the red pixel from x=1 to x=0.
    v = s.render(1.5)
    np.testing.assert_allclose(v[0, 0], [0.5, 0, 0.5, 1])
    np.testing.assert_allclose(v[0, 1], [0, 0, 1, 1])
    # Position 2 (offset +1): x = 1 - 2 = -1, outside: only the blue plane is left.
    np.testing.assert_allclose(s.render(2)[0], [[0, 0, 1, 1]] * 3)


def test_render_integer_and_half_pixel_shifts():
    rgba = np.zeros((2, 1, 6, 4), np.float32)
    rgba[0, ..., 1] = 1.0
    rgba[0, ..., 3] = 1.0  # opaque green back plane at d = 0
    rgba[1, 0, 3] = [1, 0, 0, 1]  # opaque red pixel at x=3, d = 1
    s = LayerStack(rgba, [0.0, 1.0], Camera.from_positions([0, 1, 2], reference=1))
    # position 2 -> offset +1 -> the red pixel appears at x = 3 - 1 = 2
    v = s.render(2)
    np.testing.assert_allclose(v[0, :, 0], [0, 0, 1, 0, 0, 0])
    np.testing.assert_allclose(v[0, :, 3], 1.0)
    # position 0 -> offset -1 -> x = 4
    np.testing.assert_allclose(s.render(0)[0, :, 0], [0, 0, 0, 0, 1, 0])
    # position 1.5 -> offset 0.5 -> x = 2.5: half of the red pixel on columns 2 and 3 (bilinear)
    v = s.render(1.5)
    np.testing.assert_allclose(v[0, :, 0], [0, 0, 0.5, 0.5, 0, 0])
    np.testing.assert_allclose(v[0, :, 1], [1, 1, 0.5, 0.5, 1, 1])
    np.testing.assert_allclose(v[0, :, 3], 1.0)
    # the reference position reproduces flatten()
    np.testing.assert_array_equal(s.render(1), s.flatten())


def test_render_with_2d_positions_shifts_rows_too():
    rgba = np.zeros((1, 5, 5, 4), np.float32)
    rgba[0, 2, 2] = [1, 1, 1, 1]
    s = LayerStack(rgba, [2.0], Camera(positions=[[0, 0], [1, 1]], reference=[0, 0], reference_index=0))
    v = s.render([1, 1])  # offset (1, 1), d = 2: the pixel moves to (y, x) = (0, 0)
    assert v[0, 0, 3] == 1.0 and v[..., 3].sum() == 1.0


def test_disparity_map_front_most_and_weighted():
    s = _two_layer_stack()
    dm = s.disparity_map(0.5)
    np.testing.assert_array_equal(dm[0], [0, 0, 0])  # the red pixel is alpha 0.5, not above 0.5
    np.testing.assert_array_equal(s.disparity_map(0.4)[0], [0, 2, 0])
    w = s.disparity_map(weighted=True)
    # middle pixel: weights 0.5 (d=2) and 0.5*1 (d=0) -> 1.0
    np.testing.assert_allclose(w[0], [0, 1.0, 0])


def test_disparity_map_is_nan_where_nothing_is_opaque():
    s = LayerStack(np.zeros((2, 2, 2, 4), np.float32), [0.0, 1.0])
    assert np.isnan(s.disparity_map()).all()
    assert np.isnan(s.disparity_map(weighted=True)).all()


def test_visibility_weights_sum_to_flattened_alpha(rng):
    a = rng.uniform(0, 1, (4, 5, 6, 1)).astype(np.float32)
    rgba = np.concatenate([a * rng.uniform(0, 1, (4, 5, 6, 3)), a], axis=-1).astype(np.float32)
    s = LayerStack(rgba, np.arange(4.0))
    np.testing.assert_allclose(s.visibility_weights().sum(0), s.flatten()[..., 3], atol=1e-6)


def test_alpha_coverage():
    s = _two_layer_stack()
    np.testing.assert_allclose(s.alpha_coverage(), [1.0, 0.5 / 3])


def test_the_one_pass_stack_checks_agree_with_the_layer_by_layer_ones(rng):
    """Stacks of a million values and more are checked by a numba kernel; smaller ones a layer at a time."""
    from vfxstereo import stack as stack_module
    from vfxstereo._edge_kernels import stack_checks

    rgba = rng.uniform(0, 1, (5, 64, 64, 4)).astype(np.float32)
    rgba[..., :3] *= rgba[..., 3:]
    rgba[1, 3, 4, 0] = -0.2
    rgba[2, 5, 6, 1] = 1.5  # more than alpha
    for case in (rgba, np.where(np.arange(4) == 2, np.nan, rgba)[:2].astype(np.float32)):
        slow = stack_module._layer_checks(case, 1.0)  # small: the numpy path
        fast = stack_checks(np.ascontiguousarray(case).reshape(-1, 4), 1.0)
        assert fast[0] == slow[0]
        np.testing.assert_allclose(fast[1:], slow[1:], atol=1e-6)
    rgba[1, 3, 4, 0] = 0.0
    with pytest.raises(VfxStereoError, match="exceeds alpha"):
        LayerStack(np.repeat(rgba, 52, axis=0), np.arange(260.0))  # 4 M values: the kernel's path
