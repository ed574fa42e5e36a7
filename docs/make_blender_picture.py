"""Render docs/blender-planes.jpg headless: the demo stack imported as planes, a CG card among them.

Left: the planes seen from the side (one camera-facing plane per layer, at its depth, each filling the
scene camera's frame there; the z-key card sits between the pumpkin's plane and the hair's). Right: the
same scene rendered through the scene camera: the plate, with the card behind the hair and in front of the
pumpkin. Made with the extension zip, installed into a temporary user folder::

    make blender-extension
    .venv-blender/bin/python docs/make_blender_picture.py [dist/vfxstereo-0.1.0-linux_x64.zip]
"""

import os
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))  # this checkout's vfxstereo, whatever the environment has installed
USER = tempfile.mkdtemp(prefix="vfxstereo-picture-")
os.environ["BLENDER_USER_RESOURCES"] = os.path.join(USER, "user")  # never the real user folders
os.environ["XDG_CACHE_HOME"] = os.path.join(USER, "cache")

import bpy  # noqa: E402
import mathutils  # noqa: E402
import numpy as np  # noqa: E402

from vfxstereo import samples  # noqa: E402
from vfxstereo.io import exr, plates, preview  # noqa: E402

FOCAL_BASELINE = 4.0  # depths 1 (hair, d = 4) and 2 (pumpkin, d = 2); the background (d = 0) behind them
CARD_DISPARITY = 3.0
SCALE = 200  # render percentage: each half of the picture is twice the sample's 320 x 225


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> mathutils.Matrix:
    """Camera matrix at ``eye`` looking at ``target`` (in the shot camera's frame: y up, looking down -z)."""
    eye, target, up = (mathutils.Vector(v) for v in (eye, target, up))
    forward = (target - eye).normalized()
    right = forward.cross(up).normalized()
    m = mathutils.Matrix((right, right.cross(forward), -forward)).transposed().to_4x4()
    m.translation = eye
    return m


def render(scene, camera, path: Path, samples_per_pixel: int) -> np.ndarray:
    """Render ``scene`` through ``camera`` with Cycles; premultiplied RGBA, top row first."""
    scene.camera = camera
    scene.cycles.samples = samples_per_pixel
    settings = scene.render.image_settings
    settings.media_type, settings.file_format, settings.color_depth = "IMAGE", "OPEN_EXR", "32"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    pixels, names, _ = exr.read_image(path)
    return pixels[..., [names.index(c) for c in "RGBA"]]


def main(zip_path: Path) -> None:
    """Install, import, add the card, render both views, write the picture."""
    work = Path(USER)
    stack = samples.demo_scene().stack
    stack_path = exr.write_stack(work / "demo_stack.exr", stack)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default", enable_on_install=True)
    scene = bpy.context.scene
    bpy.ops.vfxstereo.import_stack_planes(filepath=str(stack_path), focal_baseline=FOCAL_BASELINE)
    shot = scene.camera

    # The CG card at the depth of d = 3, filling the frame there, through the add-on's own plane maker.
    from vfxstereo.scene import PlanePlacement, depth_mapping

    addon = sys.modules["bl_ext.user_default.vfxstereo.operators.import_planes"]
    element, _ = plates.read_element(REPO / "samples" / "demo" / "element.exr")
    z = float(depth_mapping(None, FOCAL_BASELINE).depth(CARD_DISPARITY))
    cx, cy, w, h = addon.frustum_of(shot, scene).frame(z)
    card = addon.make_plane("card", PlanePlacement(0, "card", CARD_DISPARITY, z, (cx, cy, -z), (w, h)), element, shot)
    scene.collection.objects.link(card)

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.render.resolution_percentage = SCALE
    through_camera = render(scene, shot, work / "shot.exr", 4)

    # A second camera off to the side, looking at the stack of planes.
    side = bpy.data.objects.new("side view", bpy.data.cameras.new("side view"))
    scene.collection.objects.link(side)
    side.matrix_world = shot.matrix_world @ look_at((1.45, 0.5, -0.55), (-0.05, -0.05, -1.55))
    side.data.lens = 40.0
    side.data.clip_end = 1000.0
    scene.cycles.filter_width = 1.5
    side_view = render(scene, side, work / "side.exr", 16)

    picture = np.concatenate([preview.over_background(side_view, 0.05),
                              preview.over_background(through_camera, "checker")], axis=1)
    out = preview.write_png(work / "picture.png", picture)
    import OpenImageIO as oiio

    image = oiio.ImageBuf(str(out))
    image.specmod().attribute("Compression", "jpeg:80")
    image.write(str(HERE / "blender-planes.jpg"))
    print(f"{HERE / 'blender-planes.jpg'} ({(HERE / 'blender-planes.jpg').stat().st_size / 1e3:.0f} KB)")


if __name__ == "__main__":
    try:
        main(Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "dist" / "vfxstereo-0.1.0-linux_x64.zip")
    finally:
        shutil.rmtree(USER, ignore_errors=True)
