"""Robust matching costs: the census kernel and the cost-accumulation kernels against plain references."""

import numpy as np
import pytest

from vfxstereo import matching
from vfxstereo.geometry import Camera
from vfxstereo.homography import rectified_rig_matrices
from vfxstereo.matching import MatchingParams
from vfxstereo.warp import Warper


def test_census_kernel_equals_the_numpy_reference(rng):
    gray = rng.integers(0, 6, (23, 31)).astype(np.float32)  # ties on purpose: "darker" is strict
    for radius in [(3, 4), (1, 1), (2, 0)]:
        np.testing.assert_array_equal(matching.census_transform(gray, radius),
                                      matching.census_transform_reference(gray, radius))


def test_census_bits_by_hand():
    g = np.array([[5, 1, 9], [2, 4, 7], [4, 3, 8]], np.float32)
    # centre 4; neighbours row-major without the centre: 5 1 9 2 7 4 3 8 -> darker: 0 1 0 1 0 0 1 0
    code = matching.census_transform_reference(g, (1, 1))[1, 1]
    assert int(code) == 0b01010010
    assert int(matching.census_transform(g, (1, 1))[1, 1]) == 0b01010010


def test_census_is_unchanged_by_gain_and_offset(rng):
    gray = rng.uniform(0, 200, (20, 20)).astype(np.float32)
    np.testing.assert_array_equal(matching.census_transform(gray), matching.census_transform(1.3 * gray + 17.0))


def test_hamming_counts_bits():
    a = np.array([0, 0b1011, 2**63], np.uint64)
    b = np.array([0, 0b0001, 0], np.uint64)
    np.testing.assert_array_equal(matching.hamming(a, b), [0, 2, 1])


def _prepared(rng, K=3, h=14, w=20):
    views = rng.uniform(0.05, 0.9, (K, h, w, 3)).astype(np.float32)
    return views, matching.prepare(views)


@pytest.mark.parametrize("general", [False, True])
def test_accumulated_costs_equal_the_per_cell_reference(rng, general):
    views, prep = _prepared(rng)
    h, w = views.shape[1:3]
    positions = [0.0, 1.0, 2.5]
    planes = np.array([0.0, 0.75, 1.5, 2.0])
    cam = Camera.from_positions(positions, 1)
    if general:
        M, M0 = rectified_rig_matrices(positions, positions[1], (h, w))
        cam = Camera(positions=positions, reference=positions[1], reference_index=1, matrices=M, M0=M0)
    warper = Warper(cam, planes, (h, w))
    params = MatchingParams()
    for k in (0, 2):
        total = np.zeros((h, w, len(planes)), np.float32)
        count = np.zeros((h, w, len(planes)), np.uint8)
        matching.accumulate(prep, warper, k, 1, total, count, params=params)
        off = positions[k] - positions[1]
        for y in range(0, h, 3):
            for x in range(w):
                for i, d in enumerate(planes):
                    want = matching.cell_cost_reference(prep, k, 1, y, x, x - d * off, float(y), params)
                    if np.isnan(want):
                        assert count[y, x, i] == 0
                    else:
                        assert count[y, x, i] == 1
                        # the kernel reads the colour term from a table in 1/8-unit steps
                        assert total[y, x, i] == pytest.approx(want, abs=5e-3)


def test_centred_costs_are_each_views_costs_minus_their_mean_over_the_planes_it_sees(rng):
    views, prep = _prepared(rng)
    h, w = views.shape[1:3]
    planes = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    warper = Warper(Camera.from_positions([0.0, 1.0, 2.0], 1), planes, (h, w))
    raw_t = np.zeros((h, w, 5), np.float32)
    raw_c = np.zeros((h, w, 5), np.uint8)
    cen_t = np.zeros_like(raw_t)
    cen_c = np.zeros_like(raw_c)
    matching.accumulate(prep, warper, 2, 1, raw_t, raw_c)
    matching.accumulate(prep, warper, 2, 1, cen_t, cen_c, centre=True)
    np.testing.assert_array_equal(raw_c, cen_c)
    n = raw_c.sum(axis=2)
    mean = np.where(n > 0, raw_t.sum(axis=2) / np.maximum(n, 1), 0)
    np.testing.assert_allclose(cen_t, np.where(raw_c > 0, raw_t - mean[..., None], 0), atol=1e-5)


