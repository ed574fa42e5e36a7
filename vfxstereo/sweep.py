"""Stage 1: the plane sweep and the per-cell colour statistics (Section 4, Eq. 1; Section 5 re-estimation).

Every view is resampled onto every disparity plane (Eq. 1, through :class:`vfxstereo.warp.Warper`), and
each cell ``(x, y, d)`` gets the (weighted) mean colour and colour variance of the views that see it.

Decisions, stated once
----------------------
* **Votes.** View k votes at a cell only where the cell's whole bilinear footprint lies inside view k:
  ``Warper.coverage(k, i) > 1 - 1e-6`` (:data:`COVERAGE_THRESHOLD`). A footprint that straddles the frame
  edge would blend the view with the zero outside it and vote a wrong colour.
* **Visibility weights (Section 5).** With ``visibility`` given -- for each view k an array ``V_k`` of shape
  (D, H, W) in *view k's* coordinates -- the paper's ``c̄_k(u, v, d) = c_k(u, v) V_k(u, v, d)`` is resampled
  through Eq. (1) together with ``V_k`` itself: view k's weight at the cell is ``w_k = W_f(V_k)`` and its
  colour sample is ``W_f(c_k V_k) / W_f(V_k)`` (the visible part of the footprint only). Without visibility
  every ``V_k = 1`` and ``w_k`` is 1 (or 0 outside the frame).
* **Statistics.** Weighted mean ``mu = sum_k w_k c_k / sum_k w_k`` (scene-linear, the colour the initial
  volume gets) and weighted population variance ``sum_k w_k (m_k - mu_m)^2 / sum_k w_k`` of the *matching
  values* ``m_k``, **averaged over the three colour channels** (a grey image stored as RGB gets the variance
  of its grey values, as in the paper's footnote 2).
* **Units.** Matching values are scaled by 255, so variances are in 8-bit units squared like the paper's
  thresholds (sigma_max = 16, theta_min = 10). ``matching="srgb"`` (the default) matches on sRGB-encoded
  values, closest to the paper's 8-bit data; ``"linear"`` matches on the scene-linear values times 255.
  The choice was measured on Middlebury tsukuba (see :data:`MATCHING`).
* **Too few votes.** Where the total weight ``sum_k w_k`` is below ``min_votes`` (2 by default: one view
  alone always has zero variance), the variance is ``+inf`` so the cell never wins. The mean is 0 where no
  view sees the cell.
* **Resampling tolerance** (``tolerant=True``; not in the paper). Bilinear resampling at fractional shifts
  blurs: at a half-pixel shift a view's sample of a correct cell is ``[1 2 1] / 4`` of the texture while the
  reference's is sharp, and on a random-dot texture that alone costs a variance of ~0.4 of the texture's
  (the paper's Section 7: "significant re-sampling errors" for the background "at an odd disparity"). A
  tolerant sweep also computes the variance of the matching values low-passed by ``[1 2 1] / 4`` along the
  directions the views move in (:func:`lowpass_axes`), and keeps the smaller of the two per cell. On the
  Fig. 7 stimulus (3 seeds) the selection then decides 90 % of the pixels instead of 42 %; on the
  integral-shift Fig. 6 stimulus the sharp variance is exact (zero at the truth) and nothing changes where
  every view sees the surface. Low-passing alone (no minimum) also decides 87 % on Fig. 7 but blurs across
  depth edges and makes 3-8 wrong choices on Fig. 6 at pixels every view sees. Twice the matching work.
* **Memory.** One plane at a time: (K, H, W, 3) samples are held, never (D, K, H, W, 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.color import linear_to_srgb
from vfxstereo.progress import Progress, report

COVERAGE_THRESHOLD = 1.0 - 1e-6
"""A view votes at a cell when at least this much of the cell's bilinear footprint lies inside the view."""

SCALE = 255.0
"""Matching values are colours times this, so variances are in 8-bit units squared (the paper's units)."""

MATCHING = ("srgb", "linear")
"""Matching encodings; ``"srgb"`` (sRGB-encoded values, the default) or ``"linear"`` (scene-linear values).

Measured on Middlebury tsukuba (5 views, reference col3, d = 0..15, 18 px border, bad = |d - gt| > 1):
plain winner-take-all after Eq. (2) is a tie (16.5 % sRGB, 16.4 % linear), but with a box window sRGB wins
(13.4 % vs 15.1 %), and with the paper's thresholds sRGB is better at equal coverage (59.6 % decided at
4.7 % bad, against linear's 56.9 % decided at 5.5 % bad). Linear values squeeze the dark half of the range,
so a fixed threshold in 8-bit units is too loose in the shadows and too tight in the highlights."""

