"""Import Stack as Planes: one camera-facing plane per layer, parented to the scene camera, at its depth.

Where each plane goes and how big it is comes from :mod:`vfxstereo.scene` (tested without Blender); this
module makes the Blender objects. Each plane's material reproduces the layer's premultiplied colour and
alpha: ``Emission(colour) + Transparent((1 - alpha))``, so the renderer composites the planes (and any CG
placed among them) with the over operator, in Cycles and EEVEE alike. The planes are seen by the camera
only: they light, shadow and reflect nothing.
"""

import math
import os

import bpy
from mathutils import Matrix

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.stackinfo import read_stack_info, read_stack_layer
from vfxstereo.scene import CameraFrustum, DepthMapping, clip_range, depth_mapping, layout_planes

from .. import preferences, properties

EXTRA_TRANSPARENT_BOUNCES = 8
"""Transparent bounces Cycles gets beyond one per layer, for CG objects among the planes."""


class VFXSTEREO_OT_import_stack_planes(bpy.types.Operator):
    """Import a vfxstereo stack EXR as one camera-facing plane per layer, at the depth of its disparity."""

    bl_idname = "vfxstereo.import_stack_planes"
    bl_label = "Import Stack as Planes"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Stack", subtype="FILE_PATH",
                                       description="The stack EXR; empty: the scene's vfxstereo stack")
    filter_glob: bpy.props.StringProperty(default="*.exr", options={"HIDDEN"})
    focal_baseline: bpy.props.FloatProperty(
        name="Focal x Baseline", default=0.0, min=0.0,
        description="Focal length (px) times baseline (scene units per view step): a layer of disparity d "
                    "goes to depth focal x baseline / d; 0: from the stack's camera, else the add-on "
                    "preferences, else 1 / d")
    configure_scene: bpy.props.BoolProperty(
        name="Configure Scene", default=True,
        description="Set the render size to the stack's, pixel filters to 0.01 px, enough Cycles "
                    "transparent bounces and the Standard view transform, so the planes render the plate "
                    "pixel for pixel")

    def invoke(self, context, event):
        """Use the scene's stack, or pick one in the file browser."""
        if not self.filepath and context.scene.vfxstereo.stack_path:
            self.filepath = context.scene.vfxstereo.stack_path
        if not self.filepath:
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}
        return self.execute(context)

    def execute(self, context):
        """Make the planes."""
        scene = context.scene
        try:
            path = properties.stack_file(self.filepath, scene)
            info = read_stack_info(path)
            mapping = self.mapping(context, info.camera)
            camera, made_camera = scene_camera(scene)
            if self.configure_scene:
                configure_scene(scene, info.width, info.height, info.depth)
            placements = layout_planes(info.disparities, info.layer_names, frustum_of(camera, scene), mapping)
            stem = os.path.splitext(os.path.basename(path))[0]
            collection = bpy.data.collections.new(f"{stem} planes")
            scene.collection.children.link(collection)
            for placement in placements:
                pixels = read_stack_layer(path, placement.index)
                plane = make_plane(f"{stem} {placement.name}", placement, pixels, camera)
                plane["vfxstereo_stack"] = path
                collection.objects.link(plane)
        except VfxStereoError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        depths = [p.depth for p in placements]
        camera.data.clip_start, camera.data.clip_end = clip_range(depths, camera.data.clip_start,
                                                                  camera.data.clip_end)
        self.report({"INFO"}, f"Imported {len(placements)} layers of {os.path.basename(path)} as planes at "
                              f"depths {min(depths):.4g}..{max(depths):.4g}: {mapping.describe()}"
                              + (f"; made the camera {camera.name}" if made_camera else ""))
        return {"FINISHED"}

    def mapping(self, context, camera) -> DepthMapping:
        """Disparity to depth: this operator's value, else the stack's camera, else the preferences'."""
        mapping = depth_mapping(camera, self.focal_baseline or context.scene.vfxstereo.focal_baseline)
        fallback = preferences.get(context).focal_baseline
        if mapping.source == "none" and fallback > 0:
            mapping = depth_mapping(None, fallback)
        return mapping


def scene_camera(scene):
    """The scene camera, or a new level one at the origin looking along +Y; and whether it was made."""
    if scene.camera is not None:
        if scene.camera.type != "CAMERA":
            raise VfxStereoError(f"the scene camera {scene.camera.name} is not a camera object")
        return scene.camera, False
    camera = bpy.data.objects.new("vfxstereo camera", bpy.data.cameras.new("vfxstereo camera"))
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)  # level, Z up: the planes stand upright along +Y
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera, True


