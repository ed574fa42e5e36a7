"""numba kernels of :mod:`vfxstereo.softedge` and :mod:`vfxstereo.layers`.

Foreground colour samples for the single-view alpha estimate; clamping a premultiplied volume in one pass.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True, nogil=True)
def clamp_premultiplied(cells, white):
    """In place, each row (R, G, B, A) of ``cells`` (N, 4): colour into ``[0, white * A]``.

    Only cells that change are written: most of a volume is empty, and its pages, never written, stay
    unallocated (writing them all cost 1.5 s per HD x 64-plane volume in page faults).
    """
    for n in prange(cells.shape[0]):
        top = white * cells[n, 3]
        for c in range(3):
            v = cells[n, c]
            if v < 0.0:
                cells[n, c] = 0.0
            elif v > top:
                cells[n, c] = top


@njit(cache=True, parallel=True, nogil=True)
def stack_checks(cells, white):
    """The stack's checks over the rows (R, G, B, A) of ``cells`` (N, 4), in one pass.

    Returns the number of non-finite values, alpha's least and largest, colour's least, and the most colour
    exceeds ``white`` times alpha.
    """
    n = cells.shape[0]
    blocks = 64
    bad = np.zeros(blocks, np.int64)
    a_min = np.full(blocks, np.inf)
    a_max = np.full(blocks, -np.inf)
    c_min = np.full(blocks, np.inf)
    excess = np.full(blocks, -np.inf)
    step = (n + blocks - 1) // blocks
    for b in prange(blocks):
        for i in range(b * step, min(n, (b + 1) * step)):
            a = cells[i, 3]
            finite = np.isfinite(a)
            for c in range(3):
                finite = finite and np.isfinite(cells[i, c])
            if not finite:
                for c in range(4):
                    if not np.isfinite(cells[i, c]):
                        bad[b] += 1
                continue
            a_min[b] = min(a_min[b], a)
            a_max[b] = max(a_max[b], a)
            for c in range(3):
                v = cells[i, c]
                c_min[b] = min(c_min[b], v)
                excess[b] = max(excess[b], v - white * a)
    return bad.sum(), a_min.min(), a_max.max(), c_min.min(), excess.max()


@njit(cache=True, nogil=True)
def colour_alpha(ys, xs, fplane, index, solid, plate, background, max_steps, tie, walk, alpha_out, sep_out, dist_out):
    """Alpha of band pixel n from the plate and its background, with the foreground colour sampled nearby.

    For each of 8 directions, the nearest ``solid`` pixel (at most ``max_steps`` away) whose plane ``index``
    equals the pixel's front plane ``fplane[n]`` and whose colour is at least ``walk[n]`` from the pixel's
    background B (``|F - B|^2``; closer ones are walked past) is a foreground sample F. With B,
    ``alpha = clip((I - B) . (F - B) / |F - B|^2, 0, 1)`` and the sample that explains the plate best
    (least ``|I - alpha F - (1 - alpha) B|^2``) wins; of samples within ``tie[n]`` of each other, the one that
    separates the layers best (largest ``|F - B|^2``). Outputs alpha, ``|F - B|^2`` (how well colour separates
    the layers) and the residual; -1 alpha where no sample was found.
    """
    H, W = index.shape
    n_px = ys.shape[0]
    for n in range(n_px):
        y = ys[n]
        x = xs[n]
        f = fplane[n]
        best = np.inf
        alpha_out[n] = -1.0
        sep_out[n] = 0.0
        dist_out[n] = np.inf
        for r in range(8):
            dy = (0, 0, 1, -1, 1, 1, -1, -1)[r]
            dx = (1, -1, 0, 0, 1, -1, 1, -1)[r]
            yy = y + dy
            xx = x + dx
            steps = 1
            num = 0.0
            den = 0.0
            while 0 <= yy < H and 0 <= xx < W and steps <= max_steps:
                if solid[yy, xx] and index[yy, xx] == f:
                    num = 0.0
                    den = 0.0
                    for c in range(3):
                        fb = plate[yy, xx, c] - background[n, c]
                        num += (plate[y, x, c] - background[n, c]) * fb
                        den += fb * fb
                    if den >= walk[n]:
                        break
                yy += dy
                xx += dx
                steps += 1
            if not (0 <= yy < H and 0 <= xx < W) or steps > max_steps:
                continue
            if den < 1e-8:
                continue
            a = min(max(num / den, 0.0), 1.0)
            dist = 0.0
            for c in range(3):
                e = plate[y, x, c] - a * plate[yy, xx, c] - (1.0 - a) * background[n, c]
                dist += e * e
            if dist < best - tie[n] or (dist < best + tie[n] and den > sep_out[n]):
                best = min(dist, best)
                alpha_out[n] = a
                sep_out[n] = den
                dist_out[n] = dist


@njit(cache=True, parallel=True, nogil=True)
def adjacent_back(ys, xs, index, fplane, jump, radius, plane_out, where_out):
    """The nearest pixel behind each pixel ``(ys[i], xs[i])``: the back surface of a soft edge.

    Nearest by Euclidean distance (ties: the first in scan order), in the square of half-side ``radius`` around
    it, among the pixels whose plane is at least ``jump`` behind ``fplane[i]``: its plane into ``plane_out[i]``
    (-1: none) and its flat index ``y * W + x`` into ``where_out[i]``.
    """
    h, w = index.shape
    for i in prange(len(ys)):
        y, x, limit = ys[i], xs[i], fplane[i] - jump
        best, bp, bw = 2 * radius * radius + 1, -1, -1
        for r in range(1, radius + 1):
            if r * r >= best:  # no pixel of this ring or beyond is nearer than the one found
                break
            for dy in range(-r, r + 1):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                step = 1 if (dy == -r or dy == r) else 2 * r
                for dx in range(-r, r + 1, step):
                    xx = x + dx
                    if xx < 0 or xx >= w or index[yy, xx] > limit:
                        continue
                    dd = dy * dy + dx * dx
                    if dd < best:
                        best, bp, bw = dd, index[yy, xx], yy * w + xx
        plane_out[i] = bp
        where_out[i] = bw
