"""Stage 2, Eq. (2): iterative evidence aggregation, and the box alternative."""

import numpy as np
import pytest

from vfxstereo.aggregate import (
    AGGREGATION_METHODS,
    aggregate,
    aggregate_box,
    aggregate_szeliski1999,
)
from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.select import WTA, select
from vfxstereo.stack import LayerStack
from vfxstereo.sweep import sweep
from vfxstereo.warp import Warper


def _hand_eq2(sigma0, iterations, a, b, c, smax, limit_centre):
    """Eq. (2) cell by cell; neighbours outside the frame replicate the cell itself."""
    D, H, W = sigma0.shape
    s = sigma0.astype(np.float64).copy()
    for _ in range(iterations):
        new = np.empty_like(s)
        for d in range(D):
            for y in range(H):
                for x in range(W):
                    nb = 0.0
                    for yy, xx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                        yy = min(max(yy, 0), H - 1)
                        xx = min(max(xx, 0), W - 1)
                        nb += min(s[d, yy, xx], smax)
                    centre = min(s[d, y, x], smax) if limit_centre else s[d, y, x]
                    if np.isinf(sigma0[d, y, x]):
                        new[d, y, x] = np.inf
                    else:
                        new[d, y, x] = a * centre + b * nb + c * sigma0[d, y, x]
        s = new
    return s


@pytest.mark.parametrize("limit_centre", [False, True])
def test_eq2_matches_hand_loop(rng, limit_centre):
    sigma0 = (rng.random((3, 5, 6)) * 40).astype(np.float32)  # values on both sides of sigma_max
    sigma0[1, 2, 3] = np.inf
    sigma0[0, 0, 0] = np.inf  # a corner without votes
    got = aggregate_szeliski1999(sigma0, iterations=4, limit_centre=limit_centre)
    want = _hand_eq2(sigma0, 4, 0.1, 0.15, 0.3, 16.0, limit_centre)
    assert got.dtype == np.float32
    assert np.array_equal(np.isinf(got), np.isinf(want))
    fin = np.isfinite(want)
    np.testing.assert_allclose(got[fin], want[fin], rtol=1e-5)


@pytest.mark.parametrize("limit_centre", [False, True])
def test_eq2_weights_sum_to_one_so_a_constant_field_stays(limit_centre):
    assert 0.1 + 4 * 0.15 + 0.3 == pytest.approx(1.0)
    for value in (0.0, 3.5, 16.0):
        field = np.full((2, 7, 9), value, dtype=np.float32)
        np.testing.assert_allclose(aggregate_szeliski1999(field, iterations=7, limit_centre=limit_centre),
                                   value, rtol=1e-6)


def test_eq2_cells_without_votes_do_not_poison_neighbours():
    sigma0 = np.full((1, 5, 5), 2.0, dtype=np.float32)
    sigma0[0, 2, 2] = np.inf
    capped = sigma0.copy()
    capped[0, 2, 2] = 16.0  # what the neighbours see of it: min(inf, sigma_max)
    got = aggregate_szeliski1999(sigma0, iterations=1)
    assert np.isinf(got[0, 2, 2])
    ref = aggregate_szeliski1999(capped, iterations=1)
    mask = np.ones((5, 5), bool)
    mask[2, 2] = False
    np.testing.assert_allclose(got[0][mask], ref[0][mask], rtol=1e-6)
    assert got[0, 1, 2] == pytest.approx(0.1 * 2 + 0.15 * (2 + 2 + 2 + 16) + 0.3 * 2)
    # stays infinite and keeps its neighbours finite over many iterations
    many = aggregate_szeliski1999(sigma0, iterations=50)
    assert np.isinf(many[0, 2, 2]) and np.isfinite(many[0][mask]).all()


def test_eq2_zero_iterations_is_the_identity(rng):
    sigma0 = rng.random((2, 4, 4)).astype(np.float32)
    np.testing.assert_array_equal(aggregate_szeliski1999(sigma0, iterations=0), sigma0)


def test_eq2_aggregation_fixes_winner_take_all_on_an_ambiguous_stereogram():
    """Eq. (2) exists to disambiguate: on a grey binary random-dot stereogram a single pixel matches a
    wrong disparity by chance about a quarter of the time (three views), so raw WTA fails often;
    aggregation must fix nearly all of it."""
    rng = np.random.default_rng(7)
    H, W, disp = 32, 48, np.arange(6.0)

    def dots(h, w):
        return np.repeat((rng.random((h, w, 1)) < 0.5).astype(np.float32), 3, axis=2)

    rgba = np.zeros((6, H, W, 4), np.float32)
    rgba[1, ..., :3] = dots(H, W)
    rgba[1, ..., 3] = 1
    rgba[4, 8:24, 14:34, :3] = dots(16, 20)
    rgba[4, 8:24, 14:34, 3] = 1
    pos = np.array([-1.0, 0.0, 1.0])
    cam = Camera.from_positions(pos, reference=1)
    stack = LayerStack(rgba, disp, cam)
    views = np.stack([stack.render(float(p))[..., :3] for p in pos])
    gt = np.full((H, W), 1)
    gt[8:24, 14:34] = 4
    st = sweep(views, Warper(cam, disp, (H, W)))
    raw = select(st.mean, st.var, views[1], **WTA).winner
    core = np.zeros((H, W), bool)
    core[2:-2, 6:-6] = True  # away from the frame edge, where views drop out
    core[8:24, 14 - 3:14] = core[8:24, 34:34 + 3] = False  # background occluded in one view
    raw_err = np.mean(raw[core] != gt[core])
    assert raw_err > 0.2
    for limit_centre in (False, True):
        cost = aggregate(st.var, iterations=10, limit_centre=limit_centre)
        agg = select(st.mean, cost, views[1], **WTA).winner
        agg_err = np.mean(agg[core] != gt[core])
        assert agg_err < 0.05 * raw_err, (limit_centre, agg_err, raw_err)


def _slow_box(var, r):
    D, H, W = var.shape
    out = np.empty_like(var, dtype=np.float64)
    for d in range(D):
        for y in range(H):
            for x in range(W):
                win = var[d, max(0, y - r): y + r + 1, max(0, x - r): x + r + 1]
                fin = win[np.isfinite(win)]
                out[d, y, x] = np.inf if not np.isfinite(var[d, y, x]) else fin.mean()
    return out


def test_box_aggregation_matches_slow_reference(rng):
    var = (rng.random((2, 6, 7)) * 50).astype(np.float32)
    var[0, 1, 1] = np.inf
    var[1, 5, 6] = np.inf
    got = aggregate_box(var, radius=1)
    want = _slow_box(var, 1)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    fin = np.isfinite(want)
    np.testing.assert_allclose(got[fin], want[fin], rtol=1e-5)


def test_registry_front_end(rng):
    var = rng.random((2, 5, 5)).astype(np.float32)
    assert set(AGGREGATION_METHODS) >= {"szeliski1999", "box"}
    np.testing.assert_array_equal(aggregate(var, iterations=3), aggregate_szeliski1999(var, iterations=3))
    np.testing.assert_array_equal(aggregate(var, "box", radius=2), aggregate_box(var, radius=2))
    calls = []
    aggregate(var, iterations=3, progress=lambda *a: calls.append(a))
    assert calls == [("aggregate", t, 3) for t in (1, 2, 3)]
    with pytest.raises(VfxStereoError):
        aggregate(var, "median")
    with pytest.raises(VfxStereoError):
        aggregate(var[0])
    with pytest.raises(VfxStereoError):
        aggregate(np.full((1, 2, 2), np.nan))
