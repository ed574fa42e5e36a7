"""Build Z-Key Compositor: the scene's compositing tree puts its render (or an image) between the layers.

The tree is :func:`nodes.build_zkey_tree` (the node groups of ``nodes/``); this operator loads the stack and
the element and makes the tree the scene's compositor.
"""

import os

import bpy

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.stackinfo import read_stack_info

from .. import properties
from ..nodes import build_zkey_tree


class VFXSTEREO_OT_build_zkey_compositor(bpy.types.Operator):
    """Make the scene's compositor z-key its render (or an image) between the layers of a stack."""

    bl_idname = "vfxstereo.build_zkey_compositor"
    bl_label = "Build Z-Key Compositor"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Stack", subtype="FILE_PATH",
                                       description="The stack EXR; empty: the scene's vfxstereo stack")
    disparity: bpy.props.FloatProperty(
        name="Disparity", default=0.0,
        description="Where the element goes: in front of the layers with d <= this, behind the others")
    element: bpy.props.EnumProperty(name="Element", default="RENDER", items=properties.ELEMENT_ITEMS)
    element_path: bpy.props.StringProperty(name="Element Image", subtype="FILE_PATH",
                                           description="The element image, for Element = Image")
    into: bpy.props.EnumProperty(name="Into", default="PLATE", items=properties.INTO_ITEMS)
    configure_scene: bpy.props.BoolProperty(
        name="Configure Scene", default=True,
        description="Set the render size to the stack's, and a transparent film when the element is the render")

    def invoke(self, context, event):
        """Take unset options from the scene's vfxstereo settings (the compositor panel)."""
        settings = context.scene.vfxstereo
        for name, setting in (("filepath", "stack_path"), ("disparity", "zkey_disparity"),
                              ("element", "element"), ("element_path", "element_path"), ("into", "into")):
            if not self.properties.is_property_set(name):
                setattr(self, name, getattr(settings, setting))
        return self.execute(context)

    def execute(self, context):
        """Build the tree and make it the scene's compositor."""
        scene = context.scene
        try:
            path = properties.stack_file(self.filepath, scene)
            info = read_stack_info(path)
            element = None
            if self.element == "IMAGE":
                element_path = bpy.path.abspath(self.element_path)
                if not os.path.isfile(element_path):
                    raise VfxStereoError(f"element image not found: {self.element_path or '(none chosen)'}")
                element = bpy.data.images.load(element_path, check_existing=True)
        except VfxStereoError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        image = bpy.data.images.load(path, check_existing=True)
        into = "plate" if self.into == "PLATE" and info.plate_layer else "stack"
        stem = os.path.splitext(os.path.basename(path))[0]
        tree = build_zkey_tree(f"vfxstereo Z-Key {stem}", image, info.layer_names, info.disparities,
                               disparity=self.disparity, element=element, plate_layer=info.plate_layer, into=into)
        scene.compositing_node_group = tree
        scene.render.use_compositing = True
        if self.configure_scene:
            r = scene.render
            r.resolution_x, r.resolution_y, r.resolution_percentage = info.width, info.height, 100
            if element is None:
                r.film_transparent = True  # the render is the element: premultiplied, empty where no CG
        if self.into == "PLATE" and not info.plate_layer:
            self.report({"WARNING"}, f"{os.path.basename(path)} holds no plate: composing into its layers")
        self.report({"INFO"}, f"Compositor {tree.name}: {'the render' if element is None else element.name} at "
                              f"d = {self.disparity:g} between {info.depth} layers, into the {into}; outputs "
                              "Image and Holdout")
        return {"FINISHED"}
