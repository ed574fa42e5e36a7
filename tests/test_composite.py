"""Compositor core: insert between layers, split, holdout, deep merge by depth, novel views, premultiply.

Ground truths are built independently of vfxstereo.composite: a new LayerStack with the element as one more
layer, per-pixel Python loops that sort samples and composite them, hand-computed 2x2 pixels, and an integer
shift-and-composite written with explicit loops.
"""

import numpy as np
import pytest

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo.composite import (
    element_disparity_from_depth,
    flatten,
    holdout,
    insert,
    over,
    premultiply,
    render_view,
    split,
    unpremultiply,
)

DISPARITIES = np.array([0.0, 1.0, 2.5, 4.0])


def _premultiplied(rng, shape, *, opaque_fraction=0.3, empty_fraction=0.3):
    """Random premultiplied RGBA with a mix of empty, soft and opaque pixels."""
    alpha = rng.uniform(0.05, 0.95, shape)
    u = rng.uniform(size=shape)
    alpha[u < empty_fraction] = 0.0
    alpha[u > 1 - opaque_fraction] = 1.0
    colour = rng.uniform(size=(*shape, 3))
    return np.concatenate([colour * alpha[..., None], alpha[..., None]], axis=-1).astype(np.float32)


def _stack(rng, h=5, w=6, disparities=DISPARITIES, camera=None):
    return LayerStack(_premultiplied(rng, (len(disparities), h, w)), disparities, camera)


def _over_py(fg, bg):
    """Porter-Duff over on one premultiplied pixel, in Python floats."""
    return [f + (1.0 - fg[3]) * b for f, b in zip(fg, bg, strict=True)]


def _deep_merge_brute_force(stack, element, element_disp):
    """Per pixel: sort the layer samples and the element sample by disparity (element over a layer at the same
    disparity) and composite back to front with Python floats."""
    d_layers, h, w = stack.depth, *stack.shape[1:]
    out = np.zeros((h, w, 4))
    for y in range(h):
        for x in range(w):
            samples = [(float(stack.disparities[i]), 0, stack.rgba[i, y, x].tolist())
                       for i in range(d_layers)]
            samples.append((float(element_disp[y, x]), 1, element[y, x].tolist()))
            samples.sort(key=lambda s: (s[0], s[1]))  # far to near; on a tie the element is nearer
            acc = [0.0, 0.0, 0.0, 0.0]
            for _, _, px in samples:
                acc = _over_py(px, acc)
            out[y, x] = acc
    return out


# --------------------------------------------------------------------------------------------------------
# over, flatten


def test_over_hand_computed_and_shape_checked():
    fg = np.array([0.5, 0.0, 0.0, 0.5], np.float32)
    bg = np.array([0.0, 0.0, 1.0, 1.0], np.float32)
    np.testing.assert_allclose(over(fg, bg), [0.5, 0.0, 0.5, 1.0])
    with pytest.raises(VfxStereoError, match="same shape"):
        over(np.zeros((2, 2, 4)), np.zeros((2, 3, 4)))
    with pytest.raises(VfxStereoError):
        over(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)))


def test_eq6_flatten_hand_computed_2x1():
    rgba = np.zeros((2, 1, 2, 4), np.float32)
    rgba[0] = [0.0, 0.0, 1.0, 1.0]  # opaque blue at the back
    rgba[1, 0, 0] = [0.2, 0.0, 0.0, 0.4]  # soft red in front, left pixel only
    out = flatten(LayerStack(rgba, [0.0, 3.0]))
    np.testing.assert_allclose(out[0, 0], [0.2, 0.0, 0.6, 1.0], atol=1e-7)
    np.testing.assert_allclose(out[0, 1], [0.0, 0.0, 1.0, 1.0])
    assert out.dtype == np.float32


# --------------------------------------------------------------------------------------------------------
# insert at one disparity, split


@pytest.mark.parametrize("D", [-1.0, 0.5, 1.0, 1.7, 2.5, 3.99, 4.0, 9.0])
def test_eq6_insert_at_disparity_is_the_flatten_of_the_stack_with_the_element_as_a_layer(rng, D):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    behind = [layer for layer, d in zip(stack.rgba, stack.disparities, strict=True) if d <= D]
    in_front = [layer for layer, d in zip(stack.rgba, stack.disparities, strict=True) if d > D]
    layers = np.stack([*behind, element, *in_front])
    truth = LayerStack(layers, np.arange(len(layers), dtype=float)).flatten()
    out = insert(stack, element, disparity=D)
    assert out.shape == (*stack.shape[1:], 4) and out.dtype == np.float32
    np.testing.assert_allclose(out, truth, atol=1e-6)


