"""Warps between input views and disparity planes, one interface for every camera model.

``Warper`` hides whether the rig is rectified (pure shifts, :mod:`vfxstereo.geometry`) or general
(homographies ``H_k + t_k [0 0 d]``, Eq. A1). Every stage that moves pixels between a view and a plane
(sweep, visibility, refinement) goes through it, so they agree on sampling and boundaries.

* ``to_plane(image, k, i)``  -- W_f: view k resampled onto plane i (Eq. 1);
* ``to_view(layer, k, i)``   -- W_b: plane i resampled into view k (Eq. 5);
* ``to_view_adjoint(g, k, i)`` -- the exact transpose of ``to_view``, for the gradient of C1 (Appendix);
* ``shifts(k)`` / ``sample_map(k, i)`` -- where the cells of each plane land in view k (for matching costs
  that are not linear in the image, :mod:`vfxstereo.matching`);
* ``project(disparity, k)`` -- where each reference pixel lands in view k at its own disparity (z-buffers).
"""

from __future__ import annotations

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera, plane_to_view, view_to_plane


class Warper:
    """Plane/view warps for ``camera`` and ``disparities`` at reference image size ``shape = (H, W)``.

    Parameters
    ----------
    camera : Camera
        The rig; rectified (positions) or general (``camera.matrices``).
    disparities : ndarray of shape (D,)
        Disparity of each plane.
    shape : tuple of int
        ``(H, W)`` of the reference (virtual) camera, which is also the size of the views.
    """

    def __init__(self, camera: Camera, disparities, shape: tuple[int, int]):
        self.camera = camera
        self.disparities = np.asarray(disparities, dtype=np.float64).reshape(-1)
        self.shape = (int(shape[0]), int(shape[1]))
        self._general = None
        if camera.is_general:
            try:
                from vfxstereo.homography import HomographyWarps
            except ImportError as exc:  # pragma: no cover - until the general path lands
                raise VfxStereoError("general (matrix) cameras are not supported in this build") from exc
            self._general = HomographyWarps(camera, self.disparities, self.shape)
        self._coverage: dict[tuple[int, int], np.ndarray] = {}

    @property
    def K(self) -> int:  # noqa: N802 - the paper's symbol
        """Number of views."""
        return self.camera.K

    @property
    def D(self) -> int:  # noqa: N802 - the paper's symbol
        """Number of planes."""
        return len(self.disparities)

    @property
    def step(self) -> float:
        """The planes' spacing (:func:`plane_step`)."""
        return plane_step(self.disparities)

    def to_plane(self, image: np.ndarray, k: int, i: int) -> np.ndarray:
        """W_f (Eq. 1): view ``k`` resampled onto plane ``i``; zero where the plane cell falls outside."""
        if self._general is not None:
            return self._general.to_plane(image, k, i)
        return view_to_plane(image, self.disparities[i], self.camera.view_offset(k))

    def to_view(self, layer: np.ndarray, k: int, i: int) -> np.ndarray:
        """W_b (Eq. 5): plane ``i`` resampled into view ``k``; zero where the view pixel sees off the plane."""
        if self._general is not None:
            return self._general.to_view(layer, k, i)
        return plane_to_view(layer, self.disparities[i], self.camera.view_offset(k))

    def to_view_adjoint(self, g: np.ndarray, k: int, i: int) -> np.ndarray:
        """Exact transpose of :meth:`to_view`: ``<to_view(a), b> == <a, to_view_adjoint(b)>``."""
        if self._general is not None:
            return self._general.to_view_adjoint(g, k, i)
        return view_to_plane(g, self.disparities[i], self.camera.view_offset(k))

    def shifts(self, k: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Rectified rigs: the shifts ``(sx, sy)`` of every plane in view ``k``, each (D,) float64.

        Plane ``i``'s cell (x, y) lands at ``(x - sx[i], y - sy[i])``; ``None`` for general cameras (use
        :meth:`sample_map`).
        """
        if self._general is not None:
            return None
        off = self.camera.view_offset(k)
        return self.disparities * off[0], self.disparities * off[1]

    def sample_map(self, k: int, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Where plane ``i``'s cells land in view ``k``: ``(u, v)``, each (H, W) float32.

        The positions :meth:`to_plane` samples bilinearly (Eq. A1); NaN where the plane is behind the view.
        """
        h, w = self.shape
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
        if self._general is None:
            sx, sy = self.shifts(k)
            return (xs - sx[i]).astype(np.float32), (ys - sy[i]).astype(np.float32)
        H = self._general.homography(k, i)
        return _dehomogenise(H[:, 0, None, None] * xs + H[:, 1, None, None] * ys + H[:, 2, None, None])

    def project(self, disparity: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Where each reference pixel lands in view ``k`` at its own disparity: ``(u, v)``, (H, W) float32.

        Eq. A1 with d = ``disparity[y, x]`` per pixel; NaN where the disparity is NaN or the point is behind
        the view.
        """
        d = np.asarray(disparity, dtype=np.float64)
        h, w = self.shape
        if d.shape != (h, w):
            raise VfxStereoError(f"a disparity map of shape {d.shape} does not match the rig's {(h, w)}")
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
        if self._general is None:
            off = self.camera.view_offset(k)
            return (xs - d * off[0]).astype(np.float32), (ys - d * off[1]).astype(np.float32)
        P = self.camera.matrices[k] @ np.linalg.inv(self.camera.M0)  # (3, 4): [x y 1 d] -> view (Eq. A1)
        return _dehomogenise(P[:, 0, None, None] * xs + P[:, 1, None, None] * ys + P[:, 2, None, None]
                             + P[:, 3, None, None] * d)

    def points_to_view(self, k: int, xs, ys, d) -> tuple[np.ndarray, np.ndarray]:
        """Where reference points ``(xs, ys)`` at disparities ``d`` (one per point) land in view ``k``.

        ``(u, v)`` float64 arrays (Eq. A1; NaN behind the view).
        """
        xs, ys, d = (np.asarray(a, np.float64) for a in (xs, ys, d))
        if self._general is None:
            off = self.camera.view_offset(k)
            return xs - d * off[0], ys - d * off[1]
        P = self.camera.matrices[k] @ np.linalg.inv(self.camera.M0)  # [x y 1 d] -> view (Eq. A1)
        q = P @ np.stack([xs, ys, np.ones_like(xs), d])
        front = q[2] > 1e-12
        wq = np.where(front, q[2], 1.0)
        return np.where(front, q[0] / wq, np.nan), np.where(front, q[1] / wq, np.nan)

    def transfer(self, k: int, xs, ys, d_from, d_to) -> tuple[np.ndarray, np.ndarray]:
        """The reference position at disparity ``d_to`` that view ``k`` sees through a point at ``d_from``.

        Per point ``(xs, ys)``: into view k at ``d_from``, then back out at ``d_to``.
        """
        xs, ys, d_from, d_to = (np.asarray(a, np.float64) for a in (xs, ys, d_from, d_to))
        if self._general is None:
            off = self.camera.view_offset(k)
            return xs - (d_from - d_to) * off[0], ys - (d_from - d_to) * off[1]
        u, v = self.points_to_view(k, xs, ys, d_from)
        # solve P [x y 1 d_to] ~ [u v 1] for (x, y): two linear equations per point, Cramer's rule
        P = self.camera.matrices[k] @ np.linalg.inv(self.camera.M0)
        c = P[:, 2, None] + P[:, 3, None] * d_to.reshape(1, -1)  # (3, N)
        uu, vv = u.reshape(-1), v.reshape(-1)
        a00, a01 = P[0, 0] - uu * P[2, 0], P[0, 1] - uu * P[2, 1]
        a10, a11 = P[1, 0] - vv * P[2, 0], P[1, 1] - vv * P[2, 1]
        r0, r1 = -(c[0] - uu * c[2]), -(c[1] - vv * c[2])
        det = a00 * a11 - a01 * a10
        with np.errstate(invalid="ignore", divide="ignore"):
            X = np.where(np.abs(det) > 1e-12, (r0 * a11 - a01 * r1) / det, np.nan)
            Y = np.where(np.abs(det) > 1e-12, (a00 * r1 - r0 * a10) / det, np.nan)
        return X.reshape(xs.shape), Y.reshape(xs.shape)

    def coverage(self, k: int, i: int) -> np.ndarray:
        """(H, W) float32 in [0, 1]: how much of each plane-``i`` cell's bilinear footprint lies in view ``k``."""
        key = (k, i)
        if key not in self._coverage:
            ones = np.ones(self.shape, dtype=np.float32)
            self._coverage[key] = self.to_plane(ones, k, i)
        return self._coverage[key]


def plane_step(disparities) -> float:
    """The planes' spacing in disparity: the median gap between neighbouring planes (1 for a single plane).

    Tolerances and jumps given "in plane steps" (depth, soft edges) are multiples of it.
    """
    d = np.asarray(disparities, np.float64).reshape(-1)
    return float(np.median(np.diff(d))) if len(d) > 1 else 1.0


def _dehomogenise(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(u, v) = (q0 / q2, q1 / q2)`` as float32, NaN where ``q2 <= 0`` (behind the camera)."""
    front = q[2] > 1e-12
    wq = np.where(front, q[2], 1.0)
    u = np.where(front, q[0] / wq, np.nan)
    v = np.where(front, q[1] / wq, np.nan)
    return u.astype(np.float32), v.astype(np.float32)
