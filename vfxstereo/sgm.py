"""Semi-global matching: smoothness along 8 (or 4) image paths over a cost volume (Hirschmueller, PAMI 2008).

Beyond the paper (Szeliski & Golland aggregate with Eq. 2, a diffusion at each depth). SGM approximates a
2-D smoothness prior by 1-D dynamic programming along several directions r and sums the results::

    L_r(p, d) = C(p, d) + min(L_r(p - r, d),
                              L_r(p - r, d - 1) + P1, L_r(p - r, d + 1) + P1,
                              min_k L_r(p - r, k) + P2') - min_k L_r(p - r, k)
    S(p, d)   = sum_r L_r(p, d)

P1 charges a step of one plane (slanted surfaces), P2' any larger jump (depth edges). Jumps should happen
at image edges, so P2 is lowered where the guide image changes along the path::

    P2' = max(P2 / (1 + |I(p) - I(p - r)| / sigma), P1)

The costs here are the AD-census means of :mod:`vfxstereo.matching` (0..2 per cell), and P1, P2 are in
the same units. The numba kernel (``_depth_kernels.sgm_path``) is tested against :func:`sgm_reference`, a
plain numpy version that walks one path at a time.
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress, report

DIRECTIONS_8 = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))
"""Path directions (dy, dx): the four axis directions and the four diagonals."""
DIRECTIONS_4 = DIRECTIONS_8[:4]

P1 = 0.5
"""Penalty of a one-plane step, in cost units (AD-census: 0..2 per cell)."""
P2 = 6.0
"""Penalty of a larger jump where the guide image is flat."""
SIGMA = 10.0
"""Guide-image difference (8-bit grey units) that halves P2."""


def _check(cost, guide, paths):
    cost = np.asarray(cost)
    if cost.ndim != 3 or cost.shape[2] < 1:
        raise VfxStereoError(f"SGM needs an (H, W, D) cost volume, got shape {cost.shape}")
    guide = np.asarray(guide, dtype=np.float32)
    if guide.shape != cost.shape[:2]:
        raise VfxStereoError(f"the guide image {guide.shape} does not match the cost volume {cost.shape[:2]}")
    if paths not in (4, 8):
        raise VfxStereoError(f"SGM runs along 4 or 8 paths, not {paths}")
    return np.ascontiguousarray(cost, dtype=np.float32), np.ascontiguousarray(guide)


def sgm(cost: np.ndarray, guide: np.ndarray, *, P1: float = P1, P2: float = P2, sigma: float = SIGMA,
        paths: int = 8, progress: Progress | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """Aggregated costs ``S`` of semi-global matching.

    Parameters
    ----------
    cost : ndarray of shape (H, W, D)
        Matching cost per pixel and plane (lower is better), finite.
    guide : ndarray of shape (H, W)
        Image whose edges lower P2 (grey, 8-bit units).
    P1, P2, sigma : float
        Penalties and the edge scale (see the module docstring).
    paths : {8, 4}
        Number of path directions.
    out : ndarray of shape (H, W, D), float32, optional
        Buffer for the result (may not be ``cost``).

    Returns
    -------
    ndarray of shape (H, W, D), float32.
    """
    from vfxstereo import _depth_kernels

    cost, guide = _check(cost, guide, paths)
    if out is None:
        out = np.zeros_like(cost)
    else:
        out[...] = 0.0
    directions = DIRECTIONS_8[:paths]
    for n, (dy, dx) in enumerate(directions):
        ys, xs = _depth_kernels.path_starts(cost.shape[0], cost.shape[1], dy, dx)
        _depth_kernels.sgm_path(cost, guide, np.float32(P1), np.float32(P2), np.float32(sigma), dy, dx, out, ys, xs)
        report(progress, "sgm", n + 1, len(directions))
    return out


def sgm_reference(cost: np.ndarray, guide: np.ndarray, *, P1: float = P1, P2: float = P2, sigma: float = SIGMA,
                  paths: int = 8) -> np.ndarray:
    """Plain numpy :func:`sgm` (float64), one path and one pixel at a time: the kernel's reference."""
    cost, guide = _check(cost, guide, paths)
    cost = cost.astype(np.float64)
    h, w, D = cost.shape
    S = np.zeros_like(cost)
    for dy, dx in DIRECTIONS_8[:paths]:
        L = np.zeros_like(cost)
        ys = range(h) if dy >= 0 else range(h - 1, -1, -1)
        xs = range(w) if dx >= 0 else range(w - 1, -1, -1)
        for y in ys:
            for x in xs:
                py, px = y - dy, x - dx
                if not (0 <= py < h and 0 <= px < w):
                    L[y, x] = cost[y, x]
                    continue
                prev = L[py, px]
                m = prev.min()
                p2 = max(P2 / (1.0 + abs(float(guide[y, x]) - float(guide[py, px])) / sigma), P1)
                up = np.concatenate([prev[1:], [np.inf]]) + P1
                down = np.concatenate([[np.inf], prev[:-1]]) + P1
                best = np.minimum.reduce([prev, up, down, np.full(D, m + p2)])
                L[y, x] = cost[y, x] + best - m
        S += L
    return S
