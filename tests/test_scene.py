"""Plane placement for the Blender add-on: depth of each disparity, the camera frame at a depth, the planes.

Expected values are worked out by hand from the pinhole model (a frame of width ``Z * sensor / lens``) and
from Camera.depth_from_disparity; Blender's own view frame is compared in tests/blender/test_addon.py.
"""

import numpy as np
import pytest

from vfxstereo import Camera, VfxStereoError
from vfxstereo.scene import (
    FAR_FACTOR,
    CameraFrustum,
    DepthMapping,
    clip_range,
    depth_mapping,
    layout_planes,
    plane_depths,
)


def test_depth_mapping_prefers_the_given_value_then_the_camera():
    cam = Camera.from_positions([0, 1, 2], focal=800.0, baseline=0.05)
    assert depth_mapping(cam, 12.0) == DepthMapping(12.0, "given")
    assert depth_mapping(cam) == DepthMapping(40.0, "camera")
    assert depth_mapping(Camera.from_positions([0, 1, 2])) == DepthMapping(1.0, "none")
    assert depth_mapping(None, 0.0) == DepthMapping(1.0, "none")
    assert "40" in depth_mapping(cam).describe()


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_depth_mapping_refuses_a_bad_focal_baseline(bad):
    with pytest.raises(VfxStereoError, match="focal x baseline"):
        depth_mapping(None, bad)


def test_finite_layers_sit_where_the_camera_maps_them():
    cam = Camera.from_positions([0, 1, 2, 3], focal=1000.0, baseline=0.02)
    d = np.array([0.5, 1.0, 2.5, 4.0])
    z = plane_depths(d, depth_mapping(cam))
    np.testing.assert_allclose(z, cam.depth_from_disparity(d))
    np.testing.assert_allclose(z, [40.0, 20.0, 8.0, 5.0])


def test_layers_at_infinity_go_behind_the_farthest_finite_layer_in_order():
    d = np.array([-2.0, -1.0, 0.0, 1.0, 4.0])
    z = plane_depths(d, DepthMapping(2.0, "given"))
    assert np.all(np.isfinite(z)) and np.all(np.diff(z) < 0)
    np.testing.assert_allclose(z[3:], [2.0, 0.5])
    far = FAR_FACTOR * 2.0
    np.testing.assert_allclose(z[:3], [far * (1 + 2 / 3), far * (1 + 1 / 3), far])


def test_a_stack_entirely_at_infinity_still_gets_ordered_depths():
    z = plane_depths([-1.0, 0.0], DepthMapping(3.0, "given"))
    np.testing.assert_allclose(z, [FAR_FACTOR * 3.0 * 1.5, FAR_FACTOR * 3.0])


@pytest.mark.parametrize("bad", [[1.0, 1.0], [2.0, 1.0], [0.0, np.nan], []])
def test_plane_depths_refuses_unsorted_or_bad_disparities(bad):
    with pytest.raises(VfxStereoError):
        plane_depths(bad, DepthMapping(1.0, "none"))


def test_frame_of_a_landscape_camera_is_sensor_over_lens_times_depth():
    f = CameraFrustum(320, 225, lens=50.0, sensor_width=36.0)
    cx, cy, w, h = f.frame(10.0)
    assert (cx, cy) == (0.0, 0.0)
    assert w == pytest.approx(36.0 * 10.0 / 50.0)
    assert h == pytest.approx(w * 225 / 320)
    assert f.frame(20.0)[2] == pytest.approx(2 * w)  # perspective: grows with depth


def test_auto_fit_puts_the_sensor_width_on_the_longer_side():
    cx, cy, w, h = CameraFrustum(200, 400, lens=35.0, sensor_width=30.0).frame(7.0)
    assert h == pytest.approx(30.0 * 7.0 / 35.0)
    assert w == pytest.approx(h / 2)


def test_vertical_fit_uses_the_sensor_height():
    cx, cy, w, h = CameraFrustum(400, 200, lens=50.0, sensor_height=20.0, sensor_fit="VERTICAL").frame(5.0)
    assert h == pytest.approx(20.0 * 5.0 / 50.0)
    assert w == pytest.approx(2 * h)


def test_shift_moves_the_frame_by_a_fraction_of_the_fitted_side():
    cx, cy, w, h = CameraFrustum(300, 100, shift_x=0.25, shift_y=-0.1).frame(4.0)
    assert cx == pytest.approx(0.25 * w)
    assert cy == pytest.approx(-0.1 * w)  # the fitted (horizontal) side, not the height


def test_pixel_aspect_keeps_the_frame_the_shape_of_the_displayed_image():
    cx, cy, w, h = CameraFrustum(100, 100, pixel_aspect_x=2.0, pixel_aspect_y=1.0).frame(1.0)
    assert w / h == pytest.approx(2.0)


def test_orthographic_frame_does_not_grow_with_depth():
    f = CameraFrustum(320, 240, ortho_scale=6.0)
    assert f.frame(1.0) == f.frame(100.0)
    assert f.frame(1.0)[2:] == pytest.approx((6.0, 4.5))


@pytest.mark.parametrize("kwargs", [{"lens": 0.0}, {"width": -5}, {"sensor_fit": "DIAGONAL"},
                                    {"ortho_scale": float("nan")}])
def test_frustum_refuses_bad_camera_values(kwargs):
    with pytest.raises(VfxStereoError):
        CameraFrustum(**{"width": 64, "height": 48, **kwargs})


def test_layout_puts_each_plane_at_its_depth_facing_the_camera_and_filling_the_frame():
    frustum = CameraFrustum(64, 48, lens=40.0, sensor_width=32.0)
    mapping = DepthMapping(6.0, "given")
    planes = layout_planes([0.0, 1.5, 3.0], ["L00_d0p00", "L01_d1p50", "L02_d3p00"], frustum, mapping)
    assert [p.index for p in planes] == [0, 1, 2]
    assert [p.name for p in planes] == ["L00_d0p00", "L01_d1p50", "L02_d3p00"]
    assert planes[2].depth == pytest.approx(2.0) and planes[1].depth == pytest.approx(4.0)
    assert planes[0].depth > planes[1].depth  # d = 0 goes behind everything
    for p in planes:
        assert p.centre == pytest.approx((0.0, 0.0, -p.depth))
        assert p.size[0] == pytest.approx(p.depth * 32.0 / 40.0)
        assert p.size[1] == pytest.approx(p.size[0] * 48 / 64)


def test_layout_refuses_a_name_count_that_differs():
    with pytest.raises(VfxStereoError, match="names"):
        layout_planes([0.0, 1.0], ["a"], CameraFrustum(4, 4), DepthMapping(1.0, "none"))


def test_clip_range_widens_to_hold_every_plane_and_never_narrows():
    assert clip_range([0.1, 30.0], 0.1, 100.0) == (pytest.approx(0.05), 100.0)
    assert clip_range([2.0, 300.0], 0.1, 100.0) == (0.1, pytest.approx(450.0))
