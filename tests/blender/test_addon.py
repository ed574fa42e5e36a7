"""The extension zip, installed the way users install it, and every operator run from Python on the sample.

The zip is ``make blender-extension``'s (``$VFXSTEREO_EXTENSION_ZIP``; built here when unset). It is installed
once per module with ``bpy.ops.extensions.package_install_files`` into the temporary user folders that
tests/conftest.py sets up. The sample's stack is solved once, by the Solve Plates operator, and the other
operators work on that file. Renders are the sample's size (320x225) with one or two samples: the planes
are emission and transparency only, so a sample per pixel is already exact.
"""

import contextlib
import ctypes
import io
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from tests.blender.conftest import REPO, render_to_array
from tests.test_runner import write_small_views
from vfxstereo import composite
from vfxstereo.io import exr, plates
from vfxstereo.scene import CameraFrustum, PlanePlacement, depth_mapping

bpy = pytest.importorskip("bpy")
mathutils = pytest.importorskip("mathutils")

ADDON = "bl_ext.user_default.vfxstereo"
DEMO = REPO / "samples" / "demo"
ELEMENT = DEMO / "element.exr"
CARD_DISPARITY = 3.5  # between the planes d = 3 and 4: in front of the pumpkin, behind the hair


def psnr(a, b):
    return float(10 * np.log10(1.0 / max(float(np.mean((np.asarray(a) - np.asarray(b)) ** 2)), 1e-20)))


def _flush_all():
    """Python's and C's stdio buffers (Blender prints reports with C's printf)."""
    sys.stdout.flush()
    sys.stderr.flush()
    ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def captured_output():
    """What Blender prints while the block runs: reports go through Python's sys.stdout when an operator is
    called from Python, and C code prints to file descriptors 1 and 2; both are caught."""
    _flush_all()
    saved = os.dup(1), os.dup(2)
    python_side = io.StringIO()
    with tempfile.TemporaryFile(mode="w+b") as f:
        os.dup2(f.fileno(), 1)
        os.dup2(f.fileno(), 2)
        text = []
        try:
            with contextlib.redirect_stdout(python_side), contextlib.redirect_stderr(python_side):
                yield text
        finally:
            _flush_all()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            f.seek(0)
            text.append(f.read().decode("utf-8", errors="replace") + python_side.getvalue())


@pytest.fixture(scope="module")
def extension_zip():
    given = os.environ.get("VFXSTEREO_EXTENSION_ZIP")
    if given:
        return Path(given)
    out = REPO / "dist" / "test" / "vfxstereo-linux_x64.zip"
    subprocess.run([sys.executable, str(REPO / "scripts" / "build_blender_extension.py"), "--output", str(out)],
                   check=True, capture_output=True)
    return out


@pytest.fixture(scope="module")
def installed(extension_zip):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.extensions.package_install_files(filepath=str(extension_zip), repo="user_default",
                                                    enable_on_install=True) == {"FINISHED"}
    assert ADDON in bpy.context.preferences.addons
    yield Path(bpy.utils.user_resource("EXTENSIONS")) / ".local" / "lib" / "python3.11" / "site-packages"
    bpy.ops.preferences.addon_disable(module=ADDON)
    repo = [i for i, r in enumerate(bpy.context.preferences.extensions.repos) if r.module == "user_default"][0]
    bpy.ops.extensions.package_uninstall(repo_index=repo, pkg_id="vfxstereo")  # its 400 MB of wheels too


