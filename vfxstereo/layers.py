"""The initial RGBA volume from a depth map: the front surface, and the hidden layers other views see.

Beyond the paper: the paper selects cells by thresholded winner-take-all (Section 4).

* **Front surface.** Each reference pixel becomes one opaque cell on the plane nearest its disparity, with the
  reference view's own colour (the plate), so the flattened volume *is* the plate.
* **Hidden layers.** Where a view sees past a foreground edge, it records background the reference does not.
  The depth map, forward-projected into view k (a z-buffer, :func:`vfxstereo.depth.zbuffer`), leaves exactly
  those view pixels uncovered: nothing the reference sees lands there. Their disparity is taken from the
  farther of the covered pixels around them (:func:`vfxstereo.depth.fill_unreliable`: a disocclusion shows
  the background, never a nearer surface), and their colours are carried onto that plane through the
  Warper (Eq. 1). Cells reached from several views get the mean; only cells strictly behind the front
  surface of their pixel are kept.

The volume's opacities are 0 or 1; soft edges come later (:mod:`vfxstereo.softedge`).
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError

MIN_WEIGHT = 0.5
"""A hidden cell needs at least this much resampled weight (of its bilinear footprint) from uncovered pixels."""


def view_gains(views: np.ndarray, warper, reference: int, disparity: np.ndarray) -> np.ndarray:
    """(K, 3) colour gains that bring each view to the reference's exposure.

    Each is the median ratio of the reference's colour to the view's at the pixels the depth map matches
    (mid-tones only). The reference's gain is 1.

    Cameras of an array differ in exposure and white balance; colours carried from one view into the
    reference's layers (hidden cells, soft edges) are multiplied by its gain.
    """
    K, h, w = views.shape[:3]
    gains = np.ones((K, 3), np.float32)
    ys, xs = np.mgrid[0:h, 0:w]
    ref = views[reference]
    for k in range(K):
        if k == reference:
            continue
        u, v = warper.points_to_view(k, xs.ravel(), ys.ravel(), np.asarray(disparity, np.float64).ravel())
        ui, vi = np.rint(u), np.rint(v)
        ok = np.isfinite(ui) & np.isfinite(vi) & (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
        sample = views[k][vi[ok].astype(np.int64), ui[ok].astype(np.int64)]
        target = ref.reshape(-1, 3)[ok]
        mid = np.all((sample > 0.05) & (sample < 0.9) & (target > 0.05) & (target < 0.9), axis=1)
        if mid.sum() < 100:
            continue
        gains[k] = np.median(target[mid] / sample[mid], axis=0)
    return gains


def clamp(rgba: np.ndarray, white: float) -> np.ndarray:
    """In place: premultiplied colour into ``[0, white * alpha]``.

    Colours carried from other views through their gains can overshoot the reference's white.
    """
    if rgba.flags.c_contiguous and rgba.dtype == np.float32:  # one parallel pass, no temporaries
        from vfxstereo._edge_kernels import clamp_premultiplied

        clamp_premultiplied(rgba.reshape(-1, 4), np.float32(white))
        return rgba
    for layer in (rgba if rgba.ndim == 4 else rgba[None]):  # a layer at a time: no volume-sized temporary
        np.clip(layer[..., :3], 0.0, None, out=layer[..., :3])
        np.minimum(layer[..., :3], np.float32(white) * layer[..., 3:4], out=layer[..., :3])
    return rgba


def plane_index(disparity: np.ndarray, disparities: np.ndarray) -> np.ndarray:
    """Index of the plane nearest each disparity (int32, NaN -> -1)."""
    d = np.asarray(disparities, np.float64)
    x = np.asarray(disparity, np.float64)
    idx = np.clip(np.searchsorted(d, x), 1, len(d) - 1) if len(d) > 1 else np.zeros(x.shape, np.int64)
    if len(d) > 1:
        idx = np.where(np.abs(x - d[idx - 1]) <= np.abs(d[idx] - x), idx - 1, idx)
    return np.where(np.isfinite(x), idx, -1).astype(np.int32)


def slots(planes: np.ndarray | None, n_planes: int) -> np.ndarray:
    """(n_planes,) int: each plane's layer in a volume holding only ``planes`` (-1: not held); identity for None.

    The volumes of :func:`front_volume`, :func:`hidden_volume` and :func:`vfxstereo.softedge.soften_edges`
    may hold a subset of the planes (``SolveConfig.keep_empty_planes``): layer ``j`` is plane ``planes[j]``.
    """
    if planes is None:
        return np.arange(n_planes)
    out = np.full(n_planes, -1, np.int64)
    out[np.asarray(planes, np.int64)] = np.arange(len(planes))
    return out


def front_volume(index: np.ndarray, plate: np.ndarray, n_planes: int, *,
                 planes: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """(D, H, W, 4) premultiplied: opaque plate colour on each pixel's plane ``index`` (-1: nothing).

    ``planes``: hold only these planes (increasing; they must include every plane of ``index``). ``out``: a
    volume of that shape to clear and write into instead of a new one.
    """
    h, w = index.shape
    if plate.shape[:2] != (h, w):
        raise VfxStereoError(f"the plate {plate.shape[:2]} and the depth map {(h, w)} differ in size")
    slot = slots(planes, n_planes)
    shape = (n_planes if planes is None else len(planes), h, w, 4)
    if out is None:
        vol = np.zeros(shape, np.float32)
    else:
        if out.shape != shape:
            raise VfxStereoError(f"front_volume: out has shape {out.shape}, not {shape}")
        vol = out
        # clear only the blocks that hold something: the stack's volume is allocated lazily (np.zeros), and the
        # planes and rows nothing was written to stay unallocated. Clearing it whole for each soft-edge pass made
        # all of it resident: at 4096x2160 x 64, 2.6 GiB more at the peak.
        rows = 64
        for p in range(len(vol)):
            for y in range(0, h, rows):
                block = vol[p, y:y + rows]
                if block.any():
                    block[...] = 0.0
    ys, xs = np.nonzero(index >= 0)
    layer = slot[index[ys, xs]]
    if (layer < 0).any():
        raise VfxStereoError("front_volume: the depth map uses a plane the volume does not hold")
    vol[layer, ys, xs, :3] = plate[ys, xs, :3]
    vol[layer, ys, xs, 3] = 1.0
    return vol


def hidden_volume(views: np.ndarray, warper, reference: int, disparity: np.ndarray, index: np.ndarray,
                  *, guide: np.ndarray | None = None, gains: np.ndarray | None = None,
                  zbuffers: list[np.ndarray] | None = None, out: np.ndarray | None = None,
                  planes: np.ndarray | None = None) -> np.ndarray:
    """(D, H, W, 4) premultiplied: opaque cells behind the front surface, coloured by the views that see them.

    Parameters
    ----------
    views : ndarray of shape (K, H, W, 3)
        Scene-linear views.
    warper : vfxstereo.warp.Warper
    reference : int
        The view the depth map belongs to.
    disparity : ndarray of shape (H, W)
        The reference's sub-pixel disparity (the front surface).
    index : ndarray of shape (H, W)
        The front surface's plane per pixel (:func:`plane_index` of ``disparity``).
    guide : ndarray of shape (K, H, W), optional
        Grey images of the views for the edge-aware fill (default: the views' luma).
    gains : ndarray of shape (K, 3), optional
        Colour gains of the views (:func:`view_gains`); the colours they give are multiplied by them.
    zbuffers : list of ndarray of shape (H, W), optional
        ``disparity``'s z-buffer in each view (:func:`vfxstereo.depth.zbuffer`), made here when not given.
    out : ndarray of shape (D, H, W, 4), optional
        Write the hidden cells into this volume (the front surface's, :func:`front_volume`: they lie strictly
        behind its cells) and return it, instead of a new one. Only planes that hold hidden cells get
        working buffers. It may hold a subset ``planes`` of the planes (see :func:`slots`).
    planes : ndarray of int, optional
        The planes ``out`` holds (default all).
    """
    from vfxstereo.depth import fill_unreliable, zbuffer
    from vfxstereo.matching import grey

    K, h, w = views.shape[:3]
    D = warper.D
    sums: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # plane -> (colour total, weight)
    for k in range(K):
        if k == reference:
            continue
        zb = zbuffer(warper, disparity, k) if zbuffers is None else zbuffers[k]
        covered = np.isfinite(zb)
        if covered.all() or not covered.any():
            continue
        g = guide[k] if guide is not None else grey(views[k])
        behind = fill_unreliable(np.where(covered, zb, 0.0), covered, g)
        hole_plane = np.where(covered, -1, plane_index(behind, warper.disparities))
        for i in np.unique(hole_plane[hole_plane >= 0]):
            m = (hole_plane == i).astype(np.float32)
            wt = warper.to_plane(m, k, int(i))
            if not (wt > MIN_WEIGHT).any():
                continue
            g = 1.0 if gains is None else gains[k]
            if int(i) not in sums:
                sums[int(i)] = (np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.float32))
            total, weight = sums[int(i)]
            total += warper.to_plane(views[k] * m[..., None], k, int(i)) * g
            weight += wt
    slot = slots(planes, D)
    vol = np.zeros((D if planes is None else len(planes), h, w, 4), np.float32) if out is None else out
    for i, (total, weight) in sums.items():
        keep = (weight > MIN_WEIGHT) & (i < index)
        if slot[i] < 0:  # hidden cells lie on planes of the depth map; a volume without them is a caller's bug
            if keep.any():
                raise VfxStereoError(f"hidden_volume: plane {i} holds hidden cells but the volume does not hold it")
            continue
        vol[slot[i], keep, :3] = total[keep] / weight[keep, None]
        vol[slot[i], keep, 3] = 1.0
    return vol


def topmost(mask: np.ndarray, fallback, values=None) -> np.ndarray:
    """The front-most layer where ``mask`` holds.

    (H, W): the index of the last layer along axis 0 of ``mask`` (D, H, W) where it holds -- or, with ``values``
    (D,), that layer's entry of it (its plane, its disparity) -- and ``fallback`` where it holds on none.
    """
    layer = mask.shape[0] - 1 - np.argmax(mask[::-1], axis=0)
    return np.where(mask.any(axis=0), layer if values is None else np.asarray(values)[layer], fallback)


def initial_volume(views: np.ndarray, warper, reference: int, disparity: np.ndarray, index: np.ndarray, *,
                   gains: np.ndarray | None = None, zbuffers: list[np.ndarray] | None = None,
                   planes: np.ndarray | None = None, white: float = 1.0,
                   out: np.ndarray | None = None) -> np.ndarray:
    """The initial volume of a depth map, clamped to ``white``: :func:`front_volume` plus :func:`hidden_volume`.

    The two are disjoint (hidden cells lie behind the front ones). Written into ``out`` when given (cleared
    first), else into a new volume.
    """
    vol = front_volume(index, views[reference], len(warper.disparities), planes=planes, out=out)
    hidden_volume(views, warper, reference, disparity, index, gains=gains, zbuffers=zbuffers, out=vol,
                  planes=planes)
    return clamp(vol, white)
