"""Cycles-rendered 5-camera z-key benchmark scenes with exact ground truth (issue 7, section 5).

Run in the Blender environment (bpy 5.0.1)::

    nice -n 10 .venv-blender/bin/python benchmarks/cycles_scenes.py --out DIR [--scenes NAMES]
        [--size 480x270] [--samples N]

For each scene it writes ``DIR/<scene>/``:

* ``view0.exr`` ... ``view4.exr``: the plates, scene-linear RGB half floats (Blender's scene linear,
  linear Rec.709), rendered by 5 identical pinhole cameras translated along their own x axis by ``B`` per
  step (a rectified, coplanar rig; positions 0..4, reference 2, no lens shift). A point at column x of the
  reference view with disparity d = f*B/Z appears at column x - d*(k - 2) of view k. The film filter is
  Cycles' default (Blackman-Harris, 1.5 px), so edges are antialiased as in real renders. Each view has its
  own fixed seed, so the render noise is independent between views (as a camera's sensor noise is).
* ``element.exr``: the CG element alone from the reference camera, premultiplied R,G,B,A (film transparent)
  and Z (its depth in scene units where A > 0, 1e10 elsewhere), float.
* ``comp.exr``: the ground-truth comp: the reference view rendered again, with the reference view's seed,
  with the element shown in the scene, so nearer objects occlude it with their real soft edges. The element
  is emission-only and visible to camera rays only (not to shadow, diffuse, glossy, transmission or volume
  rays, and never sampled as a light), so it changes nothing but the pixels it is seen in. It stays in the
  scene for the plates too, switched to a Transparent BSDF (camera rays pass through it), so plates and comp
  trace the same BVH: the comp then equals the plate *exactly* wherever the element's alpha is zero (the
  script measures it and stores the number in ``scene.json``; see :func:`element_material` for why).
* ``disparity.exr``: the reference view's true disparity d = f*B/Z of the nearest surface on each pixel's
  centre ray (channels Y and Z, both the disparity, as ``vfxstereo solve --disparity-out`` writes them;
  0 where the ray sees the sky at infinity). A depth pass is not a matte: at soft edges it is one surface
  or the other, never a mix.
* ``scene.json``: positions, reference, f (px), B (scene units per step), the element's disparity
  D = f*B/Z_element, the range of disparities in the reference view, each visible object's pixel count and
  disparity range, what covers the element, a suggested plane list, render settings, times, the measured
  comp-vs-plate difference, and a description.

and ``DIR/<scene>.png``, a contact sheet: views 0-3 on the first row; view 4, comp, element (over grey)
and disparity (white = near) on the second.

Scenes (``--scenes``; at 480x270 every one spans ~1-15 px per view step over 3+ depth layers):

* ``sphere_plant``: photo backdrop, textured sphere, a plant of thin stems and leaves; the card between the
  plant and the sphere;
* ``plush_wall``: low-texture painted wall, photo-textured slanted box, a ball with 5000 hair curves; the
  card between the ball and the box;
* ``fence_dof``: a thin wire fence in front of a slanted photo wall, ground and sky, depth of field (the same
  aperture for every camera); the card behind the fence;
* ``plane_check``: the test scene of ``tests/blender/test_cycles_scenes.py`` (not rendered by default).

Fixed numpy and Cycles seeds, no adaptive sampling, no denoiser, no path guiding: a re-run renders the same
scenes with the same noise. Not bit for bit, though: Cycles builds its scene in an order that changes from
process to process, so a re-run differs by float rounding (~1e-6) on meshes and, on ~1-2 % of the fur's
pixels, by one sample's worth (a few 1e-3 at 96 spp), probably where a ray meets two hair segments at the
same distance.
Within one run plates and comp share the scene (persistent data), which is what makes them equal.

No denoiser: a denoiser would make each view's noise depend on its content and blur thin structures
differently per view; plain path-traced noise is what a camera's grain is like and it is
identical between plate and comp.
"""

from __future__ import annotations

import argparse
import atexit
import json
import math
import os
import shutil
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

# bpy writes to the user's config and cache folders: point both at a temporary folder before importing it.
_BL_TMP = tempfile.mkdtemp(prefix="vfxstereo-cycles-")
atexit.register(shutil.rmtree, _BL_TMP, ignore_errors=True)
os.environ["BLENDER_USER_RESOURCES"] = os.path.join(_BL_TMP, "user")
os.environ["XDG_CACHE_HOME"] = os.path.join(_BL_TMP, "cache")

import bpy  # noqa: E402
import numpy as np  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("VFXSTEREO_DATA", HERE.parent.parent / "shared" / "data"))

POSITIONS = [0, 1, 2, 3, 4]
REFERENCE = 2
SENSOR_MM = 36.0
LENS_MM = 35.0
FAR = 1e9  # depth-pass values beyond this are the sky (Cycles writes 1e10)
EMPTY_Z = 1e10
SEED = 2026  # Cycles seed of view k is SEED + k; the comp uses the reference view's seed


def focal_px(width: int) -> float:
    """Focal length in pixels of the rig's cameras (35 mm lens on a 36 mm wide sensor)."""
    return width * LENS_MM / SENSOR_MM


# --------------------------------------------------------------------------------------------------------
# Scene building blocks


@dataclass
class Built:
    """What a scene builder returns."""

    element: object
    element_depth: float
    baseline: float
    description: str
    dof: dict | None = None


def _material(name: str):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender < 5 needs use_nodes; 5.0 warns that it goes away in 6.0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            mat.use_nodes = True
    return mat, mat.node_tree.nodes, mat.node_tree.links


def _principled(name: str, color=(0.8, 0.8, 0.8), roughness=0.5, specular=0.5):
    mat, nodes, links = _material(name)
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = specular
    return mat, nodes, links, bsdf


