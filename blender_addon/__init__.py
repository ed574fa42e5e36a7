"""vfxstereo for Blender: solve plates into a layer stack, import it as planes, z-key it in the compositor.

This module only registers; the operators, panels and preferences live in their own modules, and
everything that needs no Blender is in the ``vfxstereo`` package (bundled as a wheel).
"""

import bpy

from . import operators, panels, preferences, properties

classes = (
    preferences.VFXSTEREO_AddonPreferences,
    properties.VFXSTEREO_PG_settings,
    *operators.classes,
    *panels.classes,
)


def register():
    """Register every class and the scene's ``vfxstereo`` settings."""
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.vfxstereo = bpy.props.PointerProperty(type=properties.VFXSTEREO_PG_settings)


def unregister():
    """Undo :func:`register`, in reverse order."""
    del bpy.types.Scene.vfxstereo
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