def test_insert_at_a_plane_puts_the_element_over_that_plane():
    # 1x1 frame: opaque red layer at d=1, element opaque green.
    rgba = np.zeros((2, 1, 1, 4), np.float32)
    rgba[0] = [0.0, 0.0, 1.0, 1.0]
    rgba[1] = [1.0, 0.0, 0.0, 1.0]
    stack = LayerStack(rgba, [0.0, 1.0])
    green = np.array([[[0.0, 1.0, 0.0, 1.0]]], np.float32)
    np.testing.assert_array_equal(insert(stack, green, disparity=1.0)[0, 0], [0, 1, 0, 1])
    np.testing.assert_array_equal(insert(stack, green, disparity=0.999)[0, 0], [1, 0, 0, 1])


def test_insert_an_empty_element_leaves_the_flatten_unchanged(rng):
    stack = _stack(rng)
    empty = np.zeros((*stack.shape[1:], 4), np.float32)
    np.testing.assert_allclose(insert(stack, empty, disparity=1.5), stack.flatten(), atol=1e-6)


@pytest.mark.parametrize("D", [-1.0, 1.0, 3.0, 9.0])
def test_split_recomposes_to_insert(rng, D):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    front, back = split(stack, D)
    comp = over(front, over(element, back))
    np.testing.assert_allclose(comp, insert(stack, element, disparity=D), atol=1e-6)
    # Nothing is lost: with an empty element, front over back is the flattened stack.
    np.testing.assert_allclose(over(front, back), stack.flatten(), atol=1e-6)
    if D < DISPARITIES[0]:
        np.testing.assert_array_equal(back, 0.0)
    if D >= DISPARITIES[-1]:
        np.testing.assert_array_equal(front, 0.0)


