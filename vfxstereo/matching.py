"""Robust matching costs over K views: census + colour difference (AD-census), through the Warper's geometry.

Beyond the paper. Szeliski & Golland match by the colour variance across views (Eq. 1), which is exact on
synthetic plates but breaks on real cameras: exposure, vignetting and noise differ between them, and one
occluded view ruins the variance. The robust depth stage (:mod:`vfxstereo.depth`) matches instead with

* the **census transform** (Zabih & Woodfill 1994): each pixel becomes a bit string saying which neighbours
  in a ``(2 rh + 1) x (2 rw + 1)`` window are darker; two pixels match when few bits differ (Hamming
  distance). It depends only on the order of grey values, so gain, offset and vignetting between cameras
  do not change it;
* the **absolute colour difference** (AD) of the display-encoded colours, which census lacks on flat
  surfaces;

combined as in AD-census (Mei et al., ICCV Workshops 2011)::

    c_k(x, d) = rho(hamming, lambda_census) + w_ad * rho(ad, lambda_ad),   rho(c, lambda) = 1 - exp(-c / lambda)

Each term saturates at 1, so a view that sees something else (an occluder) adds at most ``1 + w_ad`` and
cannot dominate the mean over views the way a squared difference does.

Per view k and plane d, the reference pixel is compared with view k at the position the plane maps it to
(Eq. A1; a pure shift ``x - d (p_k - p_ref)`` on rectified rigs). Positions between pixels take the bilinear
blend of the four taps' census terms (the census of a resampled image is not defined) and the colour term of
the bilinearly resampled colour. The kernels read both rho from tables (:meth:`MatchingParams.tables`). A view adds to a
cell only where the position is inside its frame and, given a z-buffer of the current depth estimate in
that view (Section 5's visibility, made from a depth map), where nothing nearer lands on that view pixel.

:func:`accumulate` returns the sum of costs and the number of views per cell; the cost volume is their ratio.
Array layout: ``(H, W, D)`` with the planes innermost, the order semi-global matching walks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.sweep import matching_values

CENSUS_RADIUS = (3, 4)
"""Half-sizes ``(rh, rw)`` of the census window: 7 x 9 pixels, 62 bits (fits a uint64)."""
LAMBDA_CENSUS = 30.0
"""Scale of the Hamming distance in the AD-census cost (bits)."""
LAMBDA_AD = 10.0
"""Scale of the colour difference in the AD-census cost (8-bit sRGB units, mean over channels)."""
W_AD = 1.0
"""Weight of the colour term (0: census alone)."""


@dataclass(frozen=True)
class MatchingParams:
    """Settings of the AD-census cost (see the module docstring)."""

    census_radius: tuple[int, int] = CENSUS_RADIUS
    lambda_census: float = LAMBDA_CENSUS
    lambda_ad: float = LAMBDA_AD
    w_ad: float = W_AD

    def __post_init__(self):
        rh, rw = self.census_radius
        if rh < 0 or rw < 0 or (2 * rh + 1) * (2 * rw + 1) - 1 > 64 or rh + rw == 0:
            raise VfxStereoError(f"a census window of radius {self.census_radius} does not fit 64 bits")
        if self.lambda_census <= 0 or self.lambda_ad <= 0 or self.w_ad < 0:
            raise VfxStereoError("lambda_census and lambda_ad must be positive and w_ad not negative")

    @property
    def max_cost(self) -> float:
        """The largest cost one view can add."""
        return 1.0 + self.w_ad

    def tables(self) -> tuple[np.ndarray, np.ndarray]:
        """The kernels' look-up tables: ``rho_census`` and ``w_ad * rho_ad``.

        ``rho_census[h]`` for Hamming distances 0..64, ``w_ad * rho_ad`` of colour differences in steps of
        ``_depth_kernels.AD_TABLE_STEP`` up to where it reaches ``w_ad`` within float32.
        """
        from vfxstereo._depth_kernels import AD_TABLE_STEP

        rho_c = (1.0 - np.exp(-np.arange(65) / self.lambda_census)).astype(np.float32)
        n = int(np.ceil(20.0 * self.lambda_ad / AD_TABLE_STEP)) + 1  # exp(-20) is below float32's resolution
        rho_a = (self.w_ad * (1.0 - np.exp(-np.arange(n) * AD_TABLE_STEP / self.lambda_ad))).astype(np.float32)
        return rho_c, rho_a


def grey(values: np.ndarray) -> np.ndarray:
    """Luma (Rec. 601 weights) of ``(..., 3)`` values, float32; the census and SGM work on it."""
    return (np.asarray(values, np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)).astype(np.float32)


def census_transform(gray: np.ndarray, radius: tuple[int, int] = CENSUS_RADIUS) -> np.ndarray:
    """Census codes of an (H, W) image: bit set where the window neighbour is darker than the centre.

    Bits run over the window row by row, the centre skipped, the first neighbour in the highest bit;
    neighbours outside the frame repeat the edge pixel.

    Returns
    -------
    ndarray of shape (H, W), uint64.
    """
    from vfxstereo import _depth_kernels

    gray = np.ascontiguousarray(gray, dtype=np.float32)
    out = np.empty(gray.shape, np.uint64)
    _depth_kernels.census(gray, int(radius[0]), int(radius[1]), out)
    return out


def census_transform_reference(gray: np.ndarray, radius: tuple[int, int] = CENSUS_RADIUS) -> np.ndarray:
    """Plain numpy :func:`census_transform`, the reference its kernel is tested against."""
    gray = np.asarray(gray, dtype=np.float32)
    rh, rw = radius
    padded = np.pad(gray, ((rh, rh), (rw, rw)), mode="edge")
    h, w = gray.shape
    code = np.zeros((h, w), np.uint64)
    for dy in range(-rh, rh + 1):
        for dx in range(-rw, rw + 1):
            if dy == 0 and dx == 0:
                continue
            nb = padded[rh + dy:rh + dy + h, rw + dx:rw + dx + w]
            code = (code << np.uint64(1)) | (nb < gray).astype(np.uint64)
    return code


def hamming(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Number of differing bits of two uint64 arrays (numpy reference of the kernels' popcount)."""
    x = np.bitwise_xor(np.asarray(a, np.uint64), np.asarray(b, np.uint64))
    shape = x.shape
    bits = np.unpackbits(np.ascontiguousarray(x.reshape(-1)).view(np.uint8).reshape(-1, 8), axis=-1)
    return bits.sum(axis=-1).astype(np.float64).reshape(shape)


