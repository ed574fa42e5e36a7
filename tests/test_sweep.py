"""Stage 1, Eq. (1): the plane sweep and its weighted statistics, against a slow explicit reference."""

import math

import numpy as np
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.homography import rectified_rig_matrices
from vfxstereo.io.color import linear_to_srgb
from vfxstereo.sweep import COVERAGE_THRESHOLD, SweepStats, lowpass_axes, matching_values, sweep
from vfxstereo.warp import Warper

POS = np.array([[-1.0, 0.5], [0.0, 0.0], [1.5, 0.0], [0.5, -1.0]])
DISP = np.array([0.0, 0.5, 1.25, 2.0])
SHAPE = (6, 7)


def _snap(s):
    r = round(s)
    return float(r) if abs(s - r) < 1e-6 else s


def _taps(u, v, h, w):
    """Bilinear taps (row, col, weight) of (u, v) with non-zero weight, and whether all are inside."""
    u0, v0 = math.floor(u), math.floor(v)
    fu, fv = u - u0, v - v0
    taps, inside = [], True
    for dv, wv in ((0, 1 - fv), (1, fv)):
        for du, wu in ((0, 1 - fu), (1, fu)):
            wt = wu * wv
            if wt == 0:
                continue
            r, c = v0 + dv, u0 + du
            if 0 <= r < h and 0 <= c < w:
                taps.append((r, c, wt))
            else:
                inside = False
    return taps, inside


def _sample(img, taps):
    return sum(wt * img[r, c] for r, c, wt in taps)


def _slow_sweep(views, pos, ref, disp, vis=None, matching="linear", min_votes=2.0):
    """Explicit loops over planes, cells and views: footprint check, bilinear sample, weighted statistics."""
    K, h, w = views.shape[:3]
    views = views.astype(np.float64)
    match = views * 255.0 if matching == "linear" else linear_to_srgb(views).astype(np.float64) * 255.0
    D = len(disp)
    mean = np.zeros((D, h, w, 3))
    var = np.zeros((D, h, w))
    weight = np.zeros((D, h, w))
    for i, d in enumerate(disp):
        for y in range(h):
            for x in range(w):
                ws, cs, ms = [], [], []
                for k in range(K):
                    off = pos[k] - pos[ref]
                    u, v = _snap(x - d * off[0]), _snap(y - d * off[1])  # the cell seen from view k
                    taps, inside = _taps(u, v, h, w)
                    if not inside:
                        continue  # footprint not fully inside view k: no vote
                    if vis is None:
                        wk, ck, mk = 1.0, _sample(views[k], taps), _sample(match[k], taps)
                    else:
                        V = vis[k][i].astype(np.float64)
                        wk = _sample(V, taps)
                        if wk <= 1e-6:
                            continue
                        ck = _sample(views[k] * V[..., None], taps) / wk
                        mk = _sample(match[k] * V[..., None], taps) / wk
                    ws.append(wk)
                    cs.append(ck)
                    ms.append(mk)
                tot = sum(ws)
                weight[i, y, x] = tot
                if tot > 0:
                    mean[i, y, x] = sum(a * b for a, b in zip(ws, cs, strict=True)) / tot
                    mu = sum(a * b for a, b in zip(ws, ms, strict=True)) / tot
                    s2 = sum(a * (b - mu) ** 2 for a, b in zip(ws, ms, strict=True)) / tot
                    var[i, y, x] = np.mean(s2)
                if tot < min_votes - 1e-6:
                    var[i, y, x] = np.inf
    return mean, var, weight


def _check(stats, ref):
    mean, var, weight = ref
    np.testing.assert_allclose(stats.weight, weight, atol=1e-5)
    np.testing.assert_allclose(stats.mean, mean, atol=1e-5)
    assert np.array_equal(np.isinf(stats.var), np.isinf(var))
    fin = np.isfinite(var)
    np.testing.assert_allclose(stats.var[fin], var[fin], rtol=1e-4, atol=2e-2)


@pytest.mark.parametrize("matching", ["linear", "srgb"])
def test_eq1_sweep_matches_slow_reference(rng, matching):
    views = rng.random((len(POS), *SHAPE, 3)).astype(np.float32)
    warper = Warper(Camera.from_positions(POS, reference=1), DISP, SHAPE)
    stats = sweep(views, warper, matching=matching)
    assert isinstance(stats, SweepStats)
    assert stats.mean.shape == (4, *SHAPE, 3) and stats.var.shape == (4, *SHAPE)
    assert stats.mean.dtype == stats.var.dtype == stats.weight.dtype == np.float32
    ref = _slow_sweep(views, POS, 1, DISP, matching=matching)
    _check(stats, ref)
    # the scene has cells seen by every view, by some, and by too few
    assert (ref[2] == 4).any() and ((ref[2] >= 2) & (ref[2] < 4)).any() and np.isinf(ref[1]).any()


