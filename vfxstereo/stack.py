"""The LayerStack: premultiplied RGBA layers, one per disparity plane, and the conventions of the house.

Conventions (followed by every module):

* arrays are ``[row, col]`` (``[y, x]``); ``rgba`` is ``(D, H, W, 4)`` float32;
* colour is scene-linear; RGBA is premultiplied unless a name says ``straight``;
* ``disparities`` are strictly increasing; larger d is nearer the camera, so the last layer is on top;
* a point at column x of the reference view on plane d appears at column ``x - d * (p_k - p_ref)`` of
  view k (see :mod:`vfxstereo.geometry`).

============  =============================  ============================
array         shape                          meaning
============  =============================  ============================
``rgba``      (D, H, W, 4) float32            premultiplied, scene-linear
``disparities`` (D,) float64                  px per view step, increasing
============  =============================  ============================
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera, plane_to_view

# Tolerance of the validation rules (alpha in [0, 1], colour <= white * alpha): half-float rounding and
# bilinear resampling stay well inside it.
TOLERANCE = 2e-3


def _layer_checks(rgba: np.ndarray, white: float) -> tuple[int, float, float, float, float]:
    """Checks of a (D, H, W, 4) stack, a layer at a time (no stack-sized temporaries).

    Returns the number of non-finite values, alpha's least and largest, colour's least, and the most colour
    exceeds ``white`` times alpha.
    """
    if rgba.flags.c_contiguous and rgba.dtype == np.float32 and rgba.size >= 1 << 20:  # one parallel pass
        from vfxstereo._edge_kernels import stack_checks

        bad, a_min, a_max, c_min, excess = stack_checks(rgba.reshape(-1, 4), float(white))
        return int(bad), float(a_min), float(a_max), float(c_min), float(excess)
    bad, a_min, a_max, c_min, excess = 0, np.inf, -np.inf, np.inf, -np.inf
    for layer in rgba:
        finite = np.isfinite(layer)
        if not finite.all():
            bad += int(np.count_nonzero(~finite))
            continue
        alpha, rgb = layer[..., 3], layer[..., :3]
        a_min, a_max = min(a_min, float(alpha.min())), max(a_max, float(alpha.max()))
        c_min = min(c_min, float(rgb.min()))
        excess = max(excess, float((rgb - white * alpha[..., None]).max()))
    return bad, a_min, a_max, c_min, excess


def over(fg: np.ndarray, bg: np.ndarray) -> np.ndarray:
    """Porter-Duff over of premultiplied RGBA: ``fg + (1 - fg.a) * bg`` (Section 5, the over operator)."""
    return fg + (1.0 - fg[..., 3:4]) * bg


def composite_back_to_front(layers) -> np.ndarray:
    """Eq. (6): ``c_k = c(d_max) over ... over c(d_min)``; ``layers`` iterate from d_min (back) to d_max.

    ``layers`` is any iterable of premultiplied (H, W, 4) arrays; the first is furthest back.
    """
    acc = None
    for layer in layers:
        acc = layer.astype(np.float32, copy=True) if acc is None else over(layer, acc)
    if acc is None:
        raise VfxStereoError("nothing to composite: the stack has no layers")
    return acc


@dataclass
class LayerStack:
    """Premultiplied RGBA layers at disparity planes, the camera they were solved for, and metadata.

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied, scene-linear RGBA, one layer per disparity. Floating input is stored as float32.
    disparities : ndarray of shape (D,)
        Strictly increasing disparities (px per view step); the last layer is nearest (on top).
    camera : Camera or None
        Positions of the views and of the virtual (reference) camera; ``None`` means a single reference
        view at position 0 and views at the positions :meth:`render` is given.
    metadata : dict
        Free-form, JSON-serialisable: colour space, solver settings, source files, version.
    white : float
        Largest straight (unpremultiplied) colour value allowed, 1.0 for display-range plates; plates with
        highlights above 1.0 set it to their peak. Recorded in the metadata.
    plate : ndarray of shape (H, W, 3) or None
        The reference view the stack was solved from (scene-linear RGB), when the virtual camera is one of
        the views. Z-keying composes into it (:func:`vfxstereo.composite.insert`), so the comp equals the
        plate wherever the element changes nothing; ``None`` for stacks without a plate.

    Raises
    ------
    VfxStereoError
        On any broken rule: shapes, dtype, non-finite values, alpha outside [0, 1], colour above
        ``white * alpha`` or below 0 (all within :data:`TOLERANCE`).
    """

    rgba: np.ndarray
    disparities: np.ndarray
    camera: Camera | None = None
    metadata: dict = field(default_factory=dict)
    white: float = 1.0
    plate: np.ndarray | None = None

    def __post_init__(self):
        rgba = np.asarray(self.rgba)
        if rgba.ndim != 4 or rgba.shape[-1] != 4:
            raise VfxStereoError(f"a layer stack must be (D, H, W, 4) RGBA, got shape {rgba.shape}")
        if rgba.shape[0] == 0 or rgba.shape[1] == 0 or rgba.shape[2] == 0:
            raise VfxStereoError(f"a layer stack cannot be empty, got shape {rgba.shape}")
        if not np.issubdtype(rgba.dtype, np.floating):
            raise VfxStereoError(f"layer stack values must be floating point, got {rgba.dtype}")
        rgba = np.ascontiguousarray(rgba, dtype=np.float32)
        disp = np.asarray(self.disparities, dtype=np.float64).reshape(-1)
        if disp.shape != (rgba.shape[0],):
            raise VfxStereoError(f"{rgba.shape[0]} layers need {rgba.shape[0]} disparities, got {disp.size}")
        if not np.all(np.isfinite(disp)):
            raise VfxStereoError("disparities must be finite")
        if disp.size > 1 and not np.all(np.diff(disp) > 0):
            raise VfxStereoError("disparities must be strictly increasing (the last layer is nearest)")
        white = float(self.white)
        if not (np.isfinite(white) and white > 0):
            raise VfxStereoError(f"white must be a positive number, got {self.white}")
        bad, a_min, a_max, c_min, excess = _layer_checks(rgba, white)
        if bad:
            raise VfxStereoError(f"layer stack holds {bad} NaN or infinite values")
        if a_min < -TOLERANCE or a_max > 1 + TOLERANCE:
            raise VfxStereoError(f"alpha must lie in [0, 1], found [{a_min:.4g}, {a_max:.4g}]")
        if c_min < -TOLERANCE:
            raise VfxStereoError(f"premultiplied colour must not be negative, found {c_min:.4g}")
        if excess > TOLERANCE * max(1.0, white):
            raise VfxStereoError(
                f"premultiplied colour exceeds alpha by {excess:.4g}: the layers are not premultiplied "
                f"(or their straight colour exceeds white={white:g})"
            )
        if self.camera is not None and not isinstance(self.camera, Camera):
            raise VfxStereoError("camera must be a vfxstereo.Camera")
        if not isinstance(self.metadata, dict):
            raise VfxStereoError("metadata must be a dict")
        if self.plate is not None:
            plate = np.asarray(self.plate)
            if plate.shape != (*rgba.shape[1:3], 3) or not np.issubdtype(plate.dtype, np.floating):
                raise VfxStereoError(f"the plate must be a float (H, W, 3) image of the stack's size "
                                     f"{rgba.shape[1:3]}, got {plate.dtype} {plate.shape}")
            plate = np.ascontiguousarray(plate, dtype=np.float32)
            if not np.all(np.isfinite(plate)):
                raise VfxStereoError(f"the plate holds {int(np.count_nonzero(~np.isfinite(plate)))} NaN or "
                                     f"infinite values")
            self.plate = plate
        self.rgba = rgba
        self.disparities = disp
        self.white = white

    # ---------------------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int, int]:
        """``(D, H, W)``."""
        return self.rgba.shape[:3]

    @property
    def depth(self) -> int:
        """Number of layers D."""
        return self.rgba.shape[0]

    def copy(self) -> LayerStack:
        """A deep copy."""
        return LayerStack(self.rgba.copy(), self.disparities.copy(), self.camera, copy.deepcopy(self.metadata),
                          self.white, None if self.plate is None else self.plate.copy())

    def flatten(self) -> np.ndarray:
        """Back-to-front over of every layer (Eq. 6), the largest disparity on top.

        Returns
        -------
        ndarray of shape (H, W, 4), float32, premultiplied.
        """
        return composite_back_to_front(self.rgba)

    def render(self, position) -> np.ndarray:
        """Re-synthesise the view of a camera at baseline ``position`` (Eqs. 5-6, shift path).

        Each layer is shifted by ``d * (p - p_ref)`` (sub-pixel shifts bilinear, zero outside the frame) and
        the layers are composited back to front. ``position`` is a number or an ``(x, y)`` pair in view steps;
        interpolated and extrapolated positions both work.

        Returns
        -------
        ndarray of shape (H, W, 4), float32, premultiplied.
        """
        offset = self.camera.offset(position) if self.camera is not None else Camera(
            positions=[0.0], reference=0.0).offset(position)
        return composite_back_to_front(
            plane_to_view(layer, d, offset) for layer, d in zip(self.rgba, self.disparities, strict=True)
        )

    def visibility_weights(self) -> np.ndarray:
        """Each layer's contribution to the flattened alpha: ``alpha_d * prod_{d' > d} (1 - alpha_d')`` (Eq. 7).

        Returns
        -------
        ndarray of shape (D, H, W), float32; sums over D to the flattened alpha.
        """
        alpha = self.rgba[..., 3]
        transmit = np.ones(alpha.shape[1:], dtype=np.float32)
        w = np.empty_like(alpha)
        for i in range(self.depth - 1, -1, -1):
            w[i] = alpha[i] * transmit
            transmit = transmit * (1.0 - alpha[i])
        return w

    def disparity_map(self, threshold: float = 0.5, *, weighted: bool = False) -> np.ndarray:
        """Per-pixel disparity of the reference view.

        Parameters
        ----------
        threshold : float
            With ``weighted=False``: the disparity of the front-most layer whose alpha exceeds it.
        weighted : bool
            If True, the average of the disparities weighted by each layer's visible contribution
            (:meth:`visibility_weights`), which gives fractional disparities at soft edges.

        Returns
        -------
        ndarray of shape (H, W), float32; NaN where no layer qualifies (or nothing is visible).
        """
        if weighted:
            w = self.visibility_weights()
            total = w.sum(axis=0)
            num = np.tensordot(self.disparities.astype(np.float32), w, axes=(0, 0))
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.where(total > 1e-6, num / np.where(total > 1e-6, total, 1.0), np.nan)
            return out.astype(np.float32)
        from vfxstereo.layers import topmost

        return topmost(self.rgba[..., 3] > threshold, np.nan, self.disparities).astype(np.float32)

    def alpha_coverage(self) -> np.ndarray:
        """Mean alpha of each layer over the frame, shape (D,): how much of the picture each layer holds."""
        return self.rgba[..., 3].mean(axis=(1, 2), dtype=np.float64)
