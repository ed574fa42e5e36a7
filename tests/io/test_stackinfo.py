"""Header-only and one-layer reads of a stack file agree with read_stack, which reads it all."""

import numpy as np
import pytest

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo.io import exr
from vfxstereo.io.stackinfo import read_stack_info, read_stack_layer


def _stack(rng, plate=True, disparities=(-1.0, 0.5, 2.25, 3.0)):
    D, H, W = len(disparities), 5, 7
    alpha = rng.uniform(0, 1, (D, H, W, 1)).astype(np.float32)
    rgba = np.concatenate([rng.uniform(0, 1, (D, H, W, 3)).astype(np.float32) * alpha, alpha], -1)
    cam = Camera.from_positions([0, 1, 2], focal=500.0, baseline=0.1)
    return LayerStack(rgba, disparities, camera=cam, metadata={"k": 1},
                      plate=rng.uniform(0, 1, (H, W, 3)).astype(np.float32) if plate else None)


@pytest.mark.parametrize("plate", [True, False])
def test_info_is_the_header_read_stack_sees(tmp_path, rng, plate):
    stack = _stack(rng, plate)
    path = exr.write_stack(tmp_path / "s.exr", stack, half=False)
    info = read_stack_info(path)
    assert (info.width, info.height, info.depth) == (7, 5, 4)
    np.testing.assert_array_equal(info.disparities, stack.disparities)
    assert list(info.layer_names) == exr.layer_names(stack.disparities)
    assert info.camera == stack.camera and info.metadata == stack.metadata
    assert info.plate_layer == ("plate" if plate else None)


def test_each_layer_and_the_plate_read_alone_equal_the_whole_read(tmp_path, rng):
    stack = _stack(rng)
    path = exr.write_stack(tmp_path / "s.exr", stack, half=False)
    whole = exr.read_stack(path)
    names = exr.layer_names(stack.disparities)
    for i, name in enumerate(names):
        np.testing.assert_array_equal(read_stack_layer(path, i), whole.rgba[i])
        np.testing.assert_array_equal(read_stack_layer(path, name), whole.rgba[i])
    np.testing.assert_array_equal(read_stack_layer(path, -1), whole.rgba[-1])
    plate = read_stack_layer(path, "plate")
    np.testing.assert_array_equal(plate[..., :3], whole.plate)
    np.testing.assert_array_equal(plate[..., 3], 1.0)


def test_missing_file_and_foreign_files_are_one_line_errors(tmp_path, rng):
    with pytest.raises(VfxStereoError, match="not found"):
        read_stack_info(tmp_path / "nope.exr")
    flat = exr.write_image(tmp_path / "flat.exr", rng.uniform(0, 1, (4, 4, 4)).astype(np.float32))
    with pytest.raises(VfxStereoError, match="not a vfxstereo"):
        read_stack_info(flat)


def test_a_layer_the_file_lacks_is_refused_naming_the_ones_it_has(tmp_path, rng):
    path = exr.write_stack(tmp_path / "s.exr", _stack(rng, plate=False))
    with pytest.raises(VfxStereoError, match="no layer 4"):
        read_stack_layer(path, 4)
    with pytest.raises(VfxStereoError, match="L00_dm1p00"):
        read_stack_layer(path, "plate")
