"""Stage 2: evidence aggregation over (x, y) at each disparity (Section 4, Eq. 2), and alternatives.

The paper's rule (a variant of Scharstein & Szeliski 1996) diffuses variances to their four neighbours while
keeping the original variance in play::

    sigma_i^{t+1} = a sigma_i^t + b sum_{j in N4(i)} min(sigma_j^t, sigma_max) + c sigma_i^0     # Eq. (2)

with (a, b, c) = (0.1, 0.15, 0.3) and sigma_max = 16 (8-bit units squared). ``a + 4 b + c = 1``, so a
constant field below sigma_max stays constant. The extracted text lost which terms carry the tilde (the
limit); :func:`aggregate_szeliski1999` limits the neighbour terms only (``limit_centre=False``, the default)
or the centre term as well (``limit_centre=True``). The two differ little (a = 0.1 is small): on the Fig. 6
random-dot stereogram (10 seeds) neighbours-only picked 307 wrong winners against 324, on tsukuba they tie
(3.67 % vs 3.66 % bad among selected), so the default is the reading that lets a cell's own evidence above
sigma_max count in full.

Decisions
---------
* Frame edge: replicate -- a neighbour outside the frame is the cell itself, so the weights still sum to 1.
* Cells with no votes (variance ``+inf``, :mod:`vfxstereo.sweep`) stay ``+inf`` (the ``c sigma^0`` term keeps
  them there) and never poison their neighbours, which only see ``min(inf, sigma_max) = sigma_max``.

Registry: :data:`AGGREGATION_METHODS` maps a name to a function ``f(var, **settings)``; :func:`aggregate`
is the front end (``method="szeliski1999"`` or ``"box"``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import ndimage

from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress, report

A = 0.1
"""Weight of the current variance (a in Eq. 2)."""
B = 0.15
"""Weight of each limited neighbour variance (b in Eq. 2)."""
C = 0.3
"""Weight of the original variance sigma^0 (c in Eq. 2)."""
SIGMA_MAX = 16.0
"""Limit of the robustified variance (sigma_max in Eq. 2), 8-bit units squared."""
ITERATIONS = 10
"""Default number of iterations of Eq. (2) (the paper does not give one)."""


def _check_volume(var) -> np.ndarray:
    var = np.asarray(var, dtype=np.float32)
    if var.ndim != 3:
        raise VfxStereoError(f"a variance volume must be (D, H, W), got shape {var.shape}")
    if np.isnan(var).any():
        raise VfxStereoError("the variance volume contains NaN")
    return var


def _neighbour_sum(s: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Sum of the four (x, y) neighbours of every cell of ``s`` (D, H, W), edges replicated."""
    out[:] = 0.0
    out[:, 1:, :] += s[:, :-1, :]  # up
    out[:, 0, :] += s[:, 0, :]
    out[:, :-1, :] += s[:, 1:, :]  # down
    out[:, -1, :] += s[:, -1, :]
    out[:, :, 1:] += s[:, :, :-1]  # left
    out[:, :, 0] += s[:, :, 0]
    out[:, :, :-1] += s[:, :, 1:]  # right
    out[:, :, -1] += s[:, :, -1]
    return out