_MIN_WEIGHT = 1e-6  # a resampled visibility below this is no vote at all

LOWPASS = np.array([0.25, 0.5, 0.25])
"""The ``[1 2 1] / 4`` filter of the tolerant sweep: what a half-pixel bilinear shift and back does to a view."""


@dataclass
class SweepStats:
    """Per-cell statistics of the sweep, on the planes of the reference (virtual) camera.

    Attributes
    ----------
    mean : ndarray of shape (D, H, W, 3), float32
        Weighted mean colour, scene-linear (straight, not premultiplied); 0 where no view votes.
    var : ndarray of shape (D, H, W), float32
        Weighted population variance of the matching values, 8-bit units squared, averaged over the colour
        channels; ``+inf`` where the total weight is below ``min_votes``.
    weight : ndarray of shape (D, H, W), float32
        Total weight ``sum_k w_k`` (the number of views that vote, when there are no visibility weights).
    """

    mean: np.ndarray
    var: np.ndarray
    weight: np.ndarray


def matching_values(image: np.ndarray, matching: str = "srgb", scale: float = SCALE) -> np.ndarray:
    """The values variances are computed on: ``scale * image`` (linear) or ``scale * sRGB(image)``.

    Parameters
    ----------
    image : ndarray of shape (..., 3)
        Scene-linear colour.
    matching : {"srgb", "linear"}
        Encoding (see :data:`MATCHING`).
    scale : float
        Multiplier, 255 for 8-bit units.

    Returns
    -------
    ndarray of the same shape, float32.
    """
    image = np.asarray(image, dtype=np.float32)
    if matching == "linear":
        return image * np.float32(scale)
    if matching == "srgb":
        return linear_to_srgb(image) * np.float32(scale)
    raise VfxStereoError(f"unknown matching encoding {matching!r}; choose one of: {', '.join(MATCHING)}")


def lowpass_axes(camera, shape: tuple[int, int]) -> tuple[int, ...]:
    """Image axes (1: rows, y; 2: columns, x; of a (K, H, W, C) stack) along which the views' samples move.

    A rectified rig moves them along x where positions differ in x and along y where they differ in y.
    For general (matrix) cameras, the image of the frame's corners and centre on the planes d = 0 and
    d = 1 (Eq. A1) shows the direction; an axis counts when some point moves along it by more than 1e-3 of
    the largest motion.
    """
    if not camera.is_general:
        spread = np.ptp(camera.positions, axis=0)
    else:
        from vfxstereo.homography import plane_homography

        h, w = shape
        pts = np.array([[0, 0, 1], [w - 1, 0, 1], [0, h - 1, 1], [w - 1, h - 1, 1], [(w - 1) / 2, (h - 1) / 2, 1]],
                       dtype=np.float64).T
        motion = []
        for M in camera.matrices:
            a, b = (plane_homography(M, camera.M0, d) @ pts for d in (0.0, 1.0))
            motion.append(np.abs(b[:2] / b[2] - a[:2] / a[2]).max(axis=1))
        spread = np.max(motion, axis=0)
    big = spread.max()
    axes = tuple(ax for ax, s in ((2, spread[0]), (1, spread[1])) if s > 1e-3 * big)
    return axes or (2,)


def lowpass(values: np.ndarray, axes) -> np.ndarray:
    """``values`` (K, H, W, C) filtered by :data:`LOWPASS` along each of ``axes`` (edges replicated), float32."""
    out = np.asarray(values, dtype=np.float32)
    for ax in axes:
        out = ndimage.convolve1d(out, LOWPASS.astype(np.float32), axis=ax, mode="nearest")
    return out


def _check_inputs(views, warper, visibility):
    views = np.asarray(views, dtype=np.float32)
    if views.ndim != 4 or views.shape[-1] != 3:
        raise VfxStereoError(f"views must be (K, H, W, 3) colour images, got shape {views.shape}")
    K, H, W = views.shape[:3]
    if K != warper.K:
        raise VfxStereoError(f"{K} views given but the camera has {warper.K}")
    if (H, W) != warper.shape:
        raise VfxStereoError(f"views are {H}x{W} but the planes are {warper.shape[0]}x{warper.shape[1]}")
    if K < 2:
        raise VfxStereoError("the sweep needs at least two views")
    if not np.all(np.isfinite(views)):
        raise VfxStereoError("the views contain NaN or infinite values")
    if visibility is not None:
        if len(visibility) != K:
            raise VfxStereoError(f"visibility must give one (D, H, W) array per view, got {len(visibility)}")
        visibility = [np.asarray(v, dtype=np.float32) for v in visibility]
        for v in visibility:
            if v.shape != (warper.D, H, W):
                raise VfxStereoError(
                    f"visibility arrays must be (D, H, W) = {(warper.D, H, W)}, got {v.shape}")
    return views, visibility


