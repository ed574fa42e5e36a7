"""Warps between input views and disparity planes, one interface for every camera model.

``Warper`` hides whether the rig is rectified (pure shifts, :mod:`vfxstereo.geometry`) or general
(homographies ``H_k + t_k [0 0 d]``, Eq. A1). Every stage that moves pixels between a view and a plane
(sweep, visibility, refinement) goes through it, so they agree on sampling and boundaries.

* ``to_plane(image, k, i)``  -- W_f: view k resampled onto plane i (Eq. 1);
* ``to_view(layer, k, i)``   -- W_b: plane i resampled into view k (Eq. 5);
* ``to_view_adjoint(g, k, i)`` -- the exact transpose of ``to_view``, for the gradient of C1 (Appendix).
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

    def coverage(self, k: int, i: int) -> np.ndarray:
        """(H, W) float32 in [0, 1]: how much of each plane-``i`` cell's bilinear footprint lies in view ``k``."""
        key = (k, i)
        if key not in self._coverage:
            ones = np.ones(self.shape, dtype=np.float32)
            self._coverage[key] = self.to_plane(ones, k, i)
        return self._coverage[key]
