"""The scene's vfxstereo settings (``scene.vfxstereo``), shown in the panels and passed to the operators."""

import bpy


class VFXSTEREO_PG_settings(bpy.types.PropertyGroup):
    """Per-scene settings: the current stack and how to z-key into it."""

    stack_path: bpy.props.StringProperty(
        name="Stack",
        description="The layer stack EXR (vfxstereo solve's output); Solve Plates sets it",
        subtype="FILE_PATH",
        default="",
    )
    focal_baseline: bpy.props.FloatProperty(
        name="Focal x Baseline",
        description="Focal length (px) times baseline (scene units per view step) for the plane depths; "
                    "0: from the stack's camera, else the add-on preferences, else depth = 1 / d",
        default=0.0,
        min=0.0,
    )
    zkey_disparity: bpy.props.FloatProperty(
        name="Disparity",
        description="Where the element goes: in front of the layers with d <= this, behind the others",
        default=0.0,
    )
    element: bpy.props.EnumProperty(
        name="Element",
        description="What goes between the layers",
        items=[("RENDER", "Render", "The scene's own render (film made transparent)"),
               ("IMAGE", "Image", "An image file (premultiplied RGBA)")],
        default="RENDER",
    )
    element_path: bpy.props.StringProperty(
        name="Element Image",
        description="The element image, for Element = Image",
        subtype="FILE_PATH",
        default="",
    )
    into: bpy.props.EnumProperty(
        name="Into",
        description="Compose into the plate the stack was solved from, or into the stack's own layers",
        items=[("PLATE", "Plate", "The comp equals the plate wherever the element adds nothing"),
               ("STACK", "Stack", "Front over element over back, the stack's re-synthesis")],
        default="PLATE",
    )
