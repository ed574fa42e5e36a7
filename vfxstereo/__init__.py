"""vfxstereo: stereo matching with transparency and matting for VFX compositing.

Szeliski & Golland, "Stereo Matching with Transparency and Matting", IJCV 32(1), 1999.
"""

from vfxstereo.config import SolveConfig
from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.solver import solve
from vfxstereo.stack import LayerStack

__version__ = "0.1.0"

__all__ = ["Camera", "LayerStack", "SolveConfig", "VfxStereoError", "__version__", "solve"]
