"""General cameras: plane-induced homographies (Eq. A1) and the exact bilinear warps built from them."""

import numpy as np
import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.homography import HomographyWarps, bilinear_matrix, plane_homography, rectified_rig_matrices
from vfxstereo.warp import Warper


def _rotation(rx, ry, rz):
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _general_rig(shape):
    """Three views: the reference, one rotated and moved forward, one zoomed and moved diagonally."""
    h, w = shape
    f = float(max(h, w))
    intr = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]])
    poses = [(np.eye(3), np.zeros(3)),
             (_rotation(0.02, -0.03, 0.05), np.array([0.4, 0.1, 0.3])),
             (_rotation(-0.01, 0.02, -0.02), np.array([-0.3, -0.2, -0.2]))]
    M = np.stack([intr @ np.hstack([R, -(R @ c)[:, None]]) for R, c in poses])
    M[2] = np.diag([1.1, 1.1, 1.0]) @ M[2]  # view 2 zooms in
    M0 = np.array([[f, 0, (w - 1) / 2, 0], [0, f, (h - 1) / 2, 0], [0, 0, 1, 0], [0, 0, 0, f]])
    cam = Camera(positions=[0.0, 1.0, 2.0], reference=0.0, reference_index=0, matrices=M, M0=M0)
    return cam, M, M0


def test_eqA1_homography_maps_known_points(rng):
    cam, M, M0 = _general_rig((30, 40))
    for _ in range(20):
        X = np.array([*rng.uniform(-1, 1, 2), rng.uniform(2, 10), 1.0])  # world point in front of the rig
        x0 = M0 @ X
        x0 = x0 / x0[2]  # [x y 1 d]
        x, y, d = x0[0], x0[1], x0[3]
        for k in range(3):
            want = M[k] @ X
            got = plane_homography(M[k], M0, d) @ np.array([x, y, 1.0])  # Eq. (A1)
            np.testing.assert_allclose(got[:2] / got[2], want[:2] / want[2], rtol=0, atol=1e-9)


def test_eqA1_rectified_rig_is_a_pure_shift():
    pos = np.array([[-2.0, 0.5], [0.0, 0.0], [1.5, -1.0]])
    M, M0 = rectified_rig_matrices(pos, pos[1], (24, 32), focal=50.0, baseline=0.2)
    for k in range(3):
        off = pos[k] - pos[1]
        for d in (0.0, 0.7, 3.0):
            H = plane_homography(M[k], M0, d)
            H = H / H[2, 2]
            want = np.array([[1, 0, -d * off[0]], [0, 1, -d * off[1]], [0, 0, 1.0]])
            np.testing.assert_allclose(H, want, atol=1e-12)


def test_eqA1_general_path_equals_shift_path_for_translating_cameras(rng):
    shape = (17, 23)
    pos = np.array([[-1.5, 0.25], [0.0, 0.0], [1.0, -0.75], [2.0, 0.0]])
    shift_cam = Camera.from_positions(pos, reference=1)
    M, M0 = rectified_rig_matrices(pos, pos[1], shape)
    gen_cam = Camera(positions=pos, reference=pos[1], reference_index=1, matrices=M, M0=M0)
    disp = np.array([0.0, 0.5, 1.3, 2.0, 3.75])
    ws, wg = Warper(shift_cam, disp, shape), Warper(gen_cam, disp, shape)
    assert wg._general is not None and ws._general is None
    img = rng.random((*shape, 3)).astype(np.float32)
    gray = rng.random(shape).astype(np.float32)
    for k in range(len(pos)):
        for i in range(len(disp)):
            for a in (img, gray):
                np.testing.assert_allclose(wg.to_plane(a, k, i), ws.to_plane(a, k, i), atol=1e-6)
                np.testing.assert_allclose(wg.to_view(a, k, i), ws.to_view(a, k, i), atol=1e-6)
                np.testing.assert_allclose(wg.to_view_adjoint(a, k, i), ws.to_view_adjoint(a, k, i),
                                           atol=1e-6)
            np.testing.assert_allclose(wg.coverage(k, i), ws.coverage(k, i), atol=1e-6)


@pytest.mark.parametrize("channels", [None, 4])
def test_eq5_to_view_adjoint_is_exact_transpose(rng, channels):
    shape = (21, 27)
    cam, _, _ = _general_rig(shape)
    warps = HomographyWarps(cam, np.array([0.0, 2.5, 6.0]), shape)
    extra = () if channels is None else (channels,)
    for k in range(3):
        for i in range(3):
            a = rng.standard_normal((*shape, *extra))
            b = rng.standard_normal((*shape, *extra))
            lhs = np.sum(warps.to_view(a, k, i) * b)
            rhs = np.sum(a * warps.to_view_adjoint(b, k, i))
            assert lhs == pytest.approx(rhs, rel=1e-10, abs=1e-10)


