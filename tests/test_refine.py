"""Refinement (Section 6, Appendix): cost terms (Eqs. 9-13), exact gradient, preconditioner, step (Eq. A2)."""

import numpy as np
import pytest

from vfxstereo import Camera, LayerStack, VfxStereoError
from vfxstereo import refine as R
from vfxstereo.refine import RefineConfig, cost, cost_terms, gradient, project, refine
from vfxstereo.visibility import resynthesise
from vfxstereo.warp import Warper

# ----------------------------------------------------------------------------------------------------------
# Helpers


def random_volume(rng, D, H, W, dtype=np.float64):
    a = rng.uniform(0.05, 0.95, (D, H, W, 1))
    return np.concatenate([a * rng.uniform(0, 1, (D, H, W, 3)), a], axis=-1).astype(dtype)


@pytest.fixture
def small(rng):
    """D = 3 planes, 6x7, K = 3 views at fractional shifts; a random volume and random views (float64)."""
    D, H, W = 3, 6, 7
    cam = Camera.from_positions([-1.0, 0.0, 1.3], reference=1)
    wp = Warper(cam, [0.0, 0.7, 1.6], (H, W))
    return random_volume(rng, D, H, W), rng.uniform(0, 1, (3, H, W, 3)), wp


def finite_difference_gradient(f, x, step=1e-6):
    g = np.zeros_like(x)
    for i in np.ndindex(x.shape):
        xp, xm = x.copy(), x.copy()
        xp[i] += step
        xm[i] -= step
        g[i] = (f(xp) - f(xm)) / (2 * step)
    return g


def residuals(x, views, wp):
    """e_k for every view, flattened: the residual vector of C1 (quadratic rho, unit weights)."""
    v4 = np.concatenate([views, np.ones(views.shape[:3] + (1,))], axis=-1)
    return (resynthesise(x, wp) - v4).ravel()