@pytest.mark.parametrize("matching", ["linear", "srgb"])
def test_eq1_sweep_with_visibility_weights_matches_slow_reference(rng, matching):
    views = rng.random((len(POS), *SHAPE, 3)).astype(np.float32)
    vis = [rng.random((len(DISP), *SHAPE)).astype(np.float32) for _ in POS]
    for v in vis:
        v[v < 0.3] = 0.0  # some exactly invisible pixels
        v[v > 0.8] = 1.0
    warper = Warper(Camera.from_positions(POS, reference=1), DISP, SHAPE)
    stats = sweep(views, warper, visibility=vis, matching=matching, min_votes=1.5)
    _check(stats, _slow_sweep(views, POS, 1, DISP, vis=vis, matching=matching, min_votes=1.5))


def test_eq1_zero_visibility_is_the_same_as_leaving_the_view_out(rng):
    views = rng.random((len(POS), *SHAPE, 3)).astype(np.float32)
    cam = Camera.from_positions(POS, reference=1)
    vis = np.ones((len(POS), len(DISP), *SHAPE), dtype=np.float32)
    vis[2] = 0.0
    with_vis = sweep(views, Warper(cam, DISP, SHAPE), visibility=vis)
    keep = [0, 1, 3]
    without = sweep(views[keep], Warper(Camera.from_positions(POS[keep], reference=1), DISP, SHAPE))
    np.testing.assert_allclose(with_vis.weight, without.weight, atol=1e-6)
    np.testing.assert_allclose(with_vis.mean, without.mean, atol=1e-6)
    np.testing.assert_allclose(with_vis.var, without.var, rtol=1e-5, atol=1e-3)


def test_eq1_variance_units_are_8bit_squared_channel_mean():
    """Two views differing by one 8-bit code in one channel: variance (1/2)^2 / 3 channels."""
    shape = (3, 4)
    views = np.zeros((2, *shape, 3), dtype=np.float32)
    views[1, ..., 0] = 1.0 / 255.0
    warper = Warper(Camera.from_positions([0.0, 1.0], reference=0), np.array([0.0]), shape)
    stats = sweep(views, warper, matching="linear")
    np.testing.assert_allclose(stats.var, 0.25 / 3.0, rtol=1e-5)
    np.testing.assert_allclose(stats.mean[..., 0], 0.5 / 255.0, rtol=1e-5)
    np.testing.assert_allclose(stats.weight, 2.0)
    enc = matching_values(views, "srgb")
    want = ((enc[1, 0, 0, 0] - enc[0, 0, 0, 0]) / 2) ** 2 / 3.0
    np.testing.assert_allclose(sweep(views, warper).var, want, rtol=1e-5)


def test_eq1_true_disparity_has_zero_variance_on_integer_shifts(rng):
    """A fronto-parallel textured plane at d = 2 seen with integral shifts: zero variance there only."""
    shape, pos = (12, 20), np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    tex = rng.random((shape[0], shape[1] + 16, 3)).astype(np.float32)
    views = np.stack([tex[:, 8 + 2 * int(p): 8 + 2 * int(p) + shape[1]] for p in pos])  # u = x - 2 p
    disp = np.arange(5.0)
    stats = sweep(views, Warper(Camera.from_positions(pos, reference=2), disp, shape))
    seen_by_all = stats.weight[2] == 5
    assert seen_by_all.sum() > 0.5 * seen_by_all.size
    np.testing.assert_allclose(stats.var[2][seen_by_all], 0.0, atol=1e-3)
    np.testing.assert_allclose(stats.mean[2][seen_by_all], views[2][seen_by_all], atol=1e-6)
    others = np.delete(stats.var, 2, axis=0)
    assert np.all(others[:, seen_by_all] > 1.0)


def test_eq1_general_cameras_give_the_same_statistics(rng):
    views = rng.random((len(POS), *SHAPE, 3)).astype(np.float32)
    M, M0 = rectified_rig_matrices(POS, POS[1], SHAPE)
    gen = Camera(positions=POS, reference=POS[1], reference_index=1, matrices=M, M0=M0)
    a = sweep(views, Warper(Camera.from_positions(POS, reference=1), DISP, SHAPE))
    b = sweep(views, Warper(gen, DISP, SHAPE))
    np.testing.assert_allclose(a.mean, b.mean, atol=1e-5)
    np.testing.assert_allclose(a.weight, b.weight, atol=1e-6)
    np.testing.assert_allclose(a.var, b.var, rtol=1e-4, atol=1e-2)


