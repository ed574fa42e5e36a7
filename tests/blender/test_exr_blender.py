"""Blender 5.0 reads write_stack's file as a multilayer image: one layer per disparity, exact pixels."""

import ast
import re

import numpy as np
import pytest

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
def scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    tree = bpy.data.node_groups.new("vfxstereo_test", "CompositorNodeTree")
    tree.interface.new_socket(name="Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    sc.compositing_node_group = tree
    sc.render.use_compositing = True
    yield sc
    bpy.ops.wm.read_factory_settings(use_empty=True)


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


def test_blender_renders_a_layer_exactly(stack_file, scene, tmp_path):
    stack, path = stack_file
    tree = scene.compositing_node_group
    node = tree.nodes.new("CompositorNodeImage")
    node.image = bpy.data.images.load(str(path))
    node.layer = exr.layer_names(stack.disparities)[1]
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(node.outputs["Combined"], out.inputs["Image"])
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    settings = scene.render.image_settings
    settings.media_type = "IMAGE"
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    scene.render.filepath = str(tmp_path / "render.exr")
    bpy.ops.render.render(write_still=True)
    pixels, names, _ = exr.read_image(tmp_path / "render.exr")  # a file: top-down, like the stack
    rgba = pixels[..., [names.index(c) for c in "RGBA"]]
    np.testing.assert_array_equal(rgba, stack.rgba[1])
    assert not np.array_equal(rgba, stack.rgba[0])
