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
* **Memory.** One plane at a time: (K, H, W, 3) samples are held, never (D, K, H, W, 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
          min_votes: float = 2.0, progress: Progress | None = None) -> SweepStats:
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
    separate = matching != "linear"
    match = matching_values(views, matching, scale) if separate else None
    mean = np.zeros((D, H, W, 3), dtype=np.float32)
    var = np.empty((D, H, W), dtype=np.float32)
    weight = np.empty((D, H, W), dtype=np.float32)
    lin = np.empty((K, H, W, 3), dtype=np.float32)  # samples of one plane, scene-linear
    mv = np.empty((K, H, W, 3), dtype=np.float32) if separate else lin  # matching values (before scaling)
    wk = np.empty((K, H, W), dtype=np.float32)
    for i in range(D):
        for k in range(K):
            valid = warper.coverage(k, i) > COVERAGE_THRESHOLD
            if visibility is None:
                wk[k] = valid
                lin[k] = warper.to_plane(views[k], k, i)  # Eq. (1)
                if separate:
                    mv[k] = warper.to_plane(match[k], k, i)  # Eq. (1)
            else:
                vis = visibility[k][i]
                v = warper.to_plane(vis, k, i)  # Eq. (1) applied to V_k
                seen = valid & (v > _MIN_WEIGHT)
                wk[k] = np.where(seen, v, 0.0)
                inv = (1.0 / np.where(seen, v, 1.0))[..., None]
                lin[k] = warper.to_plane(views[k] * vis[..., None], k, i) * inv  # Eq. (1) on c̄_k = c_k V_k
                if separate:
                    mv[k] = warper.to_plane(match[k] * vis[..., None], k, i) * inv
        wsum = wk.sum(axis=0)
        safe = np.where(wsum > 0, wsum, 1.0).astype(np.float32)
        w4 = wk[..., None]
        mean[i] = (w4 * lin).sum(axis=0) / safe[..., None]  # weighted mean, scene-linear
        if separate:
            mu = (w4 * mv).sum(axis=0) / safe[..., None]
            dev = mv - mu
        else:
            dev = (lin - mean[i]) * np.float32(scale)
        v2 = (w4 * dev * dev).sum(axis=0).mean(axis=-1) / safe  # weighted population variance, channel mean
        var[i] = np.where(wsum >= min_votes - 1e-6, v2, np.inf)
        weight[i] = wsum
        report(progress, "sweep", i + 1, D)
    return SweepStats(mean=mean, var=var, weight=weight)