def test_split_per_pixel_recomposes_to_insert_by_element_disparity(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    e = rng.choice([-0.5, 0.0, 0.7, 2.5, 3.2, 5.0], size=stack.shape[1:])
    front, back = split(stack, e)
    np.testing.assert_allclose(over(front, over(element, back)), insert(stack, element, element_disparity=e),
                               atol=1e-6)


# --------------------------------------------------------------------------------------------------------
# holdout


def _holdout_stack():
    # 2x2, layers at d = 0, 1, 2 with hand-picked alphas (colour = alpha * 0.5 grey).
    a = np.array([
        [[0.2, 0.2], [0.2, 0.2]],
        [[0.5, 0.0], [1.0, 0.25]],
        [[0.5, 0.0], [0.0, 0.5]],
    ], np.float32)
    rgba = np.concatenate([np.repeat(0.5 * a[..., None], 3, axis=-1), a[..., None]], axis=-1)
    return LayerStack(rgba, [0.0, 1.0, 2.0])


@pytest.mark.parametrize(("D", "expected"), [
    (0.5, [[0.75, 0.0], [1.0, 0.625]]),   # layers 1 and 2: 1 - (1 - a1)(1 - a2)
    (1.5, [[0.5, 0.0], [0.0, 0.5]]),      # layer 2 only
    (1.0, [[0.5, 0.0], [0.0, 0.5]]),      # on plane 1: layer 1 is behind the element
    (2.0, [[0.0, 0.0], [0.0, 0.0]]),      # nothing in front
    (-1.0, [[0.8, 0.2], [1.0, 0.7]]),     # all three: 1 - 0.8 (1 - a1)(1 - a2)
])
def test_eq7_holdout_is_one_minus_the_transmittance_of_the_front_layers(D, expected):
    stack = _holdout_stack()
    h = holdout(stack, D)
    assert h.shape == (2, 2) and h.dtype == np.float32
    np.testing.assert_allclose(h, expected, atol=1e-6)
    np.testing.assert_allclose(h, split(stack, D)[0][..., 3], atol=1e-6)


def test_holdout_is_how_a_compositor_places_a_render_behind_the_front_layers(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    front, back = split(stack, 2.0)
    h = holdout(stack, 2.0)[..., None]
    np.testing.assert_allclose(front + (1 - h) * over(element, back), insert(stack, element, disparity=2.0),
                               atol=1e-6)


def test_holdout_per_pixel_equals_the_scalar_holdout_at_each_pixel(rng):
    stack = _stack(rng)
    e = rng.choice([-1.0, 0.0, 1.5, 2.5, 4.0], size=stack.shape[1:])
    h = holdout(stack, e)
    for y in range(e.shape[0]):
        for x in range(e.shape[1]):
            assert h[y, x] == pytest.approx(holdout(stack, e[y, x])[y, x], abs=1e-6)


# --------------------------------------------------------------------------------------------------------
# insert by depth / per-pixel disparity: a deep merge


def test_insert_by_element_disparity_matches_a_brute_force_deep_merge_including_ties(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:], empty_fraction=0.1)
    # Exact plane values (ties), values between planes, and values beyond both ends.
    e = rng.choice([-2.0, 0.0, 0.5, 1.0, 2.0, 2.5, 3.0, 4.0, 6.0], size=stack.shape[1:])
    out = insert(stack, element, element_disparity=e)
    np.testing.assert_allclose(out, _deep_merge_brute_force(stack, element, e), atol=1e-6)


@pytest.mark.parametrize(("focal", "baseline", "scale"), [(None, None, 1.0), (200.0, 0.05, 10.0)])
def test_insert_by_depth_matches_a_brute_force_deep_merge(rng, focal, baseline, scale):
    cam = Camera.from_positions([0.0, 1.0, 2.0], reference=1, focal=focal, baseline=baseline)
    stack = _stack(rng, camera=cam)
    element = _premultiplied(rng, stack.shape[1:], empty_fraction=0.1)
    # Disparities between planes (no ties: depth round trips are not exact), as depth Z = scale / d.
    e = rng.choice([0.3, 0.7, 1.6, 3.1, 5.0], size=stack.shape[1:])
    z = scale / e
    out = insert(stack, element, depth=z)
    np.testing.assert_allclose(out, _deep_merge_brute_force(stack, element, e), atol=1e-6)


def test_insert_by_depth_uses_the_camera_argument_over_the_stacks(rng):
    stack = _stack(rng, camera=Camera.from_positions([0.0, 1.0], focal=100.0, baseline=0.01))  # f*b = 1
    element = _premultiplied(rng, stack.shape[1:], empty_fraction=0.1)
    e = rng.choice([0.3, 1.6, 3.1, 5.0], size=stack.shape[1:])
    other = Camera.from_positions([0.0, 1.0], focal=50.0, baseline=0.1)  # f*b = 5
    out = insert(stack, element, depth=5.0 / e, camera=other)
    np.testing.assert_allclose(out, _deep_merge_brute_force(stack, element, e), atol=1e-6)
    np.testing.assert_allclose(element_disparity_from_depth(stack, 5.0 / e, camera=other), e, rtol=1e-12)
    np.testing.assert_allclose(element_disparity_from_depth(stack, 1.0 / e), e, rtol=1e-12)


def test_infinite_depth_is_disparity_zero(rng):
    stack = _stack(rng, disparities=np.array([-1.0, 0.5, 2.0]))
    z = np.full(stack.shape[1:], np.inf)
    np.testing.assert_array_equal(element_disparity_from_depth(stack, z), 0.0)


@pytest.mark.parametrize("z", [0.8, 0.25, 2.0])
def test_a_constant_depth_element_equals_insert_at_its_disparity(rng, z):
    cam = Camera.from_positions([0.0, 1.0, 2.0], reference=1, focal=100.0, baseline=0.02)  # f*b = 2
    stack = _stack(rng, camera=cam)
    element = _premultiplied(rng, stack.shape[1:])
    by_depth = insert(stack, element, depth=np.full(stack.shape[1:], z))
    np.testing.assert_allclose(by_depth, insert(stack, element, disparity=2.0 / z), atol=1e-6)


def test_an_element_passing_through_the_scene():
    # Back: opaque blue at d=0; middle: opaque red at d=2 over the whole frame; element: opaque green bar
    # whose disparity climbs from 1 (left, behind the red layer) to 3 (right, in front of it).
    h, w = 3, 8
    rgba = np.zeros((2, h, w, 4), np.float32)
    rgba[0] = [0.0, 0.0, 1.0, 1.0]
    rgba[1] = [1.0, 0.0, 0.0, 1.0]
    stack = LayerStack(rgba, [0.0, 2.0])
    element = np.zeros((h, w, 4), np.float32)
    element[1] = [0.0, 1.0, 0.0, 1.0]
    d = np.tile(np.linspace(1.0, 3.0, w), (h, 1))  # never exactly 2 at a column centre (w is even)
    out = insert(stack, element, depth=1.0 / d)
    left, right = d[1] < 2.0, d[1] > 2.0
    assert left.sum() == right.sum() == w // 2
    np.testing.assert_array_equal(out[1, left], np.tile([1.0, 0.0, 0.0, 1.0], (left.sum(), 1)))
    np.testing.assert_array_equal(out[1, right], np.tile([0.0, 1.0, 0.0, 1.0], (right.sum(), 1)))
    np.testing.assert_array_equal(out[[0, 2]], np.broadcast_to([1.0, 0.0, 0.0, 1.0], (2, w, 4)))


def test_depth_is_not_read_where_the_element_is_empty(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:], empty_fraction=0.0)
    element[0] = 0.0
    z = np.full(stack.shape[1:], 0.5)
    z[0] = np.nan
    z[0, 1] = 0.0
    out = insert(stack, element, depth=z)
    np.testing.assert_allclose(out, insert(stack, element, disparity=2.0), atol=1e-6)
    z[1, 2] = np.nan  # under a non-empty element pixel
    with pytest.raises(VfxStereoError, match="positive"):
        insert(stack, element, depth=z)
    z[1, 2] = -1.0
    with pytest.raises(VfxStereoError, match="positive"):
        insert(stack, element, depth=z)


