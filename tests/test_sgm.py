"""Semi-global matching: the numba kernel against the plain numpy reference, and what the penalties do."""

import numpy as np
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.sgm import sgm, sgm_reference


@pytest.mark.parametrize("paths", [8, 4])
def test_kernel_equals_the_reference(rng, paths):
    cost = rng.uniform(0, 2, (9, 13, 6)).astype(np.float32)
    guide = rng.uniform(0, 255, (9, 13)).astype(np.float32)
    got = sgm(cost, guide, P1=0.3, P2=2.0, sigma=10.0, paths=paths)
    want = sgm_reference(cost, guide, P1=0.3, P2=2.0, sigma=10.0, paths=paths)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-4)


def test_without_penalties_every_path_is_the_cost_itself(rng):
    cost = rng.uniform(0, 1, (5, 7, 4)).astype(np.float32)
    np.testing.assert_allclose(sgm(cost, np.zeros((5, 7), np.float32), P1=0.0, P2=0.0), 8 * cost, atol=1e-5)


def test_smoothness_fills_a_pixel_whose_cost_is_flat(rng):
    """A row of pixels prefer plane 2; one in the middle has no preference: SGM gives it plane 2 too."""
    cost = np.ones((1, 21, 5), np.float32)
    cost[..., 2] = 0.0
    cost[0, 10] = 0.5
    S = sgm(cost, np.zeros((1, 21), np.float32), P1=0.2, P2=1.0, paths=4)
    assert np.argmin(S[0, 10]) == 2


def test_p2_is_lowered_at_image_edges():
    """A 3-pixel segment prefers plane 4 a little, its surroundings plane 1. On a flat guide, jumping to plane 4
    and back costs more than the segment gains, so SGM smooths it away; where the guide has edges around it,
    the jumps are cheap and it keeps its plane."""
    cost = np.full((1, 41, 6), 1.0, np.float32)
    cost[0, :, 1] = 0.8
    cost[0, 19:22, 4] = 0.7
    flat = np.zeros((1, 41), np.float32)
    edge = flat.copy()
    edge[0, 19:22] = 200.0
    w_flat = np.argmin(sgm(cost, flat, P1=0.05, P2=5.0, sigma=10.0, paths=4)[0], axis=1)
    w_edge = np.argmin(sgm(cost, edge, P1=0.05, P2=5.0, sigma=10.0, paths=4)[0], axis=1)
    assert (w_flat == 1).all()
    assert (w_edge[19:22] == 4).all() and (np.delete(w_edge, [19, 20, 21]) == 1).all()


def test_bad_arguments_are_refused():
    with pytest.raises(VfxStereoError, match="cost volume"):
        sgm(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(VfxStereoError, match="guide"):
        sgm(np.zeros((3, 3, 2)), np.zeros((3, 4)))
    with pytest.raises(VfxStereoError, match="4 or 8"):
        sgm(np.zeros((3, 3, 2)), np.zeros((3, 3)), paths=6)