def test_progress_is_reported_per_plane(rng):
    views = rng.random((2, *SHAPE, 3)).astype(np.float32)
    calls = []
    sweep(views, Warper(Camera.from_positions([0.0, 1.0]), DISP, SHAPE), progress=lambda *a: calls.append(a))
    assert calls == [("sweep", i + 1, len(DISP)) for i in range(len(DISP))]


def test_coverage_threshold_is_just_below_one():
    assert 0.999 < COVERAGE_THRESHOLD < 1.0


def test_user_errors_raise_vfxstereo_error(rng):
    warper = Warper(Camera.from_positions([0.0, 1.0]), DISP, SHAPE)
    good = rng.random((2, *SHAPE, 3)).astype(np.float32)
    with pytest.raises(VfxStereoError):
        sweep(good[:1], warper)  # K mismatch
    with pytest.raises(VfxStereoError):
        sweep(good[..., :2], warper)  # not RGB
    with pytest.raises(VfxStereoError):
        sweep(good[:, :-1], warper)  # size mismatch
    bad = good.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(VfxStereoError):
        sweep(bad, warper)
    with pytest.raises(VfxStereoError):
        sweep(good, warper, visibility=[np.ones((2, *SHAPE))] * 2)
    with pytest.raises(VfxStereoError):
        sweep(good, warper, matching="hsv")


# ------------------------------------------------------------------------------------------------------
# Beyond the paper: the resampling-tolerant variance


def test_tolerant_variance_is_the_smaller_of_the_plain_and_the_low_passed_views(rng):
    from scipy import ndimage

    cam = Camera.from_positions([-1.0, 0.0, 0.5, 1.5], reference=1)  # a 1-D rig: x only
    views = rng.random((4, *SHAPE, 3)).astype(np.float32)
    wp = Warper(cam, DISP, SHAPE)
    plain = sweep(views, wp, matching="linear")
    # [1 2 1] / 4 along rows, edges replicated, written out with scipy rather than the code under test
    low = ndimage.correlate1d(views, [0.25, 0.5, 0.25], axis=2, mode="nearest").astype(np.float32)
    blurred = sweep(low, wp, matching="linear")
    tol = sweep(views, wp, matching="linear", tolerant=True)
    np.testing.assert_allclose(tol.var, np.minimum(plain.var, blurred.var), rtol=1e-5, atol=1e-3)
    np.testing.assert_array_equal(tol.mean, plain.mean)  # the mean (the volume's colour) is not filtered
    np.testing.assert_array_equal(tol.weight, plain.weight)


def test_tolerant_variance_forgives_half_pixel_resampling(rng):
    """A random-dot plane at a half-pixel shift: bilinear resampling inflates its variance; tolerance not."""
    texture = rng.random((12, 16, 1)).repeat(3, axis=-1).astype(np.float32)
    cam = Camera.from_positions([-1.0, 0.0, 1.0], reference=1)
    wp = Warper(cam, [0.0, 0.5, 1.5], (12, 16))
    views = np.stack([wp.to_view(texture, k, 1) for k in range(3)])  # the scene: the texture on d = 0.5
    inner = np.s_[:, 2:-2]
    plain = sweep(views, wp, matching="linear").var[1][inner]
    tol = sweep(views, wp, matching="linear", tolerant=True).var[1][inner]
    assert np.median(tol) < 0.2 * np.median(plain)


def test_lowpass_axes_follow_the_rig():
    assert lowpass_axes(Camera.from_positions([0.0, 1.0, 2.0]), SHAPE) == (2,)
    assert lowpass_axes(Camera.from_positions([[0.0, 0.0], [0.0, 1.0]]), SHAPE) == (1,)
    assert lowpass_axes(Camera.from_positions(POS, reference=1), SHAPE) == (2, 1)
    for pos in ([0.0, 1.0, 2.0], POS):
        M, M0 = rectified_rig_matrices(pos, 0.0, SHAPE)
        general = Camera(positions=pos, reference=0.0, matrices=M, M0=M0)
        assert lowpass_axes(general, SHAPE) == lowpass_axes(Camera.from_positions(pos), SHAPE)