def test_a_zbuffer_hides_the_cells_behind_it(rng):
    views, prep = _prepared(rng)
    h, w = views.shape[1:3]
    planes = np.array([0.0, 1.0, 2.0, 3.0])
    warper = Warper(Camera.from_positions([0.0, 1.0, 2.0], 1), planes, (h, w))
    zbuf = np.full((h, w), -np.inf, np.float32)
    zbuf[:, 8:12] = 3.0  # something at d = 3 covers columns 8..11 of view 2
    total = np.zeros((h, w, 4), np.float32)
    count = np.zeros((h, w, 4), np.uint8)
    matching.accumulate(prep, warper, 2, 1, total, count, zbuf=zbuf, tolerance=0.5)
    # cell (x, d) lands on column x - d of view 2: hidden there for d < 2.5, seen for d = 3
    for x in range(w):
        for i, d in enumerate(planes):
            u = x - d
            if 0 <= u <= w - 1:
                assert count[0, x, i] == (0 if (8 <= round(u) <= 11 and d < 2.5) else 1), (x, d)


@pytest.mark.parametrize("general", [False, True])
def test_skipped_pixels_get_no_cost_and_the_others_the_same(rng, general):
    views, prep = _prepared(rng)
    h, w = views.shape[1:3]
    positions = [0.0, 1.0, 2.0]
    cam = Camera.from_positions(positions, 1)
    if general:
        M, M0 = rectified_rig_matrices(positions, positions[1], (h, w))
        cam = Camera(positions=positions, reference=positions[1], reference_index=1, matrices=M, M0=M0)
    warper = Warper(cam, np.array([0.0, 1.0, 2.0, 3.0]), (h, w))
    skip = rng.uniform(size=(h, w)) < 0.3
    out = {}
    for name, sk in (("all", None), ("skip", skip)):
        t = np.zeros((h, w, 4), np.float32)
        c = np.zeros((h, w, 4), np.uint8)
        matching.accumulate(prep, warper, 2, 1, t, c, centre=True, skip=sk)
        out[name] = (t, c)
    assert out["all"][1][skip].sum() > 0 and out["skip"][1][skip].sum() == 0
    assert not out["skip"][0][skip].any()
    np.testing.assert_array_equal(out["skip"][1][~skip], out["all"][1][~skip])
    np.testing.assert_array_equal(out["skip"][0][~skip], out["all"][0][~skip])


def test_partial_views_are_those_a_frame_edge_cuts_where_another_view_sees_every_plane():
    from vfxstereo.depth import partial_views

    h, w = 6, 40
    planes = np.array([0.0, 2.0, 4.0, 6.0])
    warper = Warper(Camera.from_positions([-2.0, -1.0, 0.0, 1.0, 2.0], 2), planes, (h, w))
    partial = partial_views(warper, [0, 1, 3, 4])
    # view k sees reference column x at plane d at x - d * (pos_k - 0): inside for every plane iff both ends are
    for k, pos in ((0, -2.0), (1, -1.0), (3, 1.0), (4, 2.0)):
        x = np.arange(w)
        full_k = (x - 6.0 * pos >= 0) & (x - 6.0 * pos <= w - 1)
        # some view has every plane of every column here (the views on the other side), so the cut ones skip
        np.testing.assert_array_equal(partial[k][0], ~full_k)
    # a stereo pair: the one other view is cut at the frame edge and no view has every plane there: none skipped
    pair = Warper(Camera.from_positions([0.0, 1.0], 0), planes, (h, w))
    assert not partial_views(pair, [1])[1].any()


def test_matching_params_refuse_windows_that_do_not_fit():
    from vfxstereo.errors import VfxStereoError

    with pytest.raises(VfxStereoError, match="64 bits"):
        MatchingParams(census_radius=(4, 4))
    with pytest.raises(VfxStereoError):
        MatchingParams(lambda_ad=0.0)

