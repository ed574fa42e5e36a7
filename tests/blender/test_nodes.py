"""Every compositor node group of nodes/, rendered headless, equals its reference in vfxstereo.composite."""

import numpy as np
import pytest

import nodes
from nodes import _build
from tests.blender.conftest import image_from_array, render_to_array
from vfxstereo import LayerStack, composite

bpy = pytest.importorskip("bpy")

H, W = 6, 8
TOL = 1e-4  # float32 compositing against float32 numpy
DISPARITIES = [-1.0, 0.5, 2.0, 3.25]


def premultiplied(rng, shape=(H, W)):
    """Random premultiplied RGBA with empty, soft and opaque pixels."""
    alpha = rng.uniform(0.05, 0.95, shape)
    u = rng.random(shape)
    alpha[u < 0.25] = 0.0
    alpha[u > 0.75] = 1.0
    rgb = rng.uniform(0, 1, (*shape, 3)) * alpha[..., None]
    return np.concatenate([rgb, alpha[..., None]], -1).astype(np.float32)


def image_node(tree, name, pixels):
    node = tree.nodes.new("CompositorNodeImage")
    node.image = image_from_array(name, pixels)
    return node.outputs["Image"]


def grey_node(tree, name, values):
    """A per-pixel float from the red channel of an image holding ``values``."""
    sep = tree.nodes.new("CompositorNodeSeparateColor")
    tree.links.new(image_node(tree, name, values), sep.inputs["Image"])
    return sep.outputs["Red"]


