"""Visibility by re-projection (Section 5): Eq. (5) warps, Eq. (7), Eq. (8) == Eq. (6), a_k(d - 1)."""

import numpy as np
import pytest

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo.stack import composite_back_to_front
from vfxstereo.visibility import (
    behind,
    composite,
    reproject,
    resynthesise,
    simple_visibility,
    view_visibilities,
    visibility,
)
from vfxstereo.warp import Warper


def random_layers(rng, D=4, H=3, W=5, dtype=np.float64):
    """Premultiplied layers with alpha in [0, 1], including exact 0 and 1."""
    alpha = rng.choice([0.0, 0.2, 0.5, 0.9, 1.0], size=(D, H, W, 1)) * rng.uniform(0.8, 1.0, (D, H, W, 1))
    alpha[rng.random((D, H, W)) < 0.2] = 1.0
    rgb = alpha * rng.uniform(0, 1, (D, H, W, 3))
    return np.concatenate([rgb, alpha], axis=-1).astype(dtype)


def test_eq7_visibility_matches_brute_force(rng):
    warped = random_layers(rng)
    a = warped[..., 3]
    V = visibility(a)
    D, H, W = a.shape
    for d in range(D):
        for y in range(H):
            for x in range(W):
                expected = 1.0
                for d2 in range(d + 1, D):  # layers in front of d
                    expected *= 1.0 - a[d2, y, x]
                assert V[d, y, x] == pytest.approx(expected, abs=1e-12)
    assert np.all(V[-1] == 1.0)  # Eq. (7): V(d_max) = 1


def test_eq7_visibility_keeps_float32(rng):
    a = random_layers(rng, dtype=np.float32)[..., 3]
    assert visibility(a).dtype == np.float32


def test_simple_visibility_matches_brute_force(rng):
    a = rng.choice([0.0, 0.3, 0.6, 1.0], size=(5, 4, 6))
    a[:, 0, 0] = 0.3  # a column with no opaque pixel: everything visible
    V = simple_visibility(a, threshold=0.5)
    D, H, W = a.shape
    for y in range(H):
        for x in range(W):
            opaque = [d for d in range(D) if a[d, y, x] >= 0.5]
            d_top = max(opaque) if opaque else -1
            for d in range(D):
                assert V[d, y, x] == (1.0 if d >= d_top else 0.0)
    assert np.all(V[:, 0, 0] == 1.0)


def test_simple_visibility_equals_eq7_for_binary_alpha(rng):
    a = (rng.random((6, 4, 5)) < 0.3).astype(np.float64)
    np.testing.assert_array_equal(simple_visibility(a), visibility(a))


def test_eq8_equals_eq6(rng):
    warped = random_layers(rng, D=5, H=4, W=6)
    np.testing.assert_allclose(composite(warped, visibility(warped[..., 3])), composite_back_to_front(warped),
                               atol=1e-12)


def test_behind_matches_brute_force(rng):
    warped = random_layers(rng, D=5)
    a = behind(warped)
    assert np.all(a[0] == 0.0)
    for d in range(1, warped.shape[0]):
        np.testing.assert_allclose(a[d], composite_back_to_front(warped[:d]), atol=1e-12)


def test_appendix_split_of_the_composite(rng):
    # c~ = sum_{d' > d} c(d') V(d') + V(d) (c(d) + (1 - alpha(d)) a(d - 1)) for every d (Appendix)
    warped = random_layers(rng, D=5)
    V = visibility(warped[..., 3])
    a = behind(warped)
    full = composite(warped, V)
    for d in range(warped.shape[0]):
        front = sum((warped[e] * V[e][..., None] for e in range(d + 1, warped.shape[0])), np.zeros_like(full))
        split = front + V[d][..., None] * (warped[d] + (1.0 - warped[d, ..., 3:4]) * a[d])
        np.testing.assert_allclose(split, full, atol=1e-12)