@pytest.fixture
def fresh_scene(installed):
    """An empty scene; the add-on stays enabled (a factory reset would disable it)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    assert ADDON in bpy.context.preferences.addons
    yield bpy.context.scene
    bpy.ops.wm.read_homefile(use_empty=True)


@pytest.fixture
def prefs(installed):
    p = bpy.context.preferences.addons[ADDON].preferences
    yield p
    p.solver_command = p.default_preset = p.default_disparities = ""
    p.focal_baseline = 0.0


@pytest.fixture(scope="module")
def solved(installed, tmp_path_factory):
    """The Solve Plates operator on the shipped sample: its result, the stack, what it printed."""
    bpy.ops.wm.read_homefile(use_empty=True)
    folder = tmp_path_factory.mktemp("solve")
    with captured_output() as text:
        result = bpy.ops.vfxstereo.solve_plates(dataset=str(DEMO), output=str(folder / "stack.exr"),
                                                disparities="0:4")  # the sample's planes, as make demo does
    return {"result": result, "stack": folder / "stack.exr", "output": text[0],
            "stack_path": bpy.context.scene.vfxstereo.stack_path,
            "images": [bpy.path.abspath(i.filepath) for i in bpy.data.images]}


# --------------------------------------------------------------------------------------------------------
# The package


def test_the_zip_holds_the_add_on_nodes_and_the_wheels_its_manifest_lists(extension_zip):
    import tomllib
    import zipfile

    with zipfile.ZipFile(extension_zip) as z:
        names = set(z.namelist())
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
    assert manifest["schema_version"] == "1.0.0" and manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert manifest["blender_version_min"] == "5.0.0" and manifest["permissions"]["files"]
    assert {"__init__.py", "nodes/__init__.py", "nodes/zkey_insert.py", "operators/solve_plates.py"} <= names
    assert {w.removeprefix("./") for w in manifest["wheels"]} <= names
    assert not any(n.startswith("wheels/numpy") for n in names)  # Blender's own numpy is kept
    assert any(n.startswith("wheels/vfxstereo-") for n in names)


def test_installed_and_enabled_with_its_operators_panels_and_preferences(installed, fresh_scene):
    for name in ("VFXSTEREO_OT_solve_plates", "VFXSTEREO_OT_import_stack_planes",
                 "VFXSTEREO_OT_build_zkey_compositor", "VFXSTEREO_PT_view3d", "VFXSTEREO_PT_compositor"):
        assert hasattr(bpy.types, name), name
    assert fresh_scene.vfxstereo.stack_path == ""
    assert bpy.context.preferences.addons[ADDON].preferences.solver_command == ""
    assert installed.is_dir() and (installed / "vfxstereo" / "cli.py").is_file()
    bpy.ops.preferences.addon_disable(module=ADDON)
    assert not hasattr(bpy.types, "VFXSTEREO_OT_solve_plates")  # unregister undid every class
    bpy.ops.preferences.addon_enable(module=ADDON)
    assert hasattr(bpy.types, "VFXSTEREO_OT_solve_plates") and hasattr(bpy.context.scene, "vfxstereo")


def test_the_bundled_wheels_alone_are_enough_to_solve(installed, tmp_path):
    """Blender's Python, its numpy, and nothing but what the zip installed (no venv site-packages)."""
    import numpy

    numpy_only = tmp_path / "numpy-only"
    numpy_only.mkdir()
    for name in ("numpy", "numpy.libs"):
        source = Path(numpy.__file__).parents[1] / name
        if source.exists():
            (numpy_only / name).symlink_to(source)
    views = write_small_views(tmp_path)
    out = tmp_path / "stack.exr"
    code = ("import sys, runpy; sys.path[:0] = [sys.argv.pop(1), sys.argv.pop(1)]; import vfxstereo; "
            "assert vfxstereo.__file__.startswith(sys.path[0]), vfxstereo.__file__; "
            "runpy.run_module('vfxstereo.cli', run_name='__main__')")
    done = subprocess.run([sys.executable, "-S", "-E", "-c", code, str(installed), str(numpy_only), "solve",
                           *views, "-o", str(out), "--disparities", "0:3", "-q"], capture_output=True, text=True,
                          env={"NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PATH": os.environ.get("PATH", "")})
    assert done.returncode == 0, done.stderr[-2000:]
    assert exr.read_stack(out).depth == 4


