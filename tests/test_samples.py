"""Synthetic scenes: views are exact re-syntheses of their ground-truth stacks; each scene is what it says."""

import json
from pathlib import Path

import cv2
import numpy as np
import OpenImageIO as oiio
import pytest
from scipy.ndimage import maximum_filter

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo import samples as S

REPO = Path(__file__).resolve().parents[1]
DEMO_DIR = REPO / "samples" / "demo"
MATTING = "alphamatting_training_lowres"


def _srgb_decode(v):
    """IEC 61966-2-1, written out here so the test does not lean on the code under test."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def _read(path, fmt=oiio.FLOAT):
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    try:
        px = np.asarray(inp.read_image(fmt))
    finally:
        inp.close()
    return px


@pytest.fixture(scope="module")
def rds():
    return S.random_dot_stereogram(seed=6)


@pytest.fixture(scope="module")
def fig7():
    return S.transparent_edge_stereogram(seed=7)


@pytest.fixture(scope="module")
def matting(shared_data):
    return S.matting_scene("GT04", scale=0.25, fg_disparity=3, bg_disparity=1, data_dir=shared_data)


@pytest.fixture(scope="module")
def demo(shared_data):
    return S.demo_scene(data_dir=shared_data)


@pytest.fixture(scope="module")
def layered():
    return S.layered_scene(shape=(64, 96), num_planes=12, seed=8)


SCENES = ["rds", "fig7", "layered", pytest.param("matting", marks=pytest.mark.data),
          pytest.param("demo", marks=pytest.mark.data)]


# ------------------------------------------------------------------------------------------------------
# Every scene


@pytest.mark.parametrize("scene", SCENES)
def test_views_are_the_opaque_renders_of_the_ground_truth_stack(scene, request):
    s = request.getfixturevalue(scene)
    assert s.views.dtype == np.float32 and s.views.shape == (s.K, *s.stack.shape[1:], 3)
    assert s.camera.reference_index == s.reference
    np.testing.assert_array_equal(s.camera.positions[:, 0], s.positions)
    np.testing.assert_array_equal(s.disparities, s.stack.disparities)
    for k, p in enumerate(s.positions):
        rendered = s.stack.render(float(p))
        np.testing.assert_allclose(s.views[k], rendered[..., :3], rtol=0, atol=1e-6)
        np.testing.assert_allclose(rendered[..., 3], 1.0, rtol=0, atol=1e-6)  # opaque everywhere
    assert np.isfinite(s.gt_disparity()).all()
    assert s.description and s.name


@pytest.mark.parametrize("scene", SCENES)
def test_soft_edge_mask_is_the_mixed_pixels_dilated(scene, request):
    s = request.getfixturevalue(scene)
    mixed = s.mixed_pixels()
    # mixed = no single layer contributes the whole pixel; check against a direct product of transmittances
    alpha = s.stack.rgba[..., 3].astype(np.float64)
    best = np.zeros(alpha.shape[1:])
    for i in range(len(alpha)):
        best = np.maximum(best, alpha[i] * np.prod(1.0 - alpha[i + 1:], axis=0))
    np.testing.assert_array_equal(mixed, best < 1 - 1e-4)
    np.testing.assert_array_equal(s.soft_edge_mask(0), mixed)
    np.testing.assert_array_equal(s.soft_edge_mask(3), maximum_filter(mixed, size=7, mode="constant"))


def test_soft_edge_mask_rejects_negative_dilation(fig7):
    with pytest.raises(VfxStereoError):
        fig7.soft_edge_mask(-1)


@pytest.mark.parametrize("make", [S.random_dot_stereogram, S.transparent_edge_stereogram, S.layered_scene])
def test_same_seed_same_views_and_other_seed_other_views(make):
    a, b, c = make(seed=11), make(seed=11), make(seed=12)
    np.testing.assert_array_equal(a.views, b.views)
    np.testing.assert_array_equal(a.stack.rgba, b.stack.rgba)
    assert not np.array_equal(a.views, c.views)
    np.testing.assert_array_equal(make(seed=np.random.default_rng(11)).views, a.views)


def test_from_stack_refuses_a_stack_whose_views_are_not_opaque():
    rgba = np.zeros((2, 8, 8, 4), np.float32)
    rgba[1] = 1.0  # the only opaque layer is at d = 1: shifted views leave a column uncovered
    stack = LayerStack(rgba, [0.0, 1.0], Camera.from_positions([0, 1, 2], reference=1))
    with pytest.raises(VfxStereoError, match="not opaque"):
        S.Sample.from_stack(stack, name="x", description="x")


# ------------------------------------------------------------------------------------------------------
# Random-dot stereogram (Fig. 6)

SQUARES = [(2, 10, 12, 24, 22), (5, 24, 30, 12, 14)]  # (d, top, left, height, width)


def test_rds_geometry_is_the_papers(rds):
    assert rds.K == 5 and rds.reference == 2 and rds.shape == (64, 64)
    np.testing.assert_array_equal(rds.positions, np.arange(5))
    np.testing.assert_array_equal(rds.disparities, np.arange(8))
    shifts = rds.disparities[:, None] * (rds.positions - rds.positions[rds.reference])[None, :]
    np.testing.assert_array_equal(shifts, np.round(shifts))  # every shift a whole number of pixels
    assert set(np.unique(rds.stack.rgba[..., 3])) <= {0.0, 1.0}  # no partial alpha
    assert not rds.mixed_pixels().any()
    assert set(np.unique(rds.gt_disparity())) == {0.0, 3.0, 6.0}


def test_rds_gt_disparity_is_exactly_the_squares():
    s = S.random_dot_stereogram(shape=(48, 56), squares=SQUARES, background_disparity=1, seed=2)
    expected = np.ones((48, 56), np.float32)
    for d, top, left, h, w in SQUARES:  # painted back to front
        expected[top:top + h, left:left + w] = d
    np.testing.assert_array_equal(s.gt_disparity(), expected)


def test_rds_views_are_whole_pixel_shifts_of_the_layers():
    s = S.random_dot_stereogram(shape=(48, 56), squares=SQUARES, seed=3)
    rgba = s.stack.rgba
    _, h, w, _ = rgba.shape
    for k, p in enumerate(s.positions):
        offset = p - s.positions[s.reference]
        # painter's algorithm with integer slicing: view(x) = layer(x + d * offset), zero outside the layer
        expected = np.zeros((h, w, 3), np.float32)
        for layer, d in zip(rgba, s.disparities, strict=True):
            sh = int(d * offset)
            moved = np.zeros_like(layer)
            src = slice(max(0, sh), min(w, w + sh))
            dst = slice(max(0, -sh), min(w, w - sh))
            moved[:, dst] = layer[:, src]
            expected = np.where(moved[..., 3:] > 0, moved[..., :3], expected)  # opaque or empty only
        np.testing.assert_array_equal(s.views[k], expected)


def test_rds_front_square_moves_by_d_times_offset_columns():
    s = S.random_dot_stereogram(shape=(48, 56), squares=SQUARES, seed=4)
    d, top, left, h, w = SQUARES[1]
    patch = s.reference_view[top:top + h, left:left + w]
    for k, p in enumerate(s.positions):
        shift = int(d * (p - s.positions[s.reference]))  # column x -> x - d * (p_k - p_ref)
        np.testing.assert_array_equal(s.views[k][top:top + h, left - shift:left - shift + w], patch)
        if shift:
            assert not np.array_equal(s.views[k][top:top + h, left:left + w], patch)


def test_rds_background_away_from_zero_gets_a_backdrop_and_stays_opaque():
    s = S.random_dot_stereogram(background_disparity=2, seed=1)
    assert (s.stack.rgba[0, ..., 3] == 1).all() and (s.stack.rgba[2, ..., 3] == 1).all()
    assert s.gt_disparity().min() == 2.0


@pytest.mark.parametrize("kwargs", [
    {"squares": [(3, 50, 50, 20, 20)]},   # outside the frame
    {"squares": [(0, 5, 5, 10, 10)]},     # not in front of the background
    {"squares": [(2.5, 5, 5, 10, 10)]},   # not a plane
    {"background_disparity": 9},
    {"shape": (8, 8)},
    {"num_planes": 1},
])
def test_rds_rejects_impossible_layouts(kwargs):
    with pytest.raises(VfxStereoError):
        S.random_dot_stereogram(**kwargs)


# ------------------------------------------------------------------------------------------------------
# Transparent-edge stereogram (Figs. 3, 5, 7)


def test_fig7_odd_disparities_shift_by_half_pixels(fig7):
    np.testing.assert_array_equal(fig7.positions, [0, 0.5, 1, 1.5, 2])
    assert fig7.reference == 2 and fig7.K == 5
    np.testing.assert_array_equal(fig7.disparities, np.arange(8))
    assert set(np.unique(fig7.gt_disparity())) == {1.0, 5.0}
    # view 1 sits at offset -0.5: a background pixel (d = 1) is the mean of two neighbouring layer pixels
    bg = fig7.stack.rgba[1, ..., :3]
    rows = slice(2, 10)  # above the object
    np.testing.assert_allclose(fig7.views[1][rows, 1:], 0.5 * (bg[rows, :-1] + bg[rows, 1:]), atol=1e-6)
    np.testing.assert_allclose(fig7.views[3][rows, :-1], 0.5 * (bg[rows, :-1] + bg[rows, 1:]), atol=1e-6)
    # even disparities (the backdrop at d = 0 aside) move by whole pixels in views 0 and 4
    np.testing.assert_array_equal(fig7.views[0][rows, 1:], bg[rows, :-1])


def test_fig7_only_the_top_half_circle_edge_is_partially_transparent(fig7):
    geo = fig7.stack.metadata["object"]
    (r0, r1), (c0, c1) = geo["body_rows"], geo["body_cols"]
    alpha = fig7.stack.rgba[5, ..., 3]
    soft = (alpha > 0) & (alpha < 1)
    assert soft.sum() > 20
    rows, cols = np.nonzero(soft)
    assert rows.max() < r0  # every soft pixel lies above the body: on the half-circle
    cy, cx = geo["centre"]
    dist = np.hypot(rows - cy, cols - cx)
    assert np.all(np.abs(dist - geo["radius"]) <= geo["edge_width"] / 2 + 1e-9)
    # the body: hard, pixel-aligned rectangle; nothing below it
    body = np.zeros_like(alpha)
    body[r0:r1, c0:c1] = 1
    np.testing.assert_array_equal(alpha[r0:], body[r0:])
    # the reference view mixes exactly there (the background behind is opaque)
    np.testing.assert_array_equal(fig7.mixed_pixels(), soft)
    # the object is darker red, the background lighter blue
    obj = fig7.reference_view[alpha == 1].mean(axis=0)
    back = fig7.reference_view[alpha == 0].mean(axis=0)
    assert obj[0] > obj[2] and back[2] > back[0] and back.sum() > obj.sum()


def test_fig7_rejects_bad_settings():
    for kwargs in ({"fg_disparity": 1, "bg_disparity": 5}, {"view_step": 0}, {"edge_width": -1},
                   {"fg_disparity": 8}):
        with pytest.raises(VfxStereoError):
            S.transparent_edge_stereogram(**kwargs)


# ------------------------------------------------------------------------------------------------------
# Matting scene


def _dataset_alpha(shared_data, name, shape):
    codes = _read(shared_data / MATTING / "gt_training_lowres" / f"{name}.png", oiio.UINT8)[..., 0]
    return cv2.resize(codes.astype(np.float32) / 255.0, shape[::-1], interpolation=cv2.INTER_AREA)


@pytest.mark.data
def test_matting_alpha_is_the_datasets_alpha_resized(matting, shared_data):
    assert matting.shape == (141, 200)  # 563 x 800 at scale 0.25
    fg = matting.stack.rgba[3]
    np.testing.assert_allclose(fg[..., 3], _dataset_alpha(shared_data, "GT04", matting.shape), atol=1e-6)
    assert (fg[..., :3] <= fg[..., 3:] + 1e-6).all() and fg.min() >= 0  # premultiplied
    others = np.delete(matting.stack.rgba[..., 3], [0, 1, 3], axis=0)
    assert not others.any()  # only backdrop, background and foreground hold anything
    assert (matting.stack.rgba[[0, 1], ..., 3] == 1).all()
    assert matting.soft_edge_mask(2).sum() > matting.mixed_pixels().sum() > 1000  # real hair


@pytest.mark.data
def test_matting_background_is_the_teddy_reference_view_covering_the_frame(matting, shared_data):
    teddy = _srgb_decode(_read(shared_data / "middlebury2003_teddy" / "im2.png", oiio.UINT8) / 255.0)
    h, w = matting.shape
    scale = max(h / teddy.shape[0], w / teddy.shape[1])
    ch, cw = round(teddy.shape[0] * scale), round(teddy.shape[1] * scale)
    cover = cv2.resize(teddy.astype(np.float32), (cw, ch), interpolation=cv2.INTER_AREA)
    y0, x0 = (ch - h) // 2, (cw - w) // 2
    np.testing.assert_allclose(matting.stack.rgba[1, ..., :3], cover[y0:y0 + h, x0:x0 + w], atol=1e-5)


@pytest.mark.data
def test_load_matte_keeps_solid_colour_and_exact_alpha(shared_data):
    fg, alpha = S.load_matte("GT19", data_dir=shared_data)
    composite = _srgb_decode(_read(shared_data / MATTING / "input_training_lowres" / "GT19.png",
                                   oiio.UINT8) / 255.0)
    codes = _read(shared_data / MATTING / "gt_training_lowres" / "GT19.png", oiio.UINT8)[..., 0]
    np.testing.assert_array_equal(alpha, codes.astype(np.float32) / np.float32(255))
    solid = alpha >= 0.95
    np.testing.assert_allclose(fg[solid], composite[solid], atol=1e-6)
    assert fg.min() >= 0 and fg.max() <= 1


def test_data_folder_comes_from_argument_then_environment(tmp_path, monkeypatch):
    monkeypatch.setenv(S.DATA_ENV, str(tmp_path))
    assert S.find_data_dir() == tmp_path.resolve()
    other = tmp_path / "other"
    other.mkdir()
    assert S.find_data_dir(other) == other.resolve()
    monkeypatch.setenv(S.DATA_ENV, str(tmp_path / "missing"))
    with pytest.raises(VfxStereoError, match="VFXSTEREO_DATA"):
        S.matting_scene("GT01")
    with pytest.raises(VfxStereoError, match="not found"):
        S.load_matte("GT01", data_dir=tmp_path)  # folder exists but holds no data


@pytest.mark.data
@pytest.mark.parametrize("kwargs", [{"image": "GT99x"}, {"image": "nope"},
                                    {"fg_disparity": 1, "bg_disparity": 2},
                                    {"scale": 0}, {"K": 1}, {"background": "no-such-set"}])
def test_matting_scene_rejects_bad_arguments(kwargs, shared_data):
    with pytest.raises(VfxStereoError):
        S.matting_scene(**{"image": "GT19", "scale": 0.1, **kwargs}, data_dir=shared_data)


# ------------------------------------------------------------------------------------------------------
# Demo scene, its element and the shipped files


@pytest.mark.data
def test_demo_layers_make_z_keying_at_d3_meaningful(demo):
    assert demo.K == 5 and demo.reference == 2 and demo.shape == (225, 320)
    np.testing.assert_array_equal(demo.disparities, np.arange(5))
    assert set(np.unique(demo.gt_disparity())) == {0.0, 2.0, 4.0}
    alpha = demo.stack.rgba[..., 3]
    assert not alpha[[1, 3]].any()  # d = 3 is free for the element
    card = S.cg_element(demo.shape)[..., 3]
    hair = (alpha[4] > 0.05) & (alpha[4] < 0.95)
    assert (hair & (card == 1)).sum() > 100  # soft hair crosses in front of the card
    assert ((alpha[2] > 0.5) & (alpha[4] == 0) & (card == 1)).sum() > 50  # the card hides part of the pumpkin


def test_cg_element_is_a_premultiplied_antialiased_card():
    el = S.cg_element((120, 160), centre=(60, 80), size=50, angle=30)
    assert el.shape == (120, 160, 4) and el.dtype == np.float32
    a = el[..., 3]
    assert (el[..., :3] <= a[..., None] + 1e-6).all()
    assert a[60, 80] == 1 and a[0, 0] == 0 and a[60, 80 + 36] == 0  # centre, corner, beyond the half-diagonal
    assert ((a > 0) & (a < 1)).sum() > 100  # anti-aliased outline
    assert abs(a.sum() - 50 * 50) < 0.01 * 50 * 50  # area of the card
    inside = el[a == 1][:, :3]
    light = np.all(np.abs(inside - [0.75, 0.75, 0.72]) < 1e-6, axis=1)  # the default colours
    dark = np.all(np.abs(inside - [0.03, 0.12, 0.55]) < 1e-6, axis=1)
    assert light.mean() > 0.35 and dark.mean() > 0.35 and (light | dark).mean() > 0.7  # checks, blended edges


@pytest.mark.data
def test_shipped_demo_files_match_demo_scene(demo):
    spec = json.loads((DEMO_DIR / "dataset.json").read_text())
    assert spec["reference"] == demo.reference
    np.testing.assert_array_equal(spec["positions"], demo.positions)
    np.testing.assert_array_equal(spec["disparities"], demo.disparities)
    for k, name in enumerate(spec["views"]):
        codes = _read(DEMO_DIR / name, oiio.UINT16)
        assert codes.dtype == np.uint16
        # 16-bit sRGB quantisation: at most half a code step times the curve's slope (< 2.3) in linear
        np.testing.assert_allclose(_srgb_decode(codes / 65535.0), demo.views[k], rtol=0, atol=3e-5)
    gt = _read(DEMO_DIR / spec["gt_disparity"], oiio.UINT16)[..., 0] * spec["gt_scale"]
    np.testing.assert_array_equal(gt, demo.gt_disparity())
    element = _read(DEMO_DIR / spec["element"])
    np.testing.assert_allclose(element, S.cg_element(demo.shape), rtol=1e-3, atol=1e-4)  # half float
    assert spec["element_disparity"] == S.DEMO_ELEMENT_DISPARITY
    assert sum(f.stat().st_size for f in DEMO_DIR.iterdir()) < 3_000_000


# ------------------------------------------------------------------------------------------------------
# Layered scene (speed benchmarks)


def test_layered_sparse_stack_renders_what_the_full_grid_of_planes_renders(layered):
    """Only the occupied planes are stored; with the empty planes of the solve's grid put back, the views agree."""
    planes = layered.stack.metadata["planes"]
    assert planes == 12
    np.testing.assert_array_equal(layered.disparities, [0.0, 3.0, 7.0, 10.0])
    full = np.zeros((planes, *layered.shape, 4), np.float32)
    full[layered.disparities.astype(int)] = layered.stack.rgba
    dense = LayerStack(full, np.arange(planes, dtype=np.float64), layered.camera)
    for k, p in enumerate(layered.positions):
        np.testing.assert_allclose(dense.render(float(p))[..., :3], layered.views[k], rtol=0, atol=1e-6)