# --------------------------------------------------------------------------------------------------------
# novel views


def _render_by_integer_shifts(stack, offset):
    """Independent reference: view pixel x samples plane pixel x + d * offset (integer), zero outside."""
    d_layers, h, w = stack.shape
    out = np.zeros((h, w, 4))
    for i in range(d_layers):  # back to front
        s = stack.disparities[i] * offset
        assert s == int(s)
        s = int(s)
        for y in range(h):
            for x in range(w):
                src = stack.rgba[i, y, x + s] if 0 <= x + s < w else np.zeros(4)
                out[y, x] = _over_py(src, out[y, x])
    return out


@pytest.mark.parametrize("position", [-1.0, 0.0, 0.5, 1.0, 2.0, 3.0])
def test_render_view_equals_an_integer_shift_and_composite_reference(rng, position):
    # Views at 0, 1, 2; the virtual camera at 1. -1 and 3 are extrapolated, 0.5 interpolated.
    cam = Camera.from_positions([0.0, 1.0, 2.0], reference=1)
    rgba = _premultiplied(rng, (3, 4, 9))
    rgba[0] = [0.2, 0.3, 0.4, 1.0]  # opaque background at d = 2: shifting it opens holes at the frame edge
    stack = LayerStack(rgba, [2.0, 4.0, 6.0], cam)
    out = render_view(stack, position)
    offset = position - 1.0
    np.testing.assert_allclose(out, _render_by_integer_shifts(stack, offset), atol=1e-6)
    if offset == 0:
        np.testing.assert_allclose(out, flatten(stack), atol=1e-6)
    else:  # uncovered areas are left with alpha < 1, not filled
        assert out[..., 3].min() < 1.0


def test_render_view_reproduces_the_random_dot_stereogram_views():
    samples = pytest.importorskip("vfxstereo.samples")
    s = samples.random_dot_stereogram(shape=(16, 20), background_disparity=1.0)
    ref = s.camera.reference[0]
    for p, view in zip(s.positions, s.views, strict=True):
        out = render_view(s.stack, p)
        np.testing.assert_allclose(out[..., :3], view, atol=1e-6)
        np.testing.assert_allclose(out, _render_by_integer_shifts(s.stack, p - ref), atol=1e-6)
    # Extrapolated beyond the rig on both sides: still the integer shift-and-composite.
    for p in (-1.0, 6.0):
        np.testing.assert_allclose(render_view(s.stack, p), _render_by_integer_shifts(s.stack, p - ref),
                                   atol=1e-6)


def test_render_view_rejects_a_bad_position(rng):
    with pytest.raises(VfxStereoError, match="position"):
        render_view(_stack(rng), [1.0, 2.0, 3.0])
    with pytest.raises(VfxStereoError, match="position"):
        render_view(_stack(rng), np.nan)


# --------------------------------------------------------------------------------------------------------
# straight alpha


