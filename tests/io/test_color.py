"""sRGB curves against colour-science, OCIO conversions against the measured matrices, $OCIO, errors."""

import numpy as np
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.io import color

# sRGB (linear Rec.709) -> ACEScg with Bradford adaptation, as measured in toolchain-notes section 5.
SRGB_TO_ACESCG_BRADFORD = np.array([[0.613132, 0.339538, 0.047417],
                                    [0.070124, 0.916394, 0.013452],
                                    [0.020588, 0.109575, 0.869785]])

MINI_CONFIG = """\
ocio_profile_version: 2
roles:
  default: lin_rec709
  scene_linear: lin_rec709
  data: raw
file_rules:
  - !<Rule> {name: Default, colorspace: default}
displays:
  sRGB:
    - !<View> {name: Raw, colorspace: raw}
colorspaces:
  - !<ColorSpace>
    name: lin_rec709
  - !<ColorSpace>
    name: gamma22
    to_scene_reference: !<ExponentTransform> {value: [2.2, 2.2, 2.2, 1]}
  - !<ColorSpace>
    name: raw
    isdata: true
"""


@pytest.fixture
def mini_ocio(tmp_path, monkeypatch):
    path = tmp_path / "mini.ocio"
    path.write_text(MINI_CONFIG)
    monkeypatch.setenv("OCIO", str(path))
    return path


@pytest.fixture
def no_ocio(monkeypatch):
    monkeypatch.delenv("OCIO", raising=False)


class TestSrgbCurves:
    def test_known_values(self):
        codes = np.array([0, 128, 255]) / 255.0
        np.testing.assert_allclose(color.srgb_to_linear(codes), [0.0, 0.2158605, 1.0], atol=1e-7)
        # on the straight segment: 10/255 = 0.0392 <= 0.04045 -> V / 12.92
        assert color.srgb_to_linear(10 / 255) == pytest.approx(10 / 255 / 12.92, rel=1e-6)
        assert color.linear_to_srgb(0.001) == pytest.approx(0.01292, rel=1e-6)

    def test_against_colour_science(self):
        colour = pytest.importorskip("colour")
        v = np.linspace(-0.2, 1.5, 20001)
        np.testing.assert_allclose(color.srgb_to_linear(v), colour.models.eotf_sRGB(v), atol=2e-6, rtol=1e-6)
        np.testing.assert_allclose(color.linear_to_srgb(v), colour.models.eotf_inverse_sRGB(v),
                                   atol=2e-6, rtol=1e-6)

    def test_round_trip_ndim_dtype(self, rng):
        x = rng.random((3, 4, 5, 3))
        enc = color.linear_to_srgb(x)
        assert enc.dtype == np.float32 and enc.shape == x.shape
        np.testing.assert_allclose(color.srgb_to_linear(enc), x, atol=2e-6)

    def test_nan_stays_nan(self):
        out = color.srgb_to_linear(np.array([np.nan, 0.5]))
        assert np.isnan(out[0]) and np.isfinite(out[1])


