"""Geometry: the shift warps are bilinear, zero outside, and exact adjoints; Camera bookkeeping."""

import numpy as np
import pytest

from vfxstereo import Camera, VfxStereoError
from vfxstereo.geometry import plane_to_view, shift_bilinear, view_to_plane


def _reference_shift(img, sx, sy):
    """Slow per-pixel bilinear sampling with zero outside (the definition)."""
    h, w = img.shape[:2]
    out = np.zeros_like(img, dtype=np.float64)
    for y in range(h):
        for x in range(w):
            u, v = x + sx, y + sy
            x0, y0 = int(np.floor(u)), int(np.floor(v))
            fx, fy = u - x0, v - y0
            for yy, wy in ((y0, 1 - fy), (y0 + 1, fy)):
                for xx, wx in ((x0, 1 - fx), (x0 + 1, fx)):
                    if 0 <= yy < h and 0 <= xx < w and wx * wy != 0:
                        out[y, x] += wx * wy * img[yy, xx]
    return out


@pytest.mark.parametrize("sx,sy", [(0.0, 0.0), (2.0, 0.0), (-1.25, 0.0), (0.5, -2.75), (7.5, 1.0), (-9.0, 0.0)])
def test_shift_bilinear_matches_per_pixel_sampling(rng, sx, sy):
    img = rng.uniform(0, 1, (6, 8, 3))
    np.testing.assert_allclose(shift_bilinear(img, sx, sy), _reference_shift(img, sx, sy), atol=1e-12)


@pytest.mark.parametrize("sx,sy", [(0.3, -1.7), (2.5, 0.25), (-3.0, 1.0), (4.9, -0.1)])
def test_shift_adjoint_is_exact(rng, sx, sy):
    a = rng.normal(size=(7, 9, 4))
    b = rng.normal(size=(7, 9, 4))
    lhs = np.sum(shift_bilinear(a, sx, sy) * b)
    rhs = np.sum(a * shift_bilinear(b, -sx, -sy))
    assert lhs == pytest.approx(rhs, rel=1e-12, abs=1e-12)


def test_plane_to_view_and_view_to_plane_follow_the_house_convention():
    layer = np.zeros((1, 10), np.float32)
    layer[0, 5] = 1.0
    # view at offset p_k - p_ref = +1, plane d = 2: x=5 appears at 5 - 2 = 3
    assert np.argmax(plane_to_view(layer, 2.0, (1.0, 0.0))[0]) == 3
    view = np.zeros((1, 10), np.float32)
    view[0, 3] = 1.0
    assert np.argmax(view_to_plane(view, 2.0, (1.0, 0.0))[0]) == 5


def test_near_whole_shifts_are_snapped_to_exact_integers():
    img = np.arange(10, dtype=np.float32)[None]
    np.testing.assert_array_equal(shift_bilinear(img, 3 * 0.1 * 10), shift_bilinear(img, 3.0))


def test_camera_from_positions_and_offsets():
    cam = Camera.from_positions([0, 1, 2, 3, 4])
    assert cam.reference_index == 2 and cam.K == 5
    np.testing.assert_array_equal(cam.view_offset(0), [-2, 0])
    np.testing.assert_array_equal(cam.offset(3.5), [1.5, 0])
    # a number is a position, never a view index, whatever its type
    np.testing.assert_array_equal(cam.offset(np.int64(0)), [-2, 0])
    np.testing.assert_array_equal(cam.offset(np.int64(4)), [2, 0])
    np.testing.assert_array_equal(Camera.from_positions([0, 2, 4], reference=1).offset(np.int64(2)), [0, 0])
    assert Camera.from_dict(cam.to_dict()) == cam


def test_camera_rejects_bad_input():
    with pytest.raises(VfxStereoError):
        Camera.from_positions([0, 1], reference=5)
    with pytest.raises(VfxStereoError):
        Camera(positions=np.zeros((3, 3)), reference=0)
    with pytest.raises(VfxStereoError):
        Camera.from_dict({"positions": [0, 1]})


def test_depth_mapping_uses_focal_and_baseline_when_known():
    d = np.array([0.0, 1.0, 4.0])
    np.testing.assert_allclose(Camera.from_positions([0, 1]).depth_from_disparity(d), [np.inf, 1.0, 0.25])
    cam = Camera.from_positions([0, 1], focal=1000.0, baseline=0.1)
    np.testing.assert_allclose(cam.depth_from_disparity(d), [np.inf, 100.0, 25.0])
    np.testing.assert_allclose(cam.disparity_from_depth(cam.depth_from_disparity(d)), d)
