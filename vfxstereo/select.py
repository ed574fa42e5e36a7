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

Beyond the paper
----------------
* :func:`select_behind` -- hidden layers. After visibility re-estimation (Section 5) the cells behind a
  selected surface get votes only from the views that see them, and those are consistent where a farther
  surface continues behind the nearer one. Selecting them too (a second, thresholded winner-take-all among
  the cells behind the front winner) gives the refinement the disoccluded background instead of leaving it
  to be invented. On the Fig. 6 stimulus (seeds 0-7, paper preset) 285-310 hidden cells per image are
  selected, of which 77-84 % are ground-truth cells (90-93 % with ``tolerant_matching`` off: the tolerant
  variance admits more chance matches among two votes); the refinement removes the wrong ones. Without
  :func:`complete`, they lift the paper preset's worst RDS view from 43.7 to 46.6 dB and the reference
  pixels in the right layer from 98.9 % to 99.7 % (seeds 0-4). With it, whose background extension covers
  the same 3-6 px wide disocclusions of this stimulus, they change little (46.3 dB / 99.71 % without,
  45.9 dB / 99.77 % with); they stay on because their colours come from the views that see the cells
  and they reach as far as a disocclusion does, not a fixed number of pixels.
* :func:`complete` -- from the selection to the refinement's start (the paper's Section 6 suggests making
  the binary opacities "real-valued using a low-pass filter"). It (1) fills undecided pixels from their
  decided neighbours, taking the *farthest* neighbouring surface (the background first: whatever lies in
  front of a mixed pixel the refinement can add); (2) continues the background behind the boundary of a
  nearer surface for ``extend`` pixels; (3) makes the boundary cells of a nearer surface half transparent,
  with the straight colour of the surface's interior rather than the sweep's mean, which at a mixed pixel
  is a blend of foreground and background. Why: behind an opaque cell the gradient of C1 w.r.t. the cells
  behind is zero (V_k = 0), and with nothing behind it the gradient w.r.t. its own opacity is zero too
  (the composite's alpha is exactly 1 and a_k(d - 1) = 0), so an opaque cell with a blended colour over
  an empty background is a stationary point of the refinement; mixed pixels never become transparent.
  Measured on the Fig. 7 stimulus (seeds 0-5, lambda = (50, 1, 10)): mean alpha error of the foreground
  matte on the soft half-circle band 0.27-0.30 after selection alone, 0.14-0.17 after completion,
  0.08-0.11 after refinement. Ablations (prototype, seeds 0-2): without step (1) the refinement ends at
  0.30, without (2) at 0.18, without (3)'s softening at 0.21, without (3)'s interior colour at 0.12.
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


def select_behind(mean, cost, front, reference, **settings) -> Selection:
    """Hidden layers: thresholded winner-take-all among the cells *behind* the front winner of each pixel.

    Cells at plane indices below ``front`` compete (the reference camera cannot see them once ``front`` is
    opaque); pixels without a front winner and the cells at or in front of it are left out. The statistics
    should come from a sweep in which the reference view does not vote and the other views are weighted by
    their visibility (Section 5), so a cell's votes come only from the views that see it.

    Parameters
    ----------
    mean : ndarray of shape (D, H, W, 3)
        Mean colour per cell, scene-linear, straight.
    cost : ndarray of shape (D, H, W)
        Aggregated variance; ``inf`` = no vote.
    front : ndarray of shape (H, W), int
        Front winner per pixel (:attr:`Selection.winner`), -1 where undecided.
    reference : ndarray of shape (H, W, 3)
        The reference image (sets the threshold, as in :func:`select`).
    **settings
        ``theta_min``, ``theta_s``, ``require_clear``, ``clear_ratio``, ``matching``, ``scale`` of
        :func:`select`; the clear-winner test compares only cells behind the front winner.

    Returns
    -------
    Selection
        ``winner`` is the hidden plane per pixel (-1 where none); ``rgba`` holds only the hidden cells.
    """
    cost = np.asarray(cost, dtype=np.float32)
    front = np.asarray(front)
    if cost.ndim != 3 or front.shape != cost.shape[1:]:
        raise VfxStereoError(f"front {front.shape} must be (H, W) of the cost volume {cost.shape}")
    planes = np.arange(cost.shape[0])[:, None, None]
    behind = (front[None] >= 0) & (planes < front[None])
    return select(mean, np.where(behind, cost, np.inf), reference, **settings)


def fill_undecided(winner: np.ndarray) -> np.ndarray:
    """Give every undecided pixel the *farthest* plane among its decided 8-neighbours, growing inwards.

    Each round assigns the undecided pixels next to decided ones the smallest plane index (the farthest
    surface) among their decided neighbours, until nothing is left or nothing is decided at all. A gap
    between a near and a far surface is therefore split down the middle, ties going to the far one.

    Parameters
    ----------
    winner : ndarray of shape (H, W), int
        Plane index per pixel, -1 where undecided.

    Returns
    -------
    ndarray of shape (H, W), int64; -1 only if no pixel was decided.
    """
    w = np.asarray(winner, dtype=np.int64).copy()
    if w.ndim != 2:
        raise VfxStereoError(f"winner must be (H, W), got shape {w.shape}")
    big = int(w.max()) + 1  # a sentinel above every plane (a huge one would not survive scipy's cval cast)
    while True:
        und = w < 0
        if not und.any() or und.all():
            return w
        near = ndimage.minimum_filter(np.where(und, big, w), size=3, mode="constant", cval=big)
        grow = und & (near < big)
        w[grow] = near[grow]


def _boundary(front: np.ndarray) -> np.ndarray:
    """Decided pixels with a decided 4-neighbour on a farther plane (the edge of a nearer surface)."""
    h, w = front.shape
    pad = np.pad(front, 1, mode="edge")
    out = np.zeros((h, w), bool)
    for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        nb = pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        out |= (front >= 0) & (nb >= 0) & (nb < front)
    return out


def complete(rgba, front, mean, *, behind_mean=None, behind_weight=None, fill: bool = True, extend: int = 3,
             soft_alpha: float = 0.5, colour_radius: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """From the selected volume to the refinement's start: fill, continue the background, soften edges.

    See the module notes for why and for measurements. Steps, each optional:

    1. ``fill``: undecided pixels get the farthest neighbouring front plane (:func:`fill_undecided`), an
       opaque cell with the sweep's mean colour there.
    2. ``extend``: a front cell with no opaque cell behind it gets one on the plane of the nearest pixel
       (chessboard distance <= ``extend``) whose front plane is farther; its colour is ``behind_mean``
       where ``behind_weight > 0`` (views see it), else the colour of that nearest pixel's front cell.
    3. ``soft_alpha < 1``: front cells on the boundary of a nearer surface (a 4-neighbour's front plane is
       farther) get alpha ``soft_alpha`` and, as straight colour, the median of the interior front cells of
       the same plane within ``colour_radius`` (their own colour where there are none).

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Selected volume (front and hidden cells), premultiplied; not modified.
    front : ndarray of shape (H, W), int
        Front winner per pixel, -1 where undecided.
    mean : ndarray of shape (D, H, W, 3)
        Mean colour of the sweep the front was selected on (straight, scene-linear).
    behind_mean, behind_weight : ndarray of shape (D, H, W, 3) and (D, H, W), optional
        Mean and total weight of the sweep the hidden cells were selected on; default ``mean`` and no weight.
    fill : bool
        Step 1.
    extend : int
        Step 2's reach in pixels; 0 skips it.
    soft_alpha : float
        Step 3's opacity; 1 skips it.
    colour_radius : int
        Half-size of step 3's window.

    Returns
    -------
    rgba : ndarray of shape (D, H, W, 4), float32, premultiplied
    front : ndarray of shape (H, W), int64
        Front plane per pixel after filling.
    """
    out = np.array(rgba, dtype=np.float32, copy=True)
    mean = np.asarray(mean, dtype=np.float32)
    front = np.asarray(front, dtype=np.int64)
    D, H, W = out.shape[:3]
    if mean.shape != (D, H, W, 3) or front.shape != (H, W):
        raise VfxStereoError(f"rgba {out.shape}, mean {mean.shape} and front {front.shape} do not fit")
    if not 0.0 < soft_alpha <= 1.0:
        raise VfxStereoError(f"soft_alpha must be in (0, 1], got {soft_alpha}")
    if extend < 0 or colour_radius < 0:
        raise VfxStereoError("extend and colour_radius must be >= 0")
    if fill:  # Step 1
        filled = fill_undecided(front)
        ys, xs = np.nonzero((front < 0) & (filled >= 0))
        ws = filled[ys, xs]
        out[ws, ys, xs, :3] = mean[ws, ys, xs]
        out[ws, ys, xs, 3] = 1.0
        front = filled
    decided = front >= 0
    if extend > 0 and decided.any():  # Step 2
        b_mean = mean if behind_mean is None else np.asarray(behind_mean, dtype=np.float32)
        b_weight = np.zeros((D, H, W), np.float32) if behind_weight is None else np.asarray(behind_weight)
        planes = np.arange(D)[:, None, None]
        opaque_behind = ((out[..., 3] > 0.5) & (planes < np.maximum(front, 0)[None])).any(axis=0)
        need = decided & ~opaque_behind
        best_dist = np.full((H, W), np.inf)
        best_plane = np.full((H, W), -1, np.int64)
        best_y = np.zeros((H, W), np.int64)
        best_x = np.zeros((H, W), np.int64)
        for j in range(D):  # nearest pixel whose front is plane j, for every j; farther planes win ties
            on = front == j
            if not on.any():
                continue
            dist, (iy, ix) = ndimage.distance_transform_cdt(~on, metric="chessboard", return_indices=True)
            take = need & (j < front) & (dist <= extend) & (dist < best_dist)
            best_dist = np.where(take, dist, best_dist)
            best_plane = np.where(take, j, best_plane)
            best_y = np.where(take, iy, best_y)
            best_x = np.where(take, ix, best_x)
        ys, xs = np.nonzero(best_plane >= 0)
        js = best_plane[ys, xs]
        seen = b_weight[js, ys, xs] > 0
        colour = np.where(seen[:, None], b_mean[js, ys, xs], out[js, best_y[ys, xs], best_x[ys, xs], :3])
        out[js, ys, xs, :3] = colour
        out[js, ys, xs, 3] = 1.0
    if soft_alpha < 1.0 and decided.any():  # Step 3
        edge = _boundary(front)
        ys, xs = np.nonzero(edge)
        ws = front[ys, xs]
        r = int(colour_radius)
        if r > 0 and len(ys):
            straight = np.take_along_axis(out, np.maximum(front, 0)[None, ..., None], axis=0)[0, ..., :3]
            interior = np.where(decided & ~edge, front, -1)
            pad_c = np.pad(straight, ((r, r), (r, r), (0, 0)))
            pad_i = np.pad(interior, r, constant_values=-1)
            dy, dx = np.mgrid[0:2 * r + 1, 0:2 * r + 1]
            wy = ys[:, None] + dy.ravel()[None]
            wx = xs[:, None] + dx.ravel()[None]
            member = pad_i[wy, wx] == ws[:, None]  # (N, window)
            vals = np.where(member[..., None], pad_c[wy, wx], np.nan)
            has = member.any(axis=1)
            med = np.full((len(ys), 3), np.nan, np.float32)
            if has.any():
                med[has] = np.nanmedian(vals[has], axis=1)
            own = out[ws, ys, xs, :3]
            colour = np.where(has[:, None], med, own)
        else:
            colour = out[ws, ys, xs, :3]
        out[ws, ys, xs, :3] = soft_alpha * colour
        out[ws, ys, xs, 3] = soft_alpha
    return out, front
