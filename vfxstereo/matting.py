"""Edge matting: colour and opacity of soft edges by per-pixel least squares against the background.

A stage past Szeliski & Golland (1999) that runs on a solved volume (after Section 6's refinement or instead
of it) and re-solves the cells where matting matters: the soft-edge band around the depth discontinuities of
the front surface (hair, fur, motion blur, anti-aliasing).

The physics (docs/EQUATIONS.md, "What decides soft-edge quality")
--------------------------------------------------------------------
A reference pixel p whose front surface lies on plane f with premultiplied colour C = alpha F and opacity
alpha is seen by view k at ``u = p - d_f (p_k - p_ref)``, where the view records

    I_k(u) = T_k(u) + V_k(u, f) (C + (1 - alpha) A_k(u, f))

with ``T_k`` the composite of the layers in front of f (Eq. 8 restricted to d > f), ``V_k(u, f)`` their
transmittance (Eq. 7) and ``A_k(u, f) = a_k(u, f - 1)`` the over-composite of the layers behind f warped into
view k (:func:`vfxstereo.visibility.behind`): the background B_k that view k sees *through* p. Given the
background, that is linear in ``x = [C, alpha]``: three equations per view (and a fourth for the opacity of
the opaque views, ``1 = T_alpha + V (alpha + (1 - alpha) A_alpha)``), so 4 unknowns and 3K (4K) equations
per pixel, solved from their 4 x 4 normal equations (:func:`normal_equations`, :func:`solve_cells`). C and
alpha separate only where ``A_k`` differs between views (:func:`parallax`); a Tikhonov term towards the
current cell keeps the solve at the input where it does not.

Everything is won or lost on the background. It is re-estimated on the back planes behind the band as the
least-squares colour the views show *through the current front*: for a back cell q on plane b,
``I_k = T_k + V_k(b) Bg(q)``, so ``Bg = sum_k V_k (I_k - T_k) / sum_k V_k^2`` with ``V_k(b)`` the
visibility of plane b in view k (Eq. 7) -- views that see q unoccluded count fully, views that see it
through hair count by their transmittance, views that do not see it not at all. The first estimate treats
the band's front cells at the discontinuities as opaque (only views clear of the edge count); then the
background and the front are solved in turn (block coordinate descent on the re-synthesis error, i.e. C1 of
Eq. 9 restricted to the band and its background), with over-relaxation.

Measured (``samples.matting_scene``, the six hair/fur images of benchmarks/zkey_edges.py at scale 0.4, K = 5,
element at D = 2, full-frame card; ``python benchmarks/zkey_edges.py --matting``), band PSNR of the z-key
comp, mean over the scenes: from the ``paper`` preset's stack 17.3 -> 24.8 dB, from the ground truth with its
alpha hardened at 0.5 23.0 -> 28.3 dB; the hard matte cut from the true depth scores 23.3 dB. With the true
background given instead of estimated, the solve recovers the band's alpha to within 1e-5 on a textured
two-layer scene (tests/test_matting.py). About 2-3 s per 320 x 225 scene (D = 5); ~1 s per iteration at
450 x 317 with D = 64 when the band covers the whole frame.

Steps of :func:`matte_edges`
----------------------------
1. :func:`edge_band`: per pixel the *surface* (front-most layer with alpha > 0.5) and the *soft front*
   (front-most layer with alpha > 0.02); the front plane f of a pixel is the nearest soft front within
   ``radius`` px, the back plane b the farthest surface within ``radius`` px; the band is where f > b.
2. In the band, cells strictly between b and f are cleared (the selection's mixed pixels put there), the back
   cells seen through the band (in any view) are made opaque.
3. Background on the back planes from the views, visibility-weighted (above).
4. Per band pixel, the 4 x 4 normal equations over the views, regularised, solved in one batched
   ``np.linalg.solve``; alpha clamped to [0, 1], colour re-solved for the clamped alpha, then clamped to
   [0, white * alpha].
5. Repeat 3-4 ``iterations`` times; steps after the first are over-relaxed by ``relaxation``.

Notes
-----
==============  ==================  ===========================================================
array           shape               meaning
==============  ==================  ===========================================================
``rgba``        (D, H, W, 4)        volume c(x, y, d), premultiplied, scene-linear (reference view)
``views``       (K, H, W, 3)        input views c_k(u, v), scene-linear, opaque
``I, T, A``     (K, N, 3 / 4 / 4)   per band cell and view: view colour, composite in front, behind
``V, w``        (K, N)              transmittance of the layers in front; weight of the view
``M, r``        (N, 4, 4), (N, 4)   normal equations for ``x = [C_r, C_g, C_b, alpha]`` (premultiplied)
==============  ==================  ===========================================================

Limits
------
* A background no view sees clearly (behind a wide, nearly opaque semi-transparent surface: GT16's flag)
  is unmixed from what shows through, and the alternation can settle on "no foreground, foreground-coloured
  background"; there the result can be worse than a hard matte (GT16 from the ``paper`` stack: 13.4 ->
  17.2 dB against 26.5 dB).
* Over a flat background alpha is not observed; a background estimate polluted by unresolved foreground
  (strands the input missed) then drives alpha wrong (a flat synthetic scene: mean alpha error 0.22 ->
  0.55). ``flat_regularisation`` guards against it (0.22 -> 0.17) but is off by default: it also keeps a
  solved stack's holes in opaque surfaces, which costs more on the benchmark (from the ``paper`` stack
  21.0 dB with it, 24.8 dB without; from the hardened ground truth 28.6 against 28.3 dB).
* The back plane of a band pixel is the farthest surface within ``radius``: a third surface between front
  and back is cleared there. The per-pixel model ignores the bilinear footprint of fractional shifts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vfxstereo.errors import VfxStereoError
from vfxstereo.layers import topmost
from vfxstereo.progress import Progress, report

EMPTY_ALPHA = 0.02
"""A cell with alpha above this holds something: it can be the soft front of its pixel."""
SOLID_ALPHA = 0.5
"""A cell with alpha above this is a surface: the front-most one is the pixel's surface (as disparity_map)."""
RADIUS = 16
"""Half-width of the band around the depth discontinuities, px (2 x the largest parallax of the benchmark)."""
ITERATIONS = 16
"""Background / front alternations."""
REGULARISATION = 1e-4
"""Tikhonov weight towards the current cell, relative to the weight of one view's equation."""
BACKGROUND_PRIOR = 0.01
"""Weight of the spatial fill in the background estimate, relative to one unoccluded view."""
FLAT_VARIATION = 1e-4
"""Variation of the views through a cell below which the flat-background guard holds alpha (colour^2)."""
RELAXATION = 1.5
"""Over-relaxation of the alternation after the first pass (1 = plain alternation)."""


