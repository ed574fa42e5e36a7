"""Stage 3: thresholded winner-take-all and the initial RGBA volume (Section 4, footnote 6).

Per pixel (x, y), the disparity with the lowest aggregated variance wins, and is kept only where the answer
is "fairly certain":

1. **Threshold** (footnote 6): the winner's variance is below ``theta = theta_min + theta_s * Var3x3``, where
   ``Var3x3`` is the local variance of the reference image in a 3x3 window (8-bit units squared, on the same
   matching values as the sweep, averaged over the colour channels, edges reflected). The term allows for
   resampling errors near rapid colour changes.
2. **Clear winner**: the winner's variance is below ``clear_ratio`` times the best variance among the
   *competitors*, the disparities not adjacent to the winner (index distance >= 2; the neighbours are left
   out because a surface between two planes is legitimately good at both). A pixel with no competitor with
   finite variance passes. Repeated texture and flat regions, where a distant disparity is about as good,
   fail.

Plain winner-take-all (the paper's Fig. 6(f)) is ``theta_min=np.inf, require_clear=False``
(:data:`WTA`). The initial volume (Section 4): colour = the sweep's mean at winners, alpha = 1 at winners and
0 elsewhere, premultiplied (colour 0 where alpha is 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vfxstereo.errors import VfxStereoError
from vfxstereo.sweep import SCALE, matching_values

THETA_MIN = 10.0
"""Variance threshold floor theta_min, 8-bit units squared (footnote 6)."""
THETA_S = 0.02
"""Slope theta_s of the threshold on the local 3x3 variance of the reference image (footnote 6)."""
CLEAR_RATIO = 0.5
"""A winner is clear when its variance is below this times the best non-adjacent competitor's."""
WTA = {"theta_min": np.inf, "require_clear": False}
"""Settings of plain winner-take-all (Fig. 6(f)): every pixel with a finite variance gets its argmin."""


@dataclass
class Selection:
    """Result of :func:`select`.

    Attributes
    ----------
    rgba : ndarray of shape (D, H, W, 4), float32
        Initial volume, premultiplied, scene-linear: mean colour and alpha 1 at winners, 0 elsewhere.
    winner : ndarray of shape (H, W), int64
        Index of the selected plane, -1 where undecided.
    argmin : ndarray of shape (H, W), int64
        Winner-take-all index before the tests (-1 where every variance is infinite).
    theta : ndarray of shape (H, W), float32
        The threshold ``theta_min + theta_s * Var3x3`` used at each pixel.
    """

    rgba: np.ndarray
    winner: np.ndarray
    argmin: np.ndarray
    theta: np.ndarray

    @property
    def fraction(self) -> float:
        """Fraction of pixels that got a winner."""
        return float(np.mean(self.winner >= 0))


def local_variance(image: np.ndarray, size: int = 3) -> np.ndarray:
    """``Var3x3``: variance in a ``size x size`` window per pixel, averaged over channels (edges reflected).

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C)
        Values in the units wanted (e.g. 8-bit matching values).
    size : int
        Window size.

    Returns
    -------
    ndarray of shape (H, W), float32
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim == 2:
        img = img[..., None]
    win = (size, size, 1)
    m = ndimage.uniform_filter(img, size=win, mode="reflect")
    m2 = ndimage.uniform_filter(img * img, size=win, mode="reflect")
    return np.maximum(m2 - m * m, 0.0).mean(axis=-1).astype(np.float32)


def best_competitor(cost: np.ndarray, winner: np.ndarray, exclude: int = 1) -> np.ndarray:
    """Lowest cost per pixel among the disparities more than ``exclude`` indices away from ``winner``.

    Parameters
    ----------
    cost : ndarray of shape (D, H, W)
    winner : ndarray of shape (H, W), int
        Index per pixel (negative entries give ``inf``).
    exclude : int
        Indices ``|j - winner| <= exclude`` are not competitors.

    Returns
    -------
    ndarray of shape (H, W), float32; ``inf`` where there is no competitor.
    """
    D = cost.shape[0]
    j = np.arange(D)[:, None, None]
    far = np.abs(j - winner[None]) > exclude
    out = np.where(far, cost, np.inf).min(axis=0)
    return np.where(winner >= 0, out, np.inf).astype(np.float32)


def select(mean, cost, reference, *, theta_min: float = THETA_MIN, theta_s: float = THETA_S,
           require_clear: bool = True, clear_ratio: float = CLEAR_RATIO, matching: str = "srgb",
           scale: float = SCALE) -> Selection:
    """Thresholded winner-take-all over d, and the initial RGBA volume.

    Parameters
    ----------
    mean : ndarray of shape (D, H, W, 3)
        Mean colour per cell (:attr:`vfxstereo.sweep.SweepStats.mean`), scene-linear, straight.
    cost : ndarray of shape (D, H, W)
        Aggregated variance (:func:`vfxstereo.aggregate.aggregate`), 8-bit units squared; ``inf`` = no vote.
    reference : ndarray of shape (H, W, 3)
        The reference image (the view the virtual camera coincides with), scene-linear; its local variance
        sets the threshold.
    theta_min, theta_s : float
        Threshold ``theta = theta_min + theta_s * Var3x3`` (footnote 6). ``theta_min=np.inf`` disables it.
    require_clear : bool
        Apply the clear-winner test.
    clear_ratio : float
        The winner must be below ``clear_ratio`` times the best non-adjacent competitor.
    matching, scale : str, float
        Encoding and scale of the values Var3x3 is computed on; use the sweep's.

    Returns
    -------
    Selection
    """
    mean = np.asarray(mean, dtype=np.float32)
    cost = np.asarray(cost, dtype=np.float32)
    reference = np.asarray(reference, dtype=np.float32)
    if cost.ndim != 3 or mean.shape != (*cost.shape, 3):
        raise VfxStereoError(f"mean {mean.shape} and cost {cost.shape} must be (D, H, W, 3) and (D, H, W)")
    if reference.shape != (*cost.shape[1:], 3):
        raise VfxStereoError(f"the reference image must be (H, W, 3) = {(*cost.shape[1:], 3)}, "
                             f"got {reference.shape}")
    if np.isnan(cost).any():
        raise VfxStereoError("the cost volume contains NaN")
    D, H, W = cost.shape
    argmin = np.argmin(cost, axis=0)
    best = np.take_along_axis(cost, argmin[None], axis=0)[0]
    argmin = np.where(np.isfinite(best), argmin, -1).astype(np.int64)
    if np.isinf(theta_min):
        theta = np.full((H, W), np.inf, dtype=np.float32)
    else:
        var3 = local_variance(matching_values(reference, matching, scale))
        theta = (theta_min + theta_s * var3).astype(np.float32)  # footnote 6: theta_min + theta_s Var3x3
    keep = (argmin >= 0) & (best < theta)
    if require_clear:
        rival = best_competitor(cost, argmin, exclude=1)
        with np.errstate(invalid="ignore"):
            keep &= ~np.isfinite(rival) | (best < clear_ratio * rival)
    winner = np.where(keep, argmin, -1).astype(np.int64)
    rgba = np.zeros((D, H, W, 4), dtype=np.float32)
    ys, xs = np.nonzero(keep)
    ws = winner[ys, xs]
    rgba[ws, ys, xs, :3] = mean[ws, ys, xs]
    rgba[ws, ys, xs, 3] = 1.0
    return Selection(rgba=rgba, winner=winner, argmin=argmin, theta=theta)