_ONLY_BPY_AND_NUMPY = """
import os, sys
sys.path.insert(0, os.environ["ONLY"])
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.extensions.package_install_files(filepath=os.environ["ZIP"], repo="user_default", enable_on_install=True)
import vfxstereo, OpenImageIO
where = os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions")
assert vfxstereo.__file__.startswith(where) and OpenImageIO.__file__.startswith(where), vfxstereo.__file__
assert bpy.ops.vfxstereo.import_stack_planes(filepath=os.environ["STACK"]) == {"FINISHED"}
assert bpy.ops.vfxstereo.build_zkey_compositor(filepath=os.environ["STACK"], disparity=3) == {"FINISHED"}
print("planes", sum("vfxstereo_layer" in o for o in bpy.context.scene.objects))
"""


def test_the_add_on_runs_on_its_bundled_wheels_alone(extension_zip, solved, tmp_path):
    """A Blender that has nothing but bpy and numpy: install the zip, import planes, build the z-key tree."""
    import numpy

    only = tmp_path / "only"
    only.mkdir()
    site = Path(numpy.__file__).parents[1]
    for name in ("bpy", "numpy", "numpy.libs"):
        if (site / name).exists():
            (only / name).symlink_to(site / name)
    env = {"PATH": os.environ.get("PATH", ""), "ONLY": str(only), "ZIP": str(extension_zip),
           "STACK": str(solved["stack"]), "BLENDER_USER_RESOURCES": str(tmp_path / "user"),
           "XDG_CACHE_HOME": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-S", "-E", "-c", _ONLY_BPY_AND_NUMPY], capture_output=True,
                          text=True, env=env, cwd=tmp_path)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    assert "planes 5" in done.stdout


# --------------------------------------------------------------------------------------------------------
# Solve Plates


def test_solve_plates_writes_the_stack_loads_it_and_reports_progress(solved):
    assert solved["result"] == {"FINISHED"}
    stack = exr.read_stack(solved["stack"])
    assert stack.depth == 5 and stack.plate is not None
    assert os.listdir(solved["stack"].parent) == ["stack.exr"]  # no work folder left behind
    assert solved["stack_path"] == str(solved["stack"])
    assert str(solved["stack"]) in solved["images"]
    out = solved["output"]
    assert "Solving with the bundled vfxstereo" in out
    for stage in ("match", "soft-edges"):  # the default (robust) preset's stages
        assert f"vfxstereo: {stage} " in out, out[-3000:]
    assert "Solved with the bundled vfxstereo" in out