def aggregate_szeliski1999(var, *, iterations: int = ITERATIONS, a: float = A, b: float = B, c: float = C,
                           sigma_max: float = SIGMA_MAX, limit_centre: bool = False,
                           progress: Progress | None = None) -> np.ndarray:
    """Iterative evidence aggregation, Eq. (2).

    Parameters
    ----------
    var : ndarray of shape (D, H, W)
        The sweep's variances sigma^0 (8-bit units squared); ``+inf`` marks cells with too few votes.
    iterations : int
        Number of updates (0 returns sigma^0).
    a, b, c : float
        Weights of Eq. (2): current value, each of the four limited neighbours, original value.
    sigma_max : float
        Limit of the robustified variance ``min(sigma, sigma_max)``.
    limit_centre : bool
        Limit the centre term ``a sigma_i^t`` as well as the neighbour terms.
    progress : callable, optional
        ``progress("aggregate", t, iterations)``.

    Returns
    -------
    ndarray of shape (D, H, W), float32
        Aggregated variances; ``+inf`` where sigma^0 was.
    """
    sigma0 = _check_volume(var)
    if iterations < 0:
        raise VfxStereoError(f"aggregation iterations must be >= 0, got {iterations}")
    sigma = sigma0.copy()
    limited = np.empty_like(sigma)
    nsum = np.empty_like(sigma)
    novote = ~np.isfinite(sigma0)
    c_sigma0 = np.where(novote, 0.0, np.float32(c) * sigma0).astype(np.float32)
    a32, b32, smax = np.float32(a), np.float32(b), np.float32(sigma_max)
    for t in range(iterations):
        np.minimum(sigma, smax, out=limited)  # sigma~ = min(sigma, sigma_max)
        _neighbour_sum(limited, nsum)
        centre = limited if limit_centre else sigma
        # Eq. (2): sigma^{t+1} = a sigma^t + b sum_N4 sigma~^t + c sigma^0
        with np.errstate(invalid="ignore"):
            sigma = a32 * centre + b32 * nsum + c_sigma0
        sigma[novote] = np.inf  # cells without votes stay out of the running (the c sigma^0 term)
        report(progress, "aggregate", t + 1, iterations)
    return sigma.astype(np.float32, copy=False)


def aggregate_box(var, *, radius: int = 2, progress: Progress | None = None) -> np.ndarray:
    """Square-window aggregation (SSD/SSSD style): the mean variance over a ``(2r+1)^2`` window per plane.

    Cells with no votes (``+inf``) are left out of their neighbours' windows (normalised convolution) and
    stay ``+inf`` themselves. The window is clipped at the frame edge.

    Parameters
    ----------
    var : ndarray of shape (D, H, W)
        The sweep's variances.
    radius : int
        Window half-size r.
    progress : callable, optional
        ``progress("aggregate", 1, 1)`` when done.

    Returns
    -------
    ndarray of shape (D, H, W), float32
    """
    var = _check_volume(var)
    if radius < 0:
        raise VfxStereoError(f"box radius must be >= 0, got {radius}")
    finite = np.isfinite(var)
    vals = np.where(finite, var, 0.0).astype(np.float64)
    size = (1, 2 * radius + 1, 2 * radius + 1)
    num = ndimage.uniform_filter(vals, size=size, mode="constant", cval=0.0)
    den = ndimage.uniform_filter(finite.astype(np.float64), size=size, mode="constant", cval=0.0)
    out = np.where(finite & (den > 0), num / np.where(den > 0, den, 1.0), np.inf).astype(np.float32)
    report(progress, "aggregate", 1, 1)
    return out


AGGREGATION_METHODS: dict[str, Callable[..., np.ndarray]] = {
    "szeliski1999": aggregate_szeliski1999,
    "box": aggregate_box,
}
"""Aggregation methods by name: ``"szeliski1999"`` (Eq. 2, the default) and ``"box"`` (square window)."""


def aggregate(var, method: str = "szeliski1999", **settings) -> np.ndarray:
    """Aggregate a (D, H, W) variance volume with the named method of :data:`AGGREGATION_METHODS`.

    Parameters
    ----------
    var : ndarray of shape (D, H, W)
        Variances from :func:`vfxstereo.sweep.sweep`.
    method : str
        Key of :data:`AGGREGATION_METHODS`.
    **settings
        Passed to the method (e.g. ``iterations``, ``limit_centre`` for ``"szeliski1999"``).

    Returns
    -------
    ndarray of shape (D, H, W), float32
    """
    try:
        fn = AGGREGATION_METHODS[method]
    except KeyError:
        raise VfxStereoError(
            f"unknown aggregation method {method!r}; choose one of: {', '.join(AGGREGATION_METHODS)}"
        ) from None
    return fn(var, **settings)
