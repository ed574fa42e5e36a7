"""Refinement of colours and opacities by preconditioned gradient descent (Section 6 and the Appendix).

The volume ``c(x, y, d) = [r g b alpha]`` (premultiplied) is adjusted to minimise

    C = lambda1 C1 + lambda2 C2 + lambda3 C3                                              (Eq. 13)

* C1 (Eq. 9), re-synthesis error: ``sum_k sum_(u,v) w_k(u, v) rho1(c~_k(u, v) - c_k(u, v))``, with
  ``c~_k`` the volume re-projected into view k and composited (Eqs. 5-8) and ``c_k`` the input view as RGBA
  with alpha 1 (input views are opaque). The error is a 4-vector and its alpha component counts: this is
  the paper's formulation (``e_k`` is ``[r g b alpha]``), and it pushes the composited coverage towards 1.
* C2 (Eq. 10), smoothness: ``sum_(x,y,d) sum_{(x',y',d') in N4(x,y,d)} rho2(c(x', y', d') - c(x, y, d))``
  with N4 the four neighbours in (x, y) at the same d (as the Appendix's gradient uses). The double sum
  runs over *ordered* pairs, exactly as written, so every unordered neighbour pair counts twice; cells
  outside the frame are not neighbours. With ``premultiplied_smoothness`` the pair term is Eq. (12)'s
  C2': ``rho2(alpha(x,y,d) c(x',y',d') - alpha(x',y',d') c(x,y,d))``, which compares straight colours
  without dividing by alpha; its alpha component is identically zero, so C2' smooths colour only.
* C3 (Eq. 11), opacity prior: ``sum phi(alpha)``, ``phi(alpha) = alpha (1 - alpha)``.

``rho1`` and ``rho2`` act on each channel separately: ``"quadratic"`` is ``rho(r) = r**2`` and
``"huber"`` is ``r**2`` for ``|r| <= s`` and ``2 s |r| - s**2`` beyond (same slope at ``s``; ``s`` is
``huber_scale`` in colour units, colours in [0, 1]).

Gradient and preconditioner (Appendix, with the corrections of docs/EQUATIONS.md)
--------------------------------------------------------------------------------
Writing ``a_k(d - 1)`` for the over-composite of the warped layers behind d
(:func:`vfxstereo.visibility.behind`), ``c~_k = sum_{d' > d} c_k(d') V_k(d') + V_k(d) (c_k(d) + (1 -
alpha_k(d)) a_k(d - 1))``, so ``dc~_k/d[rgb]_k(d) = V_k(d)`` and ``dc~_k/dalpha_k(d) = V_k(d) ([0 0 0 1] -
a_k(d - 1))`` -- the V_k(d) factor multiplies the ``a_k`` term too (finite differences confirm it). With
``psi = rho1'`` per channel (``2 e`` for quadratic), the gradient in view k's coordinates is

    g_k(d) = w_k V_k(d) (psi(e_k) - [0 0 0 psi(e_k) . a_k(d - 1)])

and it is taken back to disparity space with the exact transpose of the backward warp,
:meth:`Warper.to_view_adjoint`.

The paper's Hessian diagonal ``h_k = V_k [1 1 1 1 - ||a_k||^2]`` can be negative (``||a_k||^2`` reaches 4)
and is not the square of the derivative it says it is; the Gauss-Newton diagonal -- the squared derivative
of the residual, weighted by the secant ``omega = psi(r) / r`` (2 for quadratic, as the Appendix suggests
for robust penalties) -- is

    h_k(d) = w_k V_k(d)^2 [omega_r, omega_g, omega_b,
                           sum_rgb omega_m a_m(d - 1)^2 + omega_alpha (1 - a_alpha(d - 1))^2]  >= 0.

It goes back through the same adjoint warp, as in the paper (``W^T h``): for whole-pixel shifts that is
the exact Gauss-Newton diagonal; for bilinear shifts it is larger than the diagonal (``sum W^2 h``) and than
the row sum of ``W^T diag(h) W`` over the neighbouring cells the footprints couple -- a safe bound.
C2: ``g = 2 sum_N psi(c - c')``, ``h = 2 sum_N omega``; C2': the same through ``D``'s derivatives
(``dD/dc = -alpha'``, ``dD/dalpha = c'``). C3: ``g3 = [0 0 0 1 - 2 alpha]``, ``h3 = [0 0 0 1]`` (the true
second derivative is -2; the paper sets it positive).

The step is Eq. (A2) taken downhill (the extracted text's "+" would climb C):
``c <- c - epsilon1 g / (h + epsilon2)``, then each cell is put back into the feasible set alpha in [0, 1],
colour in [0, white * alpha] -- by the projection in the metric ``h + epsilon2`` rather than by clamping
(:func:`project` says why), and a step that raised C is retried at half the size (:func:`refine`).

What the test stereograms showed (colours in [0, 1], K = 5, eps1 = eps2 = 0.5)
------------------------------------------------------------------------------
* The paper's step alone, lambda = (1, 0, 0), oscillates (C rose on 48 of 100 steps): every layer of
  a pixel takes its own half Newton step on the same error. Backtracking fixes that at no cost when the
  step is good (lambda = (50, 1, 50) never rejected a step).
* With lambda1 = 50 and [0, 1] colours, h is ~ 100 per view and eps2 = 0.5 is negligible: the steps are
  half Gauss-Newton steps, independent of the colour scale. With lambda1 = 1, eps2 damps them by ~5 %.
* C3 with lambda3 = lambda1 freezes a poor start (holes and stray pixels stay, ~30 dB re-synthesis);
  a C1-only warm-up (``warmup``) ends at a lower full C and ~45-70 dB.
* Quadratic C2' on a random-dot texture biases colours (~36 dB at lambda = (50, 1, 50)); a Huber rho2
  keeps edges of the texture, hence the default. Quadratic C2' with lambda2 = lambda1 = 1 (Fig. 6(c))
  washes the texture out (~16 dB): C2' is zero for black or empty cells, so it pulls colour down.

Notes
-----
==============  ==================  ============================================================
array           shape               meaning
==============  ==================  ============================================================
``rgba``        (D, H, W, 4)        volume c(x, y, d), premultiplied, scene-linear, float32/64
``views``       (K, H, W, 3 or 4)   input views c_k(u, v); 3 channels get alpha = 1
``view_weights`` (K,) or (K, H, W)  w_k(u, v) of Eq. (9), in view coordinates; default 1
``g``, ``h``    (D, H, W, 4)        gradient and diagonal preconditioner of C
==============  ==================  ============================================================
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress, report
from vfxstereo.visibility import composite, reproject, visibility

PENALTIES = ("quadratic", "huber")
"""Names accepted for ``rho1`` and ``rho2``."""


@dataclass(frozen=True)
class RefineConfig:
    """Settings of the refinement stage; symbols as in Szeliski & Golland (1999), Section 6 and Appendix.

    Colours are in [0, 1] (scene-linear; ``white`` above 1 for HDR plates).
    """

    lambdas: tuple[float, float, float] = (50.0, 1.0, 50.0)
    """lambda_1, lambda_2, lambda_3 of Eq. (13): re-synthesis error, smoothness, opacity prior."""
    rho1: str = "quadratic"
    """Penalty of the re-synthesis error C1: "quadratic" or "huber" (per channel)."""
    rho2: str = "huber"
    """Penalty of the smoothness term C2 / C2': "quadratic" or "huber" (per channel)."""
    huber_scale: float = 0.05
    """Huber threshold s in colour units (both penalties)."""
    premultiplied_smoothness: bool = True
    """Use C2' (Eq. 12) instead of C2 (Eq. 10)."""
    epsilon1: float = 0.5
    """Step size epsilon_1 of Eq. (A2)."""
    epsilon2: float = 0.5
    """Stabiliser epsilon_2 of Eq. (A2)."""
    iterations: int = 100
    """Steps tried, each one evaluation of C and its gradient (rejected steps count)."""
    backtrack: bool = True
    """Reject a step that raised C and retry it at half the size (see :func:`refine`)."""
    warmup: float = 0.5
    """Fraction of the iterations spent on C1 alone (lambda2 = lambda3 = 0) before the full cost.

    Not in the paper (which gives no schedule): a continuation that keeps C3's 0/1 pull and the smoothness
    from freezing the selection's holes and stray pixels. On the test stereograms, given 80 or more
    iterations, it ends at a *lower* value of the full C than descending on it from the start (which
    stalls). 0 turns it off."""
    white: float = 1.0
    """Largest straight colour: colour is kept in [0, white * alpha] after each step."""

    def __post_init__(self):
        try:
            lam = tuple(float(v) for v in self.lambdas)
        except (TypeError, ValueError):
            raise VfxStereoError(f"lambdas must be three numbers, got {self.lambdas!r}") from None
        if len(lam) != 3 or any(not np.isfinite(v) or v < 0 for v in lam):
            raise VfxStereoError(f"lambdas must be three non-negative numbers, got {self.lambdas!r}")
        object.__setattr__(self, "lambdas", lam)
        for name in ("rho1", "rho2"):
            if getattr(self, name) not in PENALTIES:
                raise VfxStereoError(
                    f"{name} must be one of {', '.join(PENALTIES)}, got {getattr(self, name)!r}")
        for name in ("huber_scale", "epsilon1", "white"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise VfxStereoError(f"{name} must be a positive number, got {v!r}")
        if not (np.isfinite(self.epsilon2) and self.epsilon2 >= 0):
            raise VfxStereoError(f"epsilon2 must be a non-negative number, got {self.epsilon2!r}")
        if not (0.0 <= self.warmup <= 1.0):
            raise VfxStereoError(f"warmup must be a fraction in [0, 1], got {self.warmup!r}")
        if int(self.iterations) != self.iterations or self.iterations < 0:
            raise VfxStereoError(f"iterations must be a non-negative whole number, got {self.iterations!r}")
        object.__setattr__(self, "iterations", int(self.iterations))

    def replace(self, **changes) -> RefineConfig:
        """A copy with ``changes`` applied; unknown names raise VfxStereoError."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise VfxStereoError(f"unknown refinement setting(s): {', '.join(unknown)}")
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class CostTerms:
    """The terms of Eq. (13), unweighted, and the weighted total ``C``."""

    C1: float
    C2: float
    C3: float
    C: float


# ----------------------------------------------------------------------------------------------------------
# Penalties, per channel: value rho, derivative psi = rho', secant weight omega = psi / r.


def _rho(r: np.ndarray, kind: str, s: float) -> np.ndarray:
    if kind == "quadratic":
        return r * r
    a = np.abs(r)
    return np.where(a <= s, r * r, 2.0 * s * a - s * s)


def _psi(r: np.ndarray, kind: str, s: float) -> np.ndarray:
    if kind == "quadratic":
        return 2.0 * r
    return 2.0 * np.clip(r, -s, s)


def _omega(r: np.ndarray, kind: str, s: float) -> np.ndarray:
    if kind == "quadratic":
        return np.full_like(r, 2.0)
    a = np.abs(r)
    return 2.0 * s / np.maximum(a, s)


# ----------------------------------------------------------------------------------------------------------
# Input checks


def _as_config(config: RefineConfig | None, settings: dict) -> RefineConfig:
    cfg = config if config is not None else RefineConfig()
    if not isinstance(cfg, RefineConfig):
        raise VfxStereoError("config must be a vfxstereo.refine.RefineConfig")
    return cfg.replace(**settings) if settings else cfg


def _check_volume(rgba, warper) -> np.ndarray:
    x = np.asarray(rgba)
    if x.ndim != 4 or x.shape[-1] != 4:
        raise VfxStereoError(f"the volume must be (D, H, W, 4) RGBA, got shape {x.shape}")
    if not np.issubdtype(x.dtype, np.floating):
        raise VfxStereoError(f"the volume must be floating point, got {x.dtype}")
    if x.shape[0] != warper.D:
        raise VfxStereoError(f"the volume has {x.shape[0]} layers but the warper {warper.D} planes")
    if tuple(x.shape[1:3]) != tuple(warper.shape):
        raise VfxStereoError(f"the volume is {x.shape[1:3]} but the warper expects {tuple(warper.shape)}")
    return x


def _views_rgba(views, warper, dtype) -> np.ndarray:
    v = np.asarray(views)
    K, (H, W) = warper.K, warper.shape
    if v.ndim != 4 or v.shape[0] != K or tuple(v.shape[1:3]) != (H, W) or v.shape[3] not in (3, 4):
        raise VfxStereoError(f"views must be ({K}, {H}, {W}, 3 or 4), got shape {v.shape}")
    out = np.ones((K, H, W, 4), dtype=dtype)
    out[..., : v.shape[3]] = v
    return out


def _weights(view_weights, warper, dtype) -> np.ndarray | None:
    if view_weights is None:
        return None
    w = np.asarray(view_weights, dtype=dtype)
    K, (H, W) = warper.K, warper.shape
    if w.shape == (K,):
        w = np.broadcast_to(w[:, None, None], (K, H, W))
    if w.shape != (K, H, W):
        raise VfxStereoError(f"view weights must have shape ({K},) or ({K}, {H}, {W}), got {w.shape}")
    if not np.all(np.isfinite(w)) or w.min() < 0:
        raise VfxStereoError("view weights must be finite and non-negative")
    return w


# ----------------------------------------------------------------------------------------------------------
# The three terms: value, and (optionally) lambda times their gradient and diagonal added into g, h.
# The numpy functions ``_gh_layer_numpy`` and ``_smoothness_numpy`` are the references of the numba kernels in
# :mod:`vfxstereo._refine_kernels` (tests compare them); the solver uses the kernels.


def _gh_layer_numpy(psi, om, v, A, warped_d, out) -> None:
    """Reference of :func:`vfxstereo._refine_kernels.gh_layer`: [g_k(d), h_k(d)] into ``out``; advance A."""
    v2 = v * v
    out[..., :4] = psi * v[..., None]  # d c~/d[rgb] = V_k(d)
    out[..., 3] -= v * np.einsum("ijc,ijc->ij", psi, A)  # d c~/d alpha = V_k(d) ([0 0 0 1] - a_k(d-1))
    out[..., 4:7] = om[..., :3] * v2[..., None]  # Gauss-Newton diagonal, colour
    out[..., 7] = v2 * (np.einsum("ijc,ijc->ij", om[..., :3], A[..., :3] ** 2)
                        + om[..., 3] * (1.0 - A[..., 3]) ** 2)  # ... and opacity
    A *= 1.0 - warped_d[..., 3:4]  # over: a_k(d) = c_k(d) + (1 - alpha_k(d)) a_k(d - 1)
    A += warped_d


def _data_term(x, views4, warper, weights, kind, s, lam=1.0, g=None, h=None, *, kernels=True) -> float:
    """C1 (Eq. 9); with g, h: add lam times its gradient and Gauss-Newton diagonal (Appendix)."""
    D, H, W, _ = x.shape
    total = 0.0
    warped = np.empty_like(x)
    gh = np.empty((H, W, 8), dtype=x.dtype)
    A = np.empty((H, W, 4), dtype=x.dtype)
    layer = _kernels().gh_layer if kernels else _gh_layer_numpy
    for k in range(warper.K):
        reproject(x, warper, k, out=warped)  # Eq. (5)
        V = visibility(warped[..., 3])  # Eq. (7)
        e = composite(warped, V) - views4[k]  # Eq. (8); e_k = c~_k - c_k
        wk = None if weights is None else weights[k][..., None]
        r = _rho(e, kind, s)
        total += float(np.sum(r if wk is None else wk * r, dtype=np.float64))  # Eq. (9)
        if g is None:
            continue
        psi = _psi(e, kind, s) * lam
        om = _omega(e, kind, s) * lam
        if wk is not None:
            psi *= wk
            om *= wk
        psi = np.ascontiguousarray(psi, dtype=x.dtype)
        om = np.ascontiguousarray(om, dtype=x.dtype)
        A[...] = 0.0  # a_k(d - 1) for d = d_min: nothing behind
        for d in range(D):
            layer(psi, om, V[d], A, warped[d], gh)  # g_k(d), h_k(d) in view k; A becomes a_k(d)
            back = warper.to_view_adjoint(gh, k, d)  # transpose of W_b (Appendix)
            g[d] += back[..., :4]
            h[d] += back[..., 4:]
    return total


def _smoothness_numpy(x, kind, s, premultiplied, lam=1.0, g=None, h=None) -> float:
    """Reference of :func:`vfxstereo._refine_kernels.smoothness`: C2 (Eq. 10) or C2' (Eq. 12), N4, same d."""
    total = 0.0
    for axis in (1, 2):
        n = x.shape[axis]
        if n < 2:
            continue
        lo = [slice(None)] * 4
        hi = [slice(None)] * 4
        lo[axis] = slice(0, n - 1)
        hi[axis] = slice(1, n)
        lo, hi = tuple(lo), tuple(hi)
        ci, cj = x[lo], x[hi]  # each cell i and its neighbour j one step further along the axis
        if not premultiplied:
            r = cj - ci  # Eq. (10); ordered pairs: each unordered pair twice
            total += 2.0 * float(np.sum(_rho(r, kind, s), dtype=np.float64))
            if g is not None:
                p2 = 2.0 * lam * _psi(r, kind, s)
                o2 = 2.0 * lam * _omega(r, kind, s)
                g[hi] += p2
                g[lo] -= p2
                h[hi] += o2
                h[lo] += o2
        else:
            ai, aj = ci[..., 3:4], cj[..., 3:4]
            Dm = ai * cj[..., :3] - aj * ci[..., :3]  # Eq. (12); the alpha component is identically 0
            total += 2.0 * float(np.sum(_rho(Dm, kind, s), dtype=np.float64))
            if g is not None:
                p2 = 2.0 * lam * _psi(Dm, kind, s)
                o2 = 2.0 * lam * _omega(Dm, kind, s)
                g[hi][..., :3] += p2 * ai  # dD/dc_j = alpha_i
                g[lo][..., :3] -= p2 * aj  # dD/dc_i = -alpha_j
                g[lo][..., 3] += np.sum(p2 * cj[..., :3], axis=-1)  # dD/dalpha_i = c_j
                g[hi][..., 3] -= np.sum(p2 * ci[..., :3], axis=-1)  # dD/dalpha_j = -c_i
                h[hi][..., :3] += o2 * ai * ai
                h[lo][..., :3] += o2 * aj * aj
                h[lo][..., 3] += np.sum(o2 * cj[..., :3] ** 2, axis=-1)
                h[hi][..., 3] += np.sum(o2 * ci[..., :3] ** 2, axis=-1)
    return total


def _smoothness_term(x, kind, s, premultiplied, lam=1.0, g=None, h=None, *, kernels=True) -> float:
    """C2 / C2' through the numba kernel (or the numpy reference)."""
    if not kernels:
        return _smoothness_numpy(x, kind, s, premultiplied, lam, g, h)
    want = g is not None
    if not want:
        g = h = np.zeros((1, 1, 1, 4), dtype=x.dtype)  # unused
    return float(_kernels().smoothness(np.ascontiguousarray(x), kind == "huber", float(s),
                                       bool(premultiplied), float(lam), g, h, want))


def _opacity_term(x, lam=1.0, g=None, h=None) -> float:
    """C3 (Eq. 11), phi(alpha) = alpha (1 - alpha); g3 = 1 - 2 alpha, h3 = 1 (Appendix)."""
    a = x[..., 3]
    total = float(np.sum(a * (1.0 - a), dtype=np.float64))  # Eq. (11)
    if g is not None:
        g[..., 3] += lam * (1.0 - 2.0 * a)
        h[..., 3] += lam
    return total


def _kernels():
    from vfxstereo import _refine_kernels

    return _refine_kernels


def _evaluate(x, views4, warper, weights, cfg: RefineConfig, want_gradient: bool, *, kernels: bool = True):
    """Cost terms and, if wanted, the combined gradient g and preconditioner h (Appendix)."""
    l1, l2, l3 = cfg.lambdas
    g = np.zeros_like(x) if want_gradient else None
    h = np.zeros_like(x) if want_gradient else None
    # g = lambda1 sum_k g1 + lambda2 g2 + lambda3 g3, h likewise; a term whose lambda is 0 is skipped
    c1 = _data_term(x, views4, warper, weights, cfg.rho1, cfg.huber_scale, l1, g, h, kernels=kernels) \
        if l1 else 0.0
    c2 = _smoothness_term(x, cfg.rho2, cfg.huber_scale, cfg.premultiplied_smoothness, l2, g, h,
                          kernels=kernels) if l2 else 0.0
    c3 = _opacity_term(x, l3, g, h) if l3 else 0.0
    return CostTerms(c1, c2, c3, l1 * c1 + l2 * c2 + l3 * c3), g, h  # Eq. (13)


# ----------------------------------------------------------------------------------------------------------
# Public API


def cost_terms(rgba, views, warper, config: RefineConfig | None = None, *, view_weights=None,
               **settings) -> CostTerms:
    """The terms C1, C2 (or C2'), C3 of Eqs. (9)-(12), unweighted, and the total C of Eq. (13).

    Terms whose lambda is 0 are not computed and reported as 0.

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied RGBA volume (float32 or float64; the arithmetic follows its dtype).
    views : ndarray of shape (K, H, W, 3) or (K, H, W, 4)
        Input views; RGB views are given alpha 1.
    warper : vfxstereo.warp.Warper
        Plane/view warps of the rig.
    config : RefineConfig, optional
        Settings (lambdas, penalties, C2 or C2'); ``settings`` override its fields.
    view_weights : array_like of shape (K,) or (K, H, W), optional
        w_k(u, v) of Eq. (9), in view coordinates.

    Returns
    -------
    CostTerms
    """
    cfg = _as_config(config, settings)
    x = _check_volume(rgba, warper)
    return _evaluate(x, _views_rgba(views, warper, x.dtype), warper, _weights(view_weights, warper, x.dtype),
                     cfg, want_gradient=False)[0]


def cost(rgba, views, warper, config: RefineConfig | None = None, *, view_weights=None, **settings) -> float:
    """Total cost ``C = lambda1 C1 + lambda2 C2 + lambda3 C3`` (Eq. 13); see :func:`cost_terms`."""
    return cost_terms(rgba, views, warper, config, view_weights=view_weights, **settings).C


def gradient(rgba, views, warper, config: RefineConfig | None = None, *, view_weights=None,
             **settings) -> tuple[np.ndarray, np.ndarray]:
    """Gradient of C (Eq. 13) w.r.t. every cell and the diagonal preconditioner of Eq. (A2).

    Parameters are those of :func:`cost_terms`.

    Returns
    -------
    g : ndarray of shape (D, H, W, 4)
        Exact gradient of :func:`cost` (the dtype of ``rgba``).
    h : ndarray of shape (D, H, W, 4)
        Non-negative diagonal preconditioner: Gauss-Newton diagonal of C1 through the adjoint warp (exact
        for whole-pixel shifts, the absolute row sum otherwise), ``2 sum_N omega`` for C2 / C2', 1 on alpha
        for C3; each weighted by its lambda.
    """
    cfg = _as_config(config, settings)
    x = _check_volume(rgba, warper)
    _, g, h = _evaluate(x, _views_rgba(views, warper, x.dtype), warper,
                        _weights(view_weights, warper, x.dtype), cfg, want_gradient=True)
    return g, h


def _project_numpy(x, q, white):
    """Reference of :func:`vfxstereo._refine_kernels.project_weighted` (same result, vectorised)."""
    c, a = x[..., :3], x[..., 3]
    order = np.argsort(-c, axis=-1, kind="stable")
    cs = np.take_along_axis(c, order, axis=-1)
    qs = np.take_along_axis(q[..., :3], order, axis=-1)
    num = q[..., 3] * a
    den = q[..., 3].copy()
    a_new = np.full(a.shape, np.nan, dtype=x.dtype)
    for n in range(4):  # n channels on their upper bound white * a'
        if n:
            num = num + white * qs[..., n - 1] * cs[..., n - 1]
            den = den + white * white * qs[..., n - 1]
        with np.errstate(invalid="ignore", divide="ignore"):
            cand = num / den
        ok = np.isnan(a_new) & (den > 0)
        if n < 3:
            ok &= cs[..., n] <= white * cand
        a_new = np.where(ok, cand, a_new)
    a_new = np.where(np.isnan(a_new), a, a_new)
    x[..., 3] = np.clip(a_new, 0.0, 1.0)
    np.clip(c, 0.0, white * x[..., 3:4], out=c)
    return x


def project(rgba: np.ndarray, *, white: float = 1.0, metric: np.ndarray | None = None) -> np.ndarray:
    """Move every cell, in place, to the nearest feasible value: alpha in [0, 1], colour in [0, white alpha].

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied RGBA, modified in place and returned.
    white : float
        Largest straight colour.
    metric : ndarray of shape (D, H, W, 4), optional
        Positive per-channel weights ``q`` of the distance ``sum q (c' - c)^2``; the refinement passes
        ``h + epsilon2`` so the projected step is the minimiser of its own quadratic model (a descent
        direction). ``None`` is Euclidean distance.

    Notes
    -----
    Plain clamping (alpha first, then colour to [0, alpha]) is not a projection in any metric: where the
    colour sits on its bound ``alpha`` and the gradient lowers alpha, it drags the colour down too, against
    the gradient. Steps clamped that way can raise C however small they are; measured, the paper's step
    then stalls with the step size backtracked to ~1e-9. The metric projection decides jointly whether to
    lower the colour or to raise alpha.
    """
    x = rgba
    q = np.ones_like(x) if metric is None else np.ascontiguousarray(metric, dtype=x.dtype)
    if x.flags.c_contiguous:
        _kernels().project_weighted(x, q, float(white))
    else:  # pragma: no cover - callers pass contiguous arrays
        _project_numpy(x, q, float(white))
    return x


_GROW = 1.1  # growth of the step after an accepted one (measured: 1.0-1.25 equally good, 2.0 wastes steps)


def refine(rgba, disparities, views, warper, config: RefineConfig | None = None, *, view_weights=None,
           progress: Progress | None = None, history: list | None = None, **settings) -> np.ndarray:
    """Refine colours and opacities by preconditioned gradient descent on C (Eq. 13, step Eq. A2).

    From the current volume c with gradient g and preconditioner h, a step tries
    ``c' = P(c - epsilon g / (h + epsilon2))`` (Eq. A2, downhill), where P moves each cell to the nearest
    feasible value (alpha in [0, 1], colour in [0, white * alpha]) in the metric ``h + epsilon2``
    (:func:`project`). ``epsilon`` starts at ``epsilon1``. With ``backtrack``, a step that raised C is
    rejected and retried from c with half the epsilon; after an accepted step epsilon grows by 10 % (up to
    ``epsilon1``). C therefore never increases, and the volume returned is the last accepted one.

    With ``warmup > 0`` (and lambda2 or lambda3 non-zero) the first ``round(warmup * iterations)`` steps
    descend on lambda1 C1 alone, the rest on the full C (a continuation; see :class:`RefineConfig`).

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Initial premultiplied RGBA volume (e.g. from selection); not modified. float32 or float64.
    disparities : array_like of shape (D,)
        The planes' disparities; must be those of ``warper``.
    views : ndarray of shape (K, H, W, 3) or (K, H, W, 4)
        Input views, scene-linear; RGB views are given alpha 1.
    warper : vfxstereo.warp.Warper
        Plane/view warps of the rig.
    config : RefineConfig, optional
        Settings; keyword ``settings`` (``lambdas=``, ``rho1=``, ``iterations=`` ...) override its fields.
    view_weights : array_like of shape (K,) or (K, H, W), optional
        w_k(u, v) of Eq. (9), in view coordinates.
    progress : callable, optional
        ``progress("refine", done, total)`` after every step (accepted or not).
    history : list, optional
        If given, the full cost C (Eq. 13) is appended for the volume the full-cost phase starts from and
        for every step it accepts (warm-up steps are not recorded): non-increasing with ``backtrack``.

    Returns
    -------
    ndarray of shape (D, H, W, 4), premultiplied RGBA, the dtype of ``rgba``.

    Raises
    ------
    VfxStereoError
        On shapes that do not fit the warper, disparities that differ from it, or bad settings.
    """
    cfg = _as_config(config, settings)
    x = np.array(_check_volume(rgba, warper), order="C", copy=True)
    disp = np.asarray(disparities, dtype=np.float64).reshape(-1)
    if disp.shape != warper.disparities.shape or not np.allclose(disp, warper.disparities):
        raise VfxStereoError("the disparities differ from the warper's planes")
    views4 = _views_rgba(views, warper, x.dtype)
    weights = _weights(view_weights, warper, x.dtype)
    project(x, white=cfg.white)
    n = cfg.iterations
    l1, l2, l3 = cfg.lambdas
    n_warm = int(round(cfg.warmup * n)) if (l1 > 0 and (l2 > 0 or l3 > 0)) else 0
    done = 0
    if n_warm:  # continuation: C1 alone first, then the full cost from there
        x = _descend(x, views4, warper, weights, cfg.replace(lambdas=(l1, 0.0, 0.0)), n_warm, 0, n,
                     progress, None)
        done = n_warm
    if n - done > 0:
        x = _descend(x, views4, warper, weights, cfg, n - done, done, n, progress, history)
    return x


def _descend(x, views4, warper, weights, cfg, steps, done, total, progress, history):
    """``steps`` preconditioned, projected, backtracked steps on the cost of ``cfg``, from ``x`` (kept)."""
    terms, g, q = _evaluate(x, views4, warper, weights, cfg, want_gradient=True)
    c_now = terms.C
    if history is not None:
        history.append(c_now)
    q += cfg.epsilon2  # the metric of the step: h + epsilon2
    trial = np.empty_like(x)
    eps = cfg.epsilon1
    for it in range(steps):
        np.divide(g, q, out=trial)
        trial *= -eps
        trial += x  # Eq. (A2), descending: c - epsilon1 g / (h + epsilon2)
        project(trial, white=cfg.white, metric=q)
        terms, g_new, h_new = _evaluate(trial, views4, warper, weights, cfg, want_gradient=True)
        if cfg.backtrack and terms.C > c_now:
            eps *= 0.5  # the step raised C: retry it from the accepted volume, half as long
        else:
            x, trial = trial, x
            g, q = g_new, h_new
            q += cfg.epsilon2
            c_now = terms.C
            eps = min(cfg.epsilon1, _GROW * eps)
            if history is not None:
                history.append(c_now)
        report(progress, "refine", done + it + 1, total)
    return x
