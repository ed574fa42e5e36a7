"""The scene's vfxstereo settings (``scene.vfxstereo``), shown in the panels and passed to the operators."""

import bpy

from vfxstereo.errors import VfxStereoError

ELEMENT_ITEMS = [("RENDER", "Render", "The scene's own render (film made transparent)"),
                 ("IMAGE", "Image", "An image file (premultiplied RGBA)")]
"""What goes between the layers in the z-key compositor."""

INTO_ITEMS = [("PLATE", "Plate", "Compose into the plate stored in the stack: the comp equals the plate "
                                 "wherever the element adds nothing"),
              ("STACK", "Stack", "Compose into the stack's own layers: front over element over back")]
"""What the z-key compositor composes into."""


def stack_file(given: str, scene) -> str:
    """The stack EXR an operator works on: its own ``filepath`` if given, else the scene's, made absolute.

    Raises
    ------
    VfxStereoError
        When neither is set.
    """
    path = bpy.path.abspath(given or scene.vfxstereo.stack_path)
    if not path:
        raise VfxStereoError("choose a stack EXR (Solve Plates sets the scene's)")
    return path


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
        items=ELEMENT_ITEMS,
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
        items=INTO_ITEMS,
        default="PLATE",
    )
