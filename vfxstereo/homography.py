"""General cameras: plane-induced homographies and exact bilinear warps (Appendix, Eq. A1).

For a view with 3x4 camera matrix ``M_k`` and the 4x4 collineation ``M0`` from world to disparity space
``x0 = [x y 1 d]^T``, a point ``(x, y)`` of plane d appears in view k at

    x_k = M_k M0^{-1} [x y 1 d]^T = (H_k + t_k [0 0 d]) [x y 1]^T                       # Eq. (A1)

where ``H_k`` (the first three columns of ``M_k M0^{-1}``) is the homography of plane d = 0 and ``t_k`` (its
last column) the epipole. :func:`plane_homography` builds that 3x3 matrix; :class:`HomographyWarps` is the
general-camera engine behind :class:`vfxstereo.warp.Warper`.

Sampling convention (the same as the shift path of :mod:`vfxstereo.geometry`): pixel centres sit at integer
``(col, row)`` coordinates, sampling is bilinear, and each of the four taps that falls outside the frame
contributes zero (so a sample half a pixel off the edge gets half the edge value). Positions within 1e-6 px
of a whole pixel are snapped to it, as the shift path does, so the two paths agree bit for bit on integral
shifts.

Every warp is a sparse matrix with (at most) four non-zeros per output pixel, built once per (view, plane,
direction) and cached; :meth:`HomographyWarps.to_view_adjoint` multiplies by the transpose of the very matrix
:meth:`HomographyWarps.to_view` uses, so it is the exact adjoint.

Cost: one matrix holds ``4 * H * W`` float32 weights and int32 column indices plus ``H * W + 1`` row
pointers, about 36 bytes per pixel: 7 MB for 500x400, 4 MB for 384x288. A full set (K views x D planes x 2
directions) for K = 5, D = 32 at 500x400 would be 2.3 GB, so the cache holds matrices up to a byte budget
(``cache_bytes``, 512 MiB by default) and builds the rest on every call (about 20-40 ms each at 500x400).
Filling stops at the budget rather than evicting: the solver visits (view, plane) pairs in the same cyclic
order every pass, which would make a least-recently-used cache miss every time.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from vfxstereo.errors import VfxStereoError

# A sample position closer than this to a whole pixel is taken as whole (as in vfxstereo.geometry).
_WHOLE_PIXEL_TOL = 1e-6

DEFAULT_CACHE_BYTES = 512 * 2**20
"""Byte budget of the warp-matrix cache of :class:`HomographyWarps` (512 MiB)."""


def plane_homography(M_k: np.ndarray, M0: np.ndarray, d: float) -> np.ndarray:
    """The 3x3 homography ``H_k + t_k [0 0 d]`` mapping plane ``d`` of disparity space into view k (Eq. A1).

    Parameters
    ----------
    M_k : ndarray of shape (3, 4)
        Camera matrix of view k: world ``[X Y Z 1]`` to image ``[u v 1]`` (up to scale).
    M0 : ndarray of shape (4, 4)
        Collineation from world ``[X Y Z 1]`` to disparity space ``[x y 1 d]`` (up to scale).
    d : float
        Disparity of the plane.

    Returns
    -------
    ndarray of shape (3, 3), float64
        ``H`` with ``[u v w]^T = H [x y 1]^T``; the view pixel is ``(u / w, v / w)`` (column, row).
    """
    M_k = np.asarray(M_k, dtype=np.float64)
    M0 = np.asarray(M0, dtype=np.float64)
    if M_k.shape != (3, 4) or M0.shape != (4, 4):
        raise VfxStereoError(f"need a 3x4 camera matrix and a 4x4 M0, got {M_k.shape} and {M0.shape}")
    try:
        P = M_k @ np.linalg.inv(M0)  # (3, 4): [x y 1 d] -> view k
    except np.linalg.LinAlgError:
        raise VfxStereoError("M0 (world to disparity space) is singular") from None
    H = P[:, :3].copy()  # H_k, the homography of plane d = 0
    H[:, 2] += float(d) * P[:, 3]  # Eq. (A1): H_k + t_k [0 0 d], t_k = P[:, 3] (the epipole)
    return H


def rectified_rig_matrices(positions, reference, shape: tuple[int, int], *, focal: float | None = None,
                           baseline: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Camera matrices ``M_k`` and ``M0`` of a rectified, coplanar rig (pure-translation cameras).

    The virtual camera sits at the world origin looking down +Z with focal length ``focal`` (pixels) and the
    principal point at the frame centre; view k is the same camera translated by
    ``baseline * (p_k - p_ref)`` in (X, Y). Disparity is ``d = focal * baseline / Z``, so a point at column x
    of the reference on plane d appears at ``x - d * (p_k - p_ref)`` in view k: exactly the shift path of
    :mod:`vfxstereo.geometry`. This is how a test checks the general path against the shift path.

    Parameters
    ----------
    positions : array_like of shape (K,) or (K, 2)
        View positions in view steps (1-D positions get y = 0).
    reference : float or array_like of shape (2,)
        Position of the virtual camera.
    shape : tuple of int
        ``(H, W)`` of the images (sets the principal point and the default focal length ``max(H, W)``).
    focal : float, optional
        Focal length in pixels.
    baseline : float
        World distance of one position step.

    Returns
    -------
    M : ndarray of shape (K, 3, 4)
        Camera matrices.
    M0 : ndarray of shape (4, 4)
        World to disparity space ``[x y 1 d]``.
    """
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim == 1:
        p = np.stack([p, np.zeros_like(p)], axis=1)
    ref = np.asarray(reference, dtype=np.float64).reshape(-1)
    if ref.size == 1:
        ref = np.array([ref[0], 0.0])
    h, w = int(shape[0]), int(shape[1])
    f = float(focal) if focal is not None else float(max(h, w))
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    intr = np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])
    M = np.empty((len(p), 3, 4))
    for k, pk in enumerate(p):
        centre = np.array([baseline * (pk[0] - ref[0]), baseline * (pk[1] - ref[1]), 0.0])
        M[k] = intr @ np.hstack([np.eye(3), -centre[:, None]])  # K [I | -C_k]
    # [X Y Z 1] -> [f X + cx Z, f Y + cy Z, Z, f B]  ~  [x, y, 1, f B / Z]
    M0 = np.array([[f, 0.0, cx, 0.0], [0.0, f, cy, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, f * baseline]])
    return M, M0


