"""Add-on preferences: which vfxstereo solves, and defaults for the operators."""

import os
import sys

import bpy

import vfxstereo
from vfxstereo.errors import VfxStereoError
from vfxstereo.runner import SolverCommand

ADDON = __package__
"""The add-on's module name (``bl_ext.<repository>.vfxstereo`` when installed as an extension)."""


class VFXSTEREO_AddonPreferences(bpy.types.AddonPreferences):
    """Preferences of the vfxstereo add-on."""

    bl_idname = ADDON

    solver_command: bpy.props.StringProperty(
        name="vfxstereo Command",
        description="An external vfxstereo executable to solve with (e.g. a pipeline install with OpenCV "
                    "and colour management); empty: the vfxstereo bundled with this extension, run by "
                    "Blender's own Python",
        subtype="FILE_PATH",
        default="",
    )
    default_preset: bpy.props.StringProperty(
        name="Default Preset",
        description="Solver preset for Solve Plates (paper, zkey, literal, wta, ...); empty: the "
                    "command's own default",
        default="",
    )
    default_disparities: bpy.props.StringProperty(
        name="Default Disparities",
        description="Disparity range MIN:MAX[:STEP] for Solve Plates; empty: the command's own default",
        default="",
    )
    focal_baseline: bpy.props.FloatProperty(
        name="Focal x Baseline",
        description="For stacks that record no focal length and baseline: focal length (px) times "
                    "baseline (scene units per view step), so a plane of disparity d sits at depth "
                    "focal x baseline / d; 0: depth = 1 / d",
        default=0.0,
        min=0.0,
    )

    def draw(self, context):
        """Preferences panel: the settings, and which vfxstereo solves."""
        layout = self.layout
        layout.prop(self, "solver_command")
        layout.label(text=f"Solving with {describe_solver(self)}")
        layout.prop(self, "default_preset")
        layout.prop(self, "default_disparities")
        layout.prop(self, "focal_baseline")


def get(context) -> VFXSTEREO_AddonPreferences:
    """The preferences of the vfxstereo add-on."""
    return context.preferences.addons[ADDON].preferences


def solver(prefs) -> SolverCommand:
    """The command that solves: the external one if set, else the bundled vfxstereo under Blender's Python.

    Raises
    ------
    VfxStereoError
        If the external command cannot be found.
    """
    if prefs.solver_command.strip():
        return SolverCommand.external(bpy.path.abspath(prefs.solver_command.strip()))
    root = os.path.dirname(os.path.dirname(vfxstereo.__file__))  # the folder holding the bundled package
    cache = bpy.utils.extension_path_user(ADDON, path="numba-cache", create=True)
    return SolverCommand.bundled(sys.executable, root, version=vfxstereo.__version__,
                                 env={"NUMBA_CACHE_DIR": cache})


def describe_solver(prefs) -> str:
    """Which vfxstereo solves, in words (for panels and reports)."""
    try:
        return solver(prefs).label
    except VfxStereoError as exc:
        return str(exc)