def image_material(name: str, path: Path, roughness=0.6, coords="UV"):
    """Principled BSDF whose base colour is an sRGB image (decoded to scene-linear by Blender)."""
    mat, nodes, links, bsdf = _principled(name, roughness=roughness, specular=0.3)
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(path), check_existing=True)
    tex.image.colorspace_settings.name = "sRGB"
    tex.interpolation = "Cubic"
    tex.extension = "EXTEND"
    coord = nodes.new("ShaderNodeTexCoord")
    links.new(coord.outputs[coords], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def procedural_material(name: str, colors, scale=4.0, detail=6.0, roughness=0.45, voronoi=0.0,
                        coords="Object"):
    """Principled BSDF coloured by 3-D noise through a colour ramp (and optionally voronoi cells)."""
    mat, nodes, links, bsdf = _principled(name, roughness=roughness)
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = scale
    noise.inputs["Detail"].default_value = detail
    noise.inputs["Roughness"].default_value = 0.6
    links.new(coord.outputs[coords], noise.inputs["Vector"])
    ramp = nodes.new("ShaderNodeValToRGB")
    elems = ramp.color_ramp.elements
    for i, c in enumerate(colors):
        pos = i / (len(colors) - 1)
        e = elems[i] if i < len(elems) else elems.new(pos)
        e.position = pos
        e.color = (*c, 1.0)
    factor = noise.outputs["Fac"]
    if voronoi:
        vor = nodes.new("ShaderNodeTexVoronoi")
        vor.inputs["Scale"].default_value = scale * 3.0
        links.new(coord.outputs[coords], vor.inputs["Vector"])
        mix = nodes.new("ShaderNodeMath")
        mix.operation = "MULTIPLY_ADD"
        mix.inputs[1].default_value = voronoi
        links.new(vor.outputs["Distance"], mix.inputs[0])
        links.new(noise.outputs["Fac"], mix.inputs[2])
        factor = mix.outputs[0]
    links.new(factor, ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


SHOW = "vfxstereo_show"  # the element's object property: 1 renders it, 0 makes it a transparent no-op


def element_material(name="element", colors=((0.9, 0.55, 0.05), (0.05, 0.25, 0.8)), squares=8.0,
                     strength=1.0):
    """Emission-only checker (a CG card): no BSDF, never sampled as a light.

    The emission is mixed with a Transparent BSDF by the object's ``SHOW`` property: the plates are rendered
    with the card in the scene and ``SHOW = 0`` (camera rays pass straight through it), the comp with
    ``SHOW = 1`` (pure emission). Plates and comp then trace the same BVH: adding or removing an object
    rebuilds it, and rays that hit the shared edge of two triangles can then pick the other one, which
    changed a handful of pixels far from the element (up to 0.005 in 8-12 of 130k pixels, fence_dof).
    The property is read at render time (an object attribute), so the shader is never constant-folded to
    something that changes the kernel's features between plate and comp.
    """
    mat, nodes, links = _material(name)
    nodes.clear()
    coord = nodes.new("ShaderNodeTexCoord")
    checker = nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = squares
    checker.inputs["Color1"].default_value = (*colors[0], 1.0)
    checker.inputs["Color2"].default_value = (*colors[1], 1.0)
    links.new(coord.outputs["UV"], checker.inputs["Vector"])
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Strength"].default_value = strength
    links.new(checker.outputs["Color"], emit.inputs["Color"])
    show = nodes.new("ShaderNodeAttribute")
    show.attribute_type = "OBJECT"
    show.attribute_name = SHOW
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(show.outputs["Fac"], mix.inputs["Fac"])
    links.new(clear.outputs["BSDF"], mix.inputs[1])
    links.new(emit.outputs["Emission"], mix.inputs[2])
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(mix.outputs["Shader"], out.inputs["Surface"])
    mat.cycles.emission_sampling = "NONE"
    return mat


def show_element(ob, on: bool):
    ob[SHOW] = 1.0 if on else 0.0
    ob.update_tag()


def link_object(name: str, data, material=None):
    ob = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(ob)
    if material is not None:
        data.materials.append(material)
    return ob


def mesh_object(name: str, verts, faces, material=None, uvs=None, smooth=False):
    """A mesh object from numpy vertices (N, 3) and a list of faces; ``uvs`` per vertex, optional."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(int(i) for i in f) for f in faces])
    if uvs is not None:
        layer = me.uv_layers.new(name="UVMap")
        loop_vi = np.empty(len(me.loops), np.int64)
        me.loops.foreach_get("vertex_index", loop_vi)
        layer.data.foreach_set("uv", np.asarray(uvs, np.float32)[loop_vi].ravel())
    if smooth:
        me.shade_smooth()
    me.validate()
    return link_object(name, me, material)


def card(name: str, width: float, height: float, center, material=None):
    """A fronto-parallel rectangle (normal +Z, towards the cameras) with UVs over [0, 1]^2."""
    cx, cy, cz = center
    w, h = width / 2.0, height / 2.0
    verts = np.array([(cx - w, cy - h, cz), (cx + w, cy - h, cz), (cx + w, cy + h, cz), (cx - w, cy + h, cz)])
    uvs = [(0, 0), (1, 0), (1, 1), (0, 1)]
    return mesh_object(name, verts, [(0, 1, 2, 3)], material, uvs=uvs)


def bm_object(name: str, build, material=None, smooth=False):
    """A mesh object from a bmesh built by ``build(bm, bmesh)`` (bmesh.ops primitives with UVs)."""
    import bmesh  # only importable after bpy

    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")  # the primitives' calc_uvs fill this layer
    build(bm, bmesh)
    bm.to_mesh(me)
    bm.free()
    if smooth:
        me.shade_smooth()
    return link_object(name, me, material)


def _frames(points: np.ndarray):
    """Unit tangents and two normals along a polyline (rotation-minimising enough for thin tubes)."""
    t = np.gradient(points, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    ref = np.array([0.0, 0.0, 1.0]) if abs(t[0, 2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    n = np.cross(t, ref)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    b = np.cross(t, n)
    return t, n, b


def tube(points, radius, sides=6):
    """Vertices and quad faces of a closed-ring tube along ``points`` (M, 3); ``radius`` scalar or (M,)."""
    points = np.asarray(points, np.float64)
    r = np.broadcast_to(np.asarray(radius, np.float64), (len(points),))
    _, n, b = _frames(points)
    ang = 2 * np.pi * np.arange(sides) / sides
    ring = np.cos(ang)[None, :, None] * n[:, None, :] + np.sin(ang)[None, :, None] * b[:, None, :]
    verts = (points[:, None, :] + r[:, None, None] * ring).reshape(-1, 3)
    faces = []
    for i in range(len(points) - 1):
        for j in range(sides):
            a, c = i * sides + j, i * sides + (j + 1) % sides
            faces.append((a, c, c + sides, a + sides))
    faces.append(tuple(range(sides - 1, -1, -1)))  # caps
    last = (len(points) - 1) * sides
    faces.append(tuple(range(last, last + sides)))
    return verts, faces


def leaf(base, direction, normal, length, width, bend, steps=8):
    """A leaf blade: a pointed ellipse along ``direction``, bent along its length; vertices and faces."""
    d = np.asarray(direction, np.float64)
    d /= np.linalg.norm(d)
    nrm = np.asarray(normal, np.float64)
    nrm = nrm - d * np.dot(nrm, d)
    nrm /= np.linalg.norm(nrm)
    side = np.cross(d, nrm)
    t = np.linspace(0.0, 1.0, steps + 1)
    half = 0.5 * width * np.sin(np.pi * t) ** 0.7
    axis = base + length * t[:, None] * d + (bend * length * t**2)[:, None] * nrm
    verts = np.concatenate([axis - half[:, None] * side, axis, axis + half[:, None] * side])
    m = steps + 1
    faces = []
    for i in range(steps):
        faces.append((i, i + 1, m + i + 1, m + i))
        faces.append((m + i, m + i + 1, 2 * m + i + 1, 2 * m + i))
    return verts, faces


class MeshBatch:
    """Collects many small parts into one mesh (one object renders faster than hundreds)."""

    def __init__(self):
        self.verts, self.faces, self.n = [], [], 0

    def add(self, verts, faces):
        self.verts.append(np.asarray(verts))
        self.faces.extend(tuple(i + self.n for i in f) for f in faces)
        self.n += len(verts)

    def build(self, name, material=None, smooth=True):
        return mesh_object(name, np.concatenate(self.verts), self.faces, material, smooth=smooth)


def sun(rotation_deg=(50.0, 10.0, 30.0), strength=3.5, angle_deg=3.0, color=(1.0, 0.96, 0.9)):
    light = bpy.data.lights.new("sun", "SUN")
    light.energy = strength
    light.angle = math.radians(angle_deg)
    light.color = color
    ob = link_object("sun", light)
    ob.rotation_euler = tuple(math.radians(a) for a in rotation_deg)
    return ob


def world(color=(0.45, 0.55, 0.7), strength=0.6):
    w = bpy.data.worlds.new("world")
    bpy.context.scene.world = w
    if w.node_tree is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            w.use_nodes = True
    bg = w.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    return w


def element_card(depth: float, center_xy, size_px, f: float, name="element"):
    """The CG element: a camera-facing checker card at depth ``depth``, ``size_px`` (w, h) at that depth."""
    w, h = size_px[0] * depth / f, size_px[1] * depth / f
    ob = card(name, w, h, (center_xy[0], center_xy[1], -depth), element_material())
    show_element(ob, True)
    ob.visible_camera = True
    for ray in ("visible_shadow", "visible_diffuse", "visible_glossy", "visible_transmission",
                "visible_volume_scatter"):
        setattr(ob, ray, False)
    return ob


def xy_at(u: float, v: float, depth: float, f: float, width: int, height: int):
    """World (x, y) seen at pixel (u, v) (top-down rows) of the reference camera at depth ``depth``."""
    return (u - width / 2.0) * depth / f, (height / 2.0 - v) * depth / f


# --------------------------------------------------------------------------------------------------------
# Scenes. Camera at the origin looking down -Z (y up); a point at depth Z has z = -Z.


def scene_sphere_plant(width: int, height: int) -> Built:
    """Photo backdrop, a textured sphere, a plant of thin stems and leaves near the camera; card between."""
    f = focal_px(width)
    rng = np.random.default_rng(11)
    world((0.5, 0.6, 0.75), 0.5)
    sun((55.0, 0.0, 35.0), 3.0, 4.0)
    # backdrop: Middlebury teddy (450x375) on a plane at Z = 22, wider than every view's frame
    z_back = 22.0
    bw = 2.3 * z_back * SENSOR_MM / (2 * LENS_MM)
    card("backdrop", bw, bw * 375 / 450, (0.0, 0.0, -z_back),
         image_material("teddy", DATA / "middlebury2003_teddy" / "im2.png"))
    # sphere: procedural marble-ish texture, mid distance
    zs, rs = 7.0, 1.25
    sx, sy = xy_at(0.63 * width, 0.47 * height, zs, f, width, height)
    sph = bm_object("sphere", lambda bm, bmesh: bmesh.ops.create_uvsphere(bm, u_segments=96, v_segments=48, radius=rs),
                    procedural_material("sphere", [(0.75, 0.2, 0.1), (0.95, 0.85, 0.6), (0.15, 0.35, 0.2),
                                                   (0.9, 0.9, 0.85)], scale=3.0, voronoi=0.6), smooth=True)
    sph.location = (sx, sy, -zs)
    # plant: stems (thin tubes) and leaves (bent pointed blades) rising from below the frame
    plant = MeshBatch()
    stems = MeshBatch()
    zp = 2.55
    bx, by = xy_at(0.24 * width, 1.25 * height, zp, f, width, height)
    base = np.array([bx, by, -zp])
    for _ in range(9):
        lean = rng.normal(0, 1, 3) * np.array([0.35, 0.0, 0.25]) + np.array([0.0, 1.0, 0.0])
        lean /= np.linalg.norm(lean)
        length = rng.uniform(1.0, 1.9)
        t = np.linspace(0, 1, 14)[:, None]
        curl = rng.normal(0, 0.18, 3) * np.array([1, 0, 1])
        pts = base + rng.normal(0, 0.03, 3) + length * t * lean + (t**2) * curl
        stems.add(*tube(pts, np.linspace(0.009, 0.004, len(pts)), sides=6))
        for s in np.sort(rng.uniform(0.3, 1.0, rng.integers(4, 8))):
            i = int(s * (len(pts) - 1))
            p = pts[i]
            out = rng.normal(0, 1, 3) * np.array([1.0, 0.4, 0.6])
            out /= np.linalg.norm(out)
            stalk = np.stack([p, p + 0.06 * out, p + 0.12 * out + np.array([0, 0.03, 0])])
            stems.add(*tube(stalk, 0.003, sides=5))
            normal = rng.normal(0, 1, 3) + np.array([0.0, 0.3, 1.6])
            plant.add(*leaf(stalk[-1], out + np.array([0, 0.5, 0]), normal, rng.uniform(0.16, 0.3),
                            rng.uniform(0.05, 0.1), rng.uniform(-0.35, 0.35)))
    leaf_mat = procedural_material("leaf", [(0.05, 0.22, 0.04), (0.2, 0.45, 0.08), (0.35, 0.55, 0.12)],
                                   scale=25.0, roughness=0.5, coords="Generated")
    plant.build("leaves", leaf_mat)
    stems.build("stems", procedural_material("stem", [(0.12, 0.2, 0.05), (0.3, 0.35, 0.12)], scale=40.0))
    # element between the plant and the sphere
    ze = 4.2
    ex, ey = xy_at(0.4 * width, 0.45 * height, ze, f, width, height)
    el = element_card(ze, (ex, ey), (0.33 * width, 0.4 * height), f)
    return Built(el, ze, baseline=0.065,
                 description="Photo backdrop (Middlebury teddy im2 on a plane at Z=22), a sphere with a procedural "
                             "noise/voronoi texture at Z=5.75-8.25, a plant of thin stems (radius 3-9 mm) and "
                             "bent leaves at Z~2.0-3.5 near the camera (thin structures with holes); the element, "
                             "an emission checker card at Z=4.2, sits between the plant and the sphere.")


def scene_plush_wall(width: int, height: int) -> Built:
    """Painted wall, a photo-textured box at mid distance, a hairy ball in front; card between."""
    f = focal_px(width)
    rng = np.random.default_rng(22)
    world((0.55, 0.55, 0.6), 0.6)
    sun((40.0, -15.0, -40.0), 2.5, 6.0)
    # wall: flat paint with a very subtle gradient (a low-texture surface)
    zw = 14.0
    ww = 2.4 * zw * SENSOR_MM / (2 * LENS_MM)
    mat, nodes, links, bsdf = _principled("paint", roughness=0.8, specular=0.2)
    coord = nodes.new("ShaderNodeTexCoord")
    grad = nodes.new("ShaderNodeTexGradient")
    links.new(coord.outputs["Generated"], grad.inputs["Vector"])
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.50, 0.46, 0.38, 1.0)
    ramp.color_ramp.elements[1].color = (0.54, 0.49, 0.41, 1.0)
    links.new(grad.outputs["Fac"], ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    card("wall", ww, ww * 0.8, (0.0, 0.0, -zw), mat)
    # mid: a box with the Middlebury "Art" photo on its faces, turned so its faces are slanted
    zb = 6.5
    bx, by = xy_at(0.36 * width, 0.45 * height, zb, f, width, height)
    box = bm_object("box", lambda bm, bmesh: bmesh.ops.create_cube(bm, size=1.0, calc_uvs=True),
                    image_material("art", DATA / "middlebury2005_2006_halfsize" / "Art" / "view1.png"))
    box.scale = (2.2, 1.7, 1.6)
    box.rotation_euler = (math.radians(8.0), math.radians(-32.0), math.radians(3.0))
    box.location = (bx, by, -zb)
    # foreground: a plush ball, a body sphere with a few thousand hair strands (hair curves)
    zf, rf = 2.6, 0.36
    fx, fy = xy_at(0.7 * width, 0.62 * height, zf, f, width, height)
    centre = np.array([fx, fy, -zf])
    fur_colors = [(0.55, 0.33, 0.12), (0.78, 0.58, 0.3), (0.4, 0.22, 0.08)]
    body = bm_object("body", lambda bm, bmesh: bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=rf),
                     procedural_material("body", fur_colors, scale=12.0), smooth=True)
    body.location = tuple(centre)
    n_hair, n_pts = 5000, 6
    gold = np.pi * (3.0 - math.sqrt(5.0))
    i = np.arange(n_hair) + 0.5
    yv = 1.0 - 2.0 * i / n_hair
    rr = np.sqrt(1.0 - yv**2)
    th = gold * i + rng.uniform(0, 0.3, n_hair)
    normals = np.stack([rr * np.cos(th), yv, rr * np.sin(th)], axis=1)
    roots = centre + rf * 0.97 * normals
    lengths = rng.uniform(0.12, 0.24, n_hair)
    dirs = normals + rng.normal(0, 0.35, (n_hair, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t = np.linspace(0, 1, n_pts)
    wiggle = rng.normal(0, 0.02, (n_hair, 1, 3)) * np.sin(np.pi * t)[None, :, None]
    droop = np.array([0.0, -0.35, 0.0])[None, None, :] * (t**2)[None, :, None] * lengths[:, None, None]
    pts = roots[:, None, :] + (lengths[:, None] * t[None, :])[..., None] * dirs[:, None, :] + wiggle + droop
    hair = bpy.data.hair_curves.new("fur")
    hair.add_curves([n_pts] * n_hair)
    hair.position_data.foreach_set("vector", pts.astype(np.float32).ravel())
    radius = hair.attributes.get("radius") or hair.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", np.tile(np.linspace(0.0028, 0.0008, n_pts), n_hair).astype(np.float32))
    # Principled BSDF rather than the Principled Hair BSDF: at equal samples the hair BSDF took 1.6x the time
    # and left twice the noise, and the benchmark is about the strands' soft silhouettes, not their shading
    hmat, _, _, _ = _principled("fur", (0.42, 0.25, 0.1), roughness=0.5, specular=0.4)
    link_object("fur", hair, hmat)
    bpy.context.scene.cycles_curves.shape = "THICK"
    # element between the plush ball and the box
    ze = 4.0
    ex, ey = xy_at(0.53 * width, 0.5 * height, ze, f, width, height)
    el = element_card(ze, (ex, ey), (0.32 * width, 0.45 * height), f)
    return Built(el, ze, baseline=0.058,
                 description="Low-texture painted wall (flat colour, 4 % gradient) at Z=14, a box with the "
                             "Middlebury Art view1 photo on its slanted faces at Z~5.2-6.6, and in front a plush "
                             f"ball (body radius {rf}) with {n_hair} hair curves (round, Principled BSDF, radius "
                             "0.8-2.8 mm) at Z~2.0-2.9; the element, an emission checker card at Z=4.0, sits "
                             "between the ball and the box.")


def scene_fence_dof(width: int, height: int) -> Built:
    """A wire fence near the camera, a slanted rock wall and ground behind it, depth of field; card behind."""
    f = focal_px(width)
    world((0.55, 0.65, 0.85), 0.8)
    sun((60.0, 0.0, 120.0), 3.5, 5.0)
    # ground: gravel-like procedural texture, from under the camera to far away
    ground = card("ground", 40.0, 60.0, (0.0, 0.0, 0.0),
                  procedural_material("gravel", [(0.3, 0.27, 0.22), (0.42, 0.38, 0.32), (0.33, 0.32, 0.3),
                                                 (0.48, 0.44, 0.38)], scale=2.0, voronoi=0.5))
    ground.rotation_euler = (math.radians(-90.0), 0.0, 0.0)
    ground.location = (0.0, -1.3, -30.0)
    # slanted wall: Middlebury Rocks1 photo, receding from Z~5 (left) to Z~16 (right)
    wall = card("wall", 16.0, 16.0 * 555 / 638, (0.0, 0.0, 0.0),
                image_material("rocks", DATA / "middlebury2005_2006_halfsize" / "Rocks1" / "view1.png"))
    wall.rotation_euler = (0.0, math.radians(-52.0), 0.0)
    wall.location = (1.5, 1.9, -10.5)
    # fence: a diamond lattice of thin wires and two posts at Z ~ 2.1
    zf = 2.1
    fence = MeshBatch()
    half_w = 0.7 * zf * SENSOR_MM / LENS_MM
    y0, y1 = -1.3, 1.6
    step = 0.17
    for c in np.arange(-half_w - (y1 - y0), half_w + (y1 - y0), step):
        for sgn in (1.0, -1.0):
            xa, xb = c, c + sgn * (y1 - y0)
            pts = np.stack([np.linspace(xa, xb, 24), np.linspace(y0, y1, 24), np.full(24, -zf)], axis=1)
            pts[:, 2] += 0.004 * sgn * np.cos(np.linspace(0, 40 * np.pi, 24))  # the weave
            fence.add(*tube(pts, 0.0045, sides=6))
    for px in (-0.9, 1.05):
        fence.add(*tube(np.array([[px, y0, -zf - 0.03], [px, y1, -zf - 0.03]]), 0.03, sides=12))
    fence.add(*tube(np.array([[-half_w, 0.9, -zf - 0.03], [half_w, 0.9, -zf - 0.03]]), 0.018, sides=10))
    metal, nodes, links, bsdf = _principled("metal", (0.5, 0.5, 0.52), roughness=0.5)
    bsdf.inputs["Metallic"].default_value = 0.6
    fence.build("fence", metal)
    # element behind the fence, in focus
    ze = 5.0
    ex, ey = xy_at(0.45 * width, 0.5 * height, ze, f, width, height)
    el = element_card(ze, (ex, ey), (0.36 * width, 0.42 * height), f)
    fstop = 1.4
    return Built(el, ze, baseline=0.065,
                 description="A chain-link fence (diamond lattice of 4.5 mm wires and posts) at Z~2.1 in front of "
                             "a slanted rock wall (Middlebury Rocks1 view1, Z~7.5-17) and gravel ground running "
                             "to the horizon, sky above (at infinity, d = 0); depth of field focused on the "
                             f"element (35 mm f/{fstop}, the same for every camera), so the fence is soft. The "
                             "element, an emission checker card at Z=5.0, is behind the fence.",
                 dof={"focus_distance": ze, "fstop": fstop})


def scene_plane_check(width: int, height: int) -> Built:
    """Test scene: a textured fronto-parallel plane at Z = 3 (emission) and a lit plane behind; card in front."""
    f = focal_px(width)
    world((0.5, 0.5, 0.5), 0.7)
    sun((30.0, 0.0, 20.0), 2.0, 5.0)
    zb = 6.0
    w = 2.0 * zb * SENSOR_MM / LENS_MM
    card("back", w, w, (0.0, 0.0, -zb), procedural_material("back", [(0.2, 0.2, 0.2), (0.8, 0.7, 0.6)], scale=3.0))
    zp = 3.0
    mat, nodes, links = _material("plane")
    nodes.clear()
    coord = nodes.new("ShaderNodeTexCoord")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 6.0
    noise.inputs["Detail"].default_value = 2.0
    links.new(coord.outputs["Object"], noise.inputs["Vector"])
    emit = nodes.new("ShaderNodeEmission")
    links.new(noise.outputs["Color"], emit.inputs["Color"])
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(emit.outputs[0], out.inputs["Surface"])
    pw = 0.55 * zp * SENSOR_MM / LENS_MM
    card("plane", pw, pw, (-0.35 * zp * SENSOR_MM / LENS_MM, 0.0, -zp), mat)
    ze = 2.0
    ex, ey = xy_at(0.72 * width, 0.5 * height, ze, f, width, height)
    el = element_card(ze, (ex, ey), (0.3 * width, 0.4 * height), f)
    return Built(el, ze, baseline=0.05, description="Test scene: an emission noise plane at Z=3 over a lit plane.")


# Samples per pixel when --samples is not given: enough for a grain below ~0.01 rms (the fur and the
# defocused fence are the noisy ones) while each image renders in well under a minute on 2 cores.
DEFAULT_SAMPLES = {"sphere_plant": 64, "plush_wall": 96, "fence_dof": 128, "plane_check": 16}

SCENES = {
    "sphere_plant": scene_sphere_plant,
    "plush_wall": scene_plush_wall,
    "fence_dof": scene_fence_dof,
    "plane_check": scene_plane_check,
}
DEFAULT_SCENES = ["sphere_plant", "plush_wall", "fence_dof"]


# --------------------------------------------------------------------------------------------------------
# Rig and rendering


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def setup_render(width: int, height: int, samples: int, threads: int = 0):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = width, height, 100
    sc.render.film_transparent = False
    sc.render.use_persistent_data = True
    sc.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        sc.render.threads = threads
    sc.render.use_motion_blur = False
    c = sc.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.use_guiding = False
    c.use_animated_seed = False
    c.seed = SEED
    c.pixel_filter_type = "BLACKMAN_HARRIS"  # Blender's default film filter, 1.5 px wide
    c.filter_width = 1.5
    c.max_bounces = 6
    c.diffuse_bounces = 3
    c.glossy_bounces = 3
    c.transmission_bounces = 6
    c.transparent_max_bounces = 8
    c.sample_clamp_indirect = 10.0
    sc.view_layers[0].use_pass_z = True
    sc.view_settings.view_transform = "Standard"
    im = sc.render.image_settings
    im.media_type = "MULTI_LAYER_IMAGE"
    im.file_format = "OPEN_EXR_MULTILAYER"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    im.use_exr_interleave = True


def make_rig(baseline: float, dof: dict | None):
    """Five identical cameras at x = (k - 2) * baseline, looking down -Z: a rectified, coplanar rig."""
    cams = []
    for k in POSITIONS:
        cd = bpy.data.cameras.new(f"cam{k}")
        cd.type = "PERSP"
        cd.sensor_fit = "HORIZONTAL"
        cd.sensor_width = SENSOR_MM
        cd.lens = LENS_MM
        cd.shift_x = cd.shift_y = 0.0
        cd.clip_start, cd.clip_end = 0.05, 1000.0
        if dof:
            cd.dof.use_dof = True
            cd.dof.focus_distance = dof["focus_distance"]
            cd.dof.aperture_fstop = dof["fstop"]
            cd.dof.aperture_blades = 0
        ob = link_object(f"cam{k}", cd)
        ob.location = ((k - POSITIONS[REFERENCE]) * baseline, 0.0, 0.0)
        ob.rotation_euler = (0.0, 0.0, 0.0)
        cams.append(ob)
    return cams


def render(path: Path) -> tuple[dict, float]:
    """Render the active camera to a multilayer EXR; its channels {name: (H, W) float32} and seconds."""
    sc = bpy.context.scene
    sc.render.filepath = str(path)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t0
    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT)
    if pixels is None or buf.has_error:
        raise RuntimeError(f"cannot read the render {path}: {buf.geterror()}")
    names = list(buf.spec().channelnames)
    channels = {n.split(".", 1)[1] if n.startswith("ViewLayer.") else n: pixels[..., i] for i, n in enumerate(names)}
    return channels, seconds


def rgba_of(ch: dict) -> np.ndarray:
    return np.stack([ch["Combined.R"], ch["Combined.G"], ch["Combined.B"], ch["Combined.A"]], axis=-1)


def write_exr(path: Path, pixels: np.ndarray, channels, *, half: bool, attributes: dict | None = None):
    """Write a flat EXR with OIIO (scanline, zip; ``A`` flagged as alpha and ``Z`` as depth)."""
    arr = np.ascontiguousarray(pixels, dtype=np.float32)
    if arr.ndim == 2:
        arr = arr[..., None]
    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, "half" if half else "float")
    spec.channelnames = tuple(channels)
    spec.alpha_channel = channels.index("A") if "A" in channels else -1
    spec.z_channel = channels.index("Z") if "Z" in channels else -1
    spec.attribute("compression", "zip")
    for key, value in (attributes or {}).items():
        spec.attribute(key, value)
    tmp = path.with_name(path.name + ".part.exr")
    out = oiio.ImageOutput.create(str(tmp))
    if out is None or not out.open(str(tmp), spec) or not out.write_image(arr):
        raise RuntimeError(f"cannot write {path}: {oiio.geterror()}")
    out.close()
    os.replace(tmp, path)


def srgb8(linear: np.ndarray) -> np.ndarray:
    x = np.clip(linear, 0.0, 1.0)
    enc = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.round(enc * 255.0).astype(np.uint8)


def contact_sheet(path: Path, views, comp, element, disparity):
    """Views 0-3 / view 4, comp, element over grey, disparity (white = near); 2 px gaps."""
    h, w = comp.shape[:2]
    grey = 0.18
    el = element[..., :3] + (1.0 - element[..., 3:4]) * grey
    dmax = max(float(np.max(disparity)), 1e-6)
    disp = np.repeat((disparity / dmax)[..., None] ** 2.2, 3, axis=-1)  # linear, so it encodes to d/dmax
    tiles = [*views[:4], views[4], comp, el, disp]
    gap = 2
    sheet = np.ones((2 * h + gap, 4 * w + 3 * gap, 3), np.float32)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, 4)
        sheet[r * (h + gap): r * (h + gap) + h, c * (w + gap): c * (w + gap) + w] = tile[..., :3]
    img = srgb8(sheet)
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(img.shape[1], img.shape[0], 3, "uint8")
    if out is None or not out.open(str(path), spec) or not out.write_image(img):
        raise RuntimeError(f"cannot write {path}: {oiio.geterror()}")
    out.close()


def suggested_planes(d_min: float, d_max: float, step: float = 0.5, margin: float = 1.0, at_least: int = 16):
    lo = max(0.0, math.floor((d_min - margin) / step) * step)
    hi = math.ceil((d_max + margin) / step) * step
    while round((hi - lo) / step) + 1 < at_least:
        hi += step
    n = int(round((hi - lo) / step)) + 1
    return [round(lo + i * step, 6) for i in range(n)]


def render_scene(name: str, out_root: Path, width: int, height: int, samples: int, *, threads: int = 0,
                 views: list[int] | None = None, contact: bool = True, blend: bool = False,
                 log=print) -> dict:
    """Build and render scene ``name`` into ``out_root/name``; returns what goes into scene.json."""
    reset()
    setup_render(width, height, samples, threads)
    built = SCENES[name](width, height)
    cams = make_rig(built.baseline, built.dof)
    sc = bpy.context.scene
    f = focal_px(width)
    B = built.baseline
    out = out_root / name
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="render-", dir=_BL_TMP))
    el = built.element
    times = {}
    views = list(POSITIONS) if views is None else list(views)

    # 1. the true depth of the reference view: one pinhole ray through each pixel centre (no DOF, no filter),
    #    and which object each ray hits (object index pass)
    el.hide_render = True
    objects = [ob for ob in sc.objects if ob.type in ("MESH", "CURVES")]
    for i, ob in enumerate(objects, start=1):
        ob.pass_index = i
    sc.view_layers[0].use_pass_object_index = True
    sc.camera = cams[REFERENCE]
    ref_dof = cams[REFERENCE].data.dof.use_dof
    cams[REFERENCE].data.dof.use_dof = False
    sc.cycles.samples, sc.cycles.filter_width, sc.cycles.max_bounces = 1, 0.01, 0
    ch, times["depth"] = render(tmp / "depth.exr")
    depth = ch["Depth.Z"]
    index = np.rint(ch["Object Index.X"]).astype(np.int64)
    sc.view_layers[0].use_pass_object_index = False
    sky = depth > FAR
    disparity = np.where(sky, 0.0, f * B / np.where(sky, 1.0, depth)).astype(np.float32)
    cams[REFERENCE].data.dof.use_dof = ref_dof
    sc.cycles.samples, sc.cycles.filter_width, sc.cycles.max_bounces = samples, 1.5, 6

    # 2. the plates, each with its own seed; the element is in the scene but transparent (see element_material)
    el.hide_render = False
    show_element(el, False)
    plates = {}
    for k in views:
        sc.camera = cams[k]
        sc.cycles.seed = SEED + k
        ch, times[f"view{k}"] = render(tmp / f"view{k}.exr")
        plates[k] = rgba_of(ch)[..., :3]
        write_exr(out / f"view{k}.exr", plates[k], "RGB", half=True)
        log(f"  {name}: view{k} {times[f'view{k}']:.1f} s")

    # 3. the comp: the reference view again, same seed, with the element shown
    sc.camera = cams[REFERENCE]
    sc.cycles.seed = SEED + REFERENCE
    show_element(el, True)
    ch, times["comp"] = render(tmp / "comp.exr")
    comp = rgba_of(ch)[..., :3]
    write_exr(out / "comp.exr", comp, "RGB", half=True)

    # 4. the element alone: everything else hidden, film transparent
    hidden = [ob for ob in sc.objects if ob is not el and ob.type != "CAMERA" and not ob.hide_render]
    for ob in hidden:
        ob.hide_render = True
    sc.render.film_transparent = True
    ch, times["element"] = render(tmp / "element.exr")
    element = rgba_of(ch)
    el_z = np.where(element[..., 3] > 0, ch["Depth.Z"], EMPTY_Z)
    write_exr(out / "element.exr", np.concatenate([element, el_z[..., None]], axis=-1), "RGBAZ", half=False)
    for ob in hidden:
        ob.hide_render = False
    sc.render.film_transparent = False
    el.hide_render = True

    # 5. comp == plate outside the element's support
    support = element[..., 3] > 0
    diff = np.abs(comp - plates[REFERENCE]) if REFERENCE in plates else None
    outside = float(diff[~support].max()) if diff is not None and (~support).any() else float("nan")
    inside = float(diff[support].max()) if diff is not None and support.any() else float("nan")
    half_diff = float("nan")
    if REFERENCE in plates:
        h_comp = comp.astype(np.float16).astype(np.float32)
        h_plate = plates[REFERENCE].astype(np.float16).astype(np.float32)
        half_diff = float(np.abs(h_comp - h_plate)[~support].max()) if (~support).any() else float("nan")

    D = f * B / built.element_depth
    seen, in_front = {}, {}
    covered = element[..., 3] >= 0.5
    for i, ob in enumerate(objects, start=1):
        on = (index == i) & ~sky
        if on.any():
            seen[ob.name] = {"pixels": int(on.sum()), "disparity": [float(disparity[on].min()),
                                                                    float(disparity[on].max())]}
        front = on & covered & (disparity > D)
        if front.any():
            in_front[ob.name] = int(front.sum())
    if sky.any():
        seen["sky"] = {"pixels": int(sky.sum()), "disparity": [0.0, 0.0]}
    d_min, d_max = float(disparity.min()), float(disparity.max())
    d_obj = float(disparity[~sky].min()) if (~sky).any() else float("nan")
    planes = suggested_planes(d_min, d_max)
    write_exr(out / "disparity.exr", np.stack([disparity, disparity], axis=-1), "YZ", half=False)
    info = {
        "scene": name,
        "description": built.description,
        "size": [width, height],
        "views": [f"view{k}.exr" for k in POSITIONS],
        "positions": POSITIONS,
        "reference": REFERENCE,
        "focal_px": f,
        "baseline": B,
        "element_disparity": D,
        "convention": "a point at column x of the reference view with disparity d = f*B/Z appears at column "
                      "x - d*(p_k - p_ref) of view k; larger d is nearer",
        "element": {"file": "element.exr", "depth": built.element_depth, "disparity": D,
                    "channels": "R,G,B,A premultiplied scene-linear, Z depth (1e10 where A = 0)",
                    "covered_pixels": int(covered.sum()),
                    "occluded_pixels": int((covered & ~sky & (disparity > D)).sum())},
        "disparity_range": [d_min, d_max],
        "disparity_range_of_surfaces": [d_obj, d_max],
        "has_sky": bool(sky.any()),
        "objects": seen,
        "objects_in_front_of_element": in_front,
        "planes": planes,
        "planes_cli": f"{planes[0]:g}:{planes[-1]:g}:0.5",
        "comp_vs_plate": {"max_abs_outside_element": outside, "max_abs_outside_element_half": half_diff,
                          "max_abs_inside_element": inside, "support_pixels": int(support.sum())},
        "render": {"engine": "CYCLES", "device": "CPU", "samples": samples, "seeds": {
                       f"view{k}": SEED + k for k in POSITIONS} | {"comp": SEED + REFERENCE,
                                                                     "element": SEED + REFERENCE},
                   "pixel_filter": "BLACKMAN_HARRIS 1.5 px", "denoiser": None, "adaptive_sampling": False,
                   "max_bounces": 6, "dof": built.dof, "colorspace": "Blender scene linear (Linear Rec.709)",
                   "depth": "one pinhole ray per pixel centre (filter 0.01 px, no DOF)",
                   "seconds": {k: round(v, 2) for k, v in times.items()}},
        "bpy": bpy.app.version_string,
    }
    (out / "scene.json").write_text(json.dumps(info, indent=1) + "\n")
    if contact and len(plates) == len(POSITIONS):
        contact_sheet(out_root / f"{name}.png", [plates[k] for k in POSITIONS], comp, element, disparity)
    if blend:
        bpy.ops.wm.save_as_mainfile(filepath=str(out / "scene.blend"), check_existing=False)
    shutil.rmtree(tmp, ignore_errors=True)
    return info


def summary_line(info: dict) -> str:
    t = info["render"]["seconds"]
    views = [v for k, v in t.items() if k.startswith("view")]
    cv = info["comp_vs_plate"]
    return (f"{info['scene']}: d {info['disparity_range'][0]:.2f}..{info['disparity_range'][1]:.2f} px/step, "
            f"element D = {info['element']['disparity']:.2f}, {len(info['planes'])} planes "
            f"{info['render']['samples']} spp, "
            f"{info['planes_cli']}; comp-plate outside element max |diff| = {cv['max_abs_outside_element']:.3g} "
            f"(inside {cv['max_abs_inside_element']:.3g}); render s: views {min(views):.1f}-{max(views):.1f}, "
            f"comp {t['comp']:.1f}, element {t['element']:.1f}, depth {t['depth']:.1f}")


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must be WxH, got {text!r}") from None
    if w < 8 or h < 8:
        raise argparse.ArgumentTypeError(f"--size {text} is too small")
    return w, h


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, type=Path, help="output folder (one sub-folder per scene)")
    ap.add_argument("--scenes", default=",".join(DEFAULT_SCENES),
                    help=f"comma-separated, from {', '.join(SCENES)} (default: {','.join(DEFAULT_SCENES)})")
    ap.add_argument("--size", type=parse_size, default=(480, 270), help="WxH (default 480x270)")
    ap.add_argument("--samples", type=int, default=None,
                    help="Cycles samples per pixel (default per scene: "
                         + ", ".join(f"{k} {v}" for k, v in DEFAULT_SAMPLES.items() if k in DEFAULT_SCENES) + ")")
    ap.add_argument("--threads", type=int, default=0, help="render threads (default: all cores)")
    ap.add_argument("--blend", action="store_true", help="also save each scene as scene.blend")
    args = ap.parse_args(argv)
    if args.samples is not None and args.samples < 1:
        ap.error("--samples must be at least 1")
    names = [s.strip() for s in args.scenes.split(",") if s.strip()]
    unknown = [s for s in names if s not in SCENES]
    if unknown:
        ap.error(f"unknown scene(s) {', '.join(unknown)}; choose from {', '.join(SCENES)}")
    if not (DATA / "middlebury2003_teddy").is_dir():
        ap.error(f"the shared data is not at {DATA} (set VFXSTEREO_DATA)")
    width, height = args.size
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    lines = []
    for name in names:
        t1 = time.perf_counter()
        samples = args.samples or DEFAULT_SAMPLES[name]
        info = render_scene(name, args.out, width, height, samples, threads=args.threads, blend=args.blend)
        lines.append(summary_line(info) + f"; total {time.perf_counter() - t1:.0f} s")
        print(lines[-1], flush=True)
    print(f"{len(names)} scene(s) at {width}x{height} in {time.perf_counter() - t0:.0f} s "
          f"-> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
