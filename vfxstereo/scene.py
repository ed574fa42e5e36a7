"""Where the layers of a stack go in a 3D scene: one camera-facing plane per layer, filling the frustum.

The Blender add-on (``blender_addon``) turns a stack into planes parented to the scene camera; everything
about that which needs no Blender lives here and is tested without it: the depth each disparity maps to,
the frame of a Blender-style camera at a given depth, and the resulting plane of every layer.

Depth of a layer
    ``Z = focal * baseline / d`` (:meth:`vfxstereo.Camera.depth_from_disparity`, the mapping of the deep
    EXR and of ``composite.insert(depth=...)``): ``focal * baseline`` comes from a value the user gives,
    else from the stack's camera, else it is 1 (``Z = 1 / d``). Layers at or beyond infinity (``d <= 0``)
    cannot sit at an infinite depth in a scene: they go behind the farthest finite layer, at
    ``FAR_FACTOR`` times its depth, the more negative disparities farther still, in order.

Frame of the camera
    A plane at depth Z that fills the frame exactly has the size and centre of the camera's view frame at
    that distance: Blender's ``BKE_camera_params_compute_viewplane`` (sensor fit, pixel aspect, lens shift)
    scaled to Z (:class:`CameraFrustum`). The plane's texture then covers the rendered frame pixel for
    pixel when the render has the stack's size.

Coordinates are the camera's local frame (Blender's): x right, y up, the camera looks down ``-z``, so a
plane at depth Z has its centre at ``z = -Z``.

==================  ==========  ====================================================================
name                shape       meaning
==================  ==========  ====================================================================
``disparities``     (D,)        the stack's disparities, increasing (the last layer is nearest)
``depths``          (D,)        distance of each plane from the camera, scene units, decreasing
``focal_baseline``  ()          focal length (px) times baseline (scene units per view step)
==================  ==========  ====================================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera

FAR_FACTOR = 10.0
"""Layers at or beyond infinity (``d <= 0``) are placed at this many times the farthest finite depth."""

SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
"""Blender's ``Camera.sensor_fit`` values."""


# --------------------------------------------------------------------------------------------------------
# Depth of each layer


@dataclass(frozen=True)
class DepthMapping:
    """How disparity becomes depth: ``Z = scale / d``, and where ``scale`` came from.

    Parameters
    ----------
    scale : float
        ``focal * baseline`` (px times scene units per view step), or 1 when neither is known.
    source : {"given", "camera", "none"}
        Where ``scale`` came from: the user, the stack's camera, or nowhere (``Z = 1 / d``).
    """

    scale: float
    source: str

    @property
    def camera(self) -> Camera:
        """A :class:`~vfxstereo.Camera` whose ``depth_from_disparity`` is this mapping."""
        return Camera(positions=[0.0], reference=0.0, focal=self.scale, baseline=1.0)

    def depth(self, disparity) -> np.ndarray:
        """``scale / d``; ``inf`` for ``d <= 0`` (:meth:`vfxstereo.Camera.depth_from_disparity`)."""
        return self.camera.depth_from_disparity(disparity)

    def describe(self) -> str:
        """The mapping in words, for reports: ``"Z = 12 / d (the stack's camera)"``."""
        where = {"given": "focal x baseline given", "camera": "the stack's camera",
                 "none": "no focal length or baseline known"}[self.source]
        return f"Z = {self.scale:g} / d ({where})"


def depth_mapping(camera: Camera | None = None, focal_baseline: float | None = None) -> DepthMapping:
    """The disparity-to-depth mapping of a stack: the given ``focal_baseline``, else the camera's, else 1.

    Parameters
    ----------
    camera : Camera, optional
        The stack's camera; used when it knows both ``focal`` and ``baseline``.
    focal_baseline : float, optional
        Focal length (px) times baseline (scene units per view step). ``None`` or 0 means "not given".

    Raises
    ------
    VfxStereoError
        For a negative or non-finite ``focal_baseline``.
    """
    if focal_baseline:
        fb = float(focal_baseline)
        if not (np.isfinite(fb) and fb > 0):
            raise VfxStereoError(f"focal x baseline must be a positive number, got {focal_baseline!r}")
        return DepthMapping(fb, "given")
    if camera is not None and camera.focal and camera.baseline:
        return DepthMapping(float(camera.focal) * float(camera.baseline), "camera")
    return DepthMapping(1.0, "none")


def plane_depths(disparities, mapping: DepthMapping, *, far_factor: float = FAR_FACTOR) -> np.ndarray:
    """Distance of each layer's plane from the camera, strictly decreasing with the layer index.

    Parameters
    ----------
    disparities : array_like of shape (D,)
        Strictly increasing disparities.
    mapping : DepthMapping
        ``Z = scale / d`` for ``d > 0``.
    far_factor : float
        Layers with ``d <= 0`` go to ``far_factor`` times the farthest finite depth (``far_factor * scale``
        when no layer is finite); the ``m`` such layers are spread over ``far * (1 + k / m)``, ``k = 0``
        for the nearest of them, so they keep their order.

    Returns
    -------
    ndarray of shape (D,), float64, finite and positive.
    """
    d = np.asarray(disparities, dtype=np.float64).reshape(-1)
    if d.size == 0 or not np.all(np.isfinite(d)) or np.any(np.diff(d) <= 0):
        raise VfxStereoError("disparities must be finite and strictly increasing")
    if not far_factor > 1:
        raise VfxStereoError(f"far_factor must exceed 1, got {far_factor!r}")
    z = mapping.depth(d)
    beyond = ~np.isfinite(z)  # d <= 0: the first layers, since d increases
    m = int(beyond.sum())
    if m:
        far = far_factor * (float(z[~beyond].max()) if m < d.size else mapping.scale)
        z[:m] = far * (1.0 + np.arange(m - 1, -1, -1) / m)  # the most negative d farthest
    return z


