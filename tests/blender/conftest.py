"""Blender tests need bpy: they run in .venv-blender (make test-blender) and are left out elsewhere.

bpy writes into the user's config and cache folders: tests/conftest.py points BLENDER_USER_RESOURCES and
XDG_CACHE_HOME at a temporary folder before anything imports bpy. The repository root is put on the path so
the tests import the ``nodes`` package from the source tree.
"""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]

if importlib.util.find_spec("bpy") is None:
    collect_ignore_glob = ["test_*.py"]
else:
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))


@pytest.fixture
def comp_scene():
    """An empty scene whose compositing tree has one output, ``Image``; reset before and after."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    tree = bpy.data.node_groups.new("vfxstereo_test", "CompositorNodeTree")
    tree.interface.new_socket(name="Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    sc.compositing_node_group = tree
    sc.render.use_compositing = True
    yield sc
    bpy.ops.wm.read_factory_settings(use_empty=True)


def image_from_array(name: str, pixels: np.ndarray):
    """A float bpy image holding ``pixels`` ((H, W, 4) top row first, or (H, W) as grey with alpha 1)."""
    import bpy

    a = np.asarray(pixels, np.float32)
    if a.ndim == 2:
        a = np.concatenate([np.repeat(a[..., None], 3, -1), np.ones((*a.shape, 1), np.float32)], -1)
    h, w = a.shape[:2]
    image = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(a[::-1]).ravel())  # bpy pixel rows are bottom-up
    return image


def render_to_array(scene, path: Path) -> np.ndarray:
    """Render ``scene`` to a float EXR at ``path`` and read it back: (H, W, 4) RGBA, top row first."""
    import bpy

    from vfxstereo.io import exr

    settings = scene.render.image_settings
    settings.media_type = "IMAGE"
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGBA"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    pixels, names, _ = exr.read_image(path)
    return pixels[..., [names.index(c) for c in "RGBA"]]