@dataclass
class Prepared:
    """What matching needs of each view, computed once: display-encoded values, grey and census codes."""

    values: np.ndarray  # (K, H, W, 3) float32, 8-bit sRGB units
    grey: np.ndarray  # (K, H, W) float32
    census: np.ndarray  # (K, H, W) uint64


def prepare(views: np.ndarray, params: MatchingParams = MatchingParams()) -> Prepared:
    """Matching values (sRGB-encoded x 255, :func:`vfxstereo.sweep.matching_values`), grey and census codes."""
    values = matching_values(views, "srgb")
    g = grey(values)
    codes = np.stack([census_transform(gk, params.census_radius) for gk in g])
    return Prepared(values=np.ascontiguousarray(values), grey=g, census=codes)


def accumulate(prepared: Prepared, warper, k: int, ref: int, total: np.ndarray, count: np.ndarray, *,
               zbuf: np.ndarray | None = None, tolerance: float = 0.0, centre: bool = False,
               params: MatchingParams = MatchingParams(), skip: np.ndarray | None = None) -> None:
    """Add view ``k``'s AD-census cost against view ``ref`` to ``total`` and 1 to ``count`` where it sees a cell.

    Parameters
    ----------
    prepared : Prepared
    warper : vfxstereo.warp.Warper
        Geometry: :meth:`~vfxstereo.warp.Warper.sample_map` gives where each plane's cells land in view k.
    k, ref : int
        The view matched and the reference view (the virtual camera).
    total : ndarray of shape (H, W, D), float32
    count : ndarray of shape (H, W, D), uint8
    zbuf : ndarray of shape (H, W), optional
        The largest disparity that lands on each of view k's pixels (:func:`vfxstereo.depth.zbuffer`): a cell
        whose disparity is more than ``tolerance`` below it is hidden in view k and gets no cost from it.
    centre : bool
        Subtract, per reference pixel, view k's mean cost over the planes it sees there. Views fall out of the
        frame (or behind an occluder) for some planes of a pixel and not others; on a surface without
        texture every plane costs about the same in each view but different views cost differently (gain,
        vignetting, noise), so a plain mean over the views that remain favours the planes the costlier views
        miss. Centred costs carry each view's preference between planes and nothing of its level.
    skip : ndarray of shape (H, W), bool, optional
        Reference pixels that get no cost from view k at all (:func:`vfxstereo.depth.partial_views`).
    """
    from vfxstereo import _depth_kernels

    h, w = warper.shape
    if zbuf is None:
        zbuf = np.full((h, w), -np.inf, np.float32)
    skip = np.zeros((h, w), np.bool_) if skip is None else np.ascontiguousarray(skip, np.bool_)
    args = (prepared.census[ref], prepared.values[ref], prepared.census[k], prepared.values[k])
    lam = params.tables()
    shifts = warper.shifts(k)
    if shifts is not None:
        sx, sy = shifts
        _depth_kernels.accumulate_shift(*args, sx, sy, zbuf, warper.disparities.astype(np.float32),
                                        np.float32(tolerance), *lam, bool(centre), total, count, skip)
        return
    t_k = np.zeros_like(total) if centre else total
    c_k = np.zeros_like(count) if centre else count
    for i in range(warper.D):
        u, v = warper.sample_map(k, i)
        _depth_kernels.accumulate_map(*args, u, v, zbuf, np.float32(warper.disparities[i]),
                                      np.float32(tolerance), *lam, t_k, c_k, i, skip)
    if centre:
        n = c_k.sum(axis=2, dtype=np.float32)
        mean = np.where(n > 0, t_k.sum(axis=2) / np.maximum(n, 1.0), 0.0).astype(np.float32)
        total += np.where(c_k > 0, t_k - mean[..., None], 0.0)
        count += c_k