def sweep(views, warper, *, visibility=None, matching: str = "srgb", scale: float = SCALE,
          min_votes: float = 2.0, tolerant: bool = False, progress: Progress | None = None) -> SweepStats:
    """Resample every view onto every plane (Eq. 1) and compute the weighted mean and variance per cell.

    Parameters
    ----------
    views : ndarray of shape (K, H, W, 3)
        The input views, scene-linear float (straight colour), in camera order.
    warper : Warper
        Plane/view warps of the rig and the disparity planes (:class:`vfxstereo.warp.Warper`).
    visibility : sequence of K ndarrays of shape (D, H, W), optional
        ``V_k(u, v, d)`` in each view's own coordinates (Section 5), in [0, 1]; ``None`` means all visible.
    matching : {"srgb", "linear"}
        Values the variance is computed on (:func:`matching_values`); the mean is always scene-linear.
    scale : float
        Multiplier of the matching values (255: variances in 8-bit units squared).
    min_votes : float
        Cells whose total weight is below this get variance ``+inf``.
    tolerant : bool
        Resampling-tolerant variance: the smaller of the variance of the matching values and of the matching
        values low-passed along the baseline (see the module notes).
    progress : callable, optional
        ``progress("sweep", plane_done, D)``.

    Returns
    -------
    SweepStats
        ``mean`` (D, H, W, 3), ``var`` (D, H, W), ``weight`` (D, H, W), all float32.
    """
    views, visibility = _check_inputs(views, warper, visibility)
    K, H, W = views.shape[:3]
    D = warper.D
    separate = matching != "linear" or tolerant
    matches = []  # matching values (K, H, W, 3) to take variances of; the first is unfiltered
    if separate:
        matches.append(matching_values(views, matching, scale))
        if tolerant:
            matches.append(lowpass(matches[0], lowpass_axes(warper.camera, warper.shape)))
    mean = np.zeros((D, H, W, 3), dtype=np.float32)
    var = np.empty((D, H, W), dtype=np.float32)
    weight = np.empty((D, H, W), dtype=np.float32)
    lin = np.empty((K, H, W, 3), dtype=np.float32)  # samples of one plane, scene-linear
    mvs = [np.empty((K, H, W, 3), dtype=np.float32) for _ in matches]  # matching samples of one plane
    wk = np.empty((K, H, W), dtype=np.float32)
    for i in range(D):
        for k in range(K):
            valid = warper.coverage(k, i) > COVERAGE_THRESHOLD
            if visibility is None:
                wk[k] = valid
                lin[k] = warper.to_plane(views[k], k, i)  # Eq. (1)
                for mv, m in zip(mvs, matches, strict=True):
                    mv[k] = warper.to_plane(m[k], k, i)  # Eq. (1)
            else:
                vis = visibility[k][i]
                v = warper.to_plane(vis, k, i)  # Eq. (1) applied to V_k
                seen = valid & (v > _MIN_WEIGHT)
                wk[k] = np.where(seen, v, 0.0)
                inv = (1.0 / np.where(seen, v, 1.0))[..., None]
                lin[k] = warper.to_plane(views[k] * vis[..., None], k, i) * inv  # Eq. (1) on c̄_k = c_k V_k
                for mv, m in zip(mvs, matches, strict=True):
                    mv[k] = warper.to_plane(m[k] * vis[..., None], k, i) * inv
        wsum = wk.sum(axis=0)
        safe = np.where(wsum > 0, wsum, 1.0).astype(np.float32)
        w4 = wk[..., None]
        mean[i] = (w4 * lin).sum(axis=0) / safe[..., None]  # weighted mean, scene-linear
        if separate:
            v2 = None
            for mv in mvs:
                mu = (w4 * mv).sum(axis=0) / safe[..., None]
                dev = mv - mu
                vk = (w4 * dev * dev).sum(axis=0).mean(axis=-1) / safe  # weighted population variance
                v2 = vk if v2 is None else np.minimum(v2, vk)  # tolerant: the smaller of the two
        else:
            dev = (lin - mean[i]) * np.float32(scale)
            v2 = (w4 * dev * dev).sum(axis=0).mean(axis=-1) / safe  # weighted population variance, channel mean
        var[i] = np.where(wsum >= min_votes - 1e-6, v2, np.inf)
        weight[i] = wsum
        report(progress, "sweep", i + 1, D)
    return SweepStats(mean=mean, var=var, weight=weight)