def _snap(a: np.ndarray) -> np.ndarray:
    """Snap coordinates within the whole-pixel tolerance to the whole pixel."""
    r = np.rint(a)
    return np.where(np.abs(a - r) < _WHOLE_PIXEL_TOL, r, a)


def bilinear_matrix(H: np.ndarray, shape: tuple[int, int], src_shape: tuple[int, int] | None = None):
    """Sparse matrix of "sample the source at ``H [x y 1]^T`` bilinearly, zero outside".

    Row ``y * W + x`` of the result holds the (at most four) bilinear weights of the source pixels around
    ``H (x, y)``; taps outside the source frame are dropped (they sample zero), and so is every tap of a
    point with ``w <= 0`` (behind the camera).

    Parameters
    ----------
    H : ndarray of shape (3, 3)
        Maps output pixel ``(col, row, 1)`` to source pixel (homogeneous).
    shape : tuple of int
        ``(H, W)`` of the output.
    src_shape : tuple of int, optional
        ``(H, W)`` of the source; defaults to ``shape``.

    Returns
    -------
    scipy.sparse.csr_matrix of shape (H*W, Hs*Ws), float32
    """
    h, w = shape
    hs, ws = src_shape if src_shape is not None else shape
    ys, xs = np.mgrid[0:h, 0:w]
    pts = np.stack([xs.ravel(), ys.ravel(), np.ones(h * w)]).astype(np.float64)  # (3, N)
    q = H @ pts
    front = q[2] > 1e-12
    wq = np.where(front, q[2], 1.0)
    u = _snap(q[0] / wq)
    v = _snap(q[1] / wq)
    u0 = np.floor(u)
    v0 = np.floor(v)
    fu = u - u0
    fv = v - v0
    u0 = u0.astype(np.int64)
    v0 = v0.astype(np.int64)
    rows, cols, vals = [], [], []
    n = np.arange(h * w)
    for du, dv, wt in ((0, 0, (1 - fu) * (1 - fv)), (1, 0, fu * (1 - fv)),
                       (0, 1, (1 - fu) * fv), (1, 1, fu * fv)):
        uu = u0 + du
        vv = v0 + dv
        ok = front & (wt > 0) & (uu >= 0) & (uu < ws) & (vv >= 0) & (vv < hs)
        rows.append(n[ok])
        cols.append(vv[ok] * ws + uu[ok])
        vals.append(wt[ok])
    mat = sp.csr_matrix(
        (np.concatenate(vals).astype(np.float32), (np.concatenate(rows), np.concatenate(cols))),
        shape=(h * w, hs * ws),
    )
    mat.sum_duplicates()
    return mat