def frustum_of(camera, scene) -> CameraFrustum:
    """The camera's view frame, as :class:`vfxstereo.scene.CameraFrustum` computes it."""
    cam = camera.data
    if cam.type not in ("PERSP", "ORTHO"):
        raise VfxStereoError(f"planes need a perspective or orthographic camera, {camera.name} is {cam.type}")
    r = scene.render
    return CameraFrustum(r.resolution_x, r.resolution_y, lens=cam.lens, sensor_width=cam.sensor_width,
                         sensor_height=cam.sensor_height, sensor_fit=cam.sensor_fit, shift_x=cam.shift_x,
                         shift_y=cam.shift_y, pixel_aspect_x=r.pixel_aspect_x, pixel_aspect_y=r.pixel_aspect_y,
                         ortho_scale=cam.ortho_scale if cam.type == "ORTHO" else None)


def configure_scene(scene, width: int, height: int, layers: int) -> None:
    """Render settings under which the planes reproduce the stack pixel for pixel."""
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.filter_size = 0.01  # EEVEE's pixel filter: one texel per pixel
    if hasattr(scene, "cycles"):
        scene.cycles.filter_width = 0.01
        bounces = max(scene.cycles.transparent_max_bounces, layers + EXTRA_TRANSPARENT_BOUNCES)
        scene.cycles.transparent_max_bounces = bounces
        scene.cycles.min_transparent_bounces = bounces  # no random termination: no noise through the layers
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"


def make_plane(name: str, placement, pixels, camera):
    """A plane object for one layer: mesh, texture, material, parented to ``camera``."""
    w, h = placement.size
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-w / 2, -h / 2, 0.0), (w / 2, -h / 2, 0.0), (w / 2, h / 2, 0.0), (-w / 2, h / 2, 0.0)],
                     [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    corners = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    for loop in mesh.loops:
        uv.data[loop.index].uv = corners[loop.vertex_index]
    mesh.materials.append(layer_material(name, layer_image(name, pixels)))
    plane = bpy.data.objects.new(name, mesh)
    plane.parent = camera
    sx, sy, sz = camera.scale
    plane.matrix_parent_inverse = Matrix.Diagonal((1 / sx, 1 / sy, 1 / sz, 1.0))  # camera scale does not size it
    plane.location = placement.centre
    for ray in ("diffuse", "glossy", "transmission", "volume_scatter", "shadow"):
        setattr(plane, f"visible_{ray}", False)
    plane["vfxstereo_layer"] = placement.name
    plane["vfxstereo_disparity"] = placement.disparity
    plane["vfxstereo_depth"] = placement.depth
    return plane


def layer_image(name: str, pixels):
    """A packed float image of one layer, read as stored (premultiplied, ``CHANNEL_PACKED``)."""
    h, w = pixels.shape[:2]
    image = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    image.pixels.foreach_set(pixels[::-1].ravel())  # bpy pixel rows are bottom-up
    image.alpha_mode = "CHANNEL_PACKED"  # colour is used as stored, not divided by alpha
    image.pack()
    return image


def layer_material(name: str, image):
    """``Emission(premultiplied colour) + Transparent(1 - alpha)``: the layer over whatever is behind."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Closest"  # one texel per rendered pixel, unblurred
    tex.extension = "CLIP"
    emit = nt.nodes.new("ShaderNodeEmission")
    emit.inputs["Strength"].default_value = 1.0
    clear = nt.nodes.new("ShaderNodeMath")
    clear.operation = "SUBTRACT"
    clear.inputs[0].default_value = 1.0
    see_through = nt.nodes.new("ShaderNodeBsdfTransparent")
    add = nt.nodes.new("ShaderNodeAddShader")
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(tex.outputs["Color"], emit.inputs["Color"])
    nt.links.new(tex.outputs["Alpha"], clear.inputs[1])
    nt.links.new(clear.outputs[0], see_through.inputs["Color"])
    nt.links.new(emit.outputs[0], add.inputs[0])
    nt.links.new(see_through.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], out.inputs["Surface"])
    for i, node in enumerate((tex, clear, emit, see_through, add, out)):
        node.location = (i * 200.0, 0.0)
    mat.surface_render_method = "BLENDED"  # EEVEE: sorted alpha blending, not dithering
    return mat
