"""Visibility by re-projection: warp the layers into each view, composite, and find what each view sees.

Section 5 of Szeliski & Golland (1999). The (x, y, d) volume is a stack of acetates (Fig. 4): each layer is
warped into view k (Eq. 5, through :class:`vfxstereo.warp.Warper`), and the warped layers are composited back
to front with the over operator (Eq. 6). The visibility ``V_k(u, v, d)`` of layer d in view k is the product
of the transparencies of the warped layers in front of it (Eq. 7), which turns compositing into a sum
(Eq. 8). The sweep re-weights its colour samples by ``V_k`` (re-estimation), and the refinement stage needs
``V_k`` and the composite of the layers *behind* each layer (:func:`behind`) for the gradient of C1.

Notes
-----
All arrays here are in the coordinates of view k after :func:`reproject`:

============  ==================  ===============================================================
array         shape               meaning
============  ==================  ===============================================================
``rgba``      (D, H, W, 4)        the volume c(x, y, d), premultiplied, scene-linear, reference view
``warped``    (D, H, W, 4)        c_k(u, v, d), every layer warped into view k (Eq. 5)
``V``         (D, H, W)           V_k(u, v, d) in [0, 1]; layer D-1 (largest d, nearest) has V = 1
``behind``    (D, H, W, 4)        a_k(u, v, d-1): over-composite of the warped layers 0..d-1
============  ==================  ===============================================================

Layer index 0 is the smallest disparity (furthest back); the last layer is on top.
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.layers import topmost


def _check_warped(warped: np.ndarray, channels: int | None = 4, name: str = "warped") -> np.ndarray:
    a = np.asarray(warped)
    if channels is None:
        if a.ndim != 3:
            raise VfxStereoError(f"{name} must be (D, H, W), got shape {a.shape}")
    elif a.ndim != 4 or a.shape[-1] != channels:
        raise VfxStereoError(f"{name} must be (D, H, W, {channels}), got shape {a.shape}")
    if a.shape[0] == 0:
        raise VfxStereoError(f"{name} has no layers")
    return a


def reproject(rgba: np.ndarray, warper, k: int, *, out: np.ndarray | None = None) -> np.ndarray:
    """Every layer of the volume warped into view ``k``: ``c_k(u, v, d) = W_b(c(x, y, d))`` (Eq. 5).

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied RGBA volume in the reference (disparity-space) coordinates.
    warper : vfxstereo.warp.Warper
        Plane/view warps for the rig and the ``D`` disparities.
    k : int
        View index.
    out : ndarray of shape (D, H, W, 4), optional
        Buffer to fill (reused across views by the refinement loop).

    Returns
    -------
    ndarray of shape (D, H, W, 4), the dtype of ``rgba``; premultiplied, zero where a view pixel sees
    outside a plane.
    """
    rgba = _check_warped(rgba, name="rgba")
    if rgba.shape[0] != warper.D:
        raise VfxStereoError(f"the volume has {rgba.shape[0]} layers but the warper {warper.D} planes")
    if out is None:
        out = np.empty_like(rgba)
    for i in range(rgba.shape[0]):
        out[i] = warper.to_view(rgba[i], k, i)  # Eq. (5)
    return out


def visibility(warped_alpha: np.ndarray) -> np.ndarray:
    """Soft visibility of each warped layer, Eq. (7).

    ``V(d_max) = 1`` and ``V(d - 1) = V(d) * (1 - alpha_k(d))``, i.e.
    ``V(d) = prod_{d' > d} (1 - alpha_k(d'))``: the fraction of light from layer d that reaches the view
    through the layers in front of it.

    Parameters
    ----------
    warped_alpha : ndarray of shape (D, H, W)
        Opacity of each warped layer, ``alpha_k(u, v, d)`` (the alpha channel of :func:`reproject`).

    Returns
    -------
    ndarray of shape (D, H, W), same floating dtype, values in [0, 1] for alpha in [0, 1].
    """
    a = _check_warped(warped_alpha, channels=None, name="warped_alpha")
    dtype = a.dtype if np.issubdtype(a.dtype, np.floating) else np.float32
    V = np.empty(a.shape, dtype=dtype)
    V[-1] = 1.0  # Eq. (7): V(d_max) = 1
    for d in range(a.shape[0] - 1, 0, -1):
        np.multiply(V[d], 1.0 - a[d], out=V[d - 1])  # Eq. (7): V(d-1) = V(d) (1 - alpha_k(d))
    return V


def simple_visibility(warped_alpha: np.ndarray, *, threshold: float = 0.5) -> np.ndarray:
    """The paper's first, binary visibility (Section 5): ``V_k(u, v, d) = 1 if d >= d_top(u, v) else 0``.

    ``d_top`` is the topmost (largest-d) layer whose warped opacity is at least ``threshold`` at that view
    pixel ("the topmost opaque pixel seen during the compositing step"); where no layer is opaque every
    layer is visible.

    Parameters
    ----------
    warped_alpha : ndarray of shape (D, H, W)
        Opacity of each warped layer.
    threshold : float
        Opacity from which a warped pixel counts as opaque (bilinear warps blur 0/1 mattes at fractional
        shifts, hence not exactly 1).

    Returns
    -------
    ndarray of shape (D, H, W), float32 (or the input's floating dtype), values 0 or 1.
    """
    a = _check_warped(warped_alpha, channels=None, name="warped_alpha")
    dtype = a.dtype if np.issubdtype(a.dtype, np.floating) else np.float32
    D = a.shape[0]
    d_top = topmost(a >= threshold, 0)  # the topmost opaque layer
    return (np.arange(D)[:, None, None] >= d_top[None]).astype(dtype)


def composite(warped: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Re-synthesised view as a visibility-weighted sum, Eq. (8): ``c~_k = sum_d c_k(d) V_k(d)``.

    With the soft visibility of :func:`visibility` this equals the back-to-front over-composite of Eq. (6).

    Parameters
    ----------
    warped : ndarray of shape (D, H, W, 4)
        Warped premultiplied layers (:func:`reproject`).
    V : ndarray of shape (D, H, W)
        Their visibilities.

    Returns
    -------
    ndarray of shape (H, W, 4), premultiplied.
    """
    warped = _check_warped(warped)
    V = np.asarray(V)
    if V.shape != warped.shape[:3]:
        raise VfxStereoError(f"visibility shape {V.shape} does not match the layers {warped.shape[:3]}")
    out = np.zeros(warped.shape[1:], dtype=np.result_type(warped.dtype, V.dtype))
    for d in range(warped.shape[0]):
        out += warped[d] * V[d][..., None]  # Eq. (8)
    return out


def behind(warped: np.ndarray) -> np.ndarray:
    """``a_k(u, v, d - 1)`` for every d: the over-composite of the warped layers behind layer d.

    ``out[0] = 0`` (nothing is behind the furthest layer) and
    ``out[d] = warped[d-1] over ... over warped[0]``.
    The gradient of C1 w.r.t. a layer's opacity needs it (Appendix): the re-synthesised view is
    ``c~_k = sum_{d' > d} c_k(d') V_k(d') + V_k(d) (c_k(d) + (1 - alpha_k(d)) a_k(d - 1))``.

    Parameters
    ----------
    warped : ndarray of shape (D, H, W, 4)
        Warped premultiplied layers.

    Returns
    -------
    ndarray of shape (D, H, W, 4), premultiplied.
    """
    warped = _check_warped(warped)
    out = np.empty_like(warped)
    out[0] = 0.0
    for d in range(1, warped.shape[0]):
        # over: f + (1 - alpha_f) b, with f the next layer up and b what lies behind it
        np.multiply(out[d - 1], 1.0 - warped[d - 1, ..., 3:4], out=out[d])
        out[d] += warped[d - 1]
    return out


def view_visibilities(rgba: np.ndarray, warper, *, simple: bool = False,
                      threshold: float = 0.5) -> tuple[list[np.ndarray], np.ndarray]:
    """Visibility volumes of every view, for the sweep's re-estimation, and the re-synthesised views.

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied RGBA volume in the reference coordinates.
    warper : vfxstereo.warp.Warper
        Plane/view warps.
    simple : bool
        Use the binary visibility of :func:`simple_visibility` instead of Eq. (7). The re-synthesised views
        are the over-composite (Eq. 6) either way.
    threshold : float
        Opacity threshold of the binary visibility.

    Returns
    -------
    visibilities : list of K ndarrays of shape (D, H, W)
        ``V_k(u, v, d)`` in the coordinates of view k, the dtype of ``rgba``.
    views : ndarray of shape (K, H, W, 4)
        Re-synthesised premultiplied views ``c~_k`` (Eqs. 6, 8).
    """
    vis = []
    views = np.empty((warper.K,) + np.shape(rgba)[1:], dtype=np.asarray(rgba).dtype)
    for k, warped, V in _per_view(rgba, warper):
        views[k] = composite(warped, V)  # Eq. (8) == Eq. (6)
        vis.append(simple_visibility(warped[..., 3], threshold=threshold) if simple else V)
    return vis, views


def _per_view(rgba: np.ndarray, warper):
    """Yield ``(k, warped layers, V_k)`` for every view; the warped buffer is reused between views."""
    rgba = _check_warped(rgba, name="rgba")
    buf = np.empty_like(rgba)
    for k in range(warper.K):
        warped = reproject(rgba, warper, k, out=buf)
        yield k, warped, visibility(warped[..., 3])  # Eq. (7)


def resynthesise(rgba: np.ndarray, warper) -> np.ndarray:
    """Every input view re-synthesised from the volume (Eqs. 5, 6, 8).

    Parameters
    ----------
    rgba : ndarray of shape (D, H, W, 4)
        Premultiplied RGBA volume in the reference coordinates.
    warper : vfxstereo.warp.Warper
        Plane/view warps.

    Returns
    -------
    ndarray of shape (K, H, W, 4), premultiplied, the dtype of ``rgba``.
    """
    views = np.empty((warper.K,) + np.shape(rgba)[1:], dtype=np.asarray(rgba).dtype)
    for k, warped, V in _per_view(rgba, warper):
        views[k] = composite(warped, V)  # Eq. (8) == Eq. (6)
    return views