# --------------------------------------------------------------------------------------------------------
# The camera's frame at a depth


@dataclass(frozen=True)
class CameraFrustum:
    """A Blender camera's view frame, as ``BKE_camera_params_compute_viewplane`` computes it.

    Parameters
    ----------
    width, height : int
        Render resolution in pixels (only their ratio, with the pixel aspect, matters).
    lens : float
        Focal length in mm (perspective cameras).
    sensor_width, sensor_height : float
        Sensor size in mm.
    sensor_fit : {"AUTO", "HORIZONTAL", "VERTICAL"}
        Which frame dimension the sensor size applies to; AUTO picks the larger one.
    shift_x, shift_y : float
        Lens shift, in units of the fitted frame dimension.
    pixel_aspect_x, pixel_aspect_y : float
        Render pixel aspect.
    ortho_scale : float or None
        Set for orthographic cameras: the fitted frame dimension in scene units, at every depth.
    """

    width: int
    height: int
    lens: float = 50.0
    sensor_width: float = 36.0
    sensor_height: float = 24.0
    sensor_fit: str = "AUTO"
    shift_x: float = 0.0
    shift_y: float = 0.0
    pixel_aspect_x: float = 1.0
    pixel_aspect_y: float = 1.0
    ortho_scale: float | None = None

    def __post_init__(self):
        if self.sensor_fit not in SENSOR_FITS:
            raise VfxStereoError(f"sensor_fit must be one of {SENSOR_FITS}, got {self.sensor_fit!r}")
        positive = {"width": self.width, "height": self.height, "lens": self.lens,
                    "sensor_width": self.sensor_width, "sensor_height": self.sensor_height,
                    "pixel_aspect_x": self.pixel_aspect_x, "pixel_aspect_y": self.pixel_aspect_y}
        if self.ortho_scale is not None:
            positive["ortho_scale"] = self.ortho_scale
        for name, value in positive.items():
            if not (np.isfinite(value) and value > 0):
                raise VfxStereoError(f"camera {name} must be a positive number, got {value!r}")

    def frame(self, depth: float) -> tuple[float, float, float, float]:
        """The view frame at distance ``depth``: ``(centre_x, centre_y, width, height)`` in scene units.

        Follows ``BKE_camera_params_compute_viewplane`` with ``clip_start`` replaced by ``depth`` (the frame
        of a perspective camera grows linearly with distance; an orthographic one does not).
        """
        ycor = self.pixel_aspect_y / self.pixel_aspect_x
        if self.sensor_fit == "AUTO":
            horizontal = self.pixel_aspect_x * self.width >= self.pixel_aspect_y * self.height
        else:
            horizontal = self.sensor_fit == "HORIZONTAL"
        if self.ortho_scale is not None:
            pixsize = float(self.ortho_scale)
        else:
            sensor = self.sensor_height if self.sensor_fit == "VERTICAL" else self.sensor_width
            pixsize = sensor * float(depth) / self.lens
        viewfac = self.width if horizontal else ycor * self.height
        pixsize /= viewfac
        width = self.width * pixsize
        height = ycor * self.height * pixsize
        return (self.shift_x * viewfac * pixsize, self.shift_y * viewfac * pixsize, width, height)


# --------------------------------------------------------------------------------------------------------
# Planes


@dataclass(frozen=True)
class PlanePlacement:
    """One layer's plane in the camera's local frame.

    Attributes
    ----------
    index : int
        Layer index in the stack (0 is furthest back).
    name : str
        Layer name in the stack file (``L03_d2p50``).
    disparity, depth : float
        The layer's disparity and the plane's distance from the camera.
    centre : tuple of 3 floats
        ``(x, y, -depth)``: the plane's centre; the plane faces the camera (its normal is +z).
    size : tuple of 2 floats
        ``(width, height)`` in scene units: the camera's frame at that depth.
    """

    index: int
    name: str
    disparity: float
    depth: float
    centre: tuple[float, float, float]
    size: tuple[float, float]


def layout_planes(disparities, names, frustum: CameraFrustum, mapping: DepthMapping) -> list[PlanePlacement]:
    """The plane of every layer: at the depth its disparity maps to, filling the camera's frame there.

    Parameters
    ----------
    disparities : array_like of shape (D,)
        Strictly increasing disparities.
    names : sequence of D str
        Layer names, in the same order.
    frustum : CameraFrustum
    mapping : DepthMapping

    Returns
    -------
    list of D PlanePlacement, in layer order (back to front).
    """
    d = np.asarray(disparities, dtype=np.float64).reshape(-1)
    if len(names) != d.size:
        raise VfxStereoError(f"{d.size} layers need {d.size} names, got {len(names)}")
    depths = plane_depths(d, mapping)
    out = []
    for i, (name, di, zi) in enumerate(zip(names, d, depths, strict=True)):
        cx, cy, w, h = frustum.frame(zi)
        out.append(PlanePlacement(i, str(name), float(di), float(zi), (cx, cy, -float(zi)), (w, h)))
    return out


def clip_range(depths, clip_start: float, clip_end: float) -> tuple[float, float]:
    """Camera clip distances that keep every plane in view: widened, never narrowed.

    ``clip_start`` becomes at most half the nearest depth, ``clip_end`` at least 1.5 times the farthest.
    """
    z = np.asarray(depths, dtype=np.float64)
    return min(float(clip_start), 0.5 * float(z.min())), max(float(clip_end), 1.5 * float(z.max()))