def dot_scene(rng, H=24, W=24):
    """Ground truth: random-dot background at d = 0 (covers every view), dotted squares at d = 2 and d = 4."""
    D = 5
    gt = np.zeros((D, H, W, 4), np.float32)

    def dots(h, w):
        return rng.integers(0, 2, (h, w, 3)).astype(np.float32) * 0.8 + 0.1

    gt[0, ..., :3] = dots(H, W)
    gt[0, ..., 3] = 1
    big = np.s_[H // 4:3 * H // 4, W // 5:W // 5 + W // 2]
    small = np.s_[3 * H // 8:3 * H // 8 + H // 5, 3 * W // 8:W // 2 + 1]
    for d, (rows, cols) in [(2, big), (4, small)]:
        gt[d, rows, cols, :3] = dots(rows.stop - rows.start, cols.stop - cols.start)
        gt[d, rows, cols, 3] = 1
    cam = Camera.from_positions([-1.0, 0.0, 1.0], reference=1)
    stack = LayerStack(gt, np.arange(D, dtype=float), cam)
    views = np.stack([stack.render(p)[..., :3] for p in cam.positions])
    return stack, views, Warper(cam, stack.disparities, (H, W))


def selection_like_start(stack, views, rng, wrong=0.05):
    """What selection gives: one opaque cell per pixel (the reference's front layer), colour from the
    reference view with noise, a few pixels in a wrong layer, nothing behind the front surface."""
    D, H, W = stack.shape
    front = np.argmax(stack.visibility_weights(), axis=0)
    bad = rng.random((H, W)) < wrong
    front[bad] = rng.integers(0, D, int(bad.sum()))
    init = np.zeros_like(stack.rgba)
    yy, xx = np.mgrid[:H, :W]
    init[front, yy, xx, :3] = np.clip(views[1] + rng.normal(0, 0.02, views[1].shape), 0, 1)
    init[front, yy, xx, 3] = 1
    return init


def psnr(x, views, wp):
    v4 = np.concatenate([views, np.ones(views.shape[:3] + (1,), views.dtype)], axis=-1)
    err = resynthesise(x, wp) - v4
    return np.array([10 * np.log10(1.0 / max(np.mean(e**2), 1e-20)) for e in err])


def right_layer_fraction(x, stack):
    """Fraction of pixels whose front-most layer with alpha > 0.5 is the ground truth's front layer."""
    got = LayerStack(np.clip(x, 0, 1), stack.disparities).disparity_map(0.5)
    return float(np.mean(got == stack.disparity_map(0.5)))


# ----------------------------------------------------------------------------------------------------------
# Cost terms against hand-computed values


def test_eq9_c1_hand_computed():
    # one plane seen by one view at the reference position: c~ = c, e = c - [view, 1]
    wp = Warper(Camera.from_positions([0.0]), [0.0], (1, 2))
    c = np.array([[[[0.2, 0.1, 0.0, 0.5], [0.3, 0.3, 0.3, 0.3]]]])
    view = np.array([[[[0.4, 0.1, 0.2], [0.3, 0.0, 0.3]]]])
    e = np.array([[-0.2, 0.0, -0.2, -0.5], [0.0, 0.3, 0.0, -0.7]])
    assert cost_terms(c, view, wp, lambdas=(1, 0, 0)).C1 == pytest.approx(np.sum(e**2))
    s = 0.25  # Huber: r^2 inside s, 2 s |r| - s^2 outside
    hub = np.where(np.abs(e) <= s, e**2, 2 * s * np.abs(e) - s * s)
    got = cost_terms(c, view, wp, lambdas=(1, 0, 0), rho1="huber", huber_scale=s).C1
    assert got == pytest.approx(hub.sum())
    w = np.array([[[0.5, 2.0]]])  # w_k(u, v) weighs each pixel's error
    expect = 0.5 * np.sum(e[0] ** 2) + 2.0 * np.sum(e[1] ** 2)
    assert cost_terms(c, view, wp, lambdas=(1, 0, 0), view_weights=w).C1 == pytest.approx(expect)


def test_eq10_eq12_eq11_hand_computed():
    # two neighbouring cells: the ordered double sum of Eq. (10) counts the pair twice
    wp = Warper(Camera.from_positions([0.0]), [0.0], (1, 2))
    c1, c2 = np.array([0.1, 0.2, 0.3, 0.5]), np.array([0.4, 0.0, 0.3, 0.8])
    x = np.array([[[c1, c2]]])
    views = np.zeros((1, 1, 2, 3))
    t = cost_terms(x, views, wp, lambdas=(0, 1, 1), rho2="quadratic", premultiplied_smoothness=False)
    assert t.C2 == pytest.approx(2 * np.sum((c2 - c1) ** 2))
    assert t.C3 == pytest.approx(0.5 * 0.5 + 0.8 * 0.2)  # Eq. (11)
    t2 = cost_terms(x, views, wp, lambdas=(0, 1, 0), rho2="quadratic", premultiplied_smoothness=True)
    D = c1[3] * c2[:3] - c2[3] * c1[:3]  # Eq. (12); the alpha component is 0
    assert t2.C2 == pytest.approx(2 * np.sum(D**2))


def test_eq13_total_is_the_weighted_sum(small):
    x, views, wp = small
    t = cost_terms(x, views, wp, lambdas=(2.0, 3.0, 5.0))
    assert t.C == pytest.approx(2 * t.C1 + 3 * t.C2 + 5 * t.C3)
    assert cost(x, views, wp, lambdas=(2.0, 3.0, 5.0)) == pytest.approx(t.C)
    alone = [cost_terms(x, views, wp, lambdas=lam) for lam in [(1, 0, 0), (0, 1, 0), (0, 0, 1)]]
    assert (alone[0].C1, alone[1].C2, alone[2].C3) == pytest.approx((t.C1, t.C2, t.C3))


# ----------------------------------------------------------------------------------------------------------
# The gradient: central finite differences of cost()

GRADIENT_CASES = {
    "C1 quadratic": dict(lambdas=(1, 0, 0), rho1="quadratic"),
    "C1 huber": dict(lambdas=(1, 0, 0), rho1="huber", huber_scale=0.1),
    "C2 quadratic": dict(lambdas=(0, 1, 0), rho2="quadratic", premultiplied_smoothness=False),
    "C2 huber": dict(lambdas=(0, 1, 0), rho2="huber", huber_scale=0.1, premultiplied_smoothness=False),
    "C2' quadratic": dict(lambdas=(0, 1, 0), rho2="quadratic", premultiplied_smoothness=True),
    "C2' huber": dict(lambdas=(0, 1, 0), rho2="huber", huber_scale=0.05, premultiplied_smoothness=True),
    "C3": dict(lambdas=(0, 0, 1)),
    "all, quadratic, C2'": dict(lambdas=(2, 3, 5), rho1="quadratic", rho2="quadratic"),
    "all, huber, C2": dict(lambdas=(50, 1, 50), rho1="huber", rho2="huber", premultiplied_smoothness=False),
}


@pytest.mark.parametrize("settings", GRADIENT_CASES.values(), ids=GRADIENT_CASES.keys())
def test_appendix_gradient_matches_finite_differences(small, settings):
    x, views, wp = small
    g, h = gradient(x, views, wp, **settings)
    fd = finite_difference_gradient(lambda y: cost(y, views, wp, **settings), x)
    np.testing.assert_allclose(g, fd, atol=1e-6 * max(1.0, np.abs(fd).max()))
    assert np.all(h >= 0)


def test_appendix_gradient_with_per_pixel_view_weights(small, rng):
    x, views, wp = small
    w = rng.uniform(0, 2, (3,) + x.shape[1:3])
    settings = dict(lambdas=(1, 0, 0), rho1="huber", huber_scale=0.2)
    g, _ = gradient(x, views, wp, view_weights=w, **settings)
    fd = finite_difference_gradient(lambda y: cost(y, views, wp, view_weights=w, **settings), x)
    np.testing.assert_allclose(g, fd, atol=1e-6 * np.abs(fd).max())


def test_appendix_hessian_is_the_gauss_newton_diagonal_for_whole_pixel_shifts(rng):
    # c~ is affine in any single cell value, so central differences give the Jacobian J exactly
    D, H, W = 3, 5, 6
    wp = Warper(Camera.from_positions([-1.0, 0.0, 1.0], reference=1), [0.0, 1.0, 2.0], (H, W))
    x, views = random_volume(rng, D, H, W), rng.uniform(0, 1, (3, H, W, 3))
    _, h = gradient(x, views, wp, lambdas=(1, 0, 0), rho1="quadratic")
    J = np.empty((x.size, 3 * H * W * 4))
    for n, i in enumerate(np.ndindex(x.shape)):
        xp, xm = x.copy(), x.copy()
        xp[i] += 0.5
        xm[i] -= 0.5
        J[n] = residuals(xp, views, wp) - residuals(xm, views, wp)
    np.testing.assert_allclose(h.ravel(), 2 * np.sum(J**2, axis=1), atol=1e-10)


def test_appendix_hessian_bounds_the_gauss_newton_diagonal_for_fractional_shifts(small):
    x, views, wp = small
    _, h = gradient(x, views, wp, lambdas=(1, 0, 0), rho1="quadratic")
    J = np.empty((x.size, 3 * x.shape[1] * x.shape[2] * 4))
    for n, i in enumerate(np.ndindex(x.shape)):
        xp, xm = x.copy(), x.copy()
        xp[i] += 0.5
        xm[i] -= 0.5
        J[n] = residuals(xp, views, wp) - residuals(xm, views, wp)
    diag = 2 * np.sum(J**2, axis=1)
    assert np.all(h.ravel() >= diag - 1e-10)
    assert np.any(h.ravel() > diag + 1e-3)  # the bilinear footprints make it a strict bound somewhere


def test_appendix_hessian_stays_positive_where_the_papers_form_is_negative():
    # three opaque white layers: ||a_k(d-1)||^2 = 4 behind the top ones, so V (1 - ||a||^2) < 0
    wp = Warper(Camera.from_positions([0.0]), [0.0, 1.0, 2.0], (2, 2))
    x = np.ones((3, 2, 2, 4))
    _, h = gradient(x, np.full((1, 2, 2, 3), 0.5), wp, lambdas=(1, 0, 0))
    assert np.all(h[..., 3] >= 0)
    assert np.all(h[2, ..., 3] > 0)  # the top layer is visible: its alpha has curvature


# ----------------------------------------------------------------------------------------------------------
# numba kernels against their numpy references


@pytest.mark.parametrize("rho", ["quadratic", "huber"])
@pytest.mark.parametrize("premultiplied", [False, True])
def test_kernels_match_numpy_reference(small, rho, premultiplied):
    x, views, wp = small
    cfg = RefineConfig(lambdas=(1.5, 2.0, 0.5), rho1=rho, rho2=rho, huber_scale=0.1,
                       premultiplied_smoothness=premultiplied)
    v4 = np.concatenate([views, np.ones(views.shape[:3] + (1,))], axis=-1)
    tk, gk, hk = R._evaluate(x, v4, wp, None, cfg, True, kernels=True)
    tn, gn, hn = R._evaluate(x, v4, wp, None, cfg, True, kernels=False)
    assert tk.C == pytest.approx(tn.C, rel=1e-12)
    np.testing.assert_allclose(gk, gn, atol=1e-12)
    np.testing.assert_allclose(hk, hn, atol=1e-12)


def test_projection_kernel_matches_numpy_reference(rng):
    x = rng.uniform(-0.5, 1.5, (3, 5, 6, 4))
    q = rng.uniform(0.1, 10, x.shape)
    for white in (1.0, 2.5):
        np.testing.assert_allclose(project(x.copy(), white=white, metric=q),
                                   R._project_numpy(x.copy(), q, white), atol=1e-12)


def test_projection_is_the_nearest_feasible_point_in_its_metric(rng):
    # brute force: for a fine grid of alpha', the best colours are clip(c, 0, alpha'); take the best alpha'
    grid = np.linspace(0, 1, 20001)
    for _ in range(30):
        c = rng.uniform(-0.5, 1.5, 4)
        q = rng.uniform(0.1, 10, 4)
        p = project(c.reshape(1, 1, 1, 4).copy(), metric=q.reshape(1, 1, 1, 4)).ravel()
        assert 0 <= p[3] <= 1 and np.all(p[:3] >= 0) and np.all(p[:3] <= p[3] + 1e-12)
        cols = np.clip(c[None, :3], 0, grid[:, None])
        f = q[3] * (grid - c[3]) ** 2 + np.sum(q[:3] * (cols - c[:3]) ** 2, axis=1)
        assert np.sum(q * (p - c) ** 2) <= f.min() + 1e-9


# ----------------------------------------------------------------------------------------------------------
# The descent


def test_eq_a2_step_descends_by_the_preconditioned_gradient():
    # C3 alone on one cell: alpha <- alpha - eps1 (1 - 2 alpha) / (1 + eps2), hand-computed, then projected
    wp = Warper(Camera.from_positions([0.0]), [0.0], (1, 1))
    x = np.array([[[[0.1, 0.1, 0.1, 0.3]]]])
    out = refine(x, [0.0], np.zeros((1, 1, 1, 3)), wp, lambdas=(0, 0, 1), iterations=1, backtrack=False)
    alpha = 0.3 - 0.5 * (1 - 0.6) / (1 + 0.5)
    np.testing.assert_allclose(out.ravel(), [0.1, 0.1, 0.1, alpha])
    out2 = refine(x, [0.0], np.zeros((1, 1, 1, 3)), wp, lambdas=(0, 0, 1), iterations=40)
    assert out2[0, 0, 0, 3] == 0.0 and np.all(out2[..., :3] == 0.0)  # C3 drives it to 0, colour follows


def test_ground_truth_is_a_fixed_point_of_the_data_term(rng):
    stack, views, wp = dot_scene(rng)
    assert cost(stack.rgba, views, wp, lambdas=(1, 0, 0)) < 1e-10
    out = refine(stack.rgba, stack.disparities, views, wp, lambdas=(1, 0, 0), iterations=5)
    np.testing.assert_allclose(out, stack.rgba, atol=1e-6)


def test_refine_recovers_the_views_from_a_selection_like_start(rng):
    stack, views, wp = dot_scene(rng)
    init = selection_like_start(stack, views, rng)
    before = psnr(init, views, wp)
    history = []
    out = refine(init, stack.disparities, views, wp, iterations=150, history=history)
    after = psnr(out, views, wp)
    assert before.min() < 20
    assert after.min() > 45
    assert right_layer_fraction(out, stack) >= 0.98 > right_layer_fraction(init, stack)
    assert np.all(np.diff(history) <= 0)  # with backtracking, C never rises
    LayerStack(out, stack.disparities)  # premultiplied, alpha in [0, 1]


def test_paper_lambdas_descend_without_backtracking(rng):
    stack, views, wp = dot_scene(rng)
    init = selection_like_start(stack, views, rng)
    history = []
    refine(init, stack.disparities, views, wp, lambdas=(50, 1, 50), rho2="quadratic", warmup=0, iterations=40,
           backtrack=False, history=history)
    assert np.all(np.diff(history) <= 1e-9 * history[0])
    assert history[-1] < 0.2 * history[0]


def test_warmup_reaches_a_lower_full_cost(rng):
    stack, views, wp = dot_scene(rng)
    init = selection_like_start(stack, views, rng)
    cfg = RefineConfig(lambdas=(50, 1, 50), iterations=100)
    direct = refine(init, stack.disparities, views, wp, cfg, warmup=0)
    warm = refine(init, stack.disparities, views, wp, cfg, warmup=0.5)
    assert cost(warm, views, wp, cfg) < cost(direct, views, wp, cfg)


def test_progress_is_reported_every_step(rng):
    stack, views, wp = dot_scene(rng, 8, 8)
    calls = []
    refine(stack.rgba, stack.disparities, views, wp, iterations=4, progress=lambda *a: calls.append(a))
    assert calls == [("refine", i, 4) for i in range(1, 5)]


def test_refine_keeps_dtype_and_input(rng):
    stack, views, wp = dot_scene(rng, 8, 8)
    init = stack.rgba.copy()
    out = refine(init, stack.disparities, views, wp, iterations=3)
    assert out.dtype == np.float32 and np.array_equal(init, stack.rgba)
    assert refine(init, stack.disparities, views, wp, iterations=0).dtype == np.float32


def test_bad_input_raises(rng):
    stack, views, wp = dot_scene(rng, 8, 8)
    with pytest.raises(VfxStereoError, match="disparities"):
        refine(stack.rgba, stack.disparities + 1, views, wp)
    with pytest.raises(VfxStereoError, match="views"):
        refine(stack.rgba, stack.disparities, views[:2], wp)
    with pytest.raises(VfxStereoError, match="layers"):
        cost(stack.rgba[:2], views, wp)
    with pytest.raises(VfxStereoError, match="weights"):
        cost(stack.rgba, views, wp, view_weights=np.ones(2))
    for bad in [dict(lambdas=(1, -1, 0)), dict(rho1="cauchy"), dict(epsilon1=0), dict(iterations=-1),
                dict(warmup=2.0), dict(no_such_setting=1)]:
        with pytest.raises(VfxStereoError):
            RefineConfig().replace(**bad)


def test_gradient_through_the_general_homography_path_equals_the_shift_path(small):
    homography = pytest.importorskip("vfxstereo.homography")
    x, views, wp = small
    pos = wp.camera.positions[:, 0]
    M, M0 = homography.rectified_rig_matrices(pos, 0.0, wp.shape)
    general = Warper(Camera(positions=pos, reference=0.0, matrices=M, M0=M0), wp.disparities, wp.shape)
    settings = dict(lambdas=(50, 1, 50))
    g_shift, h_shift = gradient(x, views, wp, **settings)
    g_gen, h_gen = gradient(x, views, general, **settings)  # sparse matrices hold float32 weights
    np.testing.assert_allclose(g_gen, g_shift, atol=1e-5 * np.abs(g_shift).max())
    np.testing.assert_allclose(h_gen, h_shift, atol=1e-5 * np.abs(h_shift).max())
