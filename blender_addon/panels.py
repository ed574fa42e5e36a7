"""Sidebar panels: the 3D viewport (solve, import as planes) and the compositor (z-key)."""

import bpy

from . import preferences


class VFXSTEREO_PT_view3d(bpy.types.Panel):
    """Solve plates and import the stack as planes."""

    bl_label = "vfxstereo"
    bl_idname = "VFXSTEREO_PT_view3d"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "vfxstereo"

    def draw(self, context):
        """Stack, solver, planes."""
        settings = context.scene.vfxstereo
        layout = self.layout
        layout.operator("vfxstereo.solve_plates", icon="IMAGE_DATA")
        layout.label(text=f"Solver: {preferences.describe_solver(preferences.get(context))}")
        layout.prop(settings, "stack_path")
        layout.prop(settings, "focal_baseline")
        op = layout.operator("vfxstereo.import_stack_planes", icon="IMAGE_PLANE")
        op.filepath = settings.stack_path
        op.focal_baseline = settings.focal_baseline


class VFXSTEREO_PT_compositor(bpy.types.Panel):
    """Build the z-key compositing tree."""

    bl_label = "vfxstereo Z-Key"
    bl_idname = "VFXSTEREO_PT_compositor"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "vfxstereo"

    @classmethod
    def poll(cls, context):
        """Only in the compositor."""
        return getattr(context.space_data, "tree_type", "") == "CompositorNodeTree"

    def draw(self, context):
        """Stack, disparity, element, target."""
        settings = context.scene.vfxstereo
        layout = self.layout
        layout.prop(settings, "stack_path")
        layout.prop(settings, "zkey_disparity")
        layout.prop(settings, "element")
        if settings.element == "IMAGE":
            layout.prop(settings, "element_path")
        layout.prop(settings, "into")
        layout.operator("vfxstereo.build_zkey_compositor", icon="NODETREE")


classes = (VFXSTEREO_PT_view3d, VFXSTEREO_PT_compositor)
