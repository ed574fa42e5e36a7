"""numba kernels of the robust depth stage (:mod:`vfxstereo.matching`, :mod:`vfxstereo.sgm`, :mod:`vfxstereo.depth`).

Private: each kernel fills buffers its public wrapper allocates, and each has a plain numpy reference in the
wrapper's module that its test compares it with.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

# --------------------------------------------------------------------------------------------------------
# Census transform and Hamming distance


@njit(cache=True, parallel=True, nogil=True)
def census(gray, rh, rw, out):
    """``out[y, x]``: one bit per window neighbour (row-major, centre skipped), set where it is darker.

    Neighbours outside the frame repeat the edge pixel (a constant border reads as "not darker").
    """
    H, W = gray.shape
    for y in prange(H):
        for x in range(W):
            c = gray[y, x]
            code = np.uint64(0)
            for dy in range(-rh, rh + 1):
                yy = min(max(y + dy, 0), H - 1)
                for dx in range(-rw, rw + 1):
                    if dy == 0 and dx == 0:
                        continue
                    xx = min(max(x + dx, 0), W - 1)
                    code = (code << np.uint64(1)) | np.uint64(1 if gray[yy, xx] < c else 0)
            out[y, x] = code


@njit(cache=True, inline="always")
def popcount(v):
    """Number of set bits of a uint64 (SWAR)."""
    v = v - ((v >> np.uint64(1)) & np.uint64(0x5555555555555555))
    v = (v & np.uint64(0x3333333333333333)) + ((v >> np.uint64(2)) & np.uint64(0x3333333333333333))
    v = (v + (v >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (v * np.uint64(0x0101010101010101)) >> np.uint64(56)


# --------------------------------------------------------------------------------------------------------
# Per-view matching cost, accumulated over views


AD_TABLE_STEP = 0.125
"""Resolution of the colour-difference table of the AD-census cost (8-bit units)."""


@njit(cache=True, inline="always")
def _cell_cost(cref, vref, cview, vview, y, x, u, v, H, W, rho_census, rho_ad):
    """AD-census cost of reference pixel (y, x) against view position (v, u).

    The census term is the bilinear blend of the taps' ``rho_census[hamming]``; the colour term is
    ``rho_ad`` of the mean absolute difference to the bilinearly resampled view colour, read from a table
    in steps of :data:`AD_TABLE_STEP` (the last entry for anything beyond). Returns -1 outside the view.
    """
    if not (u >= 0.0 and u <= W - 1 and v >= 0.0 and v <= H - 1):
        return -1.0
    u0 = int(np.floor(u))
    v0 = int(np.floor(v))
    fu = u - u0
    fv = v - v0
    u1 = min(u0 + 1, W - 1)
    v1 = min(v0 + 1, H - 1)
    code = cref[y, x]
    C = vref.shape[2]
    ad = 0.0
    if fu == 0.0:  # a whole-pixel shift (the common case): one census tap
        cen = rho_census[popcount(code ^ cview[v0, u0])]
    else:
        cen = (1.0 - fu) * rho_census[popcount(code ^ cview[v0, u0])] + fu * rho_census[popcount(code ^ cview[v0, u1])]
    if fv == 0.0:
        for ch in range(C):
            ad += abs((1.0 - fu) * vview[v0, u0, ch] + fu * vview[v0, u1, ch] - vref[y, x, ch])
    else:
        low = rho_census[popcount(code ^ cview[v1, u0])]
        if fu != 0.0:
            low = (1.0 - fu) * low + fu * rho_census[popcount(code ^ cview[v1, u1])]
        cen = (1.0 - fv) * cen + fv * low
        for ch in range(C):
            s = ((1.0 - fv) * ((1.0 - fu) * vview[v0, u0, ch] + fu * vview[v0, u1, ch])
                 + fv * ((1.0 - fu) * vview[v1, u0, ch] + fu * vview[v1, u1, ch]))
            ad += abs(s - vref[y, x, ch])
    j = min(int(ad / (C * AD_TABLE_STEP) + 0.5), rho_ad.shape[0] - 1)
    return cen + rho_ad[j]


@njit(cache=True, parallel=True, nogil=True)
def accumulate_shift(cref, vref, cview, vview, sx, sy, zbuf, planes, tol, rho_census, rho_ad, centre, total,
                     count, skip):
    """Rectified rigs: add view k's cost at every cell to ``total`` and 1 to ``count`` where the view sees it.

    Cell (y, x, i) samples the view at ``(x - sx[i], y - sy[i])``. With a z-buffer (``zbuf`` of the view's
    size, the largest disparity that lands on each view pixel, -inf where none), a cell is seen only where
    ``zbuf`` at its (nearest) view pixel is at most ``planes[i] + tol``. With ``centre``, the view's mean cost
    over the cells of the pixel it sees is subtracted first. Pixels where ``skip`` (H, W) is set get nothing.

    A row at a time, a plane at a time: a whole-pixel shift reads the view's row in order (one census tap,
    no interpolation), twice as fast as going pixel by pixel through :func:`_cell_cost`, which the other
    planes use; then the row's costs are centred and added.
    """
    H, W = cref.shape
    D = planes.shape[0]
    C = vref.shape[2]
    nad = rho_ad.shape[0] - 1
    for y in prange(H):
        row = np.full((W, D), -1.0, np.float32)  # -1: outside the view
        for i in range(D):
            s = sx[i]
            v = y - sy[i]
            if not (v >= 0.0 and v <= H - 1):
                continue
            if v != np.floor(v) or s != np.floor(s):
                for x in range(W):
                    row[x, i] = _cell_cost(cref, vref, cview, vview, y, x, x - s, v, H, W, rho_census, rho_ad)
                continue
            si = int(s)
            vi = int(v)
            for x in range(max(0, si), min(W, W + si)):
                u = x - si
                ad = 0.0
                for ch in range(C):
                    ad += abs(vview[vi, u, ch] - vref[y, x, ch])
                j = min(int(ad / (C * AD_TABLE_STEP) + 0.5), nad)
                row[x, i] = rho_census[popcount(cref[y, x] ^ cview[vi, u])] + rho_ad[j]
        for x in range(W):
            if skip[y, x]:
                continue
            sm = 0.0
            n = 0
            for i in range(D):
                if row[x, i] >= 0.0:
                    u = x - sx[i]
                    v = y - sy[i]
                    if zbuf[min(int(v + 0.5), H - 1), min(int(u + 0.5), W - 1)] <= planes[i] + tol:
                        sm += row[x, i]
                        n += 1
                    else:
                        row[x, i] = -1.0
            m = sm / n if centre and n > 0 else 0.0
            for i in range(D):
                if row[x, i] >= 0.0:
                    total[y, x, i] += row[x, i] - m
                    count[y, x, i] += 1


@njit(cache=True, parallel=True, nogil=True)
def accumulate_map(cref, vref, cview, vview, umap, vmap, zbuf, plane, tol, rho_census, rho_ad, total, count, i,
                   skip):
    """General cameras: :func:`accumulate_shift` for one plane ``i``.

    The plane's cells sample the view at ``(umap, vmap)`` (NaN: behind the camera).
    """
    H, W = cref.shape
    for y in prange(H):
        for x in range(W):
            if skip[y, x]:
                continue
            u = umap[y, x]
            v = vmap[y, x]
            c = _cell_cost(cref, vref, cview, vview, y, x, u, v, H, W, rho_census, rho_ad)
            if c < 0.0:
                continue
            if zbuf[min(int(v + 0.5), H - 1), min(int(u + 0.5), W - 1)] > plane + tol:
                continue
            total[y, x, i] += c
            count[y, x, i] += 1


@njit(cache=True, nogil=True)
def zbuffer(u, v, disparity, out):
    """Splat each reference pixel's disparity onto the view pixels around where it lands.

    Each goes to the (up to) four view pixels around ``(u, v)``; each view pixel keeps the largest (nearest).
    ``out`` starts at -inf.
    """
    H, W = u.shape
    Ho, Wo = out.shape
    for y in range(H):
        for x in range(W):
            d = disparity[y, x]
            uu = u[y, x]
            vv = v[y, x]
            if not (np.isfinite(d) and np.isfinite(uu) and np.isfinite(vv)):
                continue
            u0 = int(np.floor(uu))
            v0 = int(np.floor(vv))
            for b in range(v0, v0 + 2):
                if b < 0 or b >= Ho:
                    continue
                for a in range(u0, u0 + 2):
                    if 0 <= a < Wo and d > out[b, a]:
                        out[b, a] = d


# --------------------------------------------------------------------------------------------------------
# Semi-global matching (Hirschmueller 2008): one path direction, added into S


def path_starts(H, W, dy, dx):
    """The first pixels ``(ys, xs)`` of the paths of direction (dy, dx): those whose predecessor is outside."""
    ys, xs = [], []
    if dy != 0:  # every column starts at the top (dy = 1) or bottom row
        ys += [0 if dy > 0 else H - 1] * W
        xs += list(range(W))
    if dx != 0:  # every row starts at the left (dx = 1) or right column, but the one already started
        rows = [y for y in range(H) if dy == 0 or y != (0 if dy > 0 else H - 1)]
        ys += rows
        xs += [0 if dx > 0 else W - 1] * len(rows)
    return np.array(ys, np.int64), np.array(xs, np.int64)


@njit(cache=True, parallel=True, nogil=True)
def sgm_path(C, guide, P1, P2, sigma, dy, dx, S, start_y, start_x):
    """Add the path costs L_r of direction r = (dy, dx) to ``S`` (both (H, W, D) float32).

    ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d+-1) + P1, min_k L_r(p-r, k) + P2') - min_k L_r(p-r, k)``
    with the edge-adapted ``P2' = max(P2 / (1 + |I(p) - I(p-r)| / sigma), P1)``. Paths start afresh at the
    frame edge, at ``(start_y, start_x)`` (:func:`path_starts`); each path is a chain of pixels p, p + r, ...
    independent of the others, so the paths run in parallel (one parallel region per direction: no barrier
    per row, which oversubscribed cores turn into waiting).
    """
    H, W, D = C.shape
    for n in prange(start_y.shape[0]):
        lp = np.empty(D, np.float32)
        lc = np.empty(D, np.float32)
        y = start_y[n]
        x = start_x[n]
        m = np.float32(np.inf)
        for d in range(D):
            lc[d] = C[y, x, d]
            m = min(m, lc[d])
        for d in range(D):
            S[y, x, d] += lc[d]
            lp[d] = lc[d]
        mp = m
        while True:
            py = y
            px = x
            y += dy
            x += dx
            if y < 0 or y >= H or x < 0 or x >= W:
                break
            g = abs(guide[y, x] - guide[py, px])
            p2 = max(P2 / (1.0 + g / sigma), P1)
            m = np.float32(np.inf)
            for d in range(D):
                best = lp[d]
                if d > 0:
                    best = min(best, lp[d - 1] + P1)
                if d < D - 1:
                    best = min(best, lp[d + 1] + P1)
                best = min(best, mp + p2)
                lc[d] = C[y, x, d] + best - mp
                m = min(m, lc[d])
            for d in range(D):
                S[y, x, d] += lc[d]
                lp[d] = lc[d]
            mp = m


@njit(cache=True, parallel=True, nogil=True)
def mean_cost(total, count, unseen, out):
    """``out = total / count`` where ``count > 0``, else ``unseen`` (all (H, W, D); one pass, no temporaries)."""
    H, W, D = total.shape
    for y in prange(H):
        for x in range(W):
            for d in range(D):
                c = count[y, x, d]
                out[y, x, d] = total[y, x, d] / np.float32(c) if c > 0 else unseen


@njit(cache=True, parallel=True, nogil=True)
def box_mean(cost, r, out):
    """``out`` (H, W, D): the mean of ``cost`` over a (2r+1) x (2r+1) window per plane, edges replicated.

    Along columns from ``cost`` into ``out``, then along rows in place (a copy of one row per thread).
    """
    H, W, D = cost.shape
    inv = np.float32(1.0 / (2 * r + 1))
    for y in prange(H):
        for x in range(W):
            for d in range(D):
                out[y, x, d] = 0.0
        for j in range(-r, r + 1):
            yy = min(max(y + j, 0), H - 1)
            for x in range(W):
                for d in range(D):
                    out[y, x, d] += cost[yy, x, d]
    for y in prange(H):
        row = out[y].copy()
        for x in range(W):
            for d in range(D):
                acc = np.float32(0.0)
                for j in range(-r, r + 1):
                    acc += row[min(max(x + j, 0), W - 1), d]
                out[y, x, d] = acc * inv * inv


# --------------------------------------------------------------------------------------------------------
# The colour guided filter of a chunk of planes (depth.guided_filter)


@njit(cache=True, parallel=True, nogil=True)
def guided_stack(I, cost, d0, n, out):
    """``out`` (H, W, 4n): planes ``d0 .. d0 + n`` of ``cost`` and their products with the 3 guide channels."""
    H, W = cost.shape[:2]
    for y in prange(H):
        for x in range(W):
            for k in range(n):
                p = cost[y, x, d0 + k]
                out[y, x, k] = p
                for c in range(3):
                    out[y, x, (c + 1) * n + k] = I[y, x, c] * p


@njit(cache=True, parallel=True, nogil=True)
def guided_coefficients(mI, inv, m, n, out, total, least):
    """The guided filter's coefficients from the window means ``m`` of :func:`guided_stack`'s planes.

    ``out`` (H, W, 4n) = (a_0, a_1, a_2, b) per plane, ``a = inv . (mean(I p) - mean(I) mean(p))``,
    ``b = mean(p) - a . mean(I)``; the means of p are summed into ``total`` and their least kept in ``least``.
    """
    H, W = m.shape[:2]
    for y in prange(H):
        for x in range(W):
            for k in range(n):
                mp = m[y, x, k]
                total[y, x] += mp
                if mp < least[y, x]:
                    least[y, x] = mp
                c0 = m[y, x, n + k] - mI[y, x, 0] * mp
                c1 = m[y, x, 2 * n + k] - mI[y, x, 1] * mp
                c2 = m[y, x, 3 * n + k] - mI[y, x, 2] * mp
                b = mp
                for c in range(3):
                    a = inv[y, x, c, 0] * c0 + inv[y, x, c, 1] * c1 + inv[y, x, c, 2] * c2
                    out[y, x, c * n + k] = a
                    b -= a * mI[y, x, c]
                out[y, x, 3 * n + k] = b


@njit(cache=True, parallel=True, nogil=True)
def guided_apply(I, mab, d0, n, out):
    """``out[..., d0 + k] = mean(a) . I + mean(b)`` from the window means ``mab`` of the coefficients."""
    H, W = I.shape[:2]
    for y in prange(H):
        for x in range(W):
            for k in range(n):
                q = mab[y, x, 3 * n + k]
                for c in range(3):
                    q += mab[y, x, c * n + k] * I[y, x, c]
                out[y, x, d0 + k] = q


# --------------------------------------------------------------------------------------------------------
# Filling unreliable pixels


@njit(cache=True, nogil=True)
def fill_from_farther(disparity, reliable, guide, out):
    """Give each unreliable pixel a value from the nearest reliable pixels in 8 directions.

    Candidates nearer than the second farthest of them are dropped (a hole is filled from the background around
    it, never by inventing a nearer surface; the second, so that one stray far value does not decide); of the
    rest, the one whose guide value is closest to the pixel's wins.
    Pixels with no reliable pixel in any direction stay as they are.
    """
    H, W = disparity.shape
    vals = np.empty(8, np.float32)
    diffs = np.empty(8, np.float32)
    for y in range(H):
        for x in range(W):
            out[y, x] = disparity[y, x]
            if reliable[y, x]:
                continue
            n = 0
            for r in range(8):
                dy = (0, 0, 1, -1, 1, 1, -1, -1)[r]
                dx = (1, -1, 0, 0, 1, -1, 1, -1)[r]
                yy = y + dy
                xx = x + dx
                while 0 <= yy < H and 0 <= xx < W and not reliable[yy, xx]:
                    yy += dy
                    xx += dx
                if 0 <= yy < H and 0 <= xx < W:
                    vals[n] = disparity[yy, xx]
                    diffs[n] = abs(guide[yy, xx] - guide[y, x])
                    n += 1
            if n == 0:
                continue
            limit = np.sort(vals[:n])[min(1, n - 1)]
            best = np.inf
            for j in range(n):
                if vals[j] <= limit and diffs[j] < best:
                    best = diffs[j]
                    out[y, x] = vals[j]


# --------------------------------------------------------------------------------------------------------
# Depth-edge refinement: front or back candidate by a pixelwise cost with adaptive support weights


@njit(cache=True, nogil=True)
def edge_candidates(disparity, y, x, r, jump):
    """Front and back candidate of pixel (y, x) from its ``(2 r + 1)``-square neighbourhood.

    Returns ``(is_edge, front, back, mid)``: the neighbourhood's disparities are split at the midpoint ``mid`` of
    their range; ``front`` is the mean of those at or above it, ``back`` of those below. ``is_edge`` is False
    (and the rest meaningless) where the range is below ``jump``.
    """
    H, W = disparity.shape
    lo = np.inf
    hi = -np.inf
    for b in range(max(y - r, 0), min(y + r + 1, H)):
        for a in range(max(x - r, 0), min(x + r + 1, W)):
            lo = min(lo, disparity[b, a])
            hi = max(hi, disparity[b, a])
    if not hi - lo >= jump:
        return False, 0.0, 0.0, 0.0
    mid = 0.5 * (lo + hi)
    sf = 0.0
    nf = 0
    sb = 0.0
    nb = 0
    for b in range(max(y - r, 0), min(y + r + 1, H)):
        for a in range(max(x - r, 0), min(x + r + 1, W)):
            if disparity[b, a] >= mid:
                sf += disparity[b, a]
                nf += 1
            else:
                sb += disparity[b, a]
                nb += 1
    return True, sf / nf, sb / nb, mid


@njit(cache=True, nogil=True)
def _support_cost(cref, vref, cview, vview, y, x, sx, sy, weights, R, rho_census, rho_ad):
    """Support-weighted mean AD-census cost of the window around (y, x), every pixel shifted by (sx, sy).

    ``weights`` is the ``(2 R + 1)``-square window's weights; pixels whose shifted position leaves the view or
    whose window position leaves the frame are left out. -1 when none is left.
    """
    H, W = cref.shape
    s = 0.0
    n = 0.0
    for j in range(-R, R + 1):
        b = y + j
        if b < 0 or b >= H:
            continue
        for i in range(-R, R + 1):
            a = x + i
            if a < 0 or a >= W:
                continue
            wgt = weights[j + R, i + R]
            if wgt <= 0.0:
                continue
            c = _cell_cost(cref, vref, cview, vview, b, a, a - sx, b - sy, H, W, rho_census, rho_ad)
            if c < 0.0:
                continue
            s += wgt * c
            n += wgt
    return s / n if n > 0.0 else -1.0


@njit(cache=True, parallel=True, nogil=True)
def edge_refine(disparity, r, jump, cref, vref, cviews, vviews, offsets, zbufs, tol, rho_census, rho_ad, R,
                gamma_c, gamma_s, margin, sided, forward, out, state):
    """Re-decide each depth-edge pixel between its front and back candidate (:func:`edge_candidates`).

    For each view m (``cviews[m]``, ``vviews[m]`` at ``offsets[m]`` view steps from the reference, its z-buffer
    ``zbufs[m]``) that sees the back candidate (the view pixel it lands on holds no disparity above
    ``back + tol``), both candidates get the support-weighted pixelwise cost (:func:`_support_cost`) with
    weights ``exp(-|colour difference| / gamma_c - distance / gamma_s)`` from the reference around the pixel;
    costs are averaged over those views. The pixel moves to the other side's candidate when that costs less by
    more than ``margin``; where no view sees the back candidate it is kept. ``state``: 0 no edge, 1 kept,
    2 moved back, 3 moved forward, 4 kept with no view seeing the back candidate.

    ``sided``: the views that see the back candidate are those on the side away from the front surface instead
    (``zbufs`` unread): a surface at disparity ``front`` hides the pixel's back point in view m from the reference
    pixel ``(front - back) offsets[m]`` away, so a view whose offset points towards the neighbourhood's front
    pixels (their centroid) may not see it. ``forward`` False: back pixels are not re-decided (state 0).
    """
    H, W = disparity.shape
    M = cviews.shape[0]
    C = vref.shape[2]
    for y in prange(H):
        weights = np.empty((2 * R + 1, 2 * R + 1), np.float64)
        for x in range(W):
            out[y, x] = disparity[y, x]
            state[y, x] = 0
            is_edge, front, back, mid = edge_candidates(disparity, y, x, r, jump)
            if not is_edge:
                continue
            is_front = disparity[y, x] >= mid
            if not forward and not is_front:
                continue
            state[y, x] = 1
            cx = 0.0
            cy = 0.0
            if sided:  # towards the front surface: the centroid of the neighbourhood's front pixels
                nf = 0
                for b in range(max(y - r, 0), min(y + r + 1, H)):
                    for a in range(max(x - r, 0), min(x + r + 1, W)):
                        if disparity[b, a] >= mid:
                            cx += a - x
                            cy += b - y
                            nf += 1
                cx /= nf
                cy /= nf
            for j in range(-R, R + 1):
                for i in range(-R, R + 1):
                    b = min(max(y + j, 0), H - 1)
                    a = min(max(x + i, 0), W - 1)
                    dc = 0.0
                    for ch in range(C):
                        dc += abs(vref[b, a, ch] - vref[y, x, ch])
                    weights[j + R, i + R] = np.exp(-dc / (C * gamma_c) - np.sqrt(i * i + j * j) / gamma_s)
            cf = 0.0
            cb = 0.0
            n = 0
            for m in range(M):
                ub = x - back * offsets[m, 0]
                vb = y - back * offsets[m, 1]
                if not (ub >= 0.0 and ub <= W - 1 and vb >= 0.0 and vb <= H - 1):
                    continue
                if sided:
                    if offsets[m, 0] * cx + offsets[m, 1] * cy > 0.0:
                        continue
                elif zbufs[m, min(int(vb + 0.5), H - 1), min(int(ub + 0.5), W - 1)] > back + tol:
                    continue
                eb = _support_cost(cref, vref, cviews[m], vviews[m], y, x, back * offsets[m, 0],
                                   back * offsets[m, 1], weights, R, rho_census, rho_ad)
                ef = _support_cost(cref, vref, cviews[m], vviews[m], y, x, front * offsets[m, 0],
                                   front * offsets[m, 1], weights, R, rho_census, rho_ad)
                if eb < 0.0 or ef < 0.0:
                    continue
                cb += eb
                cf += ef
                n += 1
            if n == 0:
                state[y, x] = 4
                continue
            if is_front and cb + n * margin < cf:
                out[y, x] = back
                state[y, x] = 2
            elif not is_front and cf + n * margin < cb:
                out[y, x] = front
                state[y, x] = 3


# --------------------------------------------------------------------------------------------------------
# Reopening filled gaps: a view's colour at each reference pixel's own disparity


@njit(cache=True, inline="always")
def _bilinear_error(view, uu, vv, gain, ref, y, x):
    """``|gain * view(uu, vv) - ref[y, x]|^2``, the view sampled bilinearly at ``(uu, vv)`` (inside it)."""
    h, w = view.shape[0], view.shape[1]
    x0 = min(int(uu), w - 2) if w > 1 else 0
    y0 = min(int(vv), h - 2) if h > 1 else 0
    fx = uu - x0
    fy = vv - y0
    x1 = min(x0 + 1, w - 1)
    y1 = min(y0 + 1, h - 1)
    e = 0.0
    for c in range(3):
        s = ((1.0 - fy) * ((1.0 - fx) * view[y0, x0, c] + fx * view[y0, x1, c])
             + fy * ((1.0 - fx) * view[y1, x0, c] + fx * view[y1, x1, c]))
        dd = gain[c] * s - ref[y, x, c]
        e += dd * dd
    return e


@njit(cache=True, parallel=True, nogil=True)
def colour_error(view, ref, gain, u, v, out):
    """``|gain * view(u, v) - ref|^2`` per reference pixel, the view sampled bilinearly at ``(u, v)``.

    Positions outside the view (or NaN) are clamped to its border here; the caller masks them.
    """
    H, W = ref.shape[:2]
    h, w = view.shape[:2]
    for y in prange(H):
        for x in range(W):
            uu = u[y, x]
            vv = v[y, x]
            if not (uu == uu and vv == vv):
                uu = 0.0
                vv = 0.0
            out[y, x] = _bilinear_error(view, min(max(uu, 0.0), w - 1.0), min(max(vv, 0.0), h - 1.0), gain,
                                        ref, y, x)


# --------------------------------------------------------------------------------------------------------
# Colour reopening: how common a pixel's colour is among the farther and the same-depth pixels around it


@njit(cache=True, parallel=True, nogil=True)
def colour_shares(disparity, colour, offsets, like, jump, active, target, counts):
    """How common each pixel's colour is among the farther and the same-depth pixels around it.

    Over the window ``offsets`` (nearest first): ``counts[y, x]`` = (farther pixels of its colour, farther
    pixels, same-depth pixels of its colour, same-depth pixels); ``target[y, x]``: the disparity of the nearest
    farther pixel of its colour (NaN: none). Pixels not ``active`` (nothing farther within reach) get zeros.

    Farther: disparity below the pixel's by more than ``jump``; same depth: within ``jump / 2``; of its colour:
    every channel within ``like``. Offsets that leave the frame are skipped.
    """
    H, W = disparity.shape
    n = offsets.shape[0]
    for y in prange(H):
        for x in range(W):
            d = disparity[y, x]
            nb = 0
            NB = 0
            nf = 0
            NF = 0
            t = np.float32(np.nan)
            for i in range(n if active[y, x] else 0):
                yy = y + offsets[i, 0]
                xx = x + offsets[i, 1]
                if yy < 0 or yy >= H or xx < 0 or xx >= W:
                    continue
                dq = disparity[yy, xx]
                alike = True
                for c in range(colour.shape[2]):
                    if abs(colour[yy, xx, c] - colour[y, x, c]) >= like:
                        alike = False
                        break
                if dq < d - jump:
                    NB += 1
                    if alike:
                        nb += 1
                        if t != t:
                            t = dq
                elif abs(dq - d) <= 0.5 * jump:
                    NF += 1
                    if alike:
                        nf += 1
            target[y, x] = t
            counts[y, x, 0] = nb
            counts[y, x, 1] = NB
            counts[y, x, 2] = nf
            counts[y, x, 3] = NF


@njit(cache=True, parallel=True, nogil=True)
def plane_errors(views, reference, others, gains, offsets, ys, xs, disparities, shifts, min_views, out):
    """``out[i, n]``: how well plane ``i`` explains reference pixel ``n`` in *all* the other views.

    Per view k in ``others`` (``views[k]``, offset ``offsets[k]`` in view steps, rectified: the pixel lands at
    ``(x - d ox, y - d oy)``): the least over ``disparities[i] + shifts`` of ``|gains[k] I_k(u) - I_ref|^2``
    (bilinear), over the shifts that land inside the view; the result is the largest of those over the views,
    or inf when fewer than ``min_views`` views have one. Plain numpy reference: ``depth_plate.plane_errors_reference``.
    """
    N = ys.shape[0]
    D = disparities.shape[0]
    h, w = views.shape[1], views.shape[2]
    S = shifts.shape[0]
    ref = views[reference]
    for n in prange(N):
        y = ys[n]
        x = xs[n]
        for i in range(D):
            worst = 0.0
            inside = 0
            for k in others:
                least = np.inf
                for j in range(S):
                    d = disparities[i] + shifts[j]
                    uu = x - d * offsets[k, 0]
                    vv = y - d * offsets[k, 1]
                    if not (uu >= 0.0 and uu <= w - 1.0 and vv >= 0.0 and vv <= h - 1.0):
                        continue
                    least = min(least, _bilinear_error(views[k], uu, vv, gains[k], ref, y, x))
                if least < np.inf:
                    inside += 1
                    worst = max(worst, least)
            out[i, n] = worst if inside >= min_views else np.inf


@njit(cache=True, inline="always")
def _alike(a, y, x, b, yy, xx, like):
    """Whether ``a[y, x]`` and ``b[yy, xx]`` differ by less than ``like`` in every channel."""
    for c in range(a.shape[2]):
        if abs(a[y, x, c] - b[yy, xx, c]) >= like:
            return False
    return True


@njit(cache=True, nogil=True)
def join_plain_flood(d, source, carried, colour, flat, like, jump, max_rounds):
    """Step 12's flood (:func:`vfxstereo.depth_plate.join_plain`), in rounds, from the pixels that changed.

    ``d`` and ``carried`` change in place. In each round every flat pixel takes the farthest disparity offered by
    its 4-neighbours that are flat sources, farther than the pixel's disparity (as it was at the start of the
    round) by more than ``jump``, and whose ``carried`` colour (the colour of the source the flood started from)
    is within ``like`` of the pixel's in every channel; it then carries that colour and is a source itself. The
    first round's sources are the flat ``source`` pixels; after that only the pixels that changed in a round can
    offer anything new in the next, so each round visits only those: the flood advances one
    pixel per round from every source at once (the nearest source reaches a pixel first), as
    :func:`vfxstereo.depth_plate.join_plain_reference` does over the whole plate. At most ``max_rounds`` rounds
    (0: until nothing changes), so nothing moves farther than that many 4-connected steps from where the flood
    started.
    Returns the number of rounds.
    """
    H, W = d.shape
    C = colour.shape[2]
    fy = np.empty(H * W, np.int32)  # the frontier's rows and columns (int32: 4K plates fit)
    fx = np.empty(H * W, np.int32)
    ny = np.empty(H * W, np.int32)
    nx = np.empty(H * W, np.int32)
    nf = 0
    for y in range(H):
        for x in range(W):
            if source[y, x] and flat[y, x]:
                fy[nf] = y
                fx[nf] = x
                nf += 1
    best = d.copy()
    best_c = carried.copy()
    stamp = np.zeros((H, W), np.int32)
    rounds = 0
    while nf > 0 and (max_rounds <= 0 or rounds < max_rounds):
        rounds += 1
        nn = 0
        for i in range(nf):
            y = fy[i]
            x = fx[i]
            dq = d[y, x]
            for n in range(4):
                yy = y + (1 if n == 0 else -1 if n == 1 else 0)
                xx = x + (1 if n == 2 else -1 if n == 3 else 0)
                if yy < 0 or yy >= H or xx < 0 or xx >= W or not flat[yy, xx]:
                    continue
                if not (dq < d[yy, xx] - jump and dq < best[yy, xx]):
                    continue
                if not _alike(colour, yy, xx, carried, y, x, like):
                    continue
                best[yy, xx] = dq
                for c in range(C):
                    best_c[yy, xx, c] = carried[y, x, c]
                if stamp[yy, xx] != rounds:
                    stamp[yy, xx] = rounds
                    ny[nn] = yy
                    nx[nn] = xx
                    nn += 1
        for i in range(nn):
            y = ny[i]
            x = nx[i]
            d[y, x] = best[y, x]
            for c in range(C):
                carried[y, x, c] = best_c[y, x, c]
            fy[i] = y
            fx[i] = x
        nf = nn
    return rounds


@njit(cache=True, inline="always")
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]  # path halving
        i = parent[i]
    return i


@njit(cache=True, nogil=True)
def plain_surfaces(d, colour, flat, tolerance, like, labels):
    """:func:`vfxstereo.depth_plate.plain_surfaces` by union-find; returns the number of surfaces.

    ``labels`` (H, W) int32 gets each flat pixel's surface, numbered 0, 1, ... in raster order of their first
    pixel, and -1 elsewhere. Two 4-neighbours are joined where both are flat, their disparities differ by at
    most ``tolerance`` and their colours by less than ``like`` in every channel.
    """
    H, W = d.shape
    parent = np.arange(H * W).astype(np.int32)
    for y in range(H):
        for x in range(W):
            if not flat[y, x]:
                continue
            i = y * W + x
            for n in range(2):
                yy = y + n
                xx = x + 1 - n
                if yy >= H or xx >= W or not flat[yy, xx] or abs(d[y, x] - d[yy, xx]) > tolerance:
                    continue
                if _alike(colour, y, x, colour, yy, xx, like):
                    a = _root(parent, i)
                    b = _root(parent, yy * W + xx)
                    if a != b:
                        if a < b:
                            parent[b] = a
                        else:
                            parent[a] = b
    n = 0
    for y in range(H):
        for x in range(W):
            if not flat[y, x]:
                labels[y, x] = -1
                continue
            i = y * W + x
            r = _root(parent, i)
            if r == i:  # the root is the surface's first pixel in raster order (roots are the smaller index)
                labels[y, x] = n
                n += 1
            else:
                labels[y, x] = labels[r // W, r % W]
    return n


# --------------------------------------------------------------------------------------------------------
# Step 13: edges that claim a plain region


@njit(cache=True, parallel=True, nogil=True)
def edge_ridges(d, flat, radius, share, b0, b1, jump, far, ridge, side, behind):
    """Step 13's claiming edges (:func:`vfxstereo.depth_plate.edge_ridges`), one row per thread.

    Fills ``ridge`` (bool), ``side`` (int8) and ``behind`` (float32, NaN off the ridge), which the caller sets to
    False, 0 and NaN; :func:`vfxstereo.depth_plate.edge_ridges_reference` is its numpy version.
    """
    H, W = d.shape
    for y in prange(H):
        vals = np.empty(b1 - b0 + 1, np.float32)
        for x in range(W):
            if flat[y, x]:
                continue
            fl = False  # plain within 3 px to the left, and to the right; texture within 3 px on each side
            fr = False
            tl = False
            tr = False
            for k in range(1, 4):
                if x - k >= 0:
                    if flat[y, x - k]:
                        fl = True
                    else:
                        tl = True
                if x + k < W:
                    if flat[y, x + k]:
                        fr = True
                    else:
                        tr = True
            if fl and not fr and tr:
                s = 1
            elif fr and not fl and tl:
                s = -1
            else:
                continue
            dv = d[y, x]
            same = 0
            count = 0
            for yy in range(max(y - radius, 0), min(y + radius + 1, H)):
                for xx in range(max(x - radius, 0), min(x + radius + 1, W)):
                    if not flat[yy, xx]:
                        count += 1
                        if abs(d[yy, xx] - dv) <= 1.0:
                            same += 1
            if not same < share * max(count, 1):
                continue
            nb = 0
            nfar = 0
            for k in range(b0, b1 + 1):
                xx = x + s * k
                if xx < 0 or xx >= W or flat[y, xx]:
                    continue
                vals[nb] = d[y, xx]
                nb += 1
                if d[y, xx] < dv - jump:
                    nfar += 1
            if nb >= 3 and nfar >= far * nb:
                ridge[y, x] = True
                side[y, x] = s
                behind[y, x] = np.median(vals[:nb])


@njit(cache=True, parallel=True, nogil=True)
def rim_colours(disparity, lo, edge, colour, jump, tol, ratio, r, least, out):
    """One pass of step 19 (:func:`vfxstereo.depth_plate.rim_colours`).

    ``out`` is ``disparity`` with each near-side pixel of a jump (``disparity - lo >= jump``, ``lo`` its 3 x 3
    minimum) set to ``lo`` where its colour is nearer the mean colour of the back side than of the front side by
    more than ``ratio``.

    The sides: the pixels of the (2r+1)^2 window off the edges (``edge`` False) within ``tol`` of the pixel's
    disparity (front) and of ``lo`` (back); each needs ``least`` pixels, or the pixel stays.
    """
    H, W = disparity.shape
    C = colour.shape[2]
    for y in prange(H):
        sf = np.empty(C, np.float64)
        sb = np.empty(C, np.float64)
        for x in range(W):
            f = disparity[y, x]
            b = lo[y, x]
            out[y, x] = f
            if not f - b >= jump:
                continue
            sf[:] = 0.0
            sb[:] = 0.0
            nf = 0
            nb = 0
            for yy in range(max(y - r, 0), min(y + r + 1, H)):
                for xx in range(max(x - r, 0), min(x + r + 1, W)):
                    if edge[yy, xx]:
                        continue
                    dq = disparity[yy, xx]
                    if abs(dq - f) <= tol:
                        nf += 1
                        for c in range(C):
                            sf[c] += colour[yy, xx, c]
                    elif abs(dq - b) <= tol:
                        nb += 1
                        for c in range(C):
                            sb[c] += colour[yy, xx, c]
            if nf < least or nb < least:
                continue
            ef = 0.0
            eb = 0.0
            for c in range(C):
                ef += (colour[y, x, c] - sf[c] / nf) ** 2
                eb += (colour[y, x, c] - sb[c] / nb) ** 2
            if ratio * ratio * eb < ef:
                out[y, x] = b
