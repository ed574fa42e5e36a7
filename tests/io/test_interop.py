"""Every kind of file vfxstereo writes, opened by the readers pipelines use: OpenEXR's Python API and oiiotool.

(Blender 5.0 reads the same files in tests/blender/test_exr_blender.py.) Each reader is asked for the pixels
and the header; the expected values come from the arrays that were written, not from vfxstereo's readers.
"""

import re
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import OpenEXR
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.homography import rectified_rig_matrices
from vfxstereo.io import exr
from vfxstereo.stack import LayerStack

OIIOTOOL = Path(sys.executable).with_name("oiiotool")
H, W = 9, 11
TIME_CODE = 0x01020304  # 01:02:03:04 in SMPTE BCD
DUMP_TOL = 5.01e-10  # oiiotool --dumpdata prints 9 decimals


def rotation(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i] = r[j, j] = c
    r[i, j], r[j, i] = -s, s
    return r


def general_camera(scale=-2.5):
    """A rotated, translated reference camera; M0 given at a negative scale (a homogeneous matrix may be)."""
    R = rotation(0, 0.3) @ rotation(1, -0.2) @ rotation(2, 0.1)
    C = np.array([0.5, -1.0, 2.0])
    K = np.array([[700.0, 0.5, 5.0], [0.0, 690.0, 4.0], [0.0, 0.0, 1.0]])
    t = -R @ C
    P0 = K @ np.hstack([R, t[:, None]])
    M0 = np.vstack([P0, [0.01, 0.02, 0.03, 70.0]])  # last row: d = (0.01 X + 0.02 Y + 0.03 Z + 70) / w
    camera = Camera(positions=[0.0, 1.0], reference=0.0, matrices=np.stack([P0, P0 + 0.01]), M0=scale * M0)
    return camera, R, t, M0


@pytest.fixture(scope="module")
def stack():
    rng = np.random.default_rng(10)
    D = 4
    alpha = rng.uniform(0.05, 1.0, (D, H, W)).astype(np.float32)
    alpha[rng.random((D, H, W)) < 0.35] = 0.0
    alpha[:, 0, 0] = 0.0  # a pixel with no layer
    rgb = rng.uniform(0.0, 1.0, (D, H, W, 3)).astype(np.float32) * alpha[..., None]
    plate = rng.uniform(0.0, 1.0, (H, W, 3)).astype(np.float32)
    camera, _, _, _ = general_camera()
    metadata = {"source_files": ["/shots/a/plate.1001.exr"] * 2, "source_views": ["left", "right"],
                "frames_per_second": [24000, 1001], "time_code": [TIME_CODE, 7]}
    return LayerStack(np.concatenate([rgb, alpha[..., None]], axis=-1), [0.5, 1.0, 2.0, 3.25], camera=camera,
                      metadata=metadata, plate=plate)


@pytest.fixture(scope="module")
def files(tmp_path_factory, stack):
    folder = tmp_path_factory.mktemp("interop")
    rng = np.random.default_rng(11)
    comp = rng.uniform(0.0, 1.0, (H, W, 4)).astype(np.float32)
    comp[..., :3] *= comp[..., 3:]
    disparity = rng.uniform(0.0, 4.0, (H, W)).astype(np.float32)
    disparity[2, 3] = np.nan
    return {
        "stack": exr.write_stack(folder / "stack.exr", stack, half=False),
        "stack_half": exr.write_stack(folder / "stack_half.exr", stack),
        "deep": exr.write_deep(folder / "deep.exr", stack),
        "comp": exr.write_image(folder / "comp.exr", comp),
        "disparity": exr.write_disparity(folder / "disparity.exr", disparity),
        "comp_pixels": comp,
        "disparity_pixels": disparity,
    }


def expected_samples(stack, z):
    """Per pixel, the layers with alpha > 0, nearest first, as rows R, G, B, A, Z, ZBack."""
    out = np.empty((H, W), dtype=object)
    for y in range(H):
        for x in range(W):
            rows = [[*stack.rgba[i, y, x], z[i], z[i]] for i in range(stack.depth - 1, -1, -1)
                    if stack.rgba[i, y, x, 3] > 0]
            out[y, x] = np.array(rows, dtype=np.float32).reshape(-1, 6)
    return out