def render_output(scene, tmp_path, socket):
    """Render with ``socket`` wired to the scene's composite output."""
    tree = scene.compositing_node_group
    out = next((n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"), None) or tree.nodes.new(
        "NodeGroupOutput")
    tree.links.new(socket, out.inputs["Image"])
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = W, H, 100
    return render_to_array(scene, tmp_path / "out.exr")


def group_node(tree, group):
    node = tree.nodes.new("CompositorNodeGroup")
    node.node_tree = group
    return node


def test_every_group_has_its_documented_typed_sockets():
    expected = {
        nodes.build_premultiplied_over(): {"Foreground": "NodeSocketColor", "Background": "NodeSocketColor",
                                           "Factor": "NodeSocketFloat", "Image": "NodeSocketColor"},
        nodes.build_zkey_insert(): {"Plate": "NodeSocketColor", "Front": "NodeSocketColor",
                                    "Element": "NodeSocketColor", "Back": "NodeSocketColor",
                                    "Comp": "NodeSocketColor"},
        nodes.build_layer_holdout(2): {"Disparity": "NodeSocketFloat", "Layer 0": "NodeSocketColor",
                                       "Layer 0 Disparity": "NodeSocketFloat", "Layer 1": "NodeSocketColor",
                                       "Layer 1 Disparity": "NodeSocketFloat", "Matte": "NodeSocketFloat"},
        nodes.build_stack_split(2): {"Disparity": "NodeSocketFloat", "Layer 0": "NodeSocketColor",
                                     "Layer 0 Disparity": "NodeSocketFloat", "Layer 1": "NodeSocketColor",
                                     "Layer 1 Disparity": "NodeSocketFloat", "Front": "NodeSocketColor",
                                     "Back": "NodeSocketColor"},
    }
    for group, sockets in expected.items():
        items = {s.name: s for s in group.interface.items_tree if s.item_type == "SOCKET"}
        assert {k: s.socket_type for k, s in items.items()} == sockets, group.name
        assert all(s.description for s in items.values()), group.name
        assert "premultiplied" in group.description.lower() and "Reference: vfxstereo.composite." in (
            group.description), group.name


def test_groups_are_reused_and_rebuilt_when_an_older_version_made_them():
    group = nodes.build_zkey_insert()
    assert nodes.build_zkey_insert() is group
    group[_build.VERSION_KEY] = _build.BUILD_VERSION - 1
    n_nodes = len(group.nodes)
    group.nodes.new("CompositorNodeRGB")  # a stray node an old version might have had
    rebuilt = nodes.build_zkey_insert()
    assert rebuilt is group and len(group.nodes) == n_nodes and group[_build.VERSION_KEY] == _build.BUILD_VERSION


@pytest.mark.parametrize("factor", [1.0, 0.0, 0.4])
def test_premultiplied_over_matches_composite_over(comp_scene, tmp_path, rng, factor):
    fg, bg = premultiplied(rng), premultiplied(rng)
    tree = comp_scene.compositing_node_group
    node = group_node(tree, nodes.build_premultiplied_over())
    tree.links.new(image_node(tree, "fg", fg), node.inputs["Foreground"])
    tree.links.new(image_node(tree, "bg", bg), node.inputs["Background"])
    node.inputs["Factor"].default_value = factor
    got = render_output(comp_scene, tmp_path, node.outputs["Image"])
    expected = composite.over(factor * fg, bg) if factor not in (0.0, 1.0) else (
        composite.over(fg, bg) if factor == 1.0 else bg)
    assert np.abs(got - expected).max() < TOL
    if factor == 1.0:
        assert not np.allclose(got, bg, atol=0.05) and not np.allclose(got, fg, atol=0.05)


def test_zkey_insert_matches_insert_into_plate(comp_scene, tmp_path, rng):
    plate = np.concatenate([rng.uniform(0, 1, (H, W, 3)), np.ones((H, W, 1))], -1).astype(np.float32)
    front, element, back = premultiplied(rng), premultiplied(rng), premultiplied(rng)
    tree = comp_scene.compositing_node_group
    node = group_node(tree, nodes.build_zkey_insert())
    for name, px in (("Plate", plate), ("Front", front), ("Element", element), ("Back", back)):
        tree.links.new(image_node(tree, name, px), node.inputs[name])
    got = render_output(comp_scene, tmp_path, node.outputs["Comp"])
    expected = composite.insert_into_plate(plate, front, element, back)
    # the min() must have been exercised both ways for the test to mean something
    seen = (1 - front[..., 3:4]) * back
    assert (seen > plate).any() and (seen < plate).any()
    assert np.abs(got - expected).max() < TOL


def _stack_inputs(tree, node, rng):
    stack = LayerStack(np.stack([premultiplied(rng) for _ in DISPARITIES]), DISPARITIES)
    for i, d in enumerate(DISPARITIES):
        tree.links.new(image_node(tree, f"L{i}", stack.rgba[i]), node.inputs[f"Layer {i}"])
        node.inputs[f"Layer {i} Disparity"].default_value = d
    return stack


def _disparity_cases(rng):
    per_pixel = rng.choice([-2.0, 0.5, 1.0, 2.0, 3.0, 4.0], size=(H, W)).astype(np.float32)
    return [("between", 1.0), ("on a plane", 2.0), ("behind all", -5.0), ("before all", 9.0),
            ("per pixel", per_pixel)]


def _stack_group(tree, group, rng, case):
    """A group node fed a random 4-layer stack and one of the disparity cases; the stack and the case."""
    node = group_node(tree, group)
    stack = _stack_inputs(tree, node, rng)
    label, D = _disparity_cases(rng)[case]
    if np.ndim(D):
        tree.links.new(grey_node(tree, "D", D), node.inputs["Disparity"])
    else:
        node.inputs["Disparity"].default_value = D
    return node, stack, label, D


@pytest.mark.parametrize("case", range(5))
def test_layer_holdout_matches_composite_holdout(comp_scene, tmp_path, rng, case):
    tree = comp_scene.compositing_node_group
    node, stack, label, D = _stack_group(tree, nodes.build_layer_holdout(len(DISPARITIES)), rng, case)
    got = render_output(comp_scene, tmp_path, node.outputs["Matte"])
    assert np.abs(got[..., 0] - composite.holdout(stack, D)).max() < TOL, label


@pytest.mark.parametrize("case", range(5))
def test_stack_split_matches_composite_split(comp_scene, tmp_path, rng, case):
    tree = comp_scene.compositing_node_group
    node, stack, label, D = _stack_group(tree, nodes.build_stack_split(len(DISPARITIES)), rng, case)
    front, back = composite.split(stack, D)
    assert np.abs(render_output(comp_scene, tmp_path, node.outputs["Front"]) - front).max() < TOL, label
    assert np.abs(render_output(comp_scene, tmp_path, node.outputs["Back"]) - back).max() < TOL, label
