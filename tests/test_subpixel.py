"""Section 8.1: sub-pixel disparity from a parabola through the variance at the winner and its neighbours."""

import numpy as np
import pytest
from scipy import ndimage

from vfxstereo.aggregate import aggregate
from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.select import WTA, select
from vfxstereo.stack import LayerStack
from vfxstereo.subpixel import parabola_vertex, subpixel_disparity
from vfxstereo.sweep import sweep
from vfxstereo.warp import Warper


@pytest.mark.parametrize("disp", [np.arange(7.0), np.array([0.0, 0.4, 1.0, 1.3, 2.5, 2.75, 4.0])],
                         ids=["even", "uneven"])
def test_sec81_exact_minimum_of_a_parabolic_cost(rng, disp):
    H, W = 6, 7
    win = rng.integers(1, len(disp) - 1, (H, W))  # interior planes, so both neighbours exist
    lo = 0.5 * (disp[win - 1] + disp[win])
    hi = 0.5 * (disp[win] + disp[win + 1])
    true = lo + (hi - lo) * rng.uniform(0.02, 0.98, (H, W))  # inside the winner's half-spacing cell
    curv = rng.uniform(0.5, 20.0, (H, W))
    base = rng.uniform(0.0, 5.0, (H, W))
    cost = curv * (disp[:, None, None] - true) ** 2 + base  # (D, H, W)
    assert np.array_equal(np.argmin(cost, axis=0), win)
    got = subpixel_disparity(cost, disp, win)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, true, atol=1e-5)


def test_sec81_even_spacing_reduces_to_the_textbook_offset(rng):
    s = rng.uniform(1, 10, (3, 50))
    s[1] = s.min(axis=0) - rng.uniform(0.1, 1, 50)
    h = 0.25
    got = parabola_vertex(2.0 - h, 2.0, 2.0 + h, s[0], s[1], s[2])
    offset = (s[0] - s[2]) / (2 * (s[0] - 2 * s[1] + s[2]))
    np.testing.assert_allclose(got, 2.0 + h * offset, rtol=1e-12)


def test_sec81_offset_is_clamped_to_half_the_spacing():
    disp = np.array([0.0, 1.0, 3.0])
    # With the winner the lowest of the three the vertex never passes the midpoint; it does when the winner
    # came from another volume (e.g. selection on a different cost), and then the clamp holds it.
    for costs, bound in (([0.5, 1.0, 100.0], 0.5), ([100.0, 1.0, 0.5], 2.0)):
        free = parabola_vertex(0.0, 1.0, 3.0, *costs)
        assert (free < bound) if bound < 1 else (free > bound)  # the fitted vertex lies beyond the midpoint
        got = subpixel_disparity(np.array(costs)[:, None, None], disp, np.array([[1]]))
        assert got[0, 0] == pytest.approx(bound)  # clamped to the midpoint between the planes


def test_sec81_edges_undecided_and_missing_neighbours():
    disp = np.arange(4.0)
    cost = np.array([1.0, 2.0, 3.0, 4.0])[:, None, None] * np.ones((1, 1, 4))
    cost[1, 0, 2] = np.inf
    winner = np.array([[0, -1, 1, 1]])
    cost[:, 0, 3] = [5.0, 5.0, 5.0, 9.0]  # flat on both sides of the winner: no curvature
    cost[:, 0, 2] = [1.0, np.inf, 3.0, 4.0]
    winner[0, 2] = 2  # a neighbour without votes
    got = subpixel_disparity(cost, disp, winner)
    assert got[0, 0] == 0.0  # first plane: no left neighbour
    assert np.isnan(got[0, 1])  # undecided
    assert got[0, 2] == 2.0
    assert got[0, 3] == 1.0


def test_sec81_rendered_plane_between_two_planes_beats_the_integer_winner():
    """A smooth texture at d = 2.4, planes at 0..5: the parabola lands much closer than the integer winner."""
    rng = np.random.default_rng(3)
    H, W, dtrue = 24, 64, 2.4
    tex = ndimage.gaussian_filter(rng.random((H, W, 3)), (1.5, 1.5, 0))
    tex = ((tex - tex.min()) / (tex.max() - tex.min())).astype(np.float32)
    rgba = np.zeros((2, H, W, 4), np.float32)
    rgba[0, ..., 3] = 1.0
    rgba[1, ..., :3] = tex
    rgba[1, ..., 3] = 1.0
    pos = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    cam = Camera.from_positions(pos, reference=2)
    views = np.stack([LayerStack(rgba, [0.0, dtrue], cam).render(float(p))[..., :3] for p in pos])
    disp = np.arange(6.0)
    st = sweep(views, Warper(cam, disp, (H, W)))
    cost = aggregate(st.var, iterations=10)
    sel = select(st.mean, cost, views[2], **WTA)
    sub = subpixel_disparity(cost, disp, sel.winner)
    core = (slice(2, -2), slice(8, -8))  # every view sees these cells
    int_err = np.mean(np.abs(disp[sel.winner][core] - dtrue))
    sub_err = np.mean(np.abs(sub[core] - dtrue))
    assert int_err >= 0.35
    assert sub_err < 0.15
    assert sub_err < 0.4 * int_err


def test_user_errors():
    with pytest.raises(VfxStereoError):
        subpixel_disparity(np.zeros((3, 2, 2)), np.arange(2.0), np.zeros((2, 2), int))
    with pytest.raises(VfxStereoError):
        subpixel_disparity(np.zeros((3, 2, 2)), np.array([0.0, 2.0, 1.0]), np.zeros((2, 2), int))