def oiiotool(*args) -> str:
    done = subprocess.run([str(OIIOTOOL), *map(str, args)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def oiiotool_pixels(path) -> tuple[np.ndarray, list[str]]:
    """Every pixel as oiiotool prints it (``--dumpdata``: 9 decimals, so equal to within 5e-10)."""
    text = oiiotool("--info", "-v", "--dumpdata", path)
    names = [c.strip() for c in re.search(r"channel list: (.*)", text).group(1).split(",")]
    pixels = np.full((H, W, len(names)), np.nan)  # float64: the printed decimals, unrounded
    for x, y, values in re.findall(r"Pixel \((\d+), (\d+)\): (.*)", text):
        pixels[int(y), int(x)] = [float(v) for v in values.split()]
    return pixels, names


# ---------------------------------------------------------------------------------------------------------
# OpenEXR's Python API (OpenEXR.File): header and pixels of every kind


def test_openexr_reads_the_stack_layers_plate_and_header(files, stack):
    with OpenEXR.File(str(files["stack"]), separate_channels=True) as f:
        header = dict(f.header())  # File empties its dicts on close
        channels = {name: ch.pixels for name, ch in f.channels().items()}
    for i, name in enumerate(exr.layer_names(stack.disparities)):
        for c, component in enumerate("RGBA"):
            np.testing.assert_array_equal(channels[f"{name}.Combined.{component}"], stack.rgba[i, ..., c])
    for c, component in enumerate("RGB"):
        np.testing.assert_array_equal(channels[f"plate.Combined.{component}"], stack.plate[..., c])
    np.testing.assert_array_equal(channels["plate.Combined.A"], 1.0)
    assert header["vfxstereo/format"] == "layerstack"
    assert header["framesPerSecond"] == Fraction(24000, 1001)
    tc = header["timeCode"]
    assert (tc.hours, tc.minutes, tc.seconds, tc.frame, tc.userData) == (1, 2, 3, 4, 7)
    assert header["vfxstereo/sources"] == stack.metadata["source_files"]
    assert header["vfxstereo/views"] == ["left", "right"]
    matrices = exr.camera_matrices(stack.camera, (H, W))
    np.testing.assert_array_equal(header["worldToCamera"], matrices["worldToCamera"].astype(np.float32))
    np.testing.assert_array_equal(header["worldToNDC"], matrices["worldToNDC"].astype(np.float32))


def test_openexr_reads_the_half_stack_as_float16(files, stack):
    with OpenEXR.File(str(files["stack_half"]), separate_channels=True) as f:
        red = f.channels()[f"{exr.layer_names(stack.disparities)[2]}.Combined.R"].pixels
    assert red.dtype == np.float16
    np.testing.assert_array_equal(red, stack.rgba[2, ..., 0].astype(np.float16))


def test_openexr_opens_the_deep_file_with_every_sample(files, stack):
    """The issue: OpenEXR.File refused our deep file ("unsupported attribute type: deepImageState")."""
    with OpenEXR.File(str(files["deep"])) as f:
        header = dict(f.header())  # File empties its dicts on close
    assert header["type"] == OpenEXR.deepscanline  # what a loader checks to choose its deep reader
    assert header[exr.DEEP_STATE] == "tidy"
    assert "deepImageState" not in header
    assert header["framesPerSecond"] == Fraction(24000, 1001)
    with OpenEXR.File(str(files["deep"]), separate_channels=True) as f:
        channels = {name: ch.pixels for name, ch in f.channels().items()}
    expected = expected_samples(stack, exr.deep_depths(stack).astype(np.float32))
    for y in range(H):
        for x in range(W):
            want = expected[y, x]
            for c, name in enumerate(exr.DEEP_CHANNELS):
                got = channels[name][y, x]
                if want.shape[0] == 0:
                    assert got is None or len(got) == 0, (y, x, name)
                else:
                    np.testing.assert_array_equal(got, want[:, c], err_msg=f"{name} at {(y, x)}")


def test_openexr_reads_flat_comp_and_disparity(files):
    with OpenEXR.File(str(files["comp"])) as f:
        rgba = f.channels()["RGBA"].pixels
    np.testing.assert_array_equal(rgba, files["comp_pixels"])
    with OpenEXR.File(str(files["disparity"]), separate_channels=True) as f:
        channels = {name: ch.pixels for name, ch in f.channels().items()}
    assert sorted(channels) == ["Y", "Z"]
    for name in ("Y", "Z"):
        np.testing.assert_array_equal(channels[name], files["disparity_pixels"])  # NaN where it was


# ---------------------------------------------------------------------------------------------------------
# oiiotool: --info -v on every kind, the pixels it reads, --flatten of the deep file


def test_oiiotool_info_shows_the_standard_attributes(files):
    for kind in ("stack", "deep"):
        text = oiiotool("--info", "-v", files[kind])
        assert "framesPerSecond: 24000/1001" in text
        assert "smpte:TimeCode: 01:02:03:04" in text
        assert "worldToCamera:" in text and "worldToNDC:" in text
        assert 'vfxstereo/sources: "/shots/a/plate.1001.exr", "/shots/a/plate.1001.exr"' in text
    assert "deep float" in oiiotool("--info", "-v", files["deep"])


def test_oiiotool_reads_the_stack_pixels(files, stack):
    pixels, names = oiiotool_pixels(files["stack"])
    for i, name in enumerate(exr.layer_names(stack.disparities)):
        for c, component in enumerate("RGBA"):
            np.testing.assert_allclose(pixels[..., names.index(f"{name}.Combined.{component}")],
                                       stack.rgba[i, ..., c], rtol=0, atol=DUMP_TOL)
    np.testing.assert_allclose(pixels[..., names.index("plate.Combined.G")], stack.plate[..., 1], rtol=0,
                               atol=DUMP_TOL)


def test_oiiotool_reads_flat_comp_and_disparity(files):
    pixels, names = oiiotool_pixels(files["comp"])
    assert names == ["R", "G", "B", "A"]
    np.testing.assert_allclose(pixels, files["comp_pixels"], rtol=0, atol=DUMP_TOL)
    pixels, names = oiiotool_pixels(files["disparity"])
    assert names == ["Y", "Z"]
    for c in range(2):
        np.testing.assert_allclose(pixels[..., c], files["disparity_pixels"], rtol=0, atol=DUMP_TOL)


def test_oiiotool_flatten_of_the_deep_file_is_the_stack_flattened(files, stack, tmp_path):
    oiiotool(files["deep"], "--flatten", "-o", tmp_path / "flat.exr")
    with OpenEXR.File(str(tmp_path / "flat.exr"), separate_channels=True) as f:
        channels = {name: ch.pixels for name, ch in f.channels().items()}
    flat = np.stack([channels[c] for c in "RGBA"], axis=-1)
    np.testing.assert_allclose(flat, stack.flatten(), atol=2e-6)
    assert np.all(flat[0, 0] == 0)


# ---------------------------------------------------------------------------------------------------------
# The standard attributes' values


def test_camera_matrices_recover_the_rotation_translation_and_projection():
    camera, R, t, M0 = general_camera(scale=-2.5)
    m = exr.camera_matrices(camera, (H, W))
    w2c = m["worldToCamera"].T  # column-vector form
    np.testing.assert_allclose(w2c[:3, :3], R, atol=1e-12)
    np.testing.assert_allclose(w2c[:3, 3], t, atol=1e-12)
    np.testing.assert_array_equal(w2c[3], [0, 0, 0, 1])
    rng = np.random.default_rng(3)
    world = np.c_[rng.uniform(-2, 2, (20, 3)) + [0, 0, 6], np.ones(20)]  # (20, 4) points in front
    cam = world @ m["worldToCamera"]
    assert np.all(cam[:, 2] > 0)
    ndc = world @ m["worldToNDC"]  # row vectors, as OpenEXR's Imath applies it
    np.testing.assert_allclose(ndc[:, 3], cam[:, 2], rtol=1e-12)  # w is the camera-space depth
    projected = world @ M0.T  # [x w, y w, w, d w]
    x, y, d = (projected[:, i] / projected[:, 2] for i in (0, 1, 3))
    np.testing.assert_allclose(ndc[:, 0] / ndc[:, 3], (x + 0.5) / W, rtol=1e-10)
    np.testing.assert_allclose(ndc[:, 1] / ndc[:, 3], (y + 0.5) / H, rtol=1e-10)
    np.testing.assert_allclose(ndc[:, 2] / ndc[:, 3], d, rtol=1e-10)


def test_camera_matrices_of_a_rectified_rig_are_the_identity_camera():
    M, M0 = rectified_rig_matrices([0.0, 1.0, 2.0], 1.0, (H, W), focal=50.0, baseline=0.1)
    camera = Camera(positions=[0.0, 1.0, 2.0], reference=1.0, matrices=M, M0=M0)
    m = exr.camera_matrices(camera, (H, W))
    np.testing.assert_allclose(m["worldToCamera"], np.eye(4), atol=1e-12)
    # the frame centre on the optical axis at depth 5: NDC (0.5, 0.5), disparity focal * baseline / 5
    ndc = np.array([0.0, 0.0, 5.0, 1.0]) @ m["worldToNDC"]
    np.testing.assert_allclose(ndc[:3] / ndc[3], [0.5, 0.5, 50.0 * 0.1 / 5.0], rtol=1e-12)
    with pytest.raises(VfxStereoError, match="general cameras"):
        exr.camera_matrices(Camera.from_positions([0, 1]), (H, W))


def test_rectified_cameras_write_no_world_matrices(tmp_path, stack):
    plain = LayerStack(stack.rgba, stack.disparities, camera=Camera.from_positions([0, 1], focal=50.0,
                                                                                   baseline=0.1))
    with OpenEXR.File(str(exr.write_stack(tmp_path / "s.exr", plain))) as f:
        header = dict(f.header())  # File empties its dicts on close
    assert "worldToCamera" not in header and "worldToNDC" not in header and "framesPerSecond" not in header


@pytest.mark.parametrize("words, text", [
    ([0x01020304, 0], "01:02:03:04"), ([0x23595929, 0], "23:59:59:29"), ([0x10000000 | 0x40 | 0x02, 5],
                                                                         "10:00:00;02"),
])
def test_time_code_text(words, text):
    assert exr.time_code_text(words) == text


@pytest.mark.parametrize("key, value, match", [
    ("frames_per_second", [24, 0], "frames_per_second"), ("frames_per_second", "24", "frames_per_second"),
    ("frames_per_second", [23.976, 1], "frames_per_second"), ("time_code", [1, 2, 3], "time_code"),
    ("time_code", [-1, 0], "time_code"), ("source_files", ["a.exr", 3], "source_files"),
])
def test_bad_standard_metadata_is_refused_and_nothing_is_written(tmp_path, stack, key, value, match):
    bad = LayerStack(stack.rgba, stack.disparities, metadata={key: value})
    with pytest.raises(VfxStereoError, match=match):
        exr.write_stack(tmp_path / "s.exr", bad)
    assert list(tmp_path.iterdir()) == []


def test_pipeline_attributes_read_back_what_was_written(files, stack):
    found = exr.pipeline_attributes(exr.read_attributes(files["deep"]))
    assert found["framesPerSecond"] == [24000, 1001]
    assert found["timeCode"] == "01:02:03:04" and found["timeCodeWords"] == [TIME_CODE, 7]
    assert found["sources"] == stack.metadata["source_files"] and found["views"] == ["left", "right"]
    assert found["deepImageState"] == "tidy"
    m = exr.camera_matrices(stack.camera, (H, W))
    np.testing.assert_allclose(found["worldToCamera"], m["worldToCamera"], rtol=1e-6, atol=1e-6)