class TestOcio:
    def test_convert_matches_measured_matrix(self, no_ocio):
        # rows are pure R, G, B: their images are the matrix's columns
        out = color.convert(np.eye(3, dtype=np.float32), "Linear Rec.709 (sRGB)", "ACEScg")
        np.testing.assert_allclose(out, SRGB_TO_ACESCG_BRADFORD.T, atol=1e-4)

    def test_convert_aliases_and_rgba(self, no_ocio, rng):
        rgba = rng.random((4, 5, 4)).astype(np.float32)
        out = color.convert(rgba, "lin_rec709", "acescg")
        np.testing.assert_array_equal(out[..., 3], rgba[..., 3])
        np.testing.assert_allclose(out[..., :3], rgba[..., :3] @ SRGB_TO_ACESCG_BRADFORD.T, atol=2e-4)
        # sRGB - Texture is the sRGB curve
        np.testing.assert_allclose(color.convert(rgba[..., :3], "sRGB - Texture", "lin_rec709"),
                                   color.srgb_to_linear(rgba[..., :3]), atol=5e-5)

    def test_unknown_colour_space(self, no_ocio):
        with pytest.raises(VfxStereoError, match=r"unknown colour space 'Bogus'.*known: .*'ACEScg'"):
            color.convert(np.zeros((2, 3)), "Bogus", "ACEScg")

    def test_ocio_env_is_respected(self, mini_ocio):
        x = np.array([[0.5, 0.25, 1.0]], dtype=np.float32)
        out, info = color.to_working(x, "gamma22", encoded=True)
        np.testing.assert_allclose(out, x ** 2.2, rtol=1e-4)
        assert info.method == "ocio" and info.config == str(mini_ocio) and info.source == "gamma22"
        # a name the config lacks falls back to colour-science
        out, info = color.to_working(x, "ACEScg", encoded=False)
        assert info.method == "colour-science"
        np.testing.assert_allclose(out, x @ np.linalg.inv(SRGB_TO_ACESCG_BRADFORD).T, atol=2e-4)
        with pytest.raises(VfxStereoError, match="mini.ocio"):
            color.to_working(x, "Bogus", encoded=True)

    def test_missing_ocio_config(self, monkeypatch, tmp_path):
        monkeypatch.setenv("OCIO", str(tmp_path / "nothing.ocio"))
        with pytest.raises(VfxStereoError, match="cannot load the OCIO config"):
            color.to_working(np.zeros((1, 3)), "ACEScg", encoded=False)


class TestToWorking:
    def test_defaults(self, no_ocio, rng):
        x = rng.random((6, 7, 3)).astype(np.float32)
        out, info = color.to_working(x, encoded=True)
        np.testing.assert_array_equal(out, color.srgb_to_linear(x))
        assert info.source == "sRGB Encoded Rec.709 (sRGB)" and info.working_space == "Linear Rec.709 (sRGB)"
        out, _ = color.to_working(x, encoded=False)
        np.testing.assert_array_equal(out, x)

    def test_acescg_working_space(self, no_ocio, rng):
        x = rng.random((6, 7, 3)).astype(np.float32)
        out, info = color.to_working(x, encoded=True, working="ACEScg")
        assert info.working_space == "ACEScg"
        np.testing.assert_allclose(out, color.srgb_to_linear(x) @ SRGB_TO_ACESCG_BRADFORD.T, atol=1e-4)
        # the OCIO route agrees with the built-in route
        out2, info2 = color.to_working(x, "sRGB - Texture", encoded=True, working="acescg")
        assert info2.method == "ocio"
        np.testing.assert_allclose(out2, out, atol=2e-4)

    def test_colour_science_fallback_rec709(self, no_ocio):
        # "Rec.709" is not an OCIO name in the cg-config: inverse BT.709 OETF by hand
        v = np.array([[0.05, 0.5, 1.0]], dtype=np.float32)
        expected = np.where(v < 0.081, v / 4.5, ((v + 0.099) / 1.099) ** (1 / 0.45))
        out, info = color.to_working(v, "Rec.709", encoded=True)
        assert info.method == "colour-science" and info.source == "ITU-R BT.709"
        np.testing.assert_allclose(out, expected, rtol=1e-4)

    def test_linear_and_raw_pass_through(self, no_ocio, rng):
        x = rng.random((3, 3, 4)).astype(np.float32)
        for name in ("linear", "Raw", "Linear Rec.709 (sRGB)"):
            out, _ = color.to_working(x, name, encoded=True)
            np.testing.assert_allclose(out, x, atol=1e-6)

    def test_errors(self, no_ocio):
        with pytest.raises(VfxStereoError, match="unknown working space"):
            color.working_space("XYZ-ish")
        with pytest.raises(VfxStereoError, match="unknown colour space 'nope'"):
            color.to_working(np.zeros((1, 3)), "nope", encoded=True)
