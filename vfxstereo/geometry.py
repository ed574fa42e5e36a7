"""Camera geometry: the virtual camera, disparity planes and the warps between planes and views.

Section 3 and the Appendix of Szeliski & Golland (1999). The convention, written once here and in
:mod:`vfxstereo.stack` and followed everywhere:

* arrays are indexed ``[row, col]`` (``[y, x]``);
* a point at column x, row y of the reference (virtual) camera, on the plane of disparity d, appears at
  ``(x - d * (p_k.x - p_ref.x), y - d * (p_k.y - p_ref.y))`` in view k, where ``p`` is a camera's position
  along the baseline in view steps (1-D rigs have ``p.y == 0``);
* larger d is nearer the camera.

The rectified fast path is a pure shift per (plane, view). Sampling is bilinear with zero outside the frame,
and :func:`shift_bilinear` with ``(-sx, -sy)`` is the exact adjoint (transpose) of the same function with
``(sx, sy)``; the gradient of the refinement stage relies on that (Appendix, "transpose of the linear
mapping induced by the backward warp").

General cameras (3x4 matrices M_k and a 4x4 collineation M0) are handled by :mod:`vfxstereo.homography`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from vfxstereo.errors import VfxStereoError

# A shift closer than this to a whole pixel is taken as whole: d * dp with d on a fine grid is then exact.
_WHOLE_PIXEL_TOL = 1e-6


def _as_positions(positions) -> np.ndarray:
    """Positions as a (K, 2) float64 array; 1-D positions get y = 0."""
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim == 1:
        p = np.stack([p, np.zeros_like(p)], axis=1)
    if p.ndim != 2 or p.shape[1] != 2:
        raise VfxStereoError(f"camera positions must be K numbers or K (x, y) pairs, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise VfxStereoError("camera positions must be finite numbers")
    return p


@dataclass(frozen=True)
class Camera:
    """Where the views were taken from, relative to the virtual (reference) camera.

    Parameters
    ----------
    positions : ndarray of shape (K, 2)
        Each view's position along the baseline in view steps, ``(x, y)``; 1-D input gets ``y = 0``.
    reference : ndarray of shape (2,)
        Position of the virtual camera whose (x, y, d) space the stack lives in.
    reference_index : int or None
        Index of the view the virtual camera coincides with, when it is one of them.
    focal : float or None
        Focal length in pixels, for the disparity-to-depth mapping ``Z = focal * baseline / d``.
    baseline : float or None
        World distance of one position step (scene units per view step).
    matrices : ndarray of shape (K, 3, 4) or None
        General cameras M_k (Appendix, Eq. A1); ``None`` for the rectified shift path.
    M0 : ndarray of shape (4, 4) or None
        Collineation from world to disparity space ``[x y 1 d]``; with ``matrices``.
    """

    positions: np.ndarray
    reference: np.ndarray
    reference_index: int | None = None
    focal: float | None = None
    baseline: float | None = None
    matrices: np.ndarray | None = field(default=None)
    M0: np.ndarray | None = field(default=None)

    def __post_init__(self):
        object.__setattr__(self, "positions", _as_positions(self.positions))
        ref = np.asarray(self.reference, dtype=np.float64).reshape(-1)
        if ref.size == 1:
            ref = np.array([ref[0], 0.0])
        if ref.shape != (2,) or not np.all(np.isfinite(ref)):
            raise VfxStereoError("the reference position must be one number or an (x, y) pair")
        object.__setattr__(self, "reference", ref)
        if self.matrices is not None:
            m = np.asarray(self.matrices, dtype=np.float64)
            if m.shape != (len(self.positions), 3, 4):
                raise VfxStereoError(f"camera matrices must have shape (K, 3, 4), got {m.shape}")
            object.__setattr__(self, "matrices", m)
            m0 = np.asarray(self.M0, dtype=np.float64) if self.M0 is not None else None
            if m0 is None or m0.shape != (4, 4):
                raise VfxStereoError("general cameras need a 4x4 M0 (world to disparity space)")
            object.__setattr__(self, "M0", m0)

    @classmethod
    def from_positions(cls, positions, reference: int | None = None, **kwargs) -> Camera:
        """Camera of views at ``positions`` with the virtual camera at view ``reference`` (default middle)."""
        p = _as_positions(positions)
        k = len(p)
        if reference is None:
            reference = k // 2
        if not 0 <= reference < k:
            raise VfxStereoError(f"reference view {reference} is not one of the {k} views")
        return cls(positions=p, reference=p[reference], reference_index=int(reference), **kwargs)

    @property
    def K(self) -> int:  # noqa: N802 - the paper's symbol
        """Number of views."""
        return len(self.positions)

    @property
    def is_general(self) -> bool:
        """True when views are given by camera matrices rather than baseline positions."""
        return self.matrices is not None

    def view_offset(self, k: int) -> np.ndarray:
        """``p_k - p_ref`` of view ``k`` (an index into :attr:`positions`)."""
        return self.positions[int(k)] - self.reference

    def offset(self, position) -> np.ndarray:
        """``p - p_ref`` for a camera at ``position`` (a number or an ``(x, y)`` pair, in view steps).

        A number is always a position, never a view index: use :meth:`view_offset` for view k.
        """
        p = np.asarray(position, dtype=np.float64).reshape(-1)
        if p.size == 1:
            p = np.array([p[0], 0.0])
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise VfxStereoError(f"a camera position is one number or an (x, y) pair, got {position!r}")
        return p - self.reference

    def depth_from_disparity(self, d) -> np.ndarray:
        """Depth of disparity ``d``: ``focal * baseline / d`` when both are known, else ``1 / d``.

        Disparity 0 (infinitely far) maps to ``inf``. This is the mapping of the deep EXR's Z channel.
        """
        d = np.asarray(d, dtype=np.float64)
        scale = self.focal * self.baseline if self.focal and self.baseline else 1.0
        with np.errstate(divide="ignore"):
            return np.where(d > 0, scale / np.where(d > 0, d, 1.0), np.inf)

    def disparity_from_depth(self, z) -> np.ndarray:
        """Inverse of :meth:`depth_from_disparity`."""
        z = np.asarray(z, dtype=np.float64)
        scale = self.focal * self.baseline if self.focal and self.baseline else 1.0
        with np.errstate(divide="ignore"):
            return np.where(np.isfinite(z) & (z > 0), scale / np.where(z > 0, z, 1.0), 0.0)

    def to_dict(self) -> dict:
        """Plain-JSON form, for file headers."""
        out = {
            "positions": self.positions.tolist(),
            "reference": self.reference.tolist(),
            "reference_index": self.reference_index,
            "focal": self.focal,
            "baseline": self.baseline,
        }
        if self.matrices is not None:
            out["matrices"] = self.matrices.tolist()
            out["M0"] = self.M0.tolist()
        return out

    @classmethod
    def from_dict(cls, d: dict) -> Camera:
        """Inverse of :meth:`to_dict`."""
        try:
            return cls(
                positions=d["positions"],
                reference=d["reference"],
                reference_index=d.get("reference_index"),
                focal=d.get("focal"),
                baseline=d.get("baseline"),
                matrices=d.get("matrices"),
                M0=d.get("M0"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise VfxStereoError(f"camera description is incomplete or malformed: {exc}") from None

    def to_json(self) -> str:
        """JSON text of :meth:`to_dict`."""
        return json.dumps(self.to_dict())

    def __eq__(self, other) -> bool:
        if not isinstance(other, Camera):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None


# --------------------------------------------------------------------------------------------------------
# Rectified fast path: bilinear shifts with zero outside the frame.


def _split_shift(s: float) -> tuple[int, float]:
    """Whole and fractional part of a shift, snapping near-whole shifts to whole ones."""
    i = math.floor(s)
    f = s - i
    if f < _WHOLE_PIXEL_TOL:
        f = 0.0
    elif f > 1.0 - _WHOLE_PIXEL_TOL:
        i, f = i + 1, 0.0
    return i, f


def _add_shifted(out: np.ndarray, a: np.ndarray, i: int, w: float, axis: int) -> None:
    """``out[x] += w * a[x + i]`` along ``axis`` where ``x + i`` lies inside ``a``."""
    n = a.shape[axis]
    x0, x1 = max(0, -i), min(n, n - i)
    if x1 <= x0 or w == 0.0:
        return
    dst = [slice(None)] * a.ndim
    src = [slice(None)] * a.ndim
    dst[axis] = slice(x0, x1)
    src[axis] = slice(x0 + i, x1 + i)
    if w == 1.0:
        out[tuple(dst)] += a[tuple(src)]
    else:
        out[tuple(dst)] += np.asarray(w, dtype=a.dtype) * a[tuple(src)]


def _shift_axis(a: np.ndarray, s: float, axis: int) -> np.ndarray:
    i, f = _split_shift(s)
    out = np.zeros_like(a)
    _add_shifted(out, a, i, 1.0 - f, axis)
    _add_shifted(out, a, i + 1, f, axis)
    return out


def shift_bilinear(img: np.ndarray, sx: float, sy: float = 0.0) -> np.ndarray:
    """Sample ``img`` at ``(x + sx, y + sy)`` bilinearly, zero outside the frame.

    ``out[y, x] = img(y + sy, x + sx)``. ``shift_bilinear(g, -sx, -sy)`` is its exact adjoint: for any
    a, b, ``<shift_bilinear(a, sx, sy), b> == <a, shift_bilinear(b, -sx, -sy)>``.

    Parameters
    ----------
    img : ndarray of shape (H, W) or (H, W, C)
        Any float image; the dtype is kept.
    sx, sy : float
        Shift in pixels along columns and rows.

    Returns
    -------
    ndarray of the same shape and dtype as ``img``.
    """
    out = _shift_axis(img, float(sx), axis=1) if sx != 0 else img.copy()
    if sy != 0:
        out = _shift_axis(out, float(sy), axis=0)
    return out


def plane_to_view(layer: np.ndarray, d: float, offset) -> np.ndarray:
    """Backward warp W_b of one disparity plane into a view at ``offset = p_k - p_ref`` (Eq. 5, shift path).

    A reference pixel x on plane d lands at ``x - d * offset`` in the view, so the view samples the plane at
    ``u + d * offset``.
    """
    return shift_bilinear(layer, d * offset[0], d * offset[1])


def view_to_plane(image: np.ndarray, d: float, offset) -> np.ndarray:
    """Forward warp W_f of a view onto disparity plane d (Eq. 1, shift path); the adjoint of plane_to_view."""
    return shift_bilinear(image, -d * offset[0], -d * offset[1])