def test_eq1_to_plane_samples_an_affine_image_exactly():
    """Bilinear interpolation reproduces an affine image, so to_plane must return it at H x."""
    shape = (25, 31)
    cam, M, M0 = _general_rig(shape)
    disp = np.array([0.0, 4.0])
    warps = HomographyWarps(cam, disp, shape)
    ys, xs = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64)
    ramp = 0.3 * xs - 0.7 * ys + 5.0
    for k in range(3):
        for i in range(2):
            H = plane_homography(M[k], M0, disp[i])
            q = H @ np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
            u, v = (q[0] / q[2]).reshape(shape), (q[1] / q[2]).reshape(shape)
            inside = (u >= 0) & (u <= shape[1] - 1) & (v >= 0) & (v <= shape[0] - 1)
            far = (u < -1) | (u > shape[1]) | (v < -1) | (v > shape[0])
            got = warps.to_plane(ramp, k, i)
            assert inside.sum() > 0.5 * inside.size
            want = 0.3 * u - 0.7 * v + 5.0
            np.testing.assert_allclose(got[inside], want[inside], atol=1e-5)  # float32 weights
            assert np.all(got[far] == 0)
            cov = warps.to_plane(np.ones(shape), k, i)
            np.testing.assert_allclose(cov[inside], 1.0, atol=1e-6)


def test_to_view_inverts_to_plane_inside_the_frame(rng):
    """Sampling at H x then at H^-1 u round-trips a smooth image away from the edges."""
    shape = (40, 50)
    cam, _, _ = _general_rig(shape)
    warps = HomographyWarps(cam, np.array([3.0]), shape)
    ys, xs = np.mgrid[0:shape[0], 0:shape[1]]
    img = np.sin(xs / 6.0) + np.cos(ys / 7.0)
    back = warps.to_view(warps.to_plane(img, 1, 0), 1, 0)
    core = (slice(10, -10), slice(10, -10))
    np.testing.assert_allclose(back[core], img[core], atol=0.02)


def test_points_behind_the_camera_sample_nothing():
    H = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, -1.0]])  # w < 0 everywhere
    mat = bilinear_matrix(H, (4, 5))
    assert mat.nnz == 0


def test_cache_budget_changes_nothing_but_memory(rng):
    shape = (15, 19)
    cam, _, _ = _general_rig(shape)
    disp = np.array([0.0, 1.5])
    cached = HomographyWarps(cam, disp, shape)
    uncached = HomographyWarps(cam, disp, shape, cache_bytes=0)
    a = rng.random((*shape, 3))
    for _ in range(2):
        np.testing.assert_array_equal(cached.to_view(a, 1, 1), uncached.to_view(a, 1, 1))
        np.testing.assert_array_equal(cached.to_view_adjoint(a, 2, 0), uncached.to_view_adjoint(a, 2, 0))
    assert cached._cached_bytes > 0 and uncached._cached_bytes == 0


def test_errors_are_vfxstereo_errors():
    M, M0 = rectified_rig_matrices([0.0, 1.0], 0.0, (8, 8))
    with pytest.raises(VfxStereoError):
        plane_homography(M[0], np.zeros((4, 4)), 1.0)
    with pytest.raises(VfxStereoError):
        plane_homography(M[0][:2], M0, 1.0)
    cam = Camera(positions=[0.0, 1.0], reference=0.0, matrices=M, M0=M0)
    warps = HomographyWarps(cam, np.array([1.0]), (8, 8))
    with pytest.raises(VfxStereoError):
        warps.to_plane(np.zeros((7, 8)), 0, 0)
    with pytest.raises(VfxStereoError):
        HomographyWarps(Camera.from_positions([0.0, 1.0]), np.array([1.0]), (8, 8))


def test_plane_step_is_the_median_gap_so_one_uneven_plane_does_not_move_it():
    from vfxstereo.warp import plane_step

    assert plane_step(np.arange(0.0, 16.5, 0.5)) == 0.5
    assert plane_step([0.0, 1.0, 2.0, 3.0, 10.0]) == 1.0  # the mean gap would be 2.5
    assert plane_step([4.0]) == 1.0
    w = Warper(Camera.from_positions(np.array([0.0, 1.0]), 0), np.array([0.0, 2.0, 4.0, 5.0]), (8, 8))
    assert w.step == 2.0