def test_layered_edges_are_soft_and_odd_disparities_shift_by_half_pixels(layered):
    alpha = layered.stack.rgba[1:, ..., 3]
    assert ((alpha > 0.05) & (alpha < 0.95)).any(axis=(1, 2)).all()  # every layer has a soft edge
    np.testing.assert_array_equal(layered.positions, [0.0, 0.5, 1.0, 1.5, 2.0])
    assert layered.mixed_pixels().any()


def test_layered_wta_solve_on_the_full_grid_finds_the_layers(layered):
    """Winner-take-all over d = 0..11 recovers the front layer's disparity at most pixels: the parallax is right."""
    import vfxstereo

    result = vfxstereo.solve(layered.views, positions=layered.positions, reference=layered.reference,
                             disparities=np.arange(12.0), config=vfxstereo.SolveConfig.preset("wta"),
                             return_details=True)
    good = np.abs(result.disparity - layered.gt_disparity()) <= 1.0
    assert good.mean() > 0.8


@pytest.mark.parametrize("kwargs", [{"layers": 0}, {"layers": 5}, {"num_planes": 6}, {"view_step": 0.0},
                                    {"edge_width": -1.0}, {"shape": (8, 8)}])
def test_layered_rejects_bad_settings(kwargs):
    with pytest.raises(VfxStereoError):
        S.layered_scene(**{"shape": (32, 32), "num_planes": 8, **kwargs})
