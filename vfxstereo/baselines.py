"""What a compositor would use instead of vfxstereo, for side-by-side benchmarks and tests.

* :func:`sgbm_disparity` -- OpenCV's semi-global block matching (``StereoSGBM``, Hirschmueller 2008) on a
  classic two-view pair, with the settings issue 7 fixes for comparisons: mode HH, block 5,
  P1 = 8 * 3 * 25, P2 = 32 * 3 * 25, uniqueness 10, speckle window 100 / range 2, disp12MaxDiff 1, invalid
  pixels filled from the farther valid neighbour on the row;
* :func:`hard_key` -- a depth key: the plate where the depth map says the scene is in front of the element,
  the element over the plate elsewhere (a hard matte, what a Z-combine of a depth pass does).
* :func:`forward_warp` -- the reference view moved to another camera position by its disparity, z-buffered,
  holes filled from the background: the two-view way of making a novel view.
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.color import linear_to_srgb

SGBM_SETTINGS = {"blockSize": 5, "P1": 8 * 3 * 25, "P2": 32 * 3 * 25, "uniquenessRatio": 10,
                 "speckleWindowSize": 100, "speckleRange": 2, "disp12MaxDiff": 1}
"""OpenCV StereoSGBM settings of the comparisons (mode HH)."""


def farther_source(disparity: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the column of the farther of the nearest valid pixels to its left and right on the row.

    Returns ``(column (H, W) int64, found (H, W) bool)``; the farther is the smaller disparity.
    """
    h, w = disparity.shape
    cols = np.arange(w)[None, :]
    left = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    right = np.minimum.accumulate(np.where(valid, cols, w)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(h)[:, None]
    lv = np.where(left >= 0, disparity[rows, np.clip(left, 0, w - 1)], np.inf)
    rv = np.where(right < w, disparity[rows, np.clip(right, 0, w - 1)], np.inf)
    column = np.where(lv <= rv, np.clip(left, 0, w - 1), np.clip(right, 0, w - 1))
    return column, np.isfinite(np.minimum(lv, rv))


def fill_row_farther(disparity: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Invalid pixels take the farther of the nearest valid values to their left and right on the row.

    The farther is the smaller disparity; NaN where a row has no valid pixel.
    """
    column, found = farther_source(disparity, valid)
    filled = disparity[np.arange(disparity.shape[0])[:, None], column]
    out = np.where(valid, disparity, np.where(found, filled, np.nan)).astype(np.float32)
    out[~np.isfinite(out)] = np.nan
    return out


def _to8(view: np.ndarray) -> np.ndarray:
    """Scene-linear RGB to 8-bit sRGB BGR, as OpenCV reads files."""
    enc = np.clip(linear_to_srgb(np.asarray(view, np.float32)), 0.0, 1.0)
    return np.ascontiguousarray((enc[..., ::-1] * 255.0 + 0.5).astype(np.uint8))


def sgbm_disparity(left: np.ndarray, right: np.ndarray, steps: float, disparities) -> np.ndarray:
    """OpenCV SGBM disparity of ``left`` against ``right``, in px per view step of the caller's rig.

    Parameters
    ----------
    left, right : ndarray of shape (H, W, 3)
        Scene-linear views; ``right`` is ``steps`` view steps to the right of ``left`` (a point at column x of
        ``left`` with disparity d per step appears at ``x - d * steps`` in ``right``). Encoded to 8-bit sRGB.
    steps : float
        Baseline between the two views, in view steps (> 0).
    disparities : array_like
        The planes of the comparison; SGBM searches ``floor(min * steps) .. ceil(max * steps)`` px.

    Returns
    -------
    ndarray of shape (H, W), float32
        Disparity per view step, invalid pixels filled from the farther valid neighbour on the row.
    """
    import cv2

    if not steps > 0:
        raise VfxStereoError("SGBM needs the right view to the right of the left one (steps > 0)")
    d = np.asarray(disparities, np.float64)
    dmin = int(np.floor(d.min() * steps))
    dmax = int(np.ceil(d.max() * steps))
    num = int(np.ceil((dmax - dmin + 1) / 16.0) * 16)
    matcher = cv2.StereoSGBM_create(minDisparity=dmin, numDisparities=num, mode=cv2.STEREO_SGBM_MODE_HH,
                                    **SGBM_SETTINGS)
    raw = matcher.compute(_to8(left), _to8(right)).astype(np.float32) / 16.0
    valid = raw >= dmin
    return fill_row_farther(raw, valid) / np.float32(steps)


def hard_key(plate: np.ndarray, disparity: np.ndarray, element: np.ndarray, D) -> np.ndarray:
    """A depth key: the plate where ``disparity > D`` (the scene is in front), else the element over the plate.

    Parameters
    ----------
    plate : ndarray of shape (H, W, 3)
    disparity : ndarray of shape (H, W)
        The scene's disparity per pixel (NaN counts as far).
    element : ndarray of shape (H, W, 4)
        Premultiplied RGBA.
    D : float or ndarray of shape (H, W)
        The element's disparity.

    Returns
    -------
    ndarray of shape (H, W, 3)
    """
    front = np.nan_to_num(np.asarray(disparity, np.float64), nan=-np.inf) > np.asarray(D, np.float64)
    behind = element[..., :3] + (1.0 - element[..., 3:4]) * plate
    return np.where(front[..., None], plate, behind).astype(np.float32)


def forward_warp(image: np.ndarray, disparity: np.ndarray, offset: float) -> np.ndarray:
    """``image`` seen from ``offset`` view steps to the right, by forward-warping each pixel by its disparity.

    A pixel at column x with disparity d lands at ``x - d * offset`` (rounded to the nearest column); where
    several land on one pixel the nearest (largest d) wins; pixels nothing lands on take the colour of the
    farther of their nearest filled neighbours on the row (the background the warp uncovers).
    """
    h, w = disparity.shape
    image = np.asarray(image, np.float32)
    target = np.rint(np.arange(w)[None, :] - np.asarray(disparity, np.float64) * offset).astype(np.int64)
    ok = np.isfinite(disparity) & (target >= 0) & (target < w)
    order = np.argsort(np.where(ok, disparity, -np.inf), axis=None, kind="stable")  # far first, near last
    ys, xs = np.unravel_index(order, (h, w))
    keep = ok[ys, xs]
    ys, xs = ys[keep], xs[keep]
    out = np.zeros_like(image)
    zbuf = np.full((h, w), np.nan, np.float32)
    out[ys, target[ys, xs]] = image[ys, xs]  # later (nearer) writes win
    zbuf[ys, target[ys, xs]] = disparity[ys, xs]
    filled = np.isfinite(zbuf)
    # each hole copies the colour of the farther of its nearest filled neighbours on the row
    src, found = farther_source(np.nan_to_num(zbuf, nan=0.0), filled)
    holes = ~filled & found
    out[holes] = out[np.arange(h)[:, None], src][holes]
    return out