def test_premultiply_hand_computed():
    straight = np.array([[0.5, 0.25, 1.0, 0.5], [0.3, 0.6, 0.9, 0.0]], np.float32)
    np.testing.assert_allclose(premultiply(straight), [[0.25, 0.125, 0.5, 0.5], [0, 0, 0, 0]])
    assert premultiply(straight).dtype == np.float32
    assert premultiply(straight.astype(np.float64)).dtype == np.float64
    np.testing.assert_array_equal(straight[0], [0.5, 0.25, 1.0, 0.5])  # input untouched


def test_premultiply_unpremultiply_round_trip(rng):
    straight = rng.uniform(size=(6, 7, 4)).astype(np.float32)
    straight[..., 3] = rng.uniform(0.01, 1.0, size=(6, 7))
    np.testing.assert_allclose(unpremultiply(premultiply(straight)), straight, rtol=1e-5, atol=1e-6)
    pre = _premultiplied(rng, (6, 7))  # includes alpha 0 pixels (colour 0)
    back = premultiply(unpremultiply(pre))
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(back, pre, rtol=1e-5, atol=1e-7)


def test_unpremultiply_is_safe_at_alpha_zero():
    pre = np.array([[0.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3, 0.0], [0.2, 0.1, 0.0, 0.5]], np.float32)
    out = unpremultiply(pre)
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out, [[0, 0, 0, 0], [0.1, 0.2, 0.3, 0.0], [0.4, 0.2, 0.0, 0.5]])


@pytest.mark.parametrize("fn", [premultiply, unpremultiply])
def test_straight_alpha_helpers_need_rgba(fn):
    with pytest.raises(VfxStereoError, match="RGBA"):
        fn(np.zeros((2, 2, 3), np.float32))


# --------------------------------------------------------------------------------------------------------
# errors


def test_element_of_another_size_names_both_sizes(rng):
    stack = _stack(rng, h=5, w=6)
    with pytest.raises(VfxStereoError, match=r"7x5 \(WxH\).*6x5"):
        insert(stack, np.zeros((5, 7, 4), np.float32), disparity=1.0)


def test_depth_or_disparity_map_of_another_size_names_both_sizes(rng):
    stack = _stack(rng, h=5, w=6)
    element = np.zeros((5, 6, 4), np.float32)
    with pytest.raises(VfxStereoError, match=r"depth is 6x4 \(WxH\).*6x5"):
        insert(stack, element, depth=np.ones((4, 6)))
    with pytest.raises(VfxStereoError, match=r"6x4 \(WxH\).*6x5"):
        insert(stack, element, element_disparity=np.ones((4, 6)))
    with pytest.raises(VfxStereoError, match=r"6x4 \(WxH\).*6x5"):
        holdout(stack, np.ones((4, 6)))


@pytest.mark.parametrize("kwargs", [{}, {"disparity": 1.0, "depth": np.ones((5, 6))},
                                    {"disparity": 1.0, "element_disparity": np.ones((5, 6))}])
def test_insert_needs_exactly_one_placement(rng, kwargs):
    with pytest.raises(VfxStereoError, match="exactly one"):
        insert(_stack(rng), np.zeros((5, 6, 4), np.float32), **kwargs)


def test_insert_rejects_bad_elements_and_values(rng):
    stack = _stack(rng)
    with pytest.raises(VfxStereoError, match="RGBA"):
        insert(stack, np.zeros((5, 6, 3), np.float32), disparity=1.0)
    bad = np.zeros((5, 6, 4), np.float32)
    bad[0, 0, 0] = np.nan
    with pytest.raises(VfxStereoError, match="NaN"):
        insert(stack, bad, disparity=1.0)
    with pytest.raises(VfxStereoError, match="NaN"):
        insert(stack, np.zeros((5, 6, 4), np.float32), disparity=np.nan)
    with pytest.raises(VfxStereoError, match="camera"):
        insert(stack, np.zeros((5, 6, 4), np.float32), disparity=1.0, camera=Camera.from_positions([0, 1]))
    with pytest.raises(VfxStereoError, match="LayerStack"):
        insert(stack.rgba, np.zeros((5, 6, 4), np.float32), disparity=1.0)


# --------------------------------------------------------------------------------------------------------
# Composing into the plate (issue 7, part 1)


def _with_plate(stack, plate):
    return LayerStack(stack.rgba, stack.disparities, stack.camera, white=stack.white, plate=plate)


