"""The operators, one per module; this module only lists them for registration."""

from .build_zkey import VFXSTEREO_OT_build_zkey_compositor
from .import_planes import VFXSTEREO_OT_import_stack_planes
from .solve_plates import VFXSTEREO_OT_solve_plates

classes = (
    VFXSTEREO_OT_solve_plates,
    VFXSTEREO_OT_import_stack_planes,
    VFXSTEREO_OT_build_zkey_compositor,
)