def _apply(mat, img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``mat @ img`` for an (H, W) or (H, W, C) image, keeping the dtype (float32 in, float32 out)."""
    img = np.asarray(img)
    if img.shape[:2] != tuple(shape):
        raise VfxStereoError(f"image of shape {img.shape[:2]} does not match the rig's {tuple(shape)}")
    dtype = img.dtype if np.issubdtype(img.dtype, np.floating) else np.float32
    flat = img.reshape(img.shape[0] * img.shape[1], -1).astype(dtype, copy=False)
    out = mat @ flat
    return np.asarray(out, dtype=dtype).reshape(img.shape)


class HomographyWarps:
    """Plane/view warps of a general rig (Eq. A1), used by :class:`vfxstereo.warp.Warper`.

    Parameters
    ----------
    camera : Camera
        A rig with ``matrices`` (K, 3, 4) and ``M0`` (4, 4) set.
    disparities : ndarray of shape (D,)
        Disparity of each plane.
    shape : tuple of int
        ``(H, W)`` of the reference camera and of every view.
    cache_bytes : int
        Byte budget of the warp-matrix cache (see the module docstring for the cost).

    Notes
    -----
    ``to_plane`` (W_f, Eq. 1) samples view k at ``H x``; ``to_view`` (W_b, Eq. 5) samples the plane at
    ``H^{-1} u``; ``to_view_adjoint`` is ``to_view``'s matrix transposed. ``to_plane`` is *not* the adjoint of
    ``to_view`` for a general homography (they differ by the Jacobian of the map and by the interpolation
    kernel), which is why the adjoint is kept separate.
    """

    def __init__(self, camera, disparities, shape: tuple[int, int], *,
                 cache_bytes: int = DEFAULT_CACHE_BYTES):
        if camera.matrices is None or camera.M0 is None:
            raise VfxStereoError("HomographyWarps needs a camera with matrices and M0")
        self.camera = camera
        self.disparities = np.asarray(disparities, dtype=np.float64).reshape(-1)
        self.shape = (int(shape[0]), int(shape[1]))
        self.cache_bytes = int(cache_bytes)
        self._cache: dict[tuple[str, int, int], sp.csr_matrix] = {}
        self._cached_bytes = 0

    def homography(self, k: int, i: int) -> np.ndarray:
        """3x3 homography of plane ``i`` into view ``k``: ``(x, y, 1)`` to ``(u, v, w)`` (Eq. A1)."""
        return plane_homography(self.camera.matrices[k], self.camera.M0, self.disparities[i])

    def matrix(self, kind: str, k: int, i: int):
        """Sparse warp matrix: ``kind="plane"``: W_f (view to plane); ``"view"``: W_b (plane to view)."""
        key = (kind, int(k), int(i))
        mat = self._cache.get(key)
        if mat is not None:
            return mat
        H = self.homography(k, i)
        if kind == "plane":
            mat = bilinear_matrix(H, self.shape)
        elif kind == "view":
            try:
                Hinv = np.linalg.inv(H)
            except np.linalg.LinAlgError:
                raise VfxStereoError(f"plane {i} is seen edge-on by view {k} (singular homography)") from None
            mat = bilinear_matrix(Hinv, self.shape)
        else:  # pragma: no cover - internal
            raise ValueError(kind)
        size = mat.data.nbytes + mat.indices.nbytes + mat.indptr.nbytes
        if self._cached_bytes + size <= self.cache_bytes:
            self._cache[key] = mat
            self._cached_bytes += size
        return mat

    def to_plane(self, image: np.ndarray, k: int, i: int) -> np.ndarray:
        """W_f (Eq. 1): view ``k`` sampled at ``H x`` onto plane ``i``; zero outside the view."""
        return _apply(self.matrix("plane", k, i), image, self.shape)

    def to_view(self, layer: np.ndarray, k: int, i: int) -> np.ndarray:
        """W_b (Eq. 5): plane ``i`` sampled at ``H^{-1} u`` into view ``k``; zero off the plane's frame."""
        return _apply(self.matrix("view", k, i), layer, self.shape)

    def to_view_adjoint(self, g: np.ndarray, k: int, i: int) -> np.ndarray:
        """Exact transpose of :meth:`to_view`: ``<to_view(a), b> == <a, to_view_adjoint(b)>``."""
        return _apply(self.matrix("view", k, i).T, g, self.shape)
