"""numba kernels of :mod:`vfxstereo.refine`; the numpy references they are tested against live there.

* :func:`gh_layer` -- gradient and Gauss-Newton diagonal of C1 for one warped layer of one view (Appendix),
  fused with the running over-composite ``a_k(d)`` of the layers behind;
* :func:`smoothness` -- value, gradient and diagonal of C2 (Eq. 10) or C2' (Eq. 12) over N4 in one pass.

Both fill buffers their caller allocates; inputs are C-contiguous float32 or float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def gh_layer(psi, om, v, A, warped_d, out):  # pragma: no cover - compiled
    """Fill ``out`` (H, W, 8) with [g_k(d), h_k(d)] for layer d, then advance ``A`` to ``a_k(d)`` in place.

    ``psi``, ``om``: (H, W, 4) w_k psi(e_k) and w_k omega(e_k); ``v``: (H, W) V_k(d); ``A``: (H, W, 4)
    a_k(d - 1) on entry; ``warped_d``: (H, W, 4) the warped layer c_k(d).
    """
    H, W = v.shape
    for i in range(H):
        for j in range(W):
            vv = v[i, j]
            v2 = vv * vv
            dot = 0.0
            hal = 0.0
            for c in range(3):
                out[i, j, c] = vv * psi[i, j, c]  # d c~/d[rgb] = V_k(d)
                out[i, j, 4 + c] = v2 * om[i, j, c]
                dot += psi[i, j, c] * A[i, j, c]
                hal += om[i, j, c] * A[i, j, c] * A[i, j, c]
            dot += psi[i, j, 3] * A[i, j, 3]
            one_minus = 1.0 - A[i, j, 3]
            out[i, j, 3] = vv * (psi[i, j, 3] - dot)  # d c~/d alpha = V_k(d) ([0 0 0 1] - a_k(d-1))
            out[i, j, 7] = v2 * (hal + om[i, j, 3] * one_minus * one_minus)
            t = 1.0 - warped_d[i, j, 3]  # over: a_k(d) = c_k(d) + (1 - alpha_k(d)) a_k(d-1)
            for c in range(4):
                A[i, j, c] = warped_d[i, j, c] + t * A[i, j, c]


@njit(cache=True, inline="always")
def _penalty(r, huber, s):  # pragma: no cover - compiled
    """rho(r), psi(r) = rho'(r), omega = psi / r for the quadratic (r^2) or Huber penalty."""
    r = float(r)
    if huber:
        a = abs(r)
        if a <= s:
            return r * r, 2.0 * r, 2.0
        return 2.0 * s * a - s * s, (2.0 * s if r > 0 else -2.0 * s), 2.0 * s / a
    return r * r, 2.0 * r, 2.0


@njit(cache=True, nogil=True)
def smoothness(x, huber, s, premultiplied, lam, g, h, want_gradient):  # pragma: no cover - compiled
    """C2 or C2' of ``x`` (D, H, W, 4) over N4 at the same d, each unordered pair counted twice.

    Adds ``lam`` times its gradient and diagonal to ``g`` and ``h`` when ``want_gradient``; returns the
    (unweighted) value.
    """
    D, H, W, _ = x.shape
    total = 0.0
    for d in range(D):
        for i in range(H):
            for j in range(W):
                for nb in range(2):
                    if nb == 0:
                        i2, j2 = i, j + 1
                        if j2 >= W:
                            continue
                    else:
                        i2, j2 = i + 1, j
                        if i2 >= H:
                            continue
                    if not premultiplied:
                        for c in range(4):
                            r = x[d, i2, j2, c] - x[d, i, j, c]  # Eq. (10)
                            val, p, o = _penalty(r, huber, s)
                            total += 2.0 * val
                            if want_gradient:
                                g[d, i2, j2, c] += lam * 2.0 * p
                                g[d, i, j, c] -= lam * 2.0 * p
                                h[d, i2, j2, c] += lam * 2.0 * o
                                h[d, i, j, c] += lam * 2.0 * o
                    else:
                        ai = x[d, i, j, 3]
                        aj = x[d, i2, j2, 3]
                        for c in range(3):
                            ci = x[d, i, j, c]
                            cj = x[d, i2, j2, c]
                            r = ai * cj - aj * ci  # Eq. (12)
                            val, p, o = _penalty(r, huber, s)
                            total += 2.0 * val
                            if want_gradient:
                                p2 = lam * 2.0 * p
                                o2 = lam * 2.0 * o
                                g[d, i2, j2, c] += p2 * ai
                                g[d, i, j, c] -= p2 * aj
                                g[d, i, j, 3] += p2 * cj
                                g[d, i2, j2, 3] -= p2 * ci
                                h[d, i2, j2, c] += o2 * ai * ai
                                h[d, i, j, c] += o2 * aj * aj
                                h[d, i, j, 3] += o2 * cj * cj
                                h[d, i2, j2, 3] += o2 * ci * ci
    return total


