"""Helpers the group builders share: a compositor node group made from code, sockets with descriptions, math.

Every builder in this package makes its group through :func:`group`: the group is looked up by name and
reused when it was built by the same :data:`BUILD_VERSION`; otherwise (a new file, or a group from an
older vfxstereo) it is emptied and rebuilt in place, so node trees that use it pick up the new version.
"""

from __future__ import annotations

import bpy

BUILD_VERSION = 1
"""Bumped whenever a builder changes what it makes: older groups of the same name are rebuilt."""

VERSION_KEY = "vfxstereo_build_version"
"""Custom property of every group made here, holding :data:`BUILD_VERSION`."""

COLUMN = 220.0
"""Horizontal spacing of node columns in a built group, for a readable layout."""


class GroupBuilder:
    """A compositor node group under construction: sockets, nodes and links by short calls.

    Parameters
    ----------
    tree : bpy.types.CompositorNodeTree
        An empty group (see :func:`group`) or compositing tree.
    group_inputs : bool
        Make a Group Input node (a scene's compositing tree has no inputs).
    """

    def __init__(self, tree, *, group_inputs: bool = True):
        self.tree = tree
        self.inputs = tree.nodes.new("NodeGroupInput") if group_inputs else None
        self.outputs = tree.nodes.new("NodeGroupOutput")
        if self.inputs is not None:
            self.inputs.location = (-COLUMN, 0.0)
        self._rows: dict[int, int] = {}

    # Sockets ---------------------------------------------------------------------------------------------
    def input(self, name: str, socket_type: str, description: str, *, default=None, min_value=None,
              max_value=None):
        """Add an input socket and return the Group Input node's output for it."""
        s = self.tree.interface.new_socket(name=name, in_out="INPUT", socket_type=socket_type,
                                           description=description)
        if default is not None:
            s.default_value = default
        if min_value is not None:
            s.min_value = min_value
        if max_value is not None:
            s.max_value = max_value
        return self.inputs.outputs[name]

    def output(self, name: str, socket_type: str, description: str, source) -> None:
        """Add an output socket fed by ``source`` (a node output)."""
        self.tree.interface.new_socket(name=name, in_out="OUTPUT", socket_type=socket_type,
                                       description=description)
        self.tree.links.new(source, self.outputs.inputs[name])

    # Nodes -----------------------------------------------------------------------------------------------
    def node(self, bl_idname: str, column: int, **inputs):
        """A new node in layout column ``column``; ``inputs`` maps input names to sockets or constant values."""
        n = self.tree.nodes.new(bl_idname)
        row = self._rows.get(column, 0)
        self._rows[column] = row + 1
        n.location = (column * COLUMN, -row * 180.0)
        self.outputs.location = (max(self.outputs.location[0], (column + 1) * COLUMN), 0.0)
        for name, value in inputs.items():
            self.feed(n.inputs[name.replace("_", " ")], value)
        return n

    def feed(self, socket, value) -> None:
        """Link a node output into ``socket``, or set its constant value."""
        if isinstance(value, bpy.types.NodeSocket):
            self.tree.links.new(value, socket)
        else:
            socket.default_value = value

    def math(self, operation: str, a, b=None, *, column: int):
        """``a <operation> b`` per pixel (ShaderNodeMath, unclamped, float32); returns the result socket."""
        n = self.node("ShaderNodeMath", column)
        n.operation = operation
        n.use_clamp = False
        self.feed(n.inputs[0], a)
        if b is not None:
            self.feed(n.inputs[1], b)
        return n.outputs[0]

    def separate(self, image, *, column: int):
        """The R, G, B, A channels of an RGBA socket, as stored (premultiplied stays premultiplied)."""
        n = self.node("CompositorNodeSeparateColor", column, Image=image)
        n.mode = "RGB"
        return [n.outputs[c] for c in ("Red", "Green", "Blue", "Alpha")]

    def combine(self, channels, *, column: int):
        """An RGBA socket from four channel sockets or values, stored as given."""
        n = self.node("CompositorNodeCombineColor", column, Red=channels[0], Green=channels[1],
                      Blue=channels[2], Alpha=channels[3])
        n.mode = "RGB"
        return n.outputs["Image"]

    def group_node(self, tree, column: int, **inputs):
        """A node using the node group ``tree``; ``inputs`` as for :meth:`node`."""
        n = self.node("CompositorNodeGroup", column)
        n.node_tree = tree
        for name, value in inputs.items():
            self.feed(n.inputs[name.replace("_", " ")], value)
        return n


def group(name: str, description: str, build) -> bpy.types.NodeTree:
    """The compositor node group ``name``, made by ``build(GroupBuilder)`` unless already current.

    Parameters
    ----------
    name : str
        Name of the group in ``bpy.data.node_groups``.
    description : str
        The group's tooltip: what it computes and its alpha convention.
    build : callable
        Fills a :class:`GroupBuilder` with sockets, nodes and links.
    """
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.bl_idname == "CompositorNodeTree" and tree.get(VERSION_KEY) == BUILD_VERSION:
        return tree
    if tree is None or tree.bl_idname != "CompositorNodeTree":
        tree = bpy.data.node_groups.new(name, "CompositorNodeTree")
    tree.nodes.clear()
    tree.interface.clear()
    tree.description = description
    build(GroupBuilder(tree))
    tree[VERSION_KEY] = BUILD_VERSION
    return tree