def test_eq5_reproject_moves_a_dot_by_d_times_offset():
    # reference at position 0; a dot at column 5 of plane d = 2 appears at 5 - 2 * (p_k - p_ref) in view k
    cam = Camera.from_positions([-1.0, 0.0, 2.0], reference=1)
    wp = Warper(cam, [0.0, 1.0, 2.0], (4, 9))
    rgba = np.zeros((3, 4, 9, 4))
    rgba[2, 2, 5] = [0.5, 0.25, 0.0, 1.0]
    for k, col in [(0, 7), (1, 5), (2, 1)]:
        out = reproject(rgba, wp, k)
        expected = np.zeros_like(rgba)
        expected[2, 2, col] = rgba[2, 2, 5]
        np.testing.assert_array_equal(out, expected)


def test_eq5_reproject_fractional_shift_is_bilinear():
    cam = Camera.from_positions([0.0, 0.5], reference=0)
    wp = Warper(cam, [0.0, 1.0], (1, 6))
    rgba = np.zeros((2, 1, 6, 4))
    rgba[1, 0, 3] = [1.0, 1.0, 1.0, 1.0]
    out = reproject(rgba, wp, 1)  # shift by d * offset = 0.5 px to the left: split over columns 2 and 3
    np.testing.assert_allclose(out[1, 0, :, 3], [0, 0, 0.5, 0.5, 0, 0])


def _occlusion_scene():
    """Opaque background at d = 0 and an opaque bar at d = 2 (rows 1-2, columns 4-6), 3 views."""
    rgba = np.zeros((3, 4, 12, 4), np.float32)
    rgba[0, ..., 2] = 1.0
    rgba[0, ..., 3] = 1.0
    rgba[2, 1:3, 4:7] = [1.0, 0.0, 0.0, 1.0]
    cam = Camera.from_positions([-1.0, 0.0, 1.0], reference=1)
    return LayerStack(rgba, [0.0, 1.0, 2.0], cam), cam


@pytest.mark.parametrize("simple", [False, True])
def test_view_visibilities_occlusion_hand_computed(simple):
    stack, cam = _occlusion_scene()
    wp = Warper(cam, stack.disparities, (4, 12))
    vis, views = view_visibilities(stack.rgba, wp, simple=simple)
    assert len(vis) == 3
    for k, offset in enumerate([-1, 0, 1]):
        expected = np.ones((3, 4, 12), np.float32)
        expected[:2, 1:3, 4 - 2 * offset:7 - 2 * offset] = 0.0  # the bar hides layers 0 and 1 there
        np.testing.assert_array_equal(vis[k], expected)
        np.testing.assert_allclose(views[k], stack.render(cam.positions[k]), atol=1e-6)


def test_resynthesise_equals_stack_render_at_fractional_shifts(rng):
    rgba = random_layers(rng, D=4, H=6, W=8, dtype=np.float32)
    cam = Camera.from_positions([-1.3, 0.0, 0.7], reference=1)
    disp = [0.0, 0.6, 1.5, 2.25]
    stack = LayerStack(rgba, disp, cam)
    views = resynthesise(stack.rgba, Warper(cam, disp, (6, 8)))
    for k in range(3):
        np.testing.assert_allclose(views[k], stack.render(cam.positions[k]), atol=1e-6)


def test_bad_shapes_raise():
    with pytest.raises(VfxStereoError):
        visibility(np.zeros((2, 3, 4, 4)))
    with pytest.raises(VfxStereoError):
        composite(np.zeros((2, 3, 4, 4)), np.zeros((2, 3, 5)))
    with pytest.raises(VfxStereoError):
        behind(np.zeros((2, 3, 4, 3)))
    wp = Warper(Camera.from_positions([0.0, 1.0]), [0.0, 1.0], (3, 4))
    with pytest.raises(VfxStereoError, match="layers"):
        reproject(np.zeros((3, 3, 4, 4)), wp, 0)