def warm_up() -> None:
    """Compile (or load from cache) the kernels for float32 and float64."""
    for dt in (np.float32, np.float64):
        a = np.zeros((1, 2, 2, 4), dt)
        gh_layer(a[0], a[0], a[0, ..., 0], a[0].copy(), a[0], np.zeros((2, 2, 8), dt))
        smoothness(a, True, 0.1, True, 1.0, a.copy(), a.copy(), True)
        project_weighted(a.copy(), a + 1, 1.0)


@njit(cache=True, nogil=True)
def project_weighted(x, q, white):  # pragma: no cover - compiled
    """In place: each cell of ``x`` (D, H, W, 4) to its nearest feasible point in the metric ``q``.

    The feasible set is ``{0 <= alpha <= 1, 0 <= rgb <= white * alpha}``, the distance ``sum q (x' - x)^2``.

    For a fixed new alpha a', the best colours are ``clip(c, 0, white a')``; what remains is a convex
    piecewise-quadratic function of a', minimised in closed form on the piece that holds its root, then
    clipped to [0, 1].
    """
    D, H, W, _ = x.shape
    for d in range(D):
        for i in range(H):
            for j in range(W):
                c0, c1, c2 = x[d, i, j, 0], x[d, i, j, 1], x[d, i, j, 2]
                q0, q1, q2 = q[d, i, j, 0], q[d, i, j, 1], q[d, i, j, 2]
                # sort the three channels by colour, descending (with their weights)
                if c0 < c1:
                    c0, c1, q0, q1 = c1, c0, q1, q0
                if c1 < c2:
                    c1, c2, q1, q2 = c2, c1, q2, q1
                if c0 < c1:
                    c0, c1, q0, q1 = c1, c0, q1, q0
                qa = q[d, i, j, 3]
                num = qa * x[d, i, j, 3]
                den = qa
                a_new = x[d, i, j, 3]
                for n in range(4):  # n = how many channels sit on their upper bound white * a'
                    if n == 1:
                        num += white * q0 * c0
                        den += white * white * q0
                    elif n == 2:
                        num += white * q1 * c1
                        den += white * white * q1
                    elif n == 3:
                        num += white * q2 * c2
                        den += white * white * q2
                    if den <= 0.0:
                        continue
                    a_new = num / den
                    upper = c0 if n == 0 else (c1 if n == 1 else (c2 if n == 2 else -np.inf))
                    if upper <= white * a_new:  # the next channel stays below the bound: root found
                        break
                if a_new < 0.0:
                    a_new = 0.0
                elif a_new > 1.0:
                    a_new = 1.0
                x[d, i, j, 3] = a_new
                top = white * a_new
                for c in range(3):
                    v = x[d, i, j, c]
                    x[d, i, j, c] = 0.0 if v < 0.0 else (top if v > top else v)
    return x
