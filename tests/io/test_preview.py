"""Display encoding, PNG previews, contact sheets and disparity previews."""

import numpy as np
import OpenImageIO as oiio
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.io import preview
from vfxstereo.io.color import srgb_to_linear
from vfxstereo.io.preview import contact_sheet, disparity_preview, to_display
from vfxstereo.stack import LayerStack


def read8(path):
    """The file's 8-bit values as stored (straight alpha left as it is)."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    assert inp is not None, oiio.geterror()
    spec = inp.spec()
    px = inp.read_image("uint8")
    inp.close()
    return px, spec


class TestToDisplay:
    def test_round_trips_every_code(self):
        codes = np.arange(256, dtype=np.uint8)
        linear = srgb_to_linear(codes / 255.0)
        img = np.stack([linear] * 3, axis=-1).reshape(16, 16, 3)
        np.testing.assert_array_equal(to_display(img), np.stack([codes] * 3, axis=-1).reshape(16, 16, 3))

    def test_known_values_and_clipping(self):
        img = np.array([[[0.0, 0.2158605, 1.0], [-1.0, 7.0, np.nan]]], dtype=np.float32)
        np.testing.assert_array_equal(to_display(img), [[[0, 128, 255], [0, 255, 0]]])

    def test_rgba_is_unpremultiplied(self):
        straight = np.array([0.2158605, 1.0, 0.0])
        a = 0.5
        img = np.array([[[*(straight * a), a], [0, 0, 0, 0]]], dtype=np.float32)
        out = to_display(img)
        assert out.shape == (1, 2, 4) and out.dtype == np.uint8
        np.testing.assert_array_equal(out[0, 0], [128, 255, 0, 128])  # alpha is coverage, not encoded
        np.testing.assert_array_equal(out[0, 1], [0, 0, 0, 0])

    def test_background(self):
        img = np.zeros((16, 16, 4), np.float32)  # fully transparent
        np.testing.assert_array_equal(to_display(img, background="white"), np.full((16, 16, 3), 255))
        checker = to_display(img, background="checker")
        assert checker.shape == (16, 16, 3)
        # the greys are display values 0.4 and 0.6: codes 102 and 153
        assert checker[0, 0, 0] == 102 and checker[0, 8, 0] == 153 and checker[8, 0, 0] == 153
        assert checker[8, 8, 0] == 102
        # half-covered red over black: linear 0.5 red -> code 188
        img[..., 0] = 0.5
        img[..., 3] = 0.5
        np.testing.assert_array_equal(to_display(img, background="black")[0, 0], [188, 0, 0])
        with pytest.raises(VfxStereoError, match="unknown background"):
            to_display(img, background="plaid")


class TestWrite:
    def test_write_png_rgba_straight(self, tmp_path):
        straight = np.array([0.2158605, 1.0, 0.0], np.float32)
        img = np.zeros((2, 3, 4), np.float32)
        img[0, 0] = [*(straight * 0.5), 0.5]
        img[1, 2] = [0.0, 0.0, 1.0, 1.0]
        path = preview.write_png(tmp_path / "p.png", img)
        px, spec = read8(path)
        assert spec.nchannels == 4
        np.testing.assert_array_equal(px, to_display(img))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]  # no temporary left behind

    def test_write_png_uint8_as_is(self, tmp_path, rng):
        img = rng.integers(0, 256, (5, 6, 3), dtype=np.uint8)
        px, _ = read8(preview.write_png(tmp_path / "u.png", img))
        np.testing.assert_array_equal(px, img)

    def test_write_jpeg_composites(self, tmp_path):
        img = np.zeros((8, 8, 4), np.float32)
        img[..., 1] = 1.0
        img[..., 3] = 1.0
        px, spec = read8(preview.write_png(tmp_path / "p.jpg", img))
        assert spec.nchannels == 3
        assert abs(int(px[4, 4, 1]) - 255) <= 2 and px[4, 4, 0] <= 2

    def test_write_disparity_and_sheet(self, tmp_path, rng):
        d = rng.random((6, 7)).astype(np.float32)
        px, _ = read8(preview.write_disparity_preview(tmp_path / "d.png", d))
        np.testing.assert_array_equal(px, disparity_preview(d))
        stack = LayerStack(np.zeros((3, 5, 6, 4), np.float32), [1.0, 2.0, 3.0])
        px, _ = read8(preview.write_contact_sheet(tmp_path / "s.png", stack, label=False))
        np.testing.assert_array_equal(px, contact_sheet(stack, label=False))


def _opaque_stack(D, H, W):
    rgba = np.zeros((D, H, W, 4), np.float32)
    for i in range(D):
        rgba[i, ..., :3] = (i + 1) / (D + 1)
        rgba[i, ..., 3] = 1.0
    return LayerStack(rgba, np.arange(D, dtype=np.float64) * 0.5)


class TestContactSheet:
    @pytest.mark.parametrize(("D", "columns", "rows_cols"), [(5, None, (2, 3)), (4, None, (2, 2)),
                                                             (5, 5, (1, 5)), (1, None, (1, 1)),
                                                             (7, 2, (4, 2)), (3, 10, (1, 3))])
    def test_size(self, D, columns, rows_cols):
        H, W, gap = 6, 7, 4
        sheet = contact_sheet(_opaque_stack(D, H, W), columns=columns, gap=gap)
        rows, cols = rows_cols
        assert sheet.shape == (rows * H + (rows - 1) * gap, cols * W + (cols - 1) * gap, 3)
        assert sheet.dtype == np.uint8

    def test_tiles_and_gaps(self):
        D, H, W, gap = 5, 6, 7, 4
        stack = _opaque_stack(D, H, W)
        sheet = contact_sheet(stack, gap=gap, label=False)
        for i in range(D):
            r, c = divmod(i, 3)
            tile = sheet[r * (H + gap):r * (H + gap) + H, c * (W + gap):c * (W + gap) + W]
            np.testing.assert_array_equal(tile, to_display(stack.rgba[i][..., :3]))  # opaque
        assert (sheet[H:H + gap] == preview.SHEET_GAP_GREY).all()
        assert (sheet[2 * H + gap:, 2 * (W + gap):] == preview.SHEET_GAP_GREY).all()  # the empty 6th slot

    def test_alpha_shows_the_checker(self):
        rgba = np.zeros((2, 16, 16, 4), np.float32)
        rgba[1, :8, :8] = [0.0, 0.0, 1.0, 1.0]
        sheet = contact_sheet(rgba, label=False, gap=0)
        left = sheet[:, :16]
        empty = np.zeros((16, 16, 4), np.float32)
        np.testing.assert_array_equal(left, to_display(empty, background="checker"))
        np.testing.assert_array_equal(sheet[0, 16], [0, 0, 255])
        assert sheet[0, 16 + 8, 0] == 153  # transparent part of layer 1 shows the checker

    def test_labels_drawn_in_tile_corner(self):
        stack = _opaque_stack(2, 64, 64)
        plain = contact_sheet(stack, label=False, gap=0)
        labelled = contact_sheet(stack, label=True, gap=0)
        diff = np.any(plain != labelled, axis=-1)
        assert diff[:, :64].any() and diff[:, 64:].any()  # both tiles labelled
        assert not diff[40:].any()  # only near the top


class TestDisparityPreview:
    def test_nan_is_black_and_range(self):
        import matplotlib

        d = np.array([[np.nan, 2.0, 4.0], [6.0, np.inf, 10.0]])
        out = disparity_preview(d, cmap="viridis")
        assert out.shape == (2, 3, 3) and out.dtype == np.uint8
        np.testing.assert_array_equal(out[0, 0], [0, 0, 0])
        np.testing.assert_array_equal(out[1, 1], [0, 0, 0])
        cmap = matplotlib.colormaps["viridis"]
        np.testing.assert_array_equal(out[0, 1], cmap(0.0, bytes=True)[:3])  # finite min -> low end
        np.testing.assert_array_equal(out[1, 2], cmap(1.0, bytes=True)[:3])  # finite max -> high end

    def test_gray_is_linear_in_value(self):
        d = np.array([[0.0, 2.5, 5.0, 10.0, 20.0]])
        out = disparity_preview(d, vmin=0, vmax=10, cmap="gray")
        np.testing.assert_allclose(out[0, :, 0], [0, 64, 128, 255, 255], atol=1)  # clipped above vmax

    def test_errors(self):
        with pytest.raises(VfxStereoError, match="unknown colour map"):
            disparity_preview(np.zeros((2, 2)), cmap="nope")
        with pytest.raises(VfxStereoError, match=r"\(H, W\)"):
            disparity_preview(np.zeros((2, 2, 3)))
