"""The z-key compositor tree: a render (or any image) between the layers of a stack, with a holdout.

Assembled from the groups of this package::

    stack EXR layers ─┬─► Stack Split (n) ──► Front, Back ─┐
                      └─► Layer Holdout (n) ──► Holdout     ├─► Z-Key Insert ──► Image (the comp)
    plate layer (or Front over Back) ──────────────────────┤
    element: the scene's render, or an image ──────────────┘
    Element Disparity (a Value node) ─► Stack Split, Layer Holdout

It reproduces :func:`vfxstereo.composite.insert` with ``disparity=D``: ``into="plate"`` composes into the
stack's plate layer, ``into="stack"`` (or a stack without its plate) into ``Front over Back``.
"""

from __future__ import annotations

import bpy

from ._build import GroupBuilder
from .layer_holdout import build_layer_holdout
from .premultiplied_over import build_premultiplied_over
from .stack_split import build_stack_split
from .zkey_insert import build_zkey_insert

OUTPUTS = ("Image", "Holdout")
"""The tree's outputs: the comp (the scene's composite) and the matte of the layers in front of the element."""


def build_zkey_tree(name: str, image, layer_names, disparities, *, disparity: float, element=None,
                    plate_layer: str | None = None, into: str = "plate"):
    """A compositing node tree that z-keys an element between the layers of a stack.

    Parameters
    ----------
    name : str
        Name of the tree in ``bpy.data.node_groups``; an existing tree of that name is emptied and rebuilt.
    image : bpy.types.Image
        The stack EXR, loaded (a multilayer image: one Image node per layer picks its layer by name).
    layer_names : sequence of str
        The stack's layer names, back to front (``vfxstereo.io.stackinfo.StackInfo.layer_names``).
    disparities : sequence of float
        Their exact disparities.
    disparity : float
        Where the element goes (the value of the tree's ``Element Disparity`` node, editable afterwards).
    element : bpy.types.Image or None
        The element: an image (premultiplied), or None for the scene's own render (Render Layers).
    plate_layer : str or None
        The stack's plate layer, when it has one.
    into : {"plate", "stack"}
        Compose into the plate (when there is one) or into the stack's own flatten.

    Returns
    -------
    bpy.types.CompositorNodeTree
        Outputs ``Image`` (the premultiplied comp) and ``Holdout`` (the matte, as a grey image).
    """
    if into not in ("plate", "stack"):
        raise ValueError(f"into must be 'plate' or 'stack', got {into!r}")
    n = len(layer_names)
    if n != len(disparities) or n == 0:
        raise ValueError(f"{n} layer names for {len(disparities)} disparities")
    tree = bpy.data.node_groups.get(name)
    if tree is None or tree.bl_idname != "CompositorNodeTree":
        tree = bpy.data.node_groups.new(name, "CompositorNodeTree")
    tree.nodes.clear()
    tree.interface.clear()
    g = GroupBuilder(tree, group_inputs=False)

    value = g.node("ShaderNodeValue", 0)
    value.name = value.label = "Element Disparity"
    value.outputs[0].default_value = float(disparity)
    layer_inputs = {"Disparity": value.outputs[0]}
    for i, (layer, d) in enumerate(zip(layer_names, disparities, strict=True)):
        node = g.node("CompositorNodeImage", 0)
        node.image = image
        node.layer = layer
        node.name, node.label = layer, f"{layer} (d = {float(d):g})"
        node.hide = True
        layer_inputs[f"Layer {i}"] = node.outputs["Combined"]
        layer_inputs[f"Layer {i} Disparity"] = float(d)
    split = _group_node(g, build_stack_split(n), 1, layer_inputs)
    matte = _group_node(g, build_layer_holdout(n), 1, layer_inputs)
    front, back = split.outputs["Front"], split.outputs["Back"]

    if into == "plate" and plate_layer:
        plate_node = g.node("CompositorNodeImage", 2)
        plate_node.image = image
        plate_node.layer = plate_layer
        plate_node.name = plate_node.label = "Plate"
        plate = plate_node.outputs["Combined"]
    else:
        plate = g.group_node(build_premultiplied_over(), 2, Foreground=front, Background=back).outputs["Image"]
    if element is None:
        element_node = g.node("CompositorNodeRLayers", 2)
        element_out = element_node.outputs["Image"]
    else:
        element_node = g.node("CompositorNodeImage", 2)
        element_node.image = element
        element_out = element_node.outputs["Image"]
    element_node.name = element_node.label = "Element"
    insert = g.group_node(build_zkey_insert(), 3, Plate=plate, Front=front, Element=element_out, Back=back)
    g.output("Image", "NodeSocketColor", "The comp: the element between the layers, premultiplied",
             insert.outputs["Comp"])
    g.output("Holdout", "NodeSocketFloat", "Matte of the layers in front of the element", matte.outputs["Matte"])
    return tree


def _group_node(g, group_tree, column, inputs):
    node = g.group_node(group_tree, column)
    for key, value in inputs.items():
        g.feed(node.inputs[key], value)
    return node