def _element_with_holes(rng, h, w):
    """An element that is empty on about half the frame, soft and opaque elsewhere."""
    element = _premultiplied(rng, (h, w), opaque_fraction=0.3, empty_fraction=0.5)
    element[: h // 3] = 0.0  # whole empty rows too
    return element


@pytest.mark.parametrize("D", [0.5, 2.0, 3.0])
def test_insert_keeps_the_plate_bit_for_bit_where_the_element_is_empty(rng, D):
    from vfxstereo import samples

    scene = samples.transparent_edge_stereogram(shape=(48, 48), seed=1)
    truth = scene.stack
    plate = scene.reference_view
    # A stack with re-synthesis errors, as a solve leaves them: blurred colour, a seam, wrong alpha here and there.
    rgba = truth.rgba.copy()
    rgba[..., :3] *= 0.9
    rgba[:, :, 20:22] = rgba[:, :, 19:20]
    rgba[..., 3] = np.maximum(rgba[..., 3], rgba[..., :3].max(axis=-1))
    solved = _with_plate(LayerStack(rgba, truth.disparities, truth.camera), plate)
    h, w = plate.shape[:2]
    element = _element_with_holes(rng, h, w)
    comp = insert(solved, element, disparity=D)
    empty = ~np.any(element != 0, axis=-1)
    assert empty.sum() > h * w // 3
    np.testing.assert_array_equal(comp[empty][:, :3], plate[empty])
    np.testing.assert_array_equal(comp[empty][:, 3], 1.0)
    # ... while composing into the stack shows the stack's errors there
    assert np.abs(insert(solved, element, disparity=D, into="stack")[empty][:, :3] - plate[empty]).max() > 0.01


@pytest.mark.parametrize("D", [0.5, 2.0, 3.0])
def test_insert_into_plate_with_the_true_stack_is_the_true_comp(rng, D):
    from vfxstereo import samples

    scene = samples.transparent_edge_stereogram(shape=(48, 48), seed=2)
    plate = scene.reference_view
    np.testing.assert_allclose(scene.stack.flatten()[..., :3], plate, atol=1e-5)  # the plate is the stack's view
    element = _element_with_holes(rng, *plate.shape[:2])
    truth = insert(scene.stack, element, disparity=D, into="stack")
    np.testing.assert_allclose(insert(_with_plate(scene.stack, plate), element, disparity=D), truth, atol=1e-5)


def test_insert_into_plate_formula_against_pixels(rng):
    from vfxstereo.composite import insert_into_plate

    h, w = 4, 5
    front, element, back = (_premultiplied(rng, (h, w)) for _ in range(3))
    plate = rng.uniform(size=(h, w, 3)).astype(np.float32)
    out = insert_into_plate(plate, front, element, back)
    for y in range(h):
        for x in range(w):
            p = [*plate[y, x].tolist(), 1.0]
            see = 1.0 - front[y, x, 3]
            want = [p[c] + see * element[y, x, c] - element[y, x, 3] * min(see * back[y, x, c], p[c])
                    for c in range(4)]
            np.testing.assert_allclose(out[y, x], want, atol=1e-6)
    # an over-estimated back never takes out more than the plate holds
    assert (insert_into_plate(plate * 0.01, front, element, back * 0 + 1) >= -1e-7).all()


def test_insert_without_a_plate_composes_into_the_layers(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    np.testing.assert_allclose(insert(stack, element, disparity=1.5),
                               insert(stack, element, disparity=1.5, into="stack"), atol=1e-6)
    np.testing.assert_allclose(insert(stack, element, disparity=1.5, plate=stack.flatten()),
                               insert(stack, element, disparity=1.5, into="stack"), atol=1e-5)


def test_insert_plate_errors(rng):
    stack = _stack(rng)
    element = _premultiplied(rng, stack.shape[1:])
    with pytest.raises(VfxStereoError, match="into="):
        insert(stack, element, disparity=1.0, into="over")
    with pytest.raises(VfxStereoError, match="plate"):
        insert(stack, element, disparity=1.0, plate=np.zeros((3, 3, 3), np.float32))
    with pytest.raises(VfxStereoError, match="plate"):
        LayerStack(stack.rgba, stack.disparities, plate=np.zeros((2, 2, 3), np.float32))
    with pytest.raises(VfxStereoError, match="NaN"):
        LayerStack(stack.rgba, stack.disparities, plate=np.full((*stack.shape[1:], 3), np.nan, np.float32))
