"""Blender 5.0 reads what vfxstereo writes: the stack as a multilayer image (one layer per disparity and the
plate, exact pixels), flat comps and disparity maps exactly, and a deep file as its flattened image."""

import ast
import re

import numpy as np
import pytest

from tests.blender.conftest import render_to_array
from vfxstereo.io import exr
from vfxstereo.stack import LayerStack

bpy = pytest.importorskip("bpy")

H, W = 12, 16


@pytest.fixture
def stack_file(tmp_path, rng):
    D = 3
    alpha = rng.uniform(0.1, 1.0, (D, H, W)).astype(np.float32)
    alpha[rng.random((D, H, W)) < 0.3] = 0.0
    rgb = rng.random((D, H, W, 3)).astype(np.float32) * alpha[..., None]
    stack = LayerStack(np.concatenate([rgb, alpha[..., None]], -1), [-1.0, 0.5, 2.25])
    return stack, exr.write_stack(tmp_path / "stack.exr", stack, half=False)


@pytest.fixture
def scene(comp_scene):
    """An empty scene whose compositing tree has one output (tests/blender/conftest.py)."""
    return comp_scene


def layer_menu(node) -> list[str]:
    """The Image node's layer menu: its items are dynamic, so read them from the error a bad name raises."""
    with pytest.raises(TypeError) as info:
        node.layer = "no such layer"
    found = re.search(r"not found in (\(.*\))", str(info.value))
    assert found, str(info.value)
    items = ast.literal_eval(found.group(1))
    return [items] if isinstance(items, str) else list(items)


def test_blender_lists_one_layer_per_disparity(stack_file, scene):
    stack, path = stack_file
    image = bpy.data.images.load(str(path))
    node = scene.compositing_node_group.nodes.new("CompositorNodeImage")
    node.image = image
    assert image.type == "MULTILAYER"
    names = exr.layer_names(stack.disparities)
    assert layer_menu(node) == names
    for name in names:
        node.layer = name
        assert node.layer == name
        assert {"Combined", "Alpha"} <= {o.name for o in node.outputs}


def render(scene, path, tmp_path, *, layer=None, output=None) -> np.ndarray:
    """Load ``path`` in an Image node, render its ``output`` to an EXR, return the RGBA rendered (top-down)."""
    tree = scene.compositing_node_group
    node = tree.nodes.new("CompositorNodeImage")
    node.image = bpy.data.images.load(str(path))
    if layer is not None:
        node.layer = layer
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(node.outputs[output or ("Combined" if layer is not None else "Image")], out.inputs["Image"])
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    return render_to_array(scene, tmp_path / "render.exr")  # a file: top-down, like ours


def test_blender_renders_a_layer_exactly(stack_file, scene, tmp_path):
    stack, path = stack_file
    rgba = render(scene, path, tmp_path, layer=exr.layer_names(stack.disparities)[1])
    np.testing.assert_array_equal(rgba, stack.rgba[1])
    assert not np.array_equal(rgba, stack.rgba[0])


def test_blender_reads_the_plate_layer_of_a_stack_with_general_cameras(scene, tmp_path, rng):
    """The plate is one more layer; worldToCamera, worldToNDC, framesPerSecond, timeCode do not disturb it."""
    from vfxstereo.geometry import Camera
    from vfxstereo.homography import rectified_rig_matrices

    M, M0 = rectified_rig_matrices([0.0, 1.0], 0.0, (H, W), focal=30.0)
    camera = Camera(positions=[0.0, 1.0], reference=0.0, matrices=M, M0=M0)
    rgba = np.zeros((2, H, W, 4), np.float32)
    rgba[1, 2:6, 3:9] = [0.2, 0.1, 0.05, 0.5]
    plate = rng.uniform(0.0, 2.0, (H, W, 3)).astype(np.float32)
    stack = LayerStack(rgba, [0.0, 1.5], camera=camera, plate=plate,
                       metadata={"frames_per_second": [25, 1], "time_code": [0x10000000, 0],
                                 "source_files": ["l.exr", "r.exr"]})
    path = exr.write_stack(tmp_path / "stack.exr", stack, half=False)
    node = scene.compositing_node_group.nodes.new("CompositorNodeImage")
    node.image = bpy.data.images.load(str(path))
    assert layer_menu(node) == exr.layer_names(stack.disparities) + [exr.PLATE_LAYER]
    got = render(scene, path, tmp_path, layer=exr.PLATE_LAYER)
    np.testing.assert_array_equal(got[..., :3], plate)
    np.testing.assert_array_equal(got[..., 3], 1.0)


def test_blender_reads_a_flat_comp_exactly(scene, tmp_path, rng):
    comp = rng.uniform(0.0, 1.0, (H, W, 4)).astype(np.float32)
    comp[..., :3] *= comp[..., 3:]
    image = bpy.data.images.load(str(exr.write_image(tmp_path / "comp.exr", comp)))
    assert image.type == "IMAGE"
    np.testing.assert_array_equal(render(scene, image.filepath, tmp_path), comp)


def test_blender_reads_a_disparity_map_exactly(scene, tmp_path, rng):
    disparity = rng.uniform(-2.0, 40.0, (H, W)).astype(np.float32)
    path = exr.write_disparity(tmp_path / "disparity.exr", disparity)
    rgba = render(scene, path, tmp_path)
    for c in range(3):  # grey: the Y channel in R, G and B
        np.testing.assert_array_equal(rgba[..., c], disparity)


def test_blender_shows_a_deep_file_as_its_flattened_image(scene, tmp_path, stack_file):
    """Not a deep reader: OpenEXR composites the samples when Blender opens the file; that is all it shows."""
    stack, _ = stack_file
    path = exr.write_deep(tmp_path / "deep.exr", stack)
    image = bpy.data.images.load(str(path))
    assert image.type == "IMAGE"
    node = scene.compositing_node_group.nodes.new("CompositorNodeImage")
    node.image = image
    assert [o.name for o in node.outputs] == ["Image", "Alpha"]  # no Z, no samples, no layers
    np.testing.assert_allclose(render(scene, path, tmp_path), stack.flatten(), atol=2e-6)
