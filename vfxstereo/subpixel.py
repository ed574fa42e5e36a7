"""Sub-pixel disparity by a parabola through the variance curve (Section 8.1, future work of the paper).

At each decided pixel, a parabola is fitted through the aggregated variance at the winning plane and its two
neighbours, and its minimum is the disparity. For evenly spaced planes (spacing h) the offset from the
winner, in units of h, is::

    delta = (s[-1] - s[+1]) / (2 (s[-1] - 2 s[0] + s[+1]))

For unevenly spaced planes the parabola is fitted through the three (disparity, variance) points, which
reduces to the formula above when the spacing is even. When the winner is the lowest of the three, the vertex
always lies between the midpoints to its neighbours; the result is clamped to those midpoints anyway, for
winners chosen on another volume. Where a neighbour is missing (the winner is the first or last plane) or has
infinite variance, or the three points are collinear, the winner's own disparity is returned.

On scenes whose true disparities are whole planes (Middlebury tsukuba) the parabola can only add error; it
pays on surfaces between planes (tested on a plane at d = 2.4).
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError


def parabola_vertex(dm, d0, dp, sm, s0, sp):
    """Abscissa of the minimum of the parabola through ``(dm, sm), (d0, s0), (dp, sp)``; ``d0`` if flat.

    All arguments broadcast; ``dm < d0 < dp`` is assumed.
    """
    dm, d0, dp, sm, s0, sp = (np.asarray(a, dtype=np.float64) for a in (dm, d0, dp, sm, s0, sp))
    hm = d0 - dm
    hp = dp - d0
    num = hm * hm * (s0 - sp) - hp * hp * (s0 - sm)
    den = hm * (s0 - sp) + hp * (s0 - sm)  # < 0 for a convex parabola with s0 below both neighbours
    with np.errstate(invalid="ignore", divide="ignore"):
        x = d0 - 0.5 * num / den
    ok = np.isfinite(x) & (den < 0)
    return np.where(ok, x, d0)


def subpixel_disparity(cost, disparities, winner) -> np.ndarray:
    """Sub-pixel disparity map from the aggregated variance around each winner (Section 8.1).

    Parameters
    ----------
    cost : ndarray of shape (D, H, W)
        Aggregated variance (lower is better); ``inf`` where a cell has no votes.
    disparities : ndarray of shape (D,)
        Strictly increasing plane disparities (need not be evenly spaced).
    winner : ndarray of shape (H, W), int
        Selected plane index per pixel, -1 where undecided (:attr:`vfxstereo.select.Selection.winner`).

    Returns
    -------
    ndarray of shape (H, W), float32
        Disparity in px per view step; NaN where undecided.
    """
    cost = np.asarray(cost, dtype=np.float64)
    disp = np.asarray(disparities, dtype=np.float64).reshape(-1)
    winner = np.asarray(winner)
    if cost.ndim != 3 or disp.shape != (cost.shape[0],) or winner.shape != cost.shape[1:]:
        raise VfxStereoError(f"cost {cost.shape}, disparities {disp.shape} and winner {winner.shape} "
                             "must be (D, H, W), (D,) and (H, W)")
    if disp.size > 1 and not np.all(np.diff(disp) > 0):
        raise VfxStereoError("disparities must be strictly increasing")
    D = cost.shape[0]
    decided = winner >= 0
    w = np.clip(winner, 0, D - 1)
    wm = np.clip(w - 1, 0, D - 1)
    wp = np.clip(w + 1, 0, D - 1)
    s0 = np.take_along_axis(cost, w[None], axis=0)[0]
    sm = np.take_along_axis(cost, wm[None], axis=0)[0]
    sp = np.take_along_axis(cost, wp[None], axis=0)[0]
    d0, dm, dp = disp[w], disp[wm], disp[wp]
    inner = (w > 0) & (w < D - 1) & np.isfinite(s0) & np.isfinite(sm) & np.isfinite(sp)
    x = parabola_vertex(np.where(inner, dm, d0 - 1), d0, np.where(inner, dp, d0 + 1),
                        np.where(inner, sm, 0.0), np.where(inner, s0, 0.0), np.where(inner, sp, 0.0))
    lo = np.where(inner, 0.5 * (dm + d0), d0)
    hi = np.where(inner, 0.5 * (d0 + dp), d0)
    out = np.clip(np.where(inner, x, d0), lo, hi)
    return np.where(decided, out, np.nan).astype(np.float32)