def test_cancelling_a_solve_leaves_no_files(installed, fresh_scene, tmp_path):
    """Ctrl-C while the operator waits for the child (what Esc does in the UI: SolveRun.cancel)."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 3.0)
    try:
        with captured_output() as text:
            # 801 planes: a solve of ~14 s, well over the 3 s before the interrupt (201 planes took ~5 s, too
            # close: a child that ends on its own first exits 0 and the operator finishes)
            result = bpy.ops.vfxstereo.solve_plates(dataset=str(DEMO), output=str(tmp_path / "stack.exr"),
                                                    disparities="0:4:0.005")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert result == {"CANCELLED"}
    assert os.listdir(tmp_path) == []
    assert "cancelled" in text[0]
    with pytest.raises(ChildProcessError):
        os.waitpid(-1, os.WNOHANG)  # the child was stopped and reaped


def test_a_solve_that_fails_reports_the_commands_one_line_error(installed, fresh_scene, tmp_path):
    with pytest.raises(RuntimeError) as info:
        bpy.ops.vfxstereo.solve_plates(directory=str(tmp_path), files=[{"name": "a.png"}, {"name": "b.png"}],
                                       output=str(tmp_path / "s.exr"))
    message = str(info.value).strip()
    assert "input not found" in message and "\n" not in message
    assert os.listdir(tmp_path) == []


def test_solve_refuses_bad_options_before_starting(installed, fresh_scene, tmp_path):
    with pytest.raises(RuntimeError, match="either view files or a dataset"):
        bpy.ops.vfxstereo.solve_plates(directory=str(DEMO), files=[{"name": "view0.png"}], dataset=str(DEMO))
    with pytest.raises(RuntimeError, match="at least two views"):  # the command's own check, one line
        bpy.ops.vfxstereo.solve_plates(directory=str(DEMO), files=[{"name": "view0.png"}],
                                       output=str(tmp_path / "s.exr"))
    with pytest.raises(RuntimeError, match="MIN:MAX"):
        bpy.ops.vfxstereo.solve_plates(dataset=str(DEMO), disparities="4", output=str(tmp_path / "s.exr"))
    assert os.listdir(tmp_path) == []


def test_solve_with_an_external_command_says_so(installed, fresh_scene, prefs, tmp_path):
    command = Path(sys.executable).with_name("vfxstereo")
    prefs.solver_command = str(command)
    views = write_small_views(tmp_path)
    names = [{"name": Path(v).name} for v in views]
    with captured_output() as text:
        result = bpy.ops.vfxstereo.solve_plates(directory=str(tmp_path), files=names, disparities="0:3",
                                                output=str(tmp_path / "stack.exr"))
    assert result == {"FINISHED"}
    assert f"Solving with the external command {command}" in text[0]
    assert exr.read_stack(tmp_path / "stack.exr").depth == 4
    prefs.solver_command = str(tmp_path / "no-such-vfxstereo")
    with pytest.raises(RuntimeError, match="no-such-vfxstereo.*not found"):
        bpy.ops.vfxstereo.solve_plates(directory=str(tmp_path), files=names, output=str(tmp_path / "t.exr"))


# --------------------------------------------------------------------------------------------------------
# Import Stack as Planes


def _planes(scene):
    return sorted((o for o in scene.objects if "vfxstereo_layer" in o), key=lambda o: o["vfxstereo_disparity"])


def _cycles(scene, samples=1):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.render.film_transparent = True


def test_import_planes_puts_each_layer_at_its_depth_filling_the_camera_frame(solved, fresh_scene):
    assert bpy.ops.vfxstereo.import_stack_planes(filepath=str(solved["stack"]), focal_baseline=12.0) == {
        "FINISHED"}
    camera = fresh_scene.camera
    planes = _planes(fresh_scene)
    stack = exr.read_stack(solved["stack"])
    assert [p["vfxstereo_disparity"] for p in planes] == list(stack.disparities)
    assert (fresh_scene.render.resolution_x, fresh_scene.render.resolution_y) == (320, 225)
    frame = [v.copy() for v in camera.data.view_frame(scene=fresh_scene)]  # Blender's frame, at some depth
    for plane in planes:
        assert plane.parent == camera
        z = plane["vfxstereo_depth"]
        if plane["vfxstereo_disparity"] > 0:
            assert z == pytest.approx(12.0 / plane["vfxstereo_disparity"])
        corners = sorted(tuple(round(c, 6) for c in camera.matrix_world.inverted() @ plane.matrix_world @ v.co)
                         for v in plane.data.vertices)
        expected = sorted(tuple(round(c, 6) for c in f * (z / -f.z)) for f in frame)
        np.testing.assert_allclose(corners, expected, rtol=1e-5, atol=1e-6)
        assert camera.data.clip_start < z < camera.data.clip_end
    depths = [p["vfxstereo_depth"] for p in planes]
    assert depths == sorted(depths, reverse=True)  # larger disparity, nearer


def test_planes_render_the_flattened_stack_in_cycles(solved, fresh_scene, tmp_path):
    bpy.ops.vfxstereo.import_stack_planes(filepath=str(solved["stack"]))
    _cycles(fresh_scene, samples=2)
    got = render_to_array(fresh_scene, tmp_path / "planes.exr")
    flat = exr.read_stack(solved["stack"]).flatten()
    measured = psnr(got, flat)
    print(f"planes vs stack.flatten(): {measured:.1f} dB")
    assert measured >= 35.0


def _add_card(scene, element_rgba, disparity, focal_baseline=None):
    """A CG card of the element at the depth of ``disparity``, made as a CG artist would: the texture's
    (straight) colour through Mix(Transparent, Emission) by its alpha (not the add-on's material)."""
    camera = scene.camera
    z = float(depth_mapping(None, focal_baseline).depth(disparity))
    r = scene.render
    frustum = CameraFrustum(r.resolution_x, r.resolution_y, lens=camera.data.lens,
                            sensor_width=camera.data.sensor_width, sensor_fit=camera.data.sensor_fit)
    cx, cy, w, h = frustum.frame(z)
    placement = PlanePlacement(0, "card", disparity, z, (cx, cy, -z), (w, h))
    image = bpy.data.images.new("card", element_rgba.shape[1], element_rgba.shape[0], alpha=True,
                                float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(element_rgba[::-1]).ravel())  # float buffers: premultiplied
    image.alpha_mode = "PREMUL"  # the texture's Color output is then straight, for the Mix's Fac = alpha
    mesh = bpy.data.meshes.new("card")
    mesh.from_pydata([(-w / 2, -h / 2, 0), (w / 2, -h / 2, 0), (w / 2, h / 2, 0), (-w / 2, h / 2, 0)], [],
                     [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new()
    for loop in mesh.loops:
        uv.data[loop.index].uv = [(0, 0), (1, 0), (1, 1), (0, 1)][loop.vertex_index]
    mat = bpy.data.materials.new("card")
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = image, "Closest"
    emit, clear, mix = (nt.nodes.new(t) for t in ("ShaderNodeEmission", "ShaderNodeBsdfTransparent",
                                                  "ShaderNodeMixShader"))
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(tex.outputs["Color"], emit.inputs["Color"])
    nt.links.new(tex.outputs["Alpha"], mix.inputs["Fac"])
    nt.links.new(clear.outputs[0], mix.inputs[1])
    nt.links.new(emit.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    mat.surface_render_method = "BLENDED"
    mesh.materials.append(mat)
    card = bpy.data.objects.new("card", mesh)
    scene.collection.objects.link(card)
    card.matrix_world = camera.matrix_world @ mathutils.Matrix.Translation(placement.centre)
    return card


@pytest.mark.parametrize("engine", ["CYCLES", "BLENDER_EEVEE"])
def test_a_cg_card_among_the_planes_renders_as_insert_into_the_stack(solved, fresh_scene, tmp_path, engine):
    fb = 12.0
    bpy.ops.vfxstereo.import_stack_planes(filepath=str(solved["stack"]), focal_baseline=fb)
    element, _ = plates.read_element(ELEMENT)
    _add_card(fresh_scene, element, CARD_DISPARITY, fb)
    if engine == "CYCLES":
        _cycles(fresh_scene)
    else:
        fresh_scene.render.engine = engine
        fresh_scene.eevee.taa_render_samples = 1
        fresh_scene.render.film_transparent = True
    try:
        got = render_to_array(fresh_scene, tmp_path / "card.exr")
    except RuntimeError as exc:
        if engine == "CYCLES":
            raise
        pytest.skip(f"EEVEE cannot render on this machine (no GPU context): {exc}")
    stack = exr.read_stack(solved["stack"])
    expected = composite.insert(stack, element, disparity=CARD_DISPARITY, into="stack")
    measured = psnr(got, expected)
    print(f"{engine}: card at d = {CARD_DISPARITY} vs insert(into='stack'): {measured:.1f} dB")
    assert measured >= 30.0
    # the card is really between the layers: hidden by the hair in front, over what is behind
    assert psnr(got, composite.over(element, stack.flatten())) < measured - 3
    assert psnr(got, stack.flatten()) < measured - 3


def test_import_planes_reports_a_missing_stack_in_one_line(installed, fresh_scene, tmp_path):
    with pytest.raises(RuntimeError) as info:
        bpy.ops.vfxstereo.import_stack_planes(filepath=str(tmp_path / "missing.exr"))
    assert "not found" in str(info.value) and "\n" not in str(info.value).strip()
    assert not _planes(fresh_scene)


# --------------------------------------------------------------------------------------------------------
# Build Z-Key Compositor


def _render_output(scene, tmp_path, output):
    """Render the compositor with the tree's ``output`` shown as the composite."""
    tree = scene.compositing_node_group
    group_output = next(n for n in tree.nodes if n.bl_idname == "NodeGroupOutput")
    source = group_output.inputs[output].links[0].from_socket
    tree.links.new(source, group_output.inputs["Image"])
    return render_to_array(scene, tmp_path / f"{output}.exr")


@pytest.mark.parametrize("into", ["PLATE", "STACK"])
def test_zkey_compositor_matches_insert_and_holdout(solved, fresh_scene, tmp_path, into):
    result = bpy.ops.vfxstereo.build_zkey_compositor(filepath=str(solved["stack"]), disparity=3.0, element="IMAGE",
                                                     element_path=str(ELEMENT), into=into)
    assert result == {"FINISHED"}
    tree = fresh_scene.compositing_node_group
    assert tree is not None and {s.name for s in tree.interface.items_tree} == {"Image", "Holdout"}
    stack = exr.read_stack(solved["stack"])
    element, _ = plates.read_element(ELEMENT)
    got = render_to_array(fresh_scene, tmp_path / "comp.exr")
    expected = composite.insert(stack, element, disparity=3.0, into=into.lower())
    error = float(np.abs(got - expected).max())
    print(f"z-key tree into {into}: max error {error:.2e}")
    assert error < 1e-4
    holdout = _render_output(fresh_scene, tmp_path, "Holdout")[..., 0]
    assert float(np.abs(holdout - composite.holdout(stack, 3.0)).max()) < 1e-4


def test_zkey_compositor_puts_the_scenes_render_between_the_layers(solved, fresh_scene, tmp_path):
    bpy.ops.vfxstereo.import_stack_planes(filepath=str(solved["stack"]))  # sets the render size and a camera
    for plane in _planes(fresh_scene):
        bpy.data.objects.remove(plane)
    element, _ = plates.read_element(ELEMENT)
    _add_card(fresh_scene, element, CARD_DISPARITY)
    _cycles(fresh_scene)
    fresh_scene.render.use_compositing = False
    cg = render_to_array(fresh_scene, tmp_path / "cg.exr")  # the render alone
    assert bpy.ops.vfxstereo.build_zkey_compositor(filepath=str(solved["stack"]), disparity=CARD_DISPARITY,
                                                   element="RENDER") == {"FINISHED"}
    got = render_to_array(fresh_scene, tmp_path / "comp.exr")
    expected = composite.insert(exr.read_stack(solved["stack"]), cg, disparity=CARD_DISPARITY)
    assert float(np.abs(got - expected).max()) < 1e-4


def test_zkey_compositor_reports_missing_inputs_in_one_line(solved, fresh_scene, tmp_path):
    with pytest.raises(RuntimeError, match="not found"):
        bpy.ops.vfxstereo.build_zkey_compositor(filepath=str(tmp_path / "missing.exr"))
    with pytest.raises(RuntimeError, match="element image not found"):
        bpy.ops.vfxstereo.build_zkey_compositor(filepath=str(solved["stack"]), element="IMAGE",
                                                element_path=str(tmp_path / "nope.exr"))
    assert fresh_scene.compositing_node_group is None
