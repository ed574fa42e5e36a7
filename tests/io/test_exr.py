"""EXR files: multilayer round trips, deep stack against the stack's own flatten, plain images, errors."""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.io import exr
from vfxstereo.stack import LayerStack

OIIOTOOL = Path(sys.executable).with_name("oiiotool")


def random_stack(rng, disparities=(0.1, 1.0 / 3.0, 1.5, 2.75), H=9, W=11, *, camera=None, metadata=None,
                 white=1.0, zero_fraction=0.3):
    """Soft alphas in (0, 1], about ``zero_fraction`` of them exactly 0; colour <= white * alpha."""
    D = len(disparities)
    alpha = rng.uniform(0.05, 1.0, (D, H, W)).astype(np.float32)
    alpha[rng.random((D, H, W)) < zero_fraction] = 0.0
    alpha[:, 0, 0] = 0.0  # one pixel with no layer at all
    rgb = rng.uniform(0.0, white, (D, H, W, 3)).astype(np.float32) * alpha[..., None]
    return LayerStack(np.concatenate([rgb, alpha[..., None]], axis=-1), np.asarray(disparities, float),
                      camera=camera, metadata=metadata if metadata is not None else {}, white=white)


def exr_header(path):
    """(name, type, raw value) of every attribute of the first header, parsed from the bytes."""
    data = Path(path).read_bytes()
    assert data[:4] == b"\x76\x2f\x31\x01"
    pos, out = 8, []
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        tend = data.index(b"\0", end + 1)
        typ = data[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", data, tend + 1)
        out.append((name, typ, data[tend + 5:tend + 5 + size]))
        pos = tend + 5 + size
    return out


def oiiotool_info(path) -> str:
    done = subprocess.run([str(OIIOTOOL), "--info", "-v", str(path)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout


# ---------------------------------------------------------------------------------------------------------
# Layer names


def test_layer_names_hand_computed():
    assert exr.layer_names([-1.5, 0.0, 2.5, 12.0]) == ["L00_dm1p50", "L01_d0p00", "L02_d2p50", "L03_d12p00"]


def test_layer_names_sort_in_disparity_order_and_hold_no_dots():
    disparities = np.linspace(-3.0, 40.0, 120)
    names = exr.layer_names(disparities)
    assert sorted(names) == names
    assert len(set(names)) == 120
    assert all("." not in n and n[0].isalpha() for n in names)
    assert names[0].startswith("L000_") and names[-1].startswith("L119_")


# ---------------------------------------------------------------------------------------------------------
# Multilayer stack


def test_stack_round_trip_float_is_exact(tmp_path, rng):
    camera = Camera.from_positions([-1.0, 0.0, 1.0, 2.5], focal=1234.5, baseline=0.065)
    metadata = {"preset": "paper", "solver": {"iterations": 7, "lambda": [0.1, 1e-3]}, "frame": 12,
                "peak": np.float32(0.5), "none": None}
    stack = random_stack(rng, camera=camera, metadata=metadata, white=1.7)
    path = exr.write_stack(tmp_path / "stack.exr", stack, half=False)
    back = exr.read_stack(path)
    np.testing.assert_array_equal(back.rgba, stack.rgba)
    assert back.disparities.tolist() == stack.disparities.tolist()  # float64 exact (1/3 included)
    assert back.camera == camera
    assert back.white == 1.7
    assert back.metadata == {**metadata, "peak": 0.5}


def test_stack_round_trip_half_is_numpy_float16_rounding(tmp_path, rng):
    stack = random_stack(rng)
    back = exr.read_stack(exr.write_stack(tmp_path / "half.exr", stack))
    expected = stack.rgba.astype(np.float16).astype(np.float32)
    np.testing.assert_array_equal(back.rgba, expected)
    assert np.abs(back.rgba - stack.rgba).max() <= 2.0 ** -12  # values in [0, 1]: half spacing <= 2**-11
    assert back.camera is None and back.metadata == {} and back.white == 1.0


def test_stack_round_trip_keeps_the_plate_as_a_layer_named_plate(tmp_path, rng):
    s = random_stack(rng)
    plate = rng.uniform(0.0, 3.0, (*s.shape[1:], 3)).astype(np.float32)
    stack = LayerStack(s.rgba, s.disparities, plate=plate)
    back = exr.read_stack(exr.write_stack(tmp_path / "p.exr", stack, half=False))
    np.testing.assert_array_equal(back.plate, plate)
    np.testing.assert_array_equal(back.rgba, stack.rgba)
    info = oiiotool_info(tmp_path / "p.exr")
    assert "plate.Combined.R" in info and "vfxstereo/plate" in info
    assert exr.read_stack(exr.write_stack(tmp_path / "n.exr", s)).plate is None


def test_stack_single_layer_and_general_camera(tmp_path, rng):
    M = np.arange(24, dtype=float).reshape(2, 3, 4)
    camera = Camera(positions=[0.0, 1.0], reference=0.0, matrices=M, M0=np.eye(4))
    stack = random_stack(rng, disparities=(-0.25,), camera=camera)
    back = exr.read_stack(exr.write_stack(tmp_path / "one.exr", stack, half=False))
    assert back.disparities.tolist() == [-0.25]
    np.testing.assert_array_equal(back.camera.matrices, M)
    np.testing.assert_array_equal(back.rgba, stack.rgba)


def test_stack_channels_are_layer_pass_component(tmp_path, rng):
    """Read back with the plain reader: one channel per layer and component, named layer.Combined.C."""
    stack = random_stack(rng)
    path = exr.write_stack(tmp_path / "s.exr", stack, half=False)
    pixels, names, attributes = exr.read_image(path)
    layer = exr.layer_names(stack.disparities)
    assert sorted(names) == sorted(f"{n}.Combined.{c}" for n in layer for c in "RGBA")
    for i, n in enumerate(layer):
        for k, c in enumerate("RGBA"):
            channel = pixels[..., names.index(f"{n}.Combined.{c}")]
            np.testing.assert_array_equal(channel, stack.rgba[i, ..., k])
    assert attributes["vfxstereo/format"] == "layerstack"
    assert attributes["vfxstereo/version"] == exr.FORMAT_VERSION
    exact = dict(zip(layer, stack.disparities.tolist(), strict=True))
    assert json.loads(attributes["vfxstereo/layers"]) == exact
    np.testing.assert_allclose(attributes["vfxstereo/disparities"], stack.disparities, rtol=1e-7)
    assert attributes["compression"] == "zip"


def test_oiiotool_lists_the_stack_channels_and_header(tmp_path, rng):
    stack = random_stack(rng, camera=Camera.from_positions([0, 1, 2]))
    path = exr.write_stack(tmp_path / "s.exr", stack, compression="piz")
    text = oiiotool_info(path)
    for n in exr.layer_names(stack.disparities):
        assert f"{n}.Combined.R" in text and f"{n}.Combined.A" in text
    for key in ("vfxstereo/disparities", "vfxstereo/camera", "vfxstereo/metadata", "vfxstereo/white"):
        assert key in text
    assert "piz" in text and "half" in text


def test_working_space_becomes_the_colour_interop_id(tmp_path, rng):
    stack = random_stack(rng, metadata={"working_space": "ACEScg"})
    path = exr.write_stack(tmp_path / "s.exr", stack)
    if tuple(int(v) for v in oiio.VERSION_STRING.split(".")[:2]) < (3, 1):
        pytest.skip("OIIO 3.0 does not write oiio:ColorSpace to EXR")
    assert ("colorInteropID", "string", b"lin_ap1_scene") in exr_header(path)


def test_half_overflow_is_refused_float_keeps_it(tmp_path, rng):
    stack = random_stack(rng, white=1e5)
    stack.rgba[0, 1, 1] = [7e4, 0.0, 0.0, 1.0]
    stack = LayerStack(stack.rgba, stack.disparities, white=1e5)
    with pytest.raises(VfxStereoError, match="half"):
        exr.write_stack(tmp_path / "s.exr", stack)
    assert not (tmp_path / "s.exr").exists()
    back = exr.read_stack(exr.write_stack(tmp_path / "s.exr", stack, half=False))
    assert back.rgba[0, 1, 1, 0] == 7e4 and back.white == 1e5


def test_metadata_that_is_not_json_is_refused(tmp_path, rng):
    stack = random_stack(rng, metadata={"obj": object()})
    with pytest.raises(VfxStereoError, match="metadata"):
        exr.write_stack(tmp_path / "s.exr", stack)
    assert os.listdir(tmp_path) == []


def test_unknown_compression_is_refused(tmp_path, rng):
    with pytest.raises(VfxStereoError, match="compression"):
        exr.write_stack(tmp_path / "s.exr", random_stack(rng), compression="gzip9000")


# ---------------------------------------------------------------------------------------------------------
# Deep stack


def deep_reference(stack, z):
    """Slow reference: per pixel, the layers with alpha > 0, nearest first, as rows R,G,B,A,Z,ZBack."""
    D, H, W = stack.shape
    counts = np.zeros((H, W), int)
    rows = []
    for y in range(H):
        for x in range(W):
            for i in range(D - 1, -1, -1):
                if stack.rgba[i, y, x, 3] > 0:
                    rows.append([*stack.rgba[i, y, x], z[i], z[i]])
                    counts[y, x] += 1
    return counts, np.array(rows, dtype=np.float32).reshape(-1, 6)


def test_deep_flatten_by_oiio_equals_stack_flatten(tmp_path, rng):
    stack = random_stack(rng, disparities=(0.5, 1.0, 2.0, 3.0, 4.0), H=13, W=17, zero_fraction=0.4,
                         camera=Camera.from_positions([0, 1, 2], focal=50.0, baseline=0.2))
    path = exr.write_deep(tmp_path / "deep.exr", stack)
    buf = oiio.ImageBuf(str(path))
    assert buf.deep
    flat = oiio.ImageBufAlgo.flatten(buf).get_pixels(oiio.FLOAT)
    names = buf.spec().channelnames
    rgba = flat[..., [names.index(c) for c in "RGBA"]]
    np.testing.assert_allclose(rgba, stack.flatten(), atol=2e-6)
    assert np.all(rgba[0, 0] == 0)  # the pixel with no layer stays empty


def test_deep_samples_follow_layers_front_to_back_with_z_from_the_camera(tmp_path, rng):
    camera = Camera.from_positions([0, 1], focal=50.0, baseline=0.2)  # focal * baseline = 10
    stack = random_stack(rng, disparities=(0.5, 1.0, 2.0, 4.0), camera=camera)
    z = np.array([20.0, 10.0, 5.0, 2.5])  # 10 / d, by hand
    np.testing.assert_array_equal(exr.deep_depths(stack), z)
    deep = exr.read_deep(exr.write_deep(tmp_path / "deep.exr", stack))
    counts, samples = deep_reference(stack, z)
    assert deep.channelnames == ("R", "G", "B", "A", "Z", "ZBack")
    np.testing.assert_array_equal(deep.counts, counts)
    np.testing.assert_array_equal(deep.samples, samples)
    for y, x in [(1, 1), (4, 7), (8, 10)]:
        zs = deep.pixel(y, x)[:, 4]
        assert np.all(np.diff(zs) > 0)  # nearest first, no two at one depth
    np.testing.assert_array_equal(deep.channel("Z"), deep.channel("ZBack"))
    assert deep.attributes[exr.DEEP_STATE] == "tidy"
    assert deep.attributes["vfxstereo/format"] == "deep"


def test_deep_header_states_tidy_as_a_string_and_has_no_typed_deep_image_state(tmp_path, rng):
    """OpenEXR's Python module refuses the typed attribute: the file must not hold one, under any name."""
    path = exr.write_deep(tmp_path / "deep.exr", random_stack(rng))
    header = exr_header(path)
    assert (exr.DEEP_STATE, "string", b"tidy") in header
    assert not [h for h in header if h[1] == "deepImageState" or h[0] in ("deepImageState",
                                                                         "openexr:deepImageState")]
    text = oiiotool_info(path)
    assert "deep float" in text and "ZBack" in text and 'vfxstereo/deepImageState: "tidy"' in text


def test_deep_depths_without_camera_and_at_infinity():
    stack = LayerStack(np.zeros((4, 2, 2, 4), np.float32), [-1.0, 0.0, 1.0, 2.0])
    # 1/d for d > 0; the two layers at or beyond infinity: far = max(1e10, 2 * 1) = 1e10, far*(1 + k/2)
    np.testing.assert_array_equal(exr.deep_depths(stack), [1.5e10, 1e10, 1.0, 0.5])


def test_deep_explicit_depths(tmp_path, rng):
    stack = random_stack(rng, disparities=(0.0, 1.0, 2.0))
    deep = exr.read_deep(exr.write_deep(tmp_path / "d.exr", stack, depth=[9.0, 7.0, 3.0]))
    _, samples = deep_reference(stack, [9.0, 7.0, 3.0])
    np.testing.assert_array_equal(deep.samples, samples)
    for bad, match in [([1.0, 2.0, 3.0], "decrease"), ([9.0, 7.0], "3 depths"),
                       ([9.0, 7.0, -1.0], "positive"), ([9.0, np.inf, 1.0], "finite")]:
        with pytest.raises(VfxStereoError, match=match):
            exr.write_deep(tmp_path / "bad.exr", stack, depth=bad)
    assert not (tmp_path / "bad.exr").exists()


def test_deep_of_an_empty_stack_has_no_samples(tmp_path):
    stack = LayerStack(np.zeros((2, 3, 4, 4), np.float32), [1.0, 2.0])
    deep = exr.read_deep(exr.write_deep(tmp_path / "empty.exr", stack))
    assert deep.counts.sum() == 0 and deep.samples.shape == (0, 6)


# ---------------------------------------------------------------------------------------------------------
# Plain images


def test_write_disparity_keeps_nan_and_metadata_in_both_channels(tmp_path, rng):
    disparity = rng.uniform(0, 4, (5, 6)).astype(np.float32)
    disparity[2, 3] = np.nan
    meta = {"vfxstereo/what": "disparity", "frame": 3, "scale": 0.5, "range": [0.0, 4.0], "dict": {"a": 1}}
    path = exr.write_disparity(tmp_path / "disp.exr", disparity, metadata=meta)
    pixels, names, attributes = exr.read_image(path)
    assert names == ("Y", "Z") and pixels.shape == (5, 6, 2)
    np.testing.assert_array_equal(pixels[..., 0], disparity)  # NaN in the same place
    np.testing.assert_array_equal(pixels[..., 1], disparity)
    assert attributes["vfxstereo/what"] == "disparity" and attributes["frame"] == 3
    assert attributes["scale"] == 0.5 and tuple(attributes["range"]) == (0.0, 4.0)
    assert json.loads(attributes["dict"]) == {"a": 1}


def test_write_image_rgba_half_and_png(tmp_path, rng):
    comp = rng.random((4, 5, 4)).astype(np.float32)
    pixels, names, _ = exr.read_image(exr.write_image(tmp_path / "comp.exr", comp, half=True))
    assert names == ("R", "G", "B", "A")
    np.testing.assert_array_equal(pixels, comp.astype(np.float16).astype(np.float32))
    codes = rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    pixels, names, _ = exr.read_image(exr.write_image(tmp_path / "p.png", codes))
    np.testing.assert_array_equal(np.round(pixels * 255), codes)  # values written as given


def test_write_image_checks_its_input(tmp_path):
    with pytest.raises(VfxStereoError, match="name the 5 channels"):
        exr.write_image(tmp_path / "a.exr", np.zeros((2, 2, 5), np.float32))
    with pytest.raises(VfxStereoError, match="distinct"):
        exr.write_image(tmp_path / "a.exr", np.zeros((2, 2, 2), np.float32), channels=("Z", "Z"))
    with pytest.raises(VfxStereoError, match="shape"):
        exr.write_image(tmp_path / "a.exr", np.zeros((2,), np.float32))
    assert os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------------------------------------
# Bad input


@pytest.fixture
def files(tmp_path, rng):
    """A good stack, a deep file, a plain RGBA EXR, a PNG, truncated / corrupt copies, a missing name."""
    stack = random_stack(rng, H=40, W=30)
    good = exr.write_stack(tmp_path / "good.exr", stack, half=False)
    data = good.read_bytes()
    out = {"good": good, "missing": tmp_path / "missing.exr"}
    out["deep"] = exr.write_deep(tmp_path / "deep.exr", stack)
    out["plain"] = exr.write_image(tmp_path / "plain.exr", stack.flatten())
    out["png"] = exr.write_image(tmp_path / "plain.png", (stack.flatten() * 255).astype(np.uint8))
    (tmp_path / "truncated.exr").write_bytes(data[: len(data) // 2])
    (tmp_path / "header_cut.exr").write_bytes(data[:200])
    (tmp_path / "garbage.exr").write_bytes(bytes(rng.integers(0, 256, 4000, dtype=np.uint8)))
    broken = bytearray(data)
    broken[-1500:] = bytes(rng.integers(0, 256, 1500, dtype=np.uint8))
    (tmp_path / "corrupt.exr").write_bytes(bytes(broken))
    for name in ("truncated", "header_cut", "garbage", "corrupt"):
        out[name] = tmp_path / f"{name}.exr"
    deep = out["deep"].read_bytes()
    (tmp_path / "deep_cut.exr").write_bytes(deep[: len(deep) // 2])
    out["deep_cut"] = tmp_path / "deep_cut.exr"
    return out


@pytest.mark.parametrize("name, match", [
    ("missing", "not found"), ("plain", "not a vfxstereo layerstack"), ("png", "not a vfxstereo layerstack"),
    ("deep", "deep file, not a layerstack"), ("truncated", "cannot read"), ("header_cut", "cannot read"),
    ("garbage", "cannot read"), ("corrupt", "cannot read"),
])
def test_read_stack_refuses_bad_files(files, name, match):
    with pytest.raises(VfxStereoError, match=match) as info:
        exr.read_stack(files[name])
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("name, match", [
    ("missing", "not found"), ("deep", "deep image"), ("truncated", "cannot read"),
    ("header_cut", "cannot read"), ("garbage", "cannot read"), ("corrupt", "cannot read"),
])
def test_read_image_refuses_bad_files(files, name, match):
    with pytest.raises(VfxStereoError, match=match):
        exr.read_image(files[name])


@pytest.mark.parametrize("name, match", [
    ("missing", "not found"), ("good", "not a deep image"), ("deep_cut", "cannot read"),
    ("garbage", "cannot read"),
])
def test_read_deep_refuses_bad_files(files, name, match):
    with pytest.raises(VfxStereoError, match=match):
        exr.read_deep(files[name])


def test_read_stack_refuses_nan(tmp_path, rng):
    stack = random_stack(rng)
    stack.rgba[1, 2, 3, 0] = np.nan  # past validation: only a broken writer could do this
    path = exr.write_stack(tmp_path / "nan.exr", stack, half=False)
    with pytest.raises(VfxStereoError, match="NaN"):
        exr.read_stack(path)


def test_read_stack_refuses_a_newer_format_version(tmp_path, rng, monkeypatch):
    monkeypatch.setattr(exr, "FORMAT_VERSION", exr.FORMAT_VERSION + 1)
    path = exr.write_stack(tmp_path / "future.exr", random_stack(rng))
    monkeypatch.undo()
    with pytest.raises(VfxStereoError, match="version"):
        exr.read_stack(path)


class _DyingOutput:
    """An ImageOutput that writes the first strip, then raises: a writer dying mid-way."""

    def __init__(self, real, exc_type):
        self.real, self.exc_type, self.strips = real, exc_type, 0

    def __getattr__(self, name):
        return getattr(self.real, name)

    def write_scanlines(self, *args):
        self.strips += 1
        if self.strips > 1:
            raise self.exc_type("disk on fire")
        return self.real.write_scanlines(*args)


@pytest.mark.parametrize("exc_type", [RuntimeError, KeyboardInterrupt])
def test_failed_write_keeps_the_old_file_and_leaves_no_temp(tmp_path, rng, monkeypatch, exc_type):
    old = random_stack(rng, H=20, W=8)
    target = exr.write_stack(tmp_path / "stack.exr", old, half=False)
    new = random_stack(rng, H=20, W=8)

    class FakeOIIO:
        def __getattr__(self, name):
            return getattr(oiio, name)

        class ImageOutput:
            @staticmethod
            def create(name):
                return _DyingOutput(oiio.ImageOutput.create(name), exc_type)

    monkeypatch.setattr(exr, "_ROWS_PER_CHUNK", 4)
    monkeypatch.setattr(exr, "_oiio", lambda: FakeOIIO())
    with pytest.raises(exc_type, match="disk on fire"):
        exr.write_stack(target, new, half=False)
    monkeypatch.undo()
    assert os.listdir(tmp_path) == ["stack.exr"]
    np.testing.assert_array_equal(exr.read_stack(target).rgba, old.rgba)


def test_write_into_a_missing_folder_is_a_one_line_error(tmp_path, rng):
    with pytest.raises(VfxStereoError, match="does not exist"):
        exr.write_stack(tmp_path / "nope" / "s.exr", random_stack(rng))