def cell_cost_reference(prepared: Prepared, k: int, ref: int, y: int, x: int, u: float, v: float,
                        params: MatchingParams = MatchingParams()) -> float:
    """AD-census cost of reference pixel (y, x) against view k at (u, v): the reference of the kernels.

    NaN where (u, v) lies outside the view.
    """
    h, w = prepared.grey.shape[1:]
    if not (0 <= u <= w - 1 and 0 <= v <= h - 1):
        return float("nan")
    u0, v0 = int(np.floor(u)), int(np.floor(v))
    fu, fv = u - u0, v - v0
    u1, v1 = min(u0 + 1, w - 1), min(v0 + 1, h - 1)
    taps = [(v0, u0, (1 - fu) * (1 - fv)), (v0, u1, fu * (1 - fv)), (v1, u0, (1 - fu) * fv), (v1, u1, fu * fv)]
    code = prepared.census[ref][y, x]
    census = sum(wt * (1 - np.exp(-hamming(code, prepared.census[k][b, a]) / params.lambda_census))
                 for b, a, wt in taps)
    sample = sum(wt * prepared.values[k][b, a].astype(np.float64) for b, a, wt in taps)
    ad = float(np.abs(sample - prepared.values[ref][y, x]).mean())
    return float(census + params.w_ad * (1 - np.exp(-ad / params.lambda_ad)))
