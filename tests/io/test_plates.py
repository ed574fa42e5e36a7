"""Reading plates, elements, views and datasets: known decoded values, alpha handling, every error."""

import json

import numpy as np
import OpenImageIO as oiio
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.io import plates
from vfxstereo.io.plates import load_dataset, read_element, read_plate, read_views

# sRGB (linear Rec.709) -> ACEScg with Bradford adaptation, as measured in toolchain-notes section 5.
SRGB_TO_ACESCG_BRADFORD = np.array([[0.613132, 0.339538, 0.047417],
                                    [0.070124, 0.916394, 0.013452],
                                    [0.020588, 0.109575, 0.869785]])


def srgb_decode(v):
    """IEC 61966-2-1, written out here independently of the code under test."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def write(path, pixels, fmt, *, names=None, unassociated=False, parts=None, header=None):
    """Write ``pixels`` (H, W, C) with OIIO; multi-part: ``parts`` = [(name, channelnames, pixels), ...].

    ``header``: extra attributes; a tuple of str becomes a string vector, ``smpte:TimeCode`` a time code.
    """
    path = str(path)
    out = oiio.ImageOutput.create(path)
    if parts:
        specs = []
        for name, chans, px in parts:
            s = oiio.ImageSpec(px.shape[1], px.shape[0], px.shape[2], fmt)
            s.channelnames = tuple(chans)
            s.attribute("name", name)
            specs.append(s)
        assert out.open(path, tuple(specs))
        for i, (s, (_, _, px)) in enumerate(zip(specs, parts, strict=True)):
            if i:
                assert out.open(path, s, "AppendSubimage")
            assert out.write_image(np.ascontiguousarray(px))
        out.close()
        return path
    pixels = np.ascontiguousarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    H, W, C = pixels.shape
    spec = oiio.ImageSpec(W, H, C, fmt)
    if names:
        spec.channelnames = tuple(names)
    if unassociated:
        spec.attribute("oiio:UnassociatedAlpha", 1)
    for key, value in (header or {}).items():
        if key == "smpte:TimeCode":
            spec.attribute(key, oiio.TypeTimeCode, value)
        elif isinstance(value, tuple):
            spec.attribute(key, oiio.TypeDesc(f"string[{len(value)}]"), value)
        else:
            spec.attribute(key, value)
    assert out.open(path, spec), oiio.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


@pytest.fixture(autouse=True)
def _no_ocio_env(monkeypatch):
    monkeypatch.delenv("OCIO", raising=False)


# ---------------------------------------------------------------------------------------------------------
class TestReadPlate:
    def test_srgb_png_8bit_known_values(self, tmp_path):
        codes = np.array([[[0, 128, 255], [255, 128, 0]]], dtype=np.uint8)
        px = read_plate(write(tmp_path / "a.png", codes, "uint8"))
        assert px.dtype == np.float32 and px.shape == (1, 2, 3)
        np.testing.assert_allclose(px[0, 0], [0.0, 0.2158605, 1.0], atol=1e-6)
        np.testing.assert_allclose(px[0, 1], [1.0, 0.2158605, 0.0], atol=1e-6)

    def test_srgb_png_16bit(self, tmp_path):
        codes = np.array([[[0, 32768, 65535], [1000, 2000, 50000]]], dtype=np.uint16)
        px = read_plate(write(tmp_path / "a.png", codes, "uint16"))
        np.testing.assert_allclose(px, srgb_decode(codes / 65535.0), atol=2e-6)

    def test_tiff_16bit_and_ppm(self, tmp_path):
        codes = np.array([[[0, 30000, 65535]]], dtype=np.uint16)
        np.testing.assert_allclose(read_plate(write(tmp_path / "a.tif", codes, "uint16")),
                                   srgb_decode(codes / 65535.0), atol=2e-6)
        codes8 = np.array([[[10, 100, 200]]], dtype=np.uint8)
        np.testing.assert_allclose(read_plate(write(tmp_path / "a.ppm", codes8, "uint8")),
                                   srgb_decode(codes8 / 255.0), atol=2e-6)

    def test_exr_passes_through_unchanged(self, tmp_path, rng):
        x = (rng.random((5, 6, 3)) * 4 - 0.5).astype(np.float32)  # HDR values and negatives untouched
        np.testing.assert_array_equal(read_plate(write(tmp_path / "a.exr", x, "float")), x)
        np.testing.assert_array_equal(read_plate(write(tmp_path / "h.exr", x, "half")),
                                      x.astype(np.float16).astype(np.float32))

    def test_grey_becomes_three_channels(self, tmp_path):
        grey = np.array([[0, 128], [255, 64]], dtype=np.uint8)
        px = read_plate(write(tmp_path / "g.png", grey, "uint8"))
        assert px.shape == (2, 2, 3)
        for c in range(3):
            np.testing.assert_allclose(px[..., c], srgb_decode(grey / 255.0), atol=1e-6)

    def test_alpha_is_ignored_colour_as_stored(self, tmp_path):
        codes = np.array([[[200, 100, 50, 128]]], dtype=np.uint8)
        px = read_plate(write(tmp_path / "a.png", codes, "uint8", unassociated=True))
        np.testing.assert_allclose(px[0, 0], srgb_decode(codes[0, 0, :3] / 255.0), atol=1e-6)

    def test_colorspace_override_raw_and_acescg(self, tmp_path):
        codes = np.array([[[0, 128, 255], [30, 60, 90]]], dtype=np.uint8)
        path = write(tmp_path / "a.png", codes, "uint8")
        np.testing.assert_allclose(read_plate(path, colorspace="Linear Rec.709 (sRGB)"), codes / 255.0,
                                   atol=1e-6)
        # the values are ACEScg: to linear Rec.709 by the inverse of the measured matrix
        expected = (codes / 255.0) @ np.linalg.inv(SRGB_TO_ACESCG_BRADFORD).T
        np.testing.assert_allclose(read_plate(path, colorspace="ACEScg"), expected, atol=2e-4)

    def test_acescg_working_space_and_info(self, tmp_path, rng):
        x = rng.random((3, 4, 3)).astype(np.float32)
        plate = read_plate(write(tmp_path / "a.exr", x, "float"), working_space="acescg", return_info=True)
        assert isinstance(plate, plates.Plate)
        assert plate.working_space == "ACEScg" and plate.colour.source == "Linear Rec.709 (sRGB)"
        np.testing.assert_allclose(plate.pixels, x @ SRGB_TO_ACESCG_BRADFORD.T, atol=1e-4)
        meta = plate.to_metadata()
        assert meta["working_space"] == "ACEScg" and meta["path"].endswith("a.exr")
        json.dumps(meta)

    def test_unknown_colorspace(self, tmp_path):
        path = write(tmp_path / "a.png", np.zeros((2, 2, 3), np.uint8), "uint8")
        with pytest.raises(VfxStereoError, match="unknown colour space 'NotASpace'"):
            read_plate(path, colorspace="NotASpace")

    def test_layered_exr_picks_combined(self, tmp_path, rng):
        combined = rng.random((4, 5, 4)).astype(np.float32)
        other = rng.random((4, 5, 3)).astype(np.float32)
        px = np.concatenate([other, combined], axis=-1)
        names = ["AO.R", "AO.G", "AO.B"] + [f"ViewLayer.Combined.{c}" for c in "RGBA"]
        np.testing.assert_array_equal(read_plate(write(tmp_path / "l.exr", px, "float", names=names)),
                                      combined[..., :3])


# ---------------------------------------------------------------------------------------------------------
class TestReadElement:
    def test_straight_png_is_premultiplied_after_decoding(self, tmp_path):
        codes = np.array([[[200, 100, 50, 128], [255, 255, 255, 0], [10, 20, 30, 255]]], dtype=np.uint8)
        rgba, z = read_element(write(tmp_path / "e.png", codes, "uint8", unassociated=True))
        assert z is None and rgba.shape == (1, 3, 4) and rgba.dtype == np.float32
        a = 128 / 255
        # hand-computed: decode 200/255 -> 0.57758, times alpha 0.50196
        assert rgba[0, 0, 0] == pytest.approx(0.5775804 * a, abs=1e-6)
        np.testing.assert_allclose(rgba[0, 0, :3], srgb_decode(codes[0, 0, :3] / 255) * a, atol=1e-6)
        assert rgba[0, 0, 3] == pytest.approx(a, abs=1e-7)
        np.testing.assert_array_equal(rgba[0, 1], [0, 0, 0, 0])
        np.testing.assert_allclose(rgba[0, 2, :3], srgb_decode(codes[0, 2, :3] / 255), atol=1e-6)

    def test_tiff_unassociated_and_associated(self, tmp_path):
        codes = np.array([[[200, 100, 50, 128]]], dtype=np.uint8)
        a = 128 / 255
        rgba, _ = read_element(write(tmp_path / "u.tif", codes, "uint8", unassociated=True))
        np.testing.assert_allclose(rgba[0, 0, :3], srgb_decode(codes[0, 0, :3] / 255) * a, atol=1e-6)
        # associated alpha in the encoded space: unpremultiply, decode, premultiply
        rgba, _ = read_element(write(tmp_path / "p.tif", codes, "uint8"))
        np.testing.assert_allclose(rgba[0, 0, :3], srgb_decode(codes[0, 0, :3] / 255 / a) * a, atol=1e-6)

    def test_exr_stays_premultiplied_with_z(self, tmp_path, rng):
        rgba = rng.random((4, 5, 4)).astype(np.float32)
        rgba[..., :3] *= rgba[..., 3:4]
        z = (rng.random((4, 5)) * 10 + 1).astype(np.float32)
        px = np.concatenate([rgba, z[..., None]], axis=-1)
        got, gz = read_element(write(tmp_path / "e.exr", px, "float", names=list("RGBAZ")))
        np.testing.assert_array_equal(got, rgba)
        np.testing.assert_array_equal(gz, z)

    def test_blender_multipart_depth(self, tmp_path, rng):
        rgba = rng.random((4, 5, 4)).astype(np.float32)
        z = rng.random((4, 5, 1)).astype(np.float32)
        parts = [("ViewLayer.Combined", [f"ViewLayer.Combined.{c}" for c in "RGBA"], rgba),
                 ("ViewLayer.Depth", ["ViewLayer.Depth.Z"], z)]
        got, gz = read_element(write(tmp_path / "bl.exr", None, "float", parts=parts))
        np.testing.assert_array_equal(got, rgba)
        np.testing.assert_array_equal(gz, z[..., 0])

    def test_depth_layer_names(self, tmp_path, rng):
        px = rng.random((3, 3, 5)).astype(np.float32)
        for depth_name in ("depth.Z", "Depth.Z"):
            path = write(tmp_path / "d.exr", px, "float", names=["R", "G", "B", "A", depth_name])
            _, z = read_element(path)
            np.testing.assert_array_equal(z, px[..., 4])

    def test_depth_only_file(self, tmp_path, rng):
        z = (rng.random((3, 4, 1)) * 50).astype(np.float32)
        rgba, gz = read_element(write(tmp_path / "z.exr", z, "float", names=["Z"]), colorspace="raw")
        np.testing.assert_array_equal(gz, z[..., 0])
        np.testing.assert_array_equal(rgba[..., 1], z[..., 0])  # read as grey, not colour-converted
        np.testing.assert_array_equal(rgba[..., 3], 1.0)

    def test_no_alpha_is_opaque(self, tmp_path):
        codes = np.array([[[0, 128, 255]]], dtype=np.uint8)
        rgba, z = read_element(write(tmp_path / "o.png", codes, "uint8"))
        np.testing.assert_allclose(rgba[0, 0], [0, 0.2158605, 1, 1], atol=1e-6)
        assert z is None

    def test_nan_element(self, tmp_path):
        px = np.zeros((2, 2, 4), np.float32)
        px[1, 1, 0] = np.nan
        with pytest.raises(VfxStereoError, match="1 pixels with NaN"):
            read_element(write(tmp_path / "n.exr", px, "float"))


# ---------------------------------------------------------------------------------------------------------
class TestReadViews:
    @pytest.fixture
    def three(self, tmp_path, rng):
        paths = []
        for k in range(3):
            codes = rng.integers(0, 256, (4, 6, 3), dtype=np.uint8)
            paths.append(write(tmp_path / f"v{k}.png", codes, "uint8"))
        return paths

    def test_reads_all(self, three):
        views, infos = read_views(three, return_info=True)
        assert views.shape == (3, 4, 6, 3) and views.dtype == np.float32
        np.testing.assert_array_equal(views[1], read_plate(three[1]))
        assert len(infos) == 3 and infos[0].working_space == "Linear Rec.709 (sRGB)"

    def test_image_size(self, three, tmp_path):
        assert plates.image_size(three[0]) == (4, 6)
        with pytest.raises(VfxStereoError, match="file not found"):
            plates.image_size(tmp_path / "none.png")

    def test_too_few(self, three):
        with pytest.raises(VfxStereoError, match="at least two views, got 1"):
            read_views(three[:1])

    def test_missing(self, three, tmp_path):
        with pytest.raises(VfxStereoError, match="view not found: .*nothere.png"):
            read_views([three[0], str(tmp_path / "nothere.png")])

    def test_sizes_differ(self, three, tmp_path):
        odd = write(tmp_path / "odd.png", np.zeros((5, 6, 3), np.uint8), "uint8")
        with pytest.raises(VfxStereoError, match=r"odd.png is 6x5 but .*v0.png is 6x4") as err:
            read_views([three[0], three[1], odd, three[2]])
        assert "\n" not in str(err.value)

    def test_nan_in_exr(self, three, tmp_path):
        px = np.zeros((4, 6, 3), np.float32)
        px[0, 0, 1] = np.nan
        px[2, 3] = np.inf
        bad = write(tmp_path / "bad.exr", px, "float")
        with pytest.raises(VfxStereoError, match="bad.exr has 2 pixels with NaN"):
            read_views([three[0], bad])

    def test_corrupt_file(self, three, tmp_path):
        junk = tmp_path / "junk.png"
        junk.write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 10)
        with pytest.raises(VfxStereoError, match="cannot read .*junk.png"):
            read_views([three[0], junk])
        # a truncated EXR opens but cannot be read
        x = np.ones((64, 64, 3), np.float32)
        good = (tmp_path / "t.exr")
        write(good, x, "half")
        data = good.read_bytes()
        trunc = tmp_path / "trunc.exr"
        trunc.write_bytes(data[: len(data) // 2])
        with pytest.raises(VfxStereoError, match="cannot read .*trunc.exr"):
            read_plate(trunc)


# ---------------------------------------------------------------------------------------------------------
LAYOUTS = ["single", "single-named", "multipart"]


class TestMultiView:
    """One EXR holding the views (OpenEXR's multi-view convention), written by OpenEXR.File or OIIO."""

    @pytest.fixture
    def views(self, rng):
        return {name: rng.uniform(0.0, 2.0, (5, 7, 3)).astype(np.float32) for name in ("left", "centre", "right")}

    @pytest.mark.parametrize("layout", LAYOUTS)
    def test_reads_every_view_in_the_file_order(self, tmp_path, views, layout, multiview_exr):
        path = multiview_exr(tmp_path / "plate.exr", views, layout)
        view_set = plates.read_view_set(path)
        assert view_set.views == ["left", "centre", "right"]
        assert view_set.files == [str(path)] * 3
        np.testing.assert_array_equal(view_set.pixels, np.stack(list(views.values())))  # float: linear as is
        np.testing.assert_array_equal(read_views(path), view_set.pixels)

    @pytest.mark.parametrize("layout", LAYOUTS)
    def test_picks_views_in_the_order_asked(self, tmp_path, views, layout, multiview_exr):
        path = multiview_exr(tmp_path / "plate.exr", views, layout)
        got = read_views(path, views=["right", "left"])
        np.testing.assert_array_equal(got, np.stack([views["right"], views["left"]]))
        np.testing.assert_array_equal(read_plate(path, view="centre"), views["centre"])
        np.testing.assert_array_equal(read_plate(path), views["left"])  # without a view: the default one

    @pytest.mark.parametrize("layout", LAYOUTS)
    def test_describe_lists_views_parts_and_channels(self, tmp_path, views, layout, multiview_exr):
        layout_ = plates.describe_plate(multiview_exr(tmp_path / "plate.exr", views, layout))
        info = layout_.to_dict()
        assert [v["name"] for v in info["views"]] == ["left", "centre", "right"]
        assert [v["default"] for v in info["views"]] == [True, False, False]
        assert all((v["width"], v["height"]) == (7, 5) for v in info["views"])
        if layout == "multipart":
            assert info["multi_part"] and [p["view"] for p in info["parts"]] == ["left", "centre", "right"]
            assert [p["name"] for p in info["parts"]] == ["rgba.left", "rgba.centre", "rgba.right"]
            assert info["views"][2]["colour"] == ["R", "G", "B"]
        elif layout == "single":
            assert not info["multi_part"] and len(info["parts"]) == 1
            assert info["views"][0]["colour"] == ["R", "G", "B"]
            assert info["views"][2]["colour"] == ["right.R", "right.G", "right.B"]
            assert "right.Z" in info["views"][2]["channels"]
            assert not any("tmp.Z" in v["channels"] for v in info["views"])  # belongs to no view
        else:
            assert info["views"][0]["colour"] == ["left.R", "left.G", "left.B"]

    def test_channel_to_view_rules_of_openexr(self, tmp_path, rng):
        """OpenEXR's ImfMultiView.h examples: R, left.Z, diffuse.left.R are left; tmp.R, right.diffuse.R none."""
        names = ["R", "G", "B", "left.Z", "diffuse.left.R", "right.R", "right.G", "right.B", "diffuse.right.R",
                 "tmp.R", "right.diffuse.R", "diffuse.tmp.R"]
        px = rng.random((3, 4, len(names))).astype(np.float32)
        path = write(tmp_path / "rules.exr", px, "float", names=names, header={"multiView": ("left", "right")})
        layout = plates.describe_plate(path)
        got = {v: sorted(stored for _, stored, _ in layout.view_channels[v]) for v in layout.views}
        assert got == {"left": sorted(["R", "G", "B", "left.Z", "diffuse.left.R"]),
                       "right": sorted(["right.R", "right.G", "right.B", "diffuse.right.R"])}
        within = {stored: name for _, stored, name in layout.view_channels["right"]}
        assert within["diffuse.right.R"] == "diffuse.R" and within["right.G"] == "G"
        right = px[..., [names.index(f"right.{c}") for c in "RGB"]]
        np.testing.assert_array_equal(read_plate(path, view="right"), right)

    def test_frame_rate_and_time_code_of_the_file(self, tmp_path, views, multiview_exr):
        from fractions import Fraction

        import OpenEXR

        tc = OpenEXR.TimeCode()
        tc.hours, tc.minutes, tc.seconds, tc.frame = 1, 0, 10, 12
        path = multiview_exr(tmp_path / "plate.exr", views, "single",
                             header={"framesPerSecond": Fraction(24, 1), "timeCode": tc})
        meta = plates.read_view_set(path, views=["left", "right"]).metadata(reference=1)
        assert meta == {"source_files": [str(path)] * 2, "source_views": ["left", "right"],
                        "frames_per_second": [24, 1], "time_code": [0x01001012, 0]}

    def test_separate_files_take_the_reference_views_time_code(self, tmp_path, rng):
        paths = []
        for k in range(3):
            spec_attrs = {"smpte:TimeCode": (0x01000000 + k, 0)} if k else {}
            paths.append(write(tmp_path / f"v{k}.exr", rng.random((3, 4, 3)).astype(np.float32), "float",
                               header=spec_attrs))
        view_set = plates.read_view_set(paths)
        assert view_set.views is None
        assert view_set.metadata(reference=2)["time_code"] == [0x01000002, 0]
        assert view_set.metadata(reference=0)["time_code"] == [0x01000001, 0]  # v0 has none: the next one
        assert "source_views" not in view_set.metadata() and "frames_per_second" not in view_set.metadata()

    @pytest.mark.parametrize("layout", LAYOUTS)
    def test_a_view_the_file_lacks_lists_the_views_it_has(self, tmp_path, views, layout, multiview_exr):
        path = multiview_exr(tmp_path / "plate.exr", views, layout)
        with pytest.raises(VfxStereoError, match="has no view 'middle'; the views of .*plate.exr: left, centre, "
                                                 "right") as err:
            read_views(path, views=["left", "middle"])
        assert "\n" not in str(err.value)
        with pytest.raises(VfxStereoError, match="asked for twice"):
            read_views(path, views=["left", "left"])
        with pytest.raises(VfxStereoError, match="at least 2 views, got 1 .*left, centre, right"):
            read_views(path, views=["right"])
        with pytest.raises(VfxStereoError, match="has no view 'up'"):
            read_plate(path, view="up")

    def test_views_of_different_sizes_are_refused(self, tmp_path, views, multiview_exr):
        views["right"] = np.zeros((6, 7, 3), np.float32)
        path = multiview_exr(tmp_path / "plate.exr", views, "multipart")
        with pytest.raises(VfxStereoError, match="view right is 7x6 but view left is 7x5 .*left, centre, right"):
            read_views(path)
        np.testing.assert_array_equal(read_views(path, views=["centre", "left"])[1], views["left"])

    def test_a_plain_file_is_not_multi_view(self, tmp_path, rng):
        path = write(tmp_path / "plain.exr", rng.random((3, 4, 3)).astype(np.float32), "float")
        with pytest.raises(VfxStereoError, match="at least two views, got 1: .*plain.exr is not a multi-view"):
            read_views(path)
        with pytest.raises(VfxStereoError, match="not a multi-view EXR .*views of .*plain.exr: none"):
            read_views(path, views=["left", "right"])
        with pytest.raises(VfxStereoError, match="one multi-view EXR, but 2 files"):
            read_views([path, path], views=["left", "right"])
        assert plates.describe_plate(path).to_dict()["views"] == []


# ---------------------------------------------------------------------------------------------------------
class TestLoadDataset:
    def test_tsukuba(self, shared_data):
        ds = load_dataset(shared_data / "middlebury2001_tsukuba")
        assert ds.name == "tsukuba" and len(ds.views) == 5 and ds.reference == 2
        assert all(v.is_file() for v in ds.views)
        np.testing.assert_array_equal(ds.positions, [0, 1, 2, 3, 4])
        assert ds.gt.shape == (288, 384) and ds.border == 18 and ds.eval_steps == 1
        # GT raw 8-bit values / 16, 0 = unknown; read here independently of the code under test
        inp = oiio.ImageInput.open(str(shared_data / "middlebury2001_tsukuba" / "truedisp.row3.col3.pgm"))
        raw = inp.read_image("uint8")[..., 0].astype(np.float64)
        inp.close()
        np.testing.assert_array_equal(np.isnan(ds.gt), raw == 0)
        np.testing.assert_allclose(ds.gt[raw > 0], raw[raw > 0] / 16)
        assert np.nanmin(ds.gt) == pytest.approx(5.0) and np.nanmax(ds.gt) == pytest.approx(14.0)
        assert np.isnan(ds.gt[:18]).all()  # the border is unknown

    def test_teddy(self, shared_data):
        ds = load_dataset(shared_data / "middlebury2003_teddy" / "dataset.json")
        assert len(ds.views) == 9 and ds.reference == 2 and ds.eval_steps == 4
        assert 2 < np.nanmin(ds.gt) and np.nanmax(ds.gt) < 16

    def test_gt_channel_16bit_and_npz(self, tmp_path, rng):
        for k in range(2):
            write(tmp_path / f"v{k}.png", rng.integers(0, 256, (3, 4, 3), dtype=np.uint8), "uint8")
        gt16 = np.zeros((3, 4, 3), np.uint16)
        gt16[..., 1] = np.arange(12).reshape(3, 4) * 1000  # the channel to read; raw values, not decoded
        gt16[..., 0] = 7
        write(tmp_path / "gt.png", gt16, "uint16")
        spec = {"name": "t", "views": ["v0.png", "v1.png"], "positions": [0, 1], "reference": 1,
                "gt_disparity": "gt.png", "gt_scale": 0.001, "gt_invalid": 0, "gt_channel": 1}
        (tmp_path / "dataset.json").write_text(json.dumps(spec))
        ds = load_dataset(tmp_path)
        expected = np.arange(12).reshape(3, 4).astype(np.float64)
        expected[0, 0] = np.nan
        np.testing.assert_allclose(ds.gt, expected, rtol=1e-6)
        # npz GT, +inf = unknown (the skimage motorcycle convention)
        arr = np.arange(12, dtype=np.float32).reshape(3, 4) + 0.5
        arr[2, 3] = np.inf
        np.savez(tmp_path / "gt.npz", arr)
        spec.update(gt_disparity="gt.npz", gt_scale=1.0, gt_invalid=None, gt_channel=None)
        (tmp_path / "dataset.json").write_text(json.dumps(spec))
        gt = load_dataset(tmp_path).gt
        assert np.isnan(gt[2, 3]) and np.count_nonzero(np.isnan(gt)) == 1
        np.testing.assert_array_equal(gt[:2], arr[:2])

    def test_errors(self, tmp_path):
        with pytest.raises(VfxStereoError, match="no dataset.json"):
            load_dataset(tmp_path)
        write(tmp_path / "v0.png", np.zeros((2, 2, 3), np.uint8), "uint8")
        (tmp_path / "dataset.json").write_text(json.dumps({"views": ["v0.png", "v1.png"], "positions": [0]}))
        with pytest.raises(VfxStereoError, match="2 views but 1 positions"):
            load_dataset(tmp_path)
        (tmp_path / "dataset.json").write_text(json.dumps({"views": ["v0.png", "v1.png"]}))
        with pytest.raises(VfxStereoError, match="view not found: .*v1.png"):
            load_dataset(tmp_path)