# --------------------------------------------------------------------------------------------------------
# Per-pixel normal equations


def view_rows(I, T, V, A, *, alpha_weight: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """One view's equations ``J x = y`` for the unknowns ``x = [C_r, C_g, C_b, alpha]`` of N cells.

    Colour rows ``V C - alpha V A_rgb = I - T_rgb - V A_rgb`` and the opacity row
    ``sqrt(alpha_weight) V (1 - A_alpha) alpha = sqrt(alpha_weight) (1 - T_alpha - V A_alpha)``, from
    ``I = T + V (C + (1 - alpha) A)`` (the over operator, Eq. 8).

    Parameters
    ----------
    I : ndarray of shape (N, 3)
        The view's colour at the cell.
    T : ndarray of shape (N, 4)
        Premultiplied composite of the layers in front of the cell's plane.
    V : ndarray of shape (N,)
        Their transmittance (Eq. 7).
    A : ndarray of shape (N, 4)
        Premultiplied composite of the layers behind the cell's plane.
    alpha_weight : float
        Weight of the opacity row (the views are opaque: their alpha is 1).

    Returns
    -------
    J : ndarray of shape (N, 4, 4), float64
    y : ndarray of shape (N, 4), float64
    """
    V = np.asarray(V, np.float64)
    A = np.asarray(A, np.float64)
    T = np.asarray(T, np.float64)
    n = V.shape[0]
    sw = np.sqrt(float(alpha_weight))
    J = np.zeros((n, 4, 4), np.float64)
    for c in range(3):
        J[:, c, c] = V
        J[:, c, 3] = -V * A[:, c]
    J[:, 3, 3] = sw * V * (1.0 - A[:, 3])
    y = np.empty((n, 4), np.float64)
    y[:, :3] = np.asarray(I, np.float64) - T[:, :3] - V[:, None] * A[:, :3]
    y[:, 3] = sw * (1.0 - T[:, 3] - V * A[:, 3])
    return J, y


def normal_equations(I, T, V, A, w, *, alpha_weight: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Normal equations ``M x = r`` of the weighted least squares over K views (see :func:`view_rows`).

    Parameters
    ----------
    I, T, V, A : ndarrays of shape (K, N, 3), (K, N, 4), (K, N), (K, N, 4)
        Per view, as :func:`view_rows`.
    w : ndarray of shape (K, N)
        Weight of each view's rows (0 where the view does not see the cell).

    Returns
    -------
    M : ndarray of shape (N, 4, 4), float64, symmetric positive semi-definite
    r : ndarray of shape (N, 4), float64
    """
    I, T, V, A, w = (np.asarray(a) for a in (I, T, V, A, w))
    if V.ndim != 2 or I.shape != V.shape + (3,) or T.shape != V.shape + (4,) or A.shape != V.shape + (4,) \
            or w.shape != V.shape:
        raise VfxStereoError(f"normal_equations: inconsistent shapes I {I.shape}, T {T.shape}, V {V.shape}, "
                             f"A {A.shape}, w {w.shape}")
    n = V.shape[1]
    M = np.zeros((n, 4, 4), np.float64)
    r = np.zeros((n, 4), np.float64)
    for k in range(V.shape[0]):
        _accumulate(M, r, I[k], T[k], V[k], A[k], w[k], alpha_weight)
    return M, r


def _accumulate(M, r, I, T, V, A, w, alpha_weight) -> None:
    """``M += sum w J^T J``, ``r += sum w J^T y`` for one view, written out (J of :func:`view_rows`)."""
    V = np.asarray(V, np.float64)
    A = np.asarray(A, np.float64)
    T = np.asarray(T, np.float64)
    w = np.asarray(w, np.float64)
    wv2 = w * V * V
    y = np.asarray(I, np.float64) - T[:, :3] - V[:, None] * A[:, :3]
    ya = 1.0 - T[:, 3] - V * A[:, 3]
    oa = 1.0 - A[:, 3]
    for c in range(3):
        M[:, c, c] += wv2
        M[:, c, 3] -= wv2 * A[:, c]
        M[:, 3, c] -= wv2 * A[:, c]
        r[:, c] += w * V * y[:, c]
    M[:, 3, 3] += wv2 * ((A[:, :3] ** 2).sum(-1) + alpha_weight * oa * oa)
    r[:, 3] += w * V * (alpha_weight * oa * ya - (A[:, :3] * y).sum(-1))


def parallax(M: np.ndarray) -> np.ndarray:
    """How well the views fix alpha once colour is free: the Schur complement of the colour block of M.

    For the colour rows alone it is ``sum_k w_k V_k^2 |A_k - mean A|^2`` (weighted mean): zero where every
    view sees the same background through the pixel (alpha and colour then trade off freely).

    Parameters
    ----------
    M : ndarray of shape (N, 4, 4)
        Normal matrices of :func:`normal_equations` (colour block ``m I3``).

    Returns
    -------
    ndarray of shape (N,), float64, >= 0 up to rounding.
    """
    m = M[:, 0, 0]
    safe = np.where(m > 1e-12, m, 1.0)
    return np.where(m > 1e-12, M[:, 3, 3] - (M[:, 3, :3] ** 2).sum(-1) / safe, 0.0)


def solve_cells(M, r, x0, *, regularisation: float = REGULARISATION, white: float = 1.0) -> np.ndarray:
    """Solve ``(M + lam I) x = r + lam x0`` per cell and project onto the feasible set.

    alpha is clamped to [0, 1]; the colour is then re-solved for the clamped alpha (the colour block of M
    is diagonal) and clamped to [0, white * alpha].

    Parameters
    ----------
    M : ndarray of shape (N, 4, 4)
    r : ndarray of shape (N, 4)
    x0 : ndarray of shape (N, 4)
        Current premultiplied ``[C, alpha]``; the Tikhonov term pulls towards it.
    regularisation : float or ndarray of shape (N,) or (N, 4)
        ``lam``, relative to the weight of one view's rows. Must be > 0 where M is singular.
    white : float
        Largest straight colour.

    Returns
    -------
    ndarray of shape (N, 4), float64.
    """
    M = np.asarray(M, np.float64)
    r = np.asarray(r, np.float64)
    x0 = np.asarray(x0, np.float64)
    lam = np.asarray(regularisation, np.float64)
    if lam.ndim == 1:
        lam = lam[:, None]
    lam = np.broadcast_to(lam, x0.shape)
    Mr = M.copy()
    idx = np.arange(4)
    Mr[:, idx, idx] += lam
    rr = r + lam * x0
    x = np.linalg.solve(Mr, rr[..., None])[..., 0]
    alpha = np.clip(x[:, 3], 0.0, 1.0)
    diag = Mr[:, idx[:3], idx[:3]]
    colour = (rr[:, :3] - Mr[:, :3, 3] * alpha[:, None]) / np.where(diag > 1e-12, diag, 1.0)
    colour = np.clip(colour, 0.0, white * alpha[:, None])
    return np.concatenate([colour, alpha[:, None]], axis=1)


# --------------------------------------------------------------------------------------------------------
# The band


@dataclass
class EdgeBand:
    """Where :func:`matte_edges` works.

    Attributes
    ----------
    mask : ndarray of shape (H, W), bool
        The band.
    front : ndarray of shape (H, W), int
        Per pixel, the plane index of the front layer to solve (meaningful in the band).
    back : ndarray of shape (H, W), int
        Per pixel, the plane index of the background behind it.
    surface : ndarray of shape (H, W), int
        Front-most layer with alpha > :data:`SOLID_ALPHA` (else the most visible layer).
    """

    mask: np.ndarray
    front: np.ndarray
    back: np.ndarray
    surface: np.ndarray


def _window(radius: int) -> np.ndarray:
    return np.ones((2 * radius + 1, 2 * radius + 1), bool)


def edge_band(rgba: np.ndarray, *, radius: int = RADIUS) -> EdgeBand:
    """The soft-edge band of a volume and, per pixel, the front and back planes to matte between.

    ``surface``: the front-most layer with alpha > 0.5 (else the most visible one, Eq. 7 weights);
    ``soft``: the front-most layer with alpha > 0.02 (else ``surface``). ``front`` = the largest ``soft`` and
    ``back`` = the smallest ``surface`` within a (2 radius + 1)^2 window; the band is where front > back.

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied volume.
    radius : int
        Half-width of the window, px.

    Returns
    -------
    EdgeBand
    """
    alpha = np.asarray(rgba)[..., 3]
    transmit = np.ones(alpha.shape[1:], np.float32)
    weights = np.empty(alpha.shape, np.float32)
    for i in range(alpha.shape[0] - 1, -1, -1):  # Eq. (7): visible contribution of each layer
        weights[i] = alpha[i] * transmit
        transmit = transmit * (1.0 - alpha[i])
    surface = topmost(alpha > SOLID_ALPHA, np.argmax(weights, axis=0))
    soft = topmost(alpha > EMPTY_ALPHA, surface)
    if radius > 0:
        front = ndimage.grey_dilation(soft, footprint=_window(radius))
        back = ndimage.grey_erosion(surface, footprint=_window(radius))
    else:
        front, back = soft, surface
    return EdgeBand(mask=front > back, front=front, back=back, surface=surface)


# --------------------------------------------------------------------------------------------------------
# Sampling the volume in one view, gathered at the cells being solved


def _inside(warper, k: int, planes) -> np.ndarray:
    """(H, W) bool in view k's coordinates: the pixel's rays through every plane in ``planes`` are in frame."""
    ones = np.ones(warper.shape, np.float32)
    w = np.ones(warper.shape, np.float32)
    for i in planes:
        np.minimum(w, warper.to_view(ones, k, i), out=w)
    return w > 1.0 - 1e-6


def _occupied(vol) -> np.ndarray:
    """(D,) bool: layers holding any opacity (empty layers add nothing to a composite)."""
    return vol[..., 3].reshape(vol.shape[0], -1).max(axis=1) > 0


def _gather_front(vol, warper, k, *cell_sets, lowest: int, occupied=None):
    """What lies in front of each plane in view k, gathered at the cells of each ``cells`` dict.

    ``T`` is the composite of the layers in front of plane d (Eq. 8 over d' > d) and ``V`` their
    transmittance (Eq. 7), both resampled onto plane d and gathered at ``cells[d] = (rows, cols)``.
    Returns one dict plane -> (T (n, 4), V (n,)) per cell set. Layers below ``lowest`` are not visited.
    """
    D = vol.shape[0]
    occupied = _occupied(vol) if occupied is None else occupied
    T = np.zeros(vol.shape[1:], np.float32)
    V = np.ones(vol.shape[1:3], np.float32)
    outs = [{} for _ in cell_sets]
    for d in range(D - 1, lowest - 1, -1):
        for cells, out in zip(cell_sets, outs, strict=True):
            if d in cells:
                cy, cx = cells[d]
                out[d] = (warper.to_plane(T, k, d)[cy, cx], warper.to_plane(V, k, d)[cy, cx])
        if d == lowest:
            break
        if occupied[d]:
            layer = warper.to_view(vol[d], k, d)  # Eq. (5)
            T += V[..., None] * layer  # Eq. (8)
            V *= 1.0 - layer[..., 3]  # Eq. (7)
    return outs


def _gather_behind(vol, warper, k, cells, *, occupied=None):
    """What lies behind each plane in view k, gathered at ``cells[d] = (rows, cols)``.

    ``A = a_k(d - 1)``, the over-composite of the layers behind d (:func:`vfxstereo.visibility.behind`),
    resampled onto plane d. Returns a dict plane -> A (n, 4).
    """
    occupied = _occupied(vol) if occupied is None else occupied
    A = np.zeros(vol.shape[1:], np.float32)
    out = {}
    for d in range(0, max(cells) + 1):
        if d in cells:
            cy, cx = cells[d]
            out[d] = warper.to_plane(A, k, d)[cy, cx]
        if occupied[d]:
            layer = warper.to_view(vol[d], k, d)  # Eq. (5)
            A = layer + (1.0 - layer[..., 3:4]) * A  # over
    return out


# --------------------------------------------------------------------------------------------------------
# The two half-steps


def _solve_background(vol, views, warper, back, samples, *, prior, white, relax, inside):
    """Re-estimate the colour of the back cells (plane -> (rows, cols)) from the views, in place.

    ``samples[k][b] = (T, V)``: composite and transmittance of the layers in front of plane b in view k at
    the back cells (:func:`_gather_front`).
    """
    K = views.shape[0]
    for b, (cy, cx) in back.items():
        Y = np.empty((K, cy.size, 3), np.float64)
        V = np.empty((K, cy.size), np.float64)
        w = np.empty((K, cy.size), np.float64)
        for k in range(K):
            T, Vk = samples[k][b]
            Y[k] = warper.to_plane(views[k], k, b)[cy, cx] - T[:, :3]  # I = T + V Bg
            V[k] = Vk
            w[k] = inside[k][b][cy, cx]
        num = ((w * V)[..., None] * Y).sum(0)  # least squares over the views
        den = (w * V * V).sum(0)
        mask = np.zeros(vol.shape[1:3], bool)
        mask[cy, cx] = True
        seen = np.zeros(mask.shape, bool)
        seen[cy, cx] = den > 0.5
        estimate = vol[b, ..., :3].astype(np.float64)
        estimate[cy, cx] = np.where((den > 0.5)[:, None], num / np.maximum(den, 1e-12)[:, None],
                                    estimate[cy, cx])
        valid = seen | (~mask & (vol[b, ..., 3] > 0.99))
        if valid.any():  # where no view sees it clearly: the nearest clearly seen background
            iy, ix = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
            fill = estimate[iy[cy, cx], ix[cy, cx]]
        else:
            fill = estimate[cy, cx]
        colour = (num + prior * fill) / (den + prior)[:, None]
        if relax != 1.0:
            colour = vol[b, cy, cx, :3] + relax * (colour - vol[b, cy, cx, :3])
        vol[b, cy, cx, :3] = np.clip(colour, 0.0, white)
        vol[b, cy, cx, 3] = 1.0


def _front_system(vol, views, warper, groups, cells, samples, *, alpha_weight, inside):
    """Normal equations of every band cell from all views, and how much the views differ through it.

    ``samples[k][f] = (T, V)`` at the band cells of plane f (:func:`_gather_front`). Returns M (N, 4, 4),
    r (N, 4) and the variation (N,) ``sum_k w_k |y_k - mean y|^2`` of ``y_k = I_k - T_k``.
    """
    n = sum(g.size for g in groups.values())
    M = np.zeros((n, 4, 4), np.float64)
    r = np.zeros((n, 4), np.float64)
    s0 = np.zeros(n, np.float64)
    s1 = np.zeros((n, 3), np.float64)
    s2 = np.zeros(n, np.float64)
    occupied = _occupied(vol)
    for k in range(views.shape[0]):
        behind = _gather_behind(vol, warper, k, cells, occupied=occupied)
        for f, g in groups.items():
            cy, cx = cells[f]
            T, V = samples[k][f]
            I = warper.to_plane(views[k], k, f)[cy, cx]
            w = inside[k][f][cy, cx].astype(np.float64)
            Mg = np.zeros((g.size, 4, 4), np.float64)
            rg = np.zeros((g.size, 4), np.float64)
            _accumulate(Mg, rg, I, T, V, behind[f], w, alpha_weight)
            M[g] += Mg
            r[g] += rg
            y = I - T[:, :3]
            s0[g] += w
            s1[g] += w[:, None] * y
            s2[g] += w * (y * y).sum(-1)
    variation = np.maximum(s2 - (s1 * s1).sum(-1) / np.maximum(s0, 1e-12), 0.0)
    return M, r, variation


# --------------------------------------------------------------------------------------------------------
# The stage


@dataclass
class MattingResult:
    """What :func:`matte_edges` computed, with ``return_details=True``.

    Attributes
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        The new volume, float32, premultiplied.
    band : EdgeBand
        The band and the planes matted between.
    parallax : ndarray of shape (H, W)
        :func:`parallax` of the last solve (0 outside the band).
    """

    rgba: np.ndarray
    band: EdgeBand
    parallax: np.ndarray


def _check(rgba, disparities, views, warper):
    rgba = np.asarray(rgba)
    if rgba.ndim != 4 or rgba.shape[-1] != 4 or not np.issubdtype(rgba.dtype, np.floating):
        raise VfxStereoError(f"matting needs a floating (D, H, W, 4) RGBA volume, got {rgba.dtype} {rgba.shape}")
    views = np.asarray(views)
    if views.ndim != 4 or views.shape[-1] != 3 or views.shape[1:3] != rgba.shape[1:3]:
        raise VfxStereoError(f"views must be (K, H, W, 3) at the volume's size {rgba.shape[1:3]}, "
                             f"got {views.shape}")
    disp = np.asarray(disparities, np.float64).reshape(-1)
    if disp.shape != (rgba.shape[0],):
        raise VfxStereoError(f"{rgba.shape[0]} layers need {rgba.shape[0]} disparities, got {disp.size}")
    if warper.D != rgba.shape[0] or warper.K != views.shape[0] or tuple(warper.shape) != rgba.shape[1:3] \
            or not np.allclose(warper.disparities, disp):
        raise VfxStereoError("the warper does not match the volume, its disparities or the views")
    return rgba, views


def matte_edges(rgba, disparities, views, warper, *, band=None, radius: int = RADIUS,
                iterations: int = ITERATIONS, regularisation: float = REGULARISATION,
                background_prior: float = BACKGROUND_PRIOR, relaxation: float = RELAXATION,
                flat_regularisation: float = 0.0, flat_variation: float = FLAT_VARIATION,
                min_parallax: float = 0.0, alpha_weight: float = 1.0, estimate_background: bool = True,
                white: float = 1.0, progress: Progress | None = None, return_details: bool = False):
    """Re-solve colour and opacity of the soft-edge band against a background estimated from the views.

    See the module docstring for the model and the steps.

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied, scene-linear volume (a solved stack); not modified.
    disparities : ndarray of shape (D,)
        The planes (must be the warper's).
    views : ndarray of shape (K, H, W, 3)
        Scene-linear input views.
    warper : vfxstereo.warp.Warper
        Plane/view warps of the rig.
    band : ndarray of shape (H, W), bool, optional
        Restrict the work to these pixels (intersected with the band :func:`edge_band` finds).
    radius : int
        Half-width of the band around depth discontinuities, px.
    iterations : int
        Background / front alternations (>= 1).
    regularisation : float
        Tikhonov weight towards the current cell (:func:`solve_cells`), relative to one view; > 0.
    background_prior : float
        Weight of the spatial fill (nearest clearly seen background) in the background estimate.
    relaxation : float
        Over-relaxation factor of the alternation after its first pass, in (0, 2).
    flat_regularisation : float
        Extra Tikhonov weight on alpha where the views see (almost) the same colour through the cell,
        ``flat_regularisation * flat_variation / (variation + flat_variation)``: over a flat background
        alpha is not observed, and a background estimate polluted by unresolved foreground can then drive
        alpha anywhere. 0 (default) turns it off; 1 holds such cells at the input (it also keeps a solved
        stack's holes in opaque surfaces, which cost more on the benchmark than the guard saves: see the
        module notes).
    flat_variation : float
        ``sum_k |y_k - mean y|^2`` (colour units squared) below which the guard takes over.
    min_parallax : float
        Keep the input cell where :func:`parallax` is below this (0: never; the regularisation already
        keeps ill-posed cells near the input).
    alpha_weight : float
        Weight of the opacity rows (the views are opaque).
    estimate_background : bool
        Re-estimate the background behind the band (False: trust the volume's back layers, e.g. a known
        clean plate).
    white : float
        Largest straight colour.
    progress : callable, optional
        ``progress("matting", done, total)``.
    return_details : bool
        Return a :class:`MattingResult` instead of the volume.

    Returns
    -------
    ndarray of shape (D, H, W, 4), float32, premultiplied; or MattingResult.

    Raises
    ------
    VfxStereoError
        On inconsistent inputs or settings out of range.
    """
    rgba, views = _check(rgba, disparities, views, warper)
    if int(radius) != radius or radius < 0:
        raise VfxStereoError(f"radius must be a whole number of pixels >= 0, got {radius}")
    if int(iterations) != iterations or iterations < 1:
        raise VfxStereoError(f"iterations must be a whole number >= 1, got {iterations}")
    for name, v in (("background_prior", background_prior), ("min_parallax", min_parallax),
                    ("alpha_weight", alpha_weight), ("flat_regularisation", flat_regularisation)):
        if not (np.isfinite(v) and v >= 0):
            raise VfxStereoError(f"{name} must be a number >= 0, got {v}")
    for name, v in (("regularisation", regularisation), ("flat_variation", flat_variation)):
        if not (np.isfinite(v) and v > 0):
            raise VfxStereoError(f"{name} must be a number > 0 (cells no view observes are singular), got {v}")
    if not (0.0 < relaxation < 2.0):
        raise VfxStereoError(f"relaxation must lie in (0, 2), got {relaxation}")
    vol = np.array(rgba, dtype=np.float32, copy=True)
    views = np.ascontiguousarray(views, dtype=np.float32)
    D, H, W = vol.shape[:3]
    K = views.shape[0]

    # Step 1: the band, the front plane to solve and the back plane behind it
    eb = edge_band(vol, radius=int(radius))
    mask = eb.mask.copy()
    if band is not None:
        band = np.asarray(band, bool)
        if band.shape != (H, W):
            raise VfxStereoError(f"band must be an (H, W) = {(H, W)} mask, got {band.shape}")
        mask &= band
    eb.mask = mask
    ys, xs = np.nonzero(mask)
    par = np.zeros((H, W), np.float64)
    if ys.size == 0:
        report(progress, "matting", iterations, iterations)
        return MattingResult(vol, eb, par) if return_details else vol
    fp, bp = eb.front[ys, xs], eb.back[ys, xs]
    groups = {int(f): np.nonzero(fp == f)[0] for f in np.unique(fp)}

    # Step 2: clear the cells between back and front; the back cells seen through the band become opaque
    planes = np.arange(D)[:, None]
    di, ni = np.nonzero((planes > bp[None]) & (planes < fp[None]))
    vol[di, ys[ni], xs[ni]] = 0.0
    back: dict[int, np.ndarray] = {}
    if estimate_background:
        for b in np.unique(bp):
            seen = np.zeros((H, W), np.float32)
            for f in np.unique(fp[bp == b]):
                sel = np.zeros((H, W), np.float32)
                sel[mask & (eb.front == f) & (eb.back == b)] = 1.0
                for k in range(K):  # the cells of plane b that view k sees through band cells of plane f
                    seen += warper.to_plane(warper.to_view(sel, k, int(f)), k, int(b))
            cells = (seen > 0) & (eb.surface >= b)
            if cells.any():
                back[int(b)] = cells
                vol[b, cells, 3] = 1.0
                vol[b, cells, :3] = np.minimum(vol[b, cells, :3], white)
    used = sorted(set(groups) | set(back))
    lowest, highest = min(used), max(used)
    # view pixels whose rays through every plane in use stay in the reference frame (as the solver's
    # border weights): beyond, a view can see content no plane holds
    inside_k = [_inside(warper, k, range(lowest, highest + 1)) for k in range(K)]
    inside = [{p: warper.to_plane(inside_k[k].astype(np.float32), k, p) > 1.0 - 1e-6 for p in used}
              for k in range(K)]
    # the first background estimate: front cells at the discontinuities (after step 2) block the views
    s = edge_band(vol, radius=0).surface
    edge = (ndimage.grey_dilation(s, footprint=_window(1)) > ndimage.grey_erosion(s, footprint=_window(1)))
    sharp = edge[ys, xs]
    cells = {f: (ys[g], xs[g]) for f, g in groups.items()}
    back_cells = {b: np.nonzero(m) for b, m in back.items()}

    for it in range(int(iterations)):
        report(progress, "matting", it, iterations)
        relax = relaxation if it > 0 else 1.0
        occupied = _occupied(vol)
        # one pass per view: what lies in front of the band cells and of the back cells
        samples_f, samples_b = [], []
        for k in range(K):
            sf, sb = _gather_front(vol, warper, k, cells, back_cells, lowest=lowest, occupied=occupied)
            samples_f.append(sf)
            samples_b.append(sb)
        # Step 3: the background behind the band, from the views that see it
        if back_cells:
            if it == 0 and sharp.any():  # first estimate: band cells at the discontinuities block the views
                src = vol.copy()
                src[fp[sharp], ys[sharp], xs[sharp]] = np.array([0, 0, 0, 1], np.float32)
                occ = _occupied(src)
                samples_b = [_gather_front(src, warper, k, back_cells, lowest=lowest, occupied=occ)[0]
                             for k in range(K)]
            _solve_background(vol, views, warper, back_cells, samples_b, prior=background_prior, white=white,
                              relax=relax, inside=inside)
        # Step 4: per band cell, the regularised normal equations over the views
        M, r, variation = _front_system(vol, views, warper, groups, cells, samples_f,
                                        alpha_weight=alpha_weight, inside=inside)
        x0 = vol[fp, ys, xs].astype(np.float64)
        lam = np.full((ys.size, 4), float(regularisation))
        if flat_regularisation > 0:  # the views see the same colour through the cell: alpha is not observed
            lam[:, 3] += flat_regularisation * flat_variation / (variation + flat_variation)
        x = solve_cells(M, r, x0, regularisation=lam, white=white)
        if relax != 1.0:
            x = x0 + relax * (x - x0)
            x[:, 3] = np.clip(x[:, 3], 0.0, 1.0)
            x[:, :3] = np.clip(x[:, :3], 0.0, white * x[:, 3:4])
        P = parallax(M)
        if min_parallax > 0:
            keep = P < min_parallax
            x[keep] = x0[keep]
        vol[fp, ys, xs] = x
    par[ys, xs] = P
    report(progress, "matting", iterations, iterations)
    return MattingResult(vol, eb, par) if return_details else vol


def matte_stack(stack, views, *, warper=None, **settings):
    """:func:`matte_edges` on a :class:`~vfxstereo.stack.LayerStack`; returns a new stack.

    Parameters
    ----------
    stack : LayerStack
        A solved stack with its camera.
    views : ndarray of shape (K, H, W, 3)
        The views it was solved from, ordered as ``stack.camera.positions``.
    warper : vfxstereo.warp.Warper, optional
        Built from the stack's camera when not given.
    **settings
        Keyword settings of :func:`matte_edges` (``white`` defaults to the stack's).

    Returns
    -------
    LayerStack
        Same disparities, camera and white; metadata gains ``"edge_matting"`` (the settings used).
    """
    from vfxstereo.stack import LayerStack
    from vfxstereo.warp import Warper

    if not isinstance(stack, LayerStack):
        raise VfxStereoError("matte_stack needs a vfxstereo.LayerStack")
    if stack.camera is None:
        raise VfxStereoError("matte_stack needs a stack with a camera (the views' positions)")
    settings.pop("return_details", None)
    settings.setdefault("white", stack.white)
    if warper is None:
        warper = Warper(stack.camera, stack.disparities, stack.shape[1:])
    rgba = matte_edges(stack.rgba, stack.disparities, views, warper, **settings)
    meta = dict(stack.metadata)
    meta["edge_matting"] = {k: v for k, v in settings.items() if k != "progress" and k != "band"}
    return LayerStack(rgba, stack.disparities, stack.camera, meta, stack.white, stack.plate)
