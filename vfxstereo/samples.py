"""Synthetic multi-view scenes with exact ground truth, for the tests, the benchmarks and the demo.

Every scene is built the same way: a ground-truth :class:`~vfxstereo.stack.LayerStack` is made first, and
the K input views are its re-synthesised views, ``views[k] = stack.render(positions[k])[..., :3]``. The
stack *is* the ground truth: layer colours, opacities and disparities are exact by construction, and so
is everything derived from them (the disparity map, the mixed-pixel band). The back of every stack is
opaque over the whole frame at disparity 0, so every view is opaque (alpha 1) everywhere.

=================================  ====================================================================
scene                              what
=================================  ====================================================================
:func:`random_dot_stereogram`      Fig. 6 stimulus: K = 5, integral shifts, 8 planes d = 0..7, opaque
                                   random-dot squares (red) over a random-dot background (blue-green)
:func:`transparent_edge_stereogram`  Figs. 3/5/7 stimulus: a darker red object at d = 5 whose top
                                   half-circle has a soft (partially transparent) edge, over a lighter
                                   blue background at the odd disparity d = 1; views half a step apart,
                                   so odd disparities shift by half pixels (resampling, mixed pixels)
:func:`matting_scene`              a real soft matte (hair, fur) from the alpha-matting set over a
                                   Middlebury image used as a flat background plane
:func:`demo_scene`                 the shipped demo: trolls' hair (GT04) at d = 4, a pumpkin (GT19) at
                                   d = 2, Teddy at d = 0; 320 x 225, K = 5
:func:`cg_element`                 a premultiplied anti-aliased checker card for z-keying
:func:`layered_scene`              any size and number of planes (HD, 4K; 128 planes): soft-edged
                                   random-dot layers spread over the range, only the occupied planes
                                   stored; for speed benchmarks
=================================  ====================================================================

Conventions as in :mod:`vfxstereo.stack`: arrays ``[row, col]``, colour scene-linear float32, RGBA
premultiplied; a point at column x of the reference view on plane d appears at column
``x - d * (p_k - p_ref)`` of view k.

Data for :func:`matting_scene` and :func:`demo_scene` is read from ``../shared/data`` beside the
repository, from ``$VFXSTEREO_DATA``, or from ``data_dir=`` (in increasing priority).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.stack import LayerStack

DATA_ENV = "VFXSTEREO_DATA"
"""Environment variable naming the shared data folder (the one holding ``alphamatting_training_lowres``)."""

OPAQUE_TOLERANCE = 1e-5
"""A view counts as opaque when its rendered alpha is within this of 1 everywhere."""

# Random-dot shades, scene-linear (dark, light). The paper: "the background is blue-green, and the
# foreground is red" (Section 7); Fig. 3: "darker red object ... lighter blue background".
BLUE_GREEN = ((0.02, 0.10, 0.10), (0.15, 0.60, 0.55))
RED = ((0.10, 0.01, 0.01), (0.80, 0.10, 0.06))
DARK_RED = ((0.04, 0.004, 0.004), (0.40, 0.04, 0.03))
LIGHT_BLUE = ((0.22, 0.35, 0.65), (0.60, 0.75, 0.95))

_ALPHAMATTING = "alphamatting_training_lowres"


# --------------------------------------------------------------------------------------------------------
# The sample


@dataclass(eq=False)
class Sample:
    """A multi-view scene and its exact ground truth.

    Parameters
    ----------
    stack : LayerStack
        The ground truth: premultiplied, scene-linear RGBA layers ``(D, H, W, 4)`` on the disparity planes,
        with the camera (``Camera.from_positions(positions, reference)``).
    views : ndarray of shape (K, H, W, 3)
        float32, scene-linear, opaque RGB: ``views[k] == stack.render(positions[k])[..., :3]``.
    positions : ndarray of shape (K,)
        Camera positions along the baseline, in view steps.
    reference : int
        Index of the view the stack (virtual camera) belongs to.
    disparities : ndarray of shape (D,)
        The planes, ``stack.disparities``.
    name : str
        Short identifier, e.g. ``"rds"``.
    description : str
        One paragraph: what the scene is and how it was made.
    """

    stack: LayerStack
    views: np.ndarray
    positions: np.ndarray
    reference: int
    disparities: np.ndarray
    name: str
    description: str

    @classmethod
    def from_stack(cls, stack: LayerStack, *, name: str, description: str) -> Sample:
        """Render the views of ``stack`` at its camera's positions and wrap them as a sample.

        Raises
        ------
        VfxStereoError
            If the stack has no 1-D camera with a reference view, or a rendered view is not opaque.
        """
        cam = stack.camera
        if cam is None or cam.reference_index is None or cam.is_general or np.any(cam.positions[:, 1] != 0):
            raise VfxStereoError("a sample needs a stack with a 1-D camera whose reference is a view")
        positions = cam.positions[:, 0].copy()
        views = np.empty((len(positions), *stack.shape[1:], 3), np.float32)
        for k, p in enumerate(positions):
            rendered = stack.render(float(p))
            low = float(rendered[..., 3].min())
            if low < 1.0 - OPAQUE_TOLERANCE:
                raise VfxStereoError(f"view {k} of sample {name!r} is not opaque (alpha down to {low:.4g}); "
                                     "the back layer must cover the frame at disparity 0")
            views[k] = rendered[..., :3]
        return cls(stack, views, positions, int(cam.reference_index), stack.disparities.copy(), name,
                   description)

    def __post_init__(self):
        views = np.asarray(self.views)
        if views.ndim != 4 or views.shape[-1] != 3 or views.shape[1:3] != self.stack.shape[1:]:
            raise VfxStereoError(f"views must be (K, H, W, 3) at the stack's size, got {views.shape}")
        self.views = np.ascontiguousarray(views, dtype=np.float32)
        self.positions = np.asarray(self.positions, dtype=np.float64).reshape(-1)
        if self.positions.shape != (views.shape[0],):
            raise VfxStereoError(f"{views.shape[0]} views need {views.shape[0]} positions")
        if not 0 <= self.reference < views.shape[0]:
            raise VfxStereoError(f"reference view {self.reference} is not one of the {views.shape[0]} views")
        self.disparities = np.asarray(self.disparities, dtype=np.float64).reshape(-1)

    # ---------------------------------------------------------------------------------------------------
    @property
    def camera(self) -> Camera:
        """The rig (``stack.camera``)."""
        return self.stack.camera

    @property
    def K(self) -> int:  # noqa: N802 - the paper's symbol
        """Number of views."""
        return self.views.shape[0]

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return self.views.shape[1:3]

    @property
    def reference_view(self) -> np.ndarray:
        """``views[reference]``, (H, W, 3) float32."""
        return self.views[self.reference]

    def gt_disparity(self, threshold: float = 0.5) -> np.ndarray:
        """Ground-truth disparity of the reference view: the front-most layer with alpha > ``threshold``.

        Returns
        -------
        ndarray of shape (H, W), float32; every pixel has a value (the back layer is opaque).
        """
        return self.stack.disparity_map(threshold)

    def mixed_pixels(self, *, tol: float = 1e-4) -> np.ndarray:
        """Reference pixels whose colour comes from more than one layer.

        A pixel is mixed when no single layer's visible contribution ``alpha_d * prod_{d' > d}(1 - alpha_d')``
        (Eq. 7) reaches ``1 - tol``: a partially transparent layer covers it and something behind shows
        through. Fully hidden layers do not count. (The flattened alpha is 1 everywhere, so this is the
        meaning of "0 < alpha < 1" for an opaque scene.)

        Returns
        -------
        ndarray of shape (H, W), bool.
        """
        return self.stack.visibility_weights().max(axis=0) < 1.0 - tol

    def soft_edge_mask(self, dilate: int = 2, *, tol: float = 1e-4) -> np.ndarray:
        """The soft-edge band: :meth:`mixed_pixels` dilated by ``dilate`` pixels (a square neighbourhood).

        Benchmarks score colour and alpha in this band, where matting matters.

        Returns
        -------
        ndarray of shape (H, W), bool.
        """
        if dilate < 0:
            raise VfxStereoError(f"the soft-edge band needs a dilation of 0 or more pixels, got {dilate}")
        mask = self.mixed_pixels(tol=tol)
        if dilate and mask.any():
            from scipy.ndimage import binary_dilation

            mask = binary_dilation(mask, structure=np.ones((3, 3), bool), iterations=int(dilate))
        return mask


# --------------------------------------------------------------------------------------------------------
# Building blocks


def random_dots(rng: np.random.Generator, shape: tuple[int, int], shades) -> np.ndarray:
    """A random-dot texture: every pixel an independent uniform mix of a dark and a light shade.

    Parameters
    ----------
    rng : numpy.random.Generator
    shape : tuple of int
        ``(H, W)``.
    shades : pair of RGB triples
        ``(dark, light)``, scene-linear.

    Returns
    -------
    ndarray of shape (H, W, 3), float32, straight colour.
    """
    dark, light = (np.asarray(s, np.float32) for s in shades)
    t = rng.random(shape, dtype=np.float32)[..., None]
    return (dark + t * (light - dark)).astype(np.float32)


def _plane_index(disparities: np.ndarray, d: float, what: str) -> int:
    hit = np.flatnonzero(np.isclose(disparities, d, rtol=0.0, atol=1e-9))
    if hit.size != 1:
        raise VfxStereoError(f"{what} disparity {d:g} is not one of the planes {disparities.tolist()}")
    return int(hit[0])


def _plane_grid(num_planes: int) -> np.ndarray:
    if int(num_planes) != num_planes or num_planes < 2:
        raise VfxStereoError(f"a scene needs at least 2 whole disparity planes, got num_planes={num_planes}")
    return np.arange(int(num_planes), dtype=np.float64)


def _check_shape(shape, minimum: int = 16) -> tuple[int, int]:
    try:
        h, w = (int(v) for v in shape)
    except (TypeError, ValueError):
        raise VfxStereoError(f"shape must be (H, W), got {shape!r}") from None
    if h < minimum or w < minimum:
        raise VfxStereoError(f"shape must be at least {minimum} x {minimum} pixels, got {h} x {w}")
    return h, w


def _fill_back(rgba: np.ndarray, disparities: np.ndarray, i_bg: int, texture) -> None:
    """Make the background layer ``i_bg`` opaque and, if it is not at d = 0, add an opaque backdrop at d = 0.

    Layers are frame-sized and views are zero outside the shifted frame, so only a layer at d = 0 covers
    every view. A background at d > 0 therefore gets a backdrop at d = 0, hidden behind it in the
    reference view and seen only in the |d * (p_k - p_ref)| columns at the frame edges of the other views.
    ``texture(i)`` returns the straight colour (H, W, 3) of layer ``i``.
    """
    rgba[i_bg, ..., :3] = texture(i_bg)
    rgba[i_bg, ..., 3] = 1.0
    if disparities[i_bg] != 0.0:
        i0 = _plane_index(disparities, 0.0, "backdrop")
        if i0 >= i_bg:
            raise VfxStereoError("the background must be nearer than the backdrop at d = 0")
        rgba[i0, ..., :3] = texture(i0)
        rgba[i0, ..., 3] = 1.0


# --------------------------------------------------------------------------------------------------------
# 1. Random-dot stereogram (Fig. 6)


def _default_squares(h: int, w: int) -> tuple[tuple[int, int, int, int, int], ...]:
    # A large square at d = 3 left of centre and a smaller one at d = 6 overlapping its lower right corner;
    # at K = 5 (offsets -2..2) both stay inside the frame in every view for frames of 64 px and more.
    big = (3, round(0.22 * h), round(0.20 * w), round(0.44 * h), round(0.42 * w))
    small = (6, round(0.44 * h), round(0.52 * w), round(0.30 * h), round(0.25 * w))
    return big, small


def random_dot_stereogram(
    *,
    shape: tuple[int, int] = (64, 64),
    num_planes: int = 8,
    background_disparity: float = 0.0,
    squares=None,
    seed: int | np.random.Generator = 0,
) -> Sample:
    """The random-dot stereogram of Fig. 6: K = 5 views, integral shifts, 8 planes, no partial alpha.

    Views at positions 0..4 with the reference in the middle (index 2), planes d = 0 .. num_planes - 1, so
    every shift ``d * (p_k - p_ref)`` is a whole number of pixels. A blue-green random-dot background
    covers the frame at ``background_disparity``; red random-dot squares float in front of it. Every
    alpha is 0 or 1.

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)``, at least 16 x 16.
    num_planes : int
        Number of planes D (disparities 0 .. D - 1); 8 as in the paper.
    background_disparity : float
        Disparity of the background; a background at d > 0 gets an opaque backdrop at d = 0 (see
        :func:`_fill_back`), seen only at the frame edges of the non-reference views.
    squares : sequence of (d, top, left, height, width) or None
        The opaque squares (rectangles) in reference-view pixels, each with its own random-dot texture;
        nearer than the background. ``None``: a large square at d = 3 and a smaller one at d = 6 that
        overlaps it.
    seed : int or numpy.random.Generator
        Seed of the textures; the same seed gives the same views.

    Returns
    -------
    Sample
        ``name = "rds"``; ``stack.metadata["squares"]`` lists the squares.
    """
    h, w = _check_shape(shape)
    rng = np.random.default_rng(seed)
    disparities = _plane_grid(num_planes)
    i_bg = _plane_index(disparities, background_disparity, "background")
    squares = _default_squares(h, w) if squares is None else tuple(tuple(s) for s in squares)
    rgba = np.zeros((len(disparities), h, w, 4), np.float32)
    _fill_back(rgba, disparities, i_bg, lambda i: random_dots(rng, (h, w), BLUE_GREEN))
    for sq in squares:
        try:
            d, top, left, sh, sw = sq
            top, left, sh, sw = int(top), int(left), int(sh), int(sw)
        except (TypeError, ValueError):
            raise VfxStereoError(f"a square is (d, top, left, height, width), got {sq!r}") from None
        i = _plane_index(disparities, d, "square")
        if i <= i_bg:
            raise VfxStereoError(
                f"square at d={d:g} is not in front of the background at d={background_disparity:g}")
        if sh < 1 or sw < 1 or top < 0 or left < 0 or top + sh > h or left + sw > w:
            raise VfxStereoError(f"square {sq!r} does not lie inside the {h} x {w} frame")
        rgba[i, top:top + sh, left:left + sw, :3] = random_dots(rng, (sh, sw), RED)
        rgba[i, top:top + sh, left:left + sw, 3] = 1.0
    positions = np.arange(5, dtype=np.float64)
    camera = Camera.from_positions(positions, reference=2)
    meta = {
        "sample": "rds",
        "generator": "vfxstereo.samples.random_dot_stereogram",
        "seed": seed if isinstance(seed, int) else None,
        "background_disparity": float(background_disparity),
        "squares": [[float(s[0]), *(int(v) for v in s[1:])] for s in squares],
    }
    stack = LayerStack(rgba, disparities, camera, meta)
    description = (
        f"Random-dot stereogram (Szeliski & Golland 1999, Fig. 6): {w}x{h} px (W x H), K=5 views at "
        f"positions 0..4, reference 2, planes d=0..{len(disparities) - 1}, integral shifts. Blue-green "
        f"random-dot background at d={background_disparity:g}; opaque red random-dot squares at d="
        f"{', '.join(f'{s[0]:g}' for s in squares)}. No partially transparent pixels."
    )
    return Sample.from_stack(stack, name="rds", description=description)


# --------------------------------------------------------------------------------------------------------
# 2. Transparent-edge stereogram (Figs. 3, 5, 7)


def _tombstone(h: int, w: int, edge_width: float) -> tuple[np.ndarray, dict]:
    """Alpha of a rectangle topped by a half-disc; only the half-circle edge is soft.

    The body covers rows ``[r0, r1)`` and columns ``[c0, c1)`` with hard (0/1) edges aligned to pixels.
    The half-disc has radius ``R = (c1 - c0) / 2`` and centre ``(r0 - 0.5, (c0 + c1 - 1) / 2)`` (pixel
    centres at integers), so its flat side lies on the top boundary of row r0; it covers rows < r0 with
    ``alpha = clip((R - dist) / edge_width + 0.5, 0, 1)``, a linear ramp ``edge_width`` pixels wide
    centred on the circle.
    """
    r0, r1 = round(0.45 * h), round(0.85 * h)
    c0, c1 = round(0.32 * w), round(0.68 * w)
    radius = (c1 - c0) / 2.0
    cy, cx = r0 - 0.5, (c0 + c1 - 1) / 2.0
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    alpha = np.zeros((h, w), np.float64)
    alpha[r0:r1, c0:c1] = 1.0
    disc = np.clip((radius - np.hypot(yy - cy, xx - cx)) / edge_width + 0.5, 0.0, 1.0)
    alpha[:r0] = disc[:r0]
    geometry = {"body_rows": [r0, r1], "body_cols": [c0, c1], "centre": [cy, cx], "radius": radius,
                "edge_width": float(edge_width)}
    return alpha.astype(np.float32), geometry


def transparent_edge_stereogram(
    *,
    shape: tuple[int, int] = (64, 64),
    num_planes: int = 8,
    fg_disparity: float = 5.0,
    bg_disparity: float = 1.0,
    view_step: float = 0.5,
    edge_width: float = 2.0,
    seed: int | np.random.Generator = 0,
) -> Sample:
    """The stimulus of Figs. 3, 5 and 7: a soft-edged red object over a blue background at an odd disparity.

    A darker red random-dot object at ``fg_disparity`` (5) over a lighter blue random-dot background at
    ``bg_disparity`` (1), planes d = 0..7. The object is a rectangle with a half-disc on top; the edge of
    the half-circle is partially transparent (a linear alpha ramp ``edge_width`` pixels wide), every other
    edge is hard and pixel-aligned.

    "Odd disparity" (Section 7: "because the background layer is at an odd disparity, we get significant
    re-sampling errors ... and mixed pixels"): the K = 5 views are ``view_step`` = 0.5 apart (positions
    0, 0.5, 1, 1.5, 2; reference 2), so plane d shifts by ``d * (-1, -0.5, 0, 0.5, 1)`` pixels: even
    disparities move by whole pixels, odd ones by half pixels in views 1 and 3, which bilinear resampling
    turns into mixed pixels -- at the background (d = 1) and, as Fig. 3(c) shows, at the object (d = 5).
    The background at d = 1 is backed by an opaque blue backdrop at d = 0 (seen only at the frame edges
    of the non-reference views; see :func:`_fill_back`).

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)``, at least 16 x 16.
    num_planes : int
        Number of planes (disparities 0 .. num_planes - 1).
    fg_disparity, bg_disparity : float
        Planes of the object and of the background; ``fg_disparity > bg_disparity``.
    view_step : float
        Distance between neighbouring views, in position units.
    edge_width : float
        Width in pixels of the alpha ramp across the half-circle.
    seed : int or numpy.random.Generator
        Seed of the textures.

    Returns
    -------
    Sample
        ``name = "fig7"``; ``stack.metadata["object"]`` holds the object's geometry (see :func:`_tombstone`).
    """
    h, w = _check_shape(shape)
    if not (np.isfinite(view_step) and view_step > 0):
        raise VfxStereoError(f"view_step must be a positive number, got {view_step}")
    if not (np.isfinite(edge_width) and edge_width > 0):
        raise VfxStereoError(f"edge_width must be a positive number of pixels, got {edge_width}")
    rng = np.random.default_rng(seed)
    disparities = _plane_grid(num_planes)
    i_bg = _plane_index(disparities, bg_disparity, "background")
    i_fg = _plane_index(disparities, fg_disparity, "foreground")
    if i_fg <= i_bg:
        raise VfxStereoError("the foreground disparity must be larger (nearer) than the background's")
    rgba = np.zeros((len(disparities), h, w, 4), np.float32)
    _fill_back(rgba, disparities, i_bg, lambda i: random_dots(rng, (h, w), LIGHT_BLUE))
    alpha, geometry = _tombstone(h, w, float(edge_width))
    rgba[i_fg, ..., :3] = random_dots(rng, (h, w), DARK_RED) * alpha[..., None]
    rgba[i_fg, ..., 3] = alpha
    positions = view_step * np.arange(5, dtype=np.float64)
    camera = Camera.from_positions(positions, reference=2)
    meta = {
        "sample": "fig7",
        "generator": "vfxstereo.samples.transparent_edge_stereogram",
        "seed": seed if isinstance(seed, int) else None,
        "fg_disparity": float(fg_disparity),
        "bg_disparity": float(bg_disparity),
        "object": geometry,
    }
    stack = LayerStack(rgba, disparities, camera, meta)
    description = (
        f"Transparent-edge stereogram (Szeliski & Golland 1999, Figs. 3/5/7): {w}x{h} px (W x H), "
        f"K=5 views at "
        f"positions {', '.join(f'{p:g}' for p in positions)}, reference 2, "
        f"planes d=0..{len(disparities) - 1}. "
        f"Darker red random-dot object at d={fg_disparity:g} (a rectangle with a half-disc on top whose "
        f"edge is a {edge_width:g}-px alpha ramp) over a lighter blue random-dot background at "
        f"d={bg_disparity:g}; odd disparities shift by half pixels in views 1 and 3 (bilinear mixed pixels)."
    )
    return Sample.from_stack(stack, name="fig7", description=description)


# --------------------------------------------------------------------------------------------------------
# 3. Real soft mattes over a real background


def find_data_dir(data_dir: str | os.PathLike | None = None) -> Path:
    """The shared data folder: ``data_dir`` if given, else ``$VFXSTEREO_DATA``, else ``../shared/data``.

    Raises
    ------
    VfxStereoError
        If the folder does not exist.
    """
    if data_dir is None:
        data_dir = os.environ.get(DATA_ENV) or Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    path = Path(data_dir).resolve()
    if not path.is_dir():
        raise VfxStereoError(f"data folder {path} not found (pass data_dir= or set {DATA_ENV})")
    return path


def _read_srgb(path: Path) -> np.ndarray:
    """An 8/16-bit sRGB-encoded image as scene-linear float32 RGB (H, W, 3), by the house reader."""
    from vfxstereo.io.plates import read_plate

    if not Path(path).is_file():
        raise VfxStereoError(f"image {path} not found")
    return read_plate(path)


def _read_alpha(path: Path) -> np.ndarray:
    """A matte (linear coverage, not sRGB-encoded) as float32 (H, W) in [0, 1].

    The first channel's codes divided by 255 (8-bit files, as in the alpha-matting set) or by 65535 (16-bit).
    """
    from vfxstereo.io.plates import read_raw_values

    if not Path(path).is_file():
        raise VfxStereoError(f"matte {path} not found")
    codes = read_raw_values(path, channel=0)
    return (codes / np.float32(255.0 if codes.max() <= 255 else 65535.0)).astype(np.float32)


def _resize_area(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """cv2 INTER_AREA resize to ``(H, W)`` (INTER_LINEAR when enlarging), float32."""
    import cv2

    h, w = shape
    enlarge = h > img.shape[0] or w > img.shape[1]
    out = cv2.resize(np.ascontiguousarray(img, np.float32), (w, h),
                     interpolation=cv2.INTER_LINEAR if enlarge else cv2.INTER_AREA)
    return out.reshape(h, w, *img.shape[2:]).astype(np.float32)


def _estimate_foreground(composite: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """A plausible straight foreground colour F for ``composite = alpha * F + (1 - alpha) * B``.

    Simple and self-consistent, not a matting solver: B is filled in from the nearest clear background
    pixel (alpha <= 0.02), ``F = (I - (1 - alpha) B) / alpha`` where alpha is large enough to trust the
    division, blended towards the nearest solid foreground colour (alpha >= 0.95) as alpha falls, and
    ``F = I`` where the foreground is solid. Values are clipped to [0, 1].

    Returns
    -------
    ndarray of shape (H, W, 3), float32.
    """
    from scipy.ndimage import distance_transform_edt

    solid = alpha >= 0.95
    clear = alpha <= 0.02
    if not solid.any():
        raise VfxStereoError("the matte has no solid foreground (alpha >= 0.95) to take colours from")
    iy, ix = distance_transform_edt(~solid, return_distances=False, return_indices=True)
    f_near = composite[iy, ix]
    if clear.any():
        by, bx = distance_transform_edt(~clear, return_distances=False, return_indices=True)
        b_near = composite[by, bx]
    else:
        b_near = np.zeros_like(composite)
    a = alpha[..., None]
    f_solve = np.clip((composite - (1.0 - a) * b_near) / np.maximum(a, 1e-3), 0.0, 1.0)
    trust = np.clip((a - 0.15) / 0.5, 0.0, 1.0)
    f = trust * f_solve + (1.0 - trust) * f_near
    f[solid] = composite[solid]
    return np.clip(f, 0.0, 1.0).astype(np.float32)


def _check_image_name(image: str) -> str:
    name = str(image)
    if name.lower().endswith(".png"):
        name = name[:-4]
    if len(name) != 4 or not name.upper().startswith("GT") or not name[2:].isdigit():
        raise VfxStereoError(f"matting image must be one of GT01..GT27, got {image!r}")
    return name.upper()


def load_matte(image: str = "GT01", *,
               data_dir: str | os.PathLike | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One image of the alpha-matting training set: straight foreground colour and exact alpha.

    ``input_training_lowres/GTxx.png`` (sRGB, decoded to scene-linear) is the composite I;
    ``gt_training_lowres/GTxx.png`` is the alpha (linear coverage, 8-bit, value / 255). The foreground
    colour F is estimated by :func:`_estimate_foreground`.

    Returns
    -------
    foreground : ndarray of shape (H, W, 3)
        Straight scene-linear colour, float32 in [0, 1].
    alpha : ndarray of shape (H, W)
        float32 in [0, 1], the dataset's alpha exactly.
    """
    name = _check_image_name(image)
    root = find_data_dir(data_dir) / _ALPHAMATTING
    composite = _read_srgb(root / "input_training_lowres" / f"{name}.png")
    alpha = _read_alpha(root / "gt_training_lowres" / f"{name}.png")
    if alpha.shape != composite.shape[:2]:
        raise VfxStereoError(f"{name}: alpha {alpha.shape} and image {composite.shape[:2]} differ in size")
    return _estimate_foreground(composite, alpha), alpha


def _matte_layer(foreground: np.ndarray, alpha: np.ndarray, *, size: tuple[int, int], frame: tuple[int, int],
                 top: int = 0, left: int = 0) -> np.ndarray:
    """A premultiplied (H, W, 4) layer holding the matte resized to ``size`` with its corner at (top, left).

    The matte is resized premultiplied (cv2 INTER_AREA on ``alpha * F`` and on ``alpha``): area
    averaging of coverage-weighted colour is the physically right downsampling of a matte, and it keeps
    colour <= alpha. Parts falling outside the frame are cut off.
    """
    h, w = frame
    sh, sw = size
    premult = _resize_area(foreground * alpha[..., None], size)
    a = np.clip(_resize_area(alpha, size), 0.0, 1.0)
    premult = np.clip(premult, 0.0, a[..., None])
    layer = np.zeros((h, w, 4), np.float32)
    y0, x0 = max(top, 0), max(left, 0)
    y1, x1 = min(top + sh, h), min(left + sw, w)
    if y1 <= y0 or x1 <= x0:
        raise VfxStereoError(f"the matte placed at ({top}, {left}) lies outside the {h} x {w} frame")
    layer[y0:y1, x0:x1, :3] = premult[y0 - top:y1 - top, x0 - left:x1 - left]
    layer[y0:y1, x0:x1, 3] = a[y0 - top:y1 - top, x0 - left:x1 - left]
    return layer


def load_background(background: str | os.PathLike = "teddy", *, shape: tuple[int, int],
                    data_dir: str | os.PathLike | None = None) -> np.ndarray:
    """A background plate, scene-linear float32 (H, W, 3), scaled to cover ``shape`` and centre-cropped.

    Parameters
    ----------
    background : str or path
        The name of a folder of the shared data with a ``dataset.json`` (``"teddy"``, ``"tsukuba"``,
        ``"cones"`` are short for the Middlebury folders), whose reference view is used; or the path of
        an sRGB-encoded image file.
    shape : tuple of int
        ``(H, W)`` of the result.
    """
    root = find_data_dir(data_dir)
    aliases = {"teddy": "middlebury2003_teddy", "tsukuba": "middlebury2001_tsukuba",
               "cones": "middlebury2003_cones_halfsize", "venus": "middlebury2001_venus"}
    name = str(background)
    folder = root / aliases.get(name.lower(), name)
    if (folder / "dataset.json").is_file():
        try:
            meta = json.loads((folder / "dataset.json").read_text())
            path = folder / meta["views"][int(meta.get("reference", 0))]
        except (ValueError, KeyError, IndexError, TypeError) as exc:
            raise VfxStereoError(f"{folder / 'dataset.json'} is malformed: {exc}") from None
    else:
        path = Path(background)
        if not path.is_file():
            raise VfxStereoError(f"background {background!r} is not a dataset folder in {root} nor a file")
    img = _read_srgb(path)
    h, w = shape
    scale = max(h / img.shape[0], w / img.shape[1])
    ch, cw = max(h, round(img.shape[0] * scale)), max(w, round(img.shape[1] * scale))
    img = _resize_area(img, (ch, cw))
    y0, x0 = (ch - h) // 2, (cw - w) // 2
    return np.ascontiguousarray(np.clip(img[y0:y0 + h, x0:x0 + w], 0.0, None))


def _scaled_size(shape: tuple[int, int], scale: float) -> tuple[int, int]:
    if not (np.isfinite(scale) and scale > 0):
        raise VfxStereoError(f"scale must be a positive number, got {scale}")
    size = (max(1, round(shape[0] * scale)), max(1, round(shape[1] * scale)))
    return size


def matting_scene(
    image: str = "GT01",
    *,
    scale: float = 0.4,
    fg_disparity: float = 4.0,
    bg_disparity: float = 0.0,
    K: int = 5,  # noqa: N803 - the paper's symbol
    num_planes: int | None = None,
    background: str | os.PathLike = "teddy",
    data_dir: str | os.PathLike | None = None,
) -> Sample:
    """A real soft matte (hair, fur, leaves) at ``fg_disparity`` over a flat real background.

    Layers: the Middlebury ``background`` image as an opaque plane at ``bg_disparity`` (backed at d = 0 by
    a copy of itself when ``bg_disparity > 0``, see :func:`_fill_back`) and the premultiplied foreground
    ``alpha * F`` of the alpha-matting image at ``fg_disparity``, both at the matting image's size times
    ``scale`` (INTER_AREA). The foreground's alpha is the dataset's ground-truth alpha resized; its colour
    F is estimated from the composite (:func:`load_matte`): plausible, and exact as ground truth because
    the stack defines the views.

    Parameters
    ----------
    image : str
        ``"GT01"`` .. ``"GT27"`` of ``alphamatting_training_lowres``.
    scale : float
        Size relative to the dataset's low-resolution image (800 px on the long side).
    fg_disparity, bg_disparity : float
        Planes of the foreground and background; whole numbers below ``num_planes``.
    K : int
        Number of views, at positions 0 .. K - 1 with the reference at ``K // 2``.
    num_planes : int or None
        Planes d = 0 .. num_planes - 1; default ``fg_disparity + 1``.
    background : str or path
        See :func:`load_background`.
    data_dir : path or None
        See :func:`find_data_dir`.

    Returns
    -------
    Sample
        ``name = "matting-GTxx"``.
    """
    name = _check_image_name(image)
    if int(K) != K or K < 2:
        raise VfxStereoError(f"K must be a whole number of views >= 2, got {K}")
    if num_planes is None:
        num_planes = int(np.floor(max(fg_disparity, bg_disparity))) + 1
    disparities = _plane_grid(num_planes)
    i_bg = _plane_index(disparities, bg_disparity, "background")
    i_fg = _plane_index(disparities, fg_disparity, "foreground")
    if i_fg <= i_bg:
        raise VfxStereoError("the foreground disparity must be larger (nearer) than the background's")
    foreground, alpha = load_matte(name, data_dir=data_dir)
    h, w = _scaled_size(alpha.shape, scale)
    bg = load_background(background, shape=(h, w), data_dir=data_dir)
    rgba = np.zeros((len(disparities), h, w, 4), np.float32)
    _fill_back(rgba, disparities, i_bg, lambda i: bg)
    rgba[i_fg] = _matte_layer(foreground, alpha, size=(h, w), frame=(h, w))
    positions = np.arange(int(K), dtype=np.float64)
    camera = Camera.from_positions(positions, reference=int(K) // 2)
    meta = {
        "sample": f"matting-{name}",
        "generator": "vfxstereo.samples.matting_scene",
        "image": name,
        "scale": float(scale),
        "fg_disparity": float(fg_disparity),
        "bg_disparity": float(bg_disparity),
        "background": str(background),
        "sources": "alphamatting.com training set (Rhemann et al., CVPR 2009); Middlebury stereo "
                   "(Scharstein & Szeliski)",
    }
    stack = LayerStack(rgba, disparities, camera, meta)
    description = (
        f"Alpha-matting image {name} (exact alpha, estimated straight colour) at d={fg_disparity:g} over "
        f"the {background} image as a flat plane at d={bg_disparity:g}; {w}x{h} px (W x H), K={K} views at "
        f"positions 0..{K - 1}, reference {K // 2}, planes d=0..{len(disparities) - 1}."
    )
    return Sample.from_stack(stack, name=f"matting-{name}", description=description)


# --------------------------------------------------------------------------------------------------------
# 4. The shipped demo and its CG element

DEMO_ELEMENT_DISPARITY = 3.0
"""Where the demo z-keys :func:`cg_element`: in front of the pumpkin (d = 2), behind the trolls (d = 4)."""


def demo_scene(*, data_dir: str | os.PathLike | None = None) -> Sample:
    """The shipped demo: the trolls' hair of GT04 at d = 4, the pumpkin of GT19 at d = 2, Teddy at d = 0.

    320 x 225 pixels (W x H; GT04 at scale 0.4), K = 5 views at positions 0..4, reference 2, planes d = 0..4.
    The pumpkin (GT19 at scale 0.16, 128 x 93 px) stands in the lower left corner, partly behind the
    pink troll's arm. A CG element z-keyed at :data:`DEMO_ELEMENT_DISPARITY` (d = 3) lands in front of the
    pumpkin and behind the trolls, so their hair must cross it with its soft alpha.

    Returns
    -------
    Sample
        ``name = "demo"``.
    """
    trolls, trolls_alpha = load_matte("GT04", data_dir=data_dir)
    pumpkin, pumpkin_alpha = load_matte("GT19", data_dir=data_dir)
    h, w = _scaled_size(trolls_alpha.shape, 0.4)
    ph, pw = _scaled_size(pumpkin_alpha.shape, 0.16)
    disparities = _plane_grid(5)
    rgba = np.zeros((len(disparities), h, w, 4), np.float32)
    bg = load_background("teddy", shape=(h, w), data_dir=data_dir)
    _fill_back(rgba, disparities, 0, lambda i: bg)
    rgba[2] = _matte_layer(pumpkin, pumpkin_alpha, size=(ph, pw), frame=(h, w), top=h - ph, left=6)
    rgba[4] = _matte_layer(trolls, trolls_alpha, size=(h, w), frame=(h, w))
    camera = Camera.from_positions(np.arange(5, dtype=np.float64), reference=2)
    meta = {
        "sample": "demo",
        "generator": "vfxstereo.samples.demo_scene",
        "layers": {"0": "Middlebury 2003 Teddy im2 (flat)", "2": "alphamatting GT19 (pumpkin)",
                   "4": "alphamatting GT04 (trolls' hair)"},
        "element_disparity": DEMO_ELEMENT_DISPARITY,
        "sources": "alphamatting.com training set (Rhemann et al., CVPR 2009); Middlebury 2003 Teddy "
                   "(Scharstein & Szeliski, CVPR 2003)",
    }
    stack = LayerStack(rgba, disparities, camera, meta)
    description = (
        f"Demo: {w}x{h} px (W x H), K=5 views at positions 0..4, reference 2, planes d=0..4. Trolls "
        "with long pink and green hair (alpha-matting GT04, exact alpha) at d=4, a pumpkin (GT19) at d=2 "
        "in the lower left, and the Teddy image (Middlebury 2003) as a flat background at d=0. Z-key CG "
        "elements at d=3: in front of the pumpkin, behind the hair."
    )
    return Sample.from_stack(stack, name="demo", description=description)


def cg_element(
    shape: tuple[int, int] = (225, 320),
    *,
    centre: tuple[float, float] | None = None,
    size: float | None = None,
    angle: float = 20.0,
    checks: int = 6,
    colours=((0.75, 0.75, 0.72), (0.03, 0.12, 0.55)),
    supersample: int = 4,
) -> np.ndarray:
    """A CG element for z-keying: an anti-aliased, rotated checker card, premultiplied RGBA.

    Coverage and colour are box-filtered over ``supersample`` x ``supersample`` samples per pixel, so
    the card's outline and its checks have anti-aliased (fractional-alpha) edges.

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)`` of the frame.
    centre : (row, col) or None
        Centre of the card in pixels; default ``(0.47 H, 0.18 W)``, left of the middle: in the demo
        (:func:`demo_scene`) the pink troll's hair crosses it and it covers the top of the pumpkin.
    size : float or None
        Side of the (square) card in pixels; default ``0.42 * min(H, W)``.
    angle : float
        Rotation in degrees, counter-clockwise on screen.
    checks : int
        Checks per side.
    colours : pair of RGB triples
        Scene-linear straight colours of the two kinds of check.
    supersample : int
        Samples per pixel along each axis.

    Returns
    -------
    ndarray of shape (H, W, 4)
        float32, premultiplied, scene-linear; alpha 1 inside the card, 0 outside, fractional on its edge.
    """
    h, w = _check_shape(shape, minimum=2)
    if int(supersample) != supersample or supersample < 1 or int(checks) != checks or checks < 1:
        raise VfxStereoError("supersample and checks must be positive whole numbers")
    ss = int(supersample)
    cy, cx = (0.47 * h, 0.18 * w) if centre is None else (float(centre[0]), float(centre[1]))
    side = 0.42 * min(h, w) if size is None else float(size)
    if not side > 0:
        raise VfxStereoError(f"the card size must be positive, got {size}")
    c0, c1 = (np.asarray(c, np.float64) for c in colours)
    offs = (np.arange(ss) + 0.5) / ss - 0.5  # sample offsets inside a pixel
    y = (np.arange(h)[:, None] + offs[None, :]).reshape(-1) - cy  # (H*ss,)
    x = (np.arange(w)[:, None] + offs[None, :]).reshape(-1) - cx  # (W*ss,)
    t = np.deg2rad(angle)
    # card coordinates: rotate screen (x right, y down) by +angle on screen (counter-clockwise)
    u = np.cos(t) * x[None, :] - np.sin(t) * y[:, None]
    v = np.sin(t) * x[None, :] + np.cos(t) * y[:, None]
    half = side / 2.0
    inside = (np.abs(u) < half) & (np.abs(v) < half)
    cell = side / int(checks)
    odd = ((np.floor((u + half) / cell) + np.floor((v + half) / cell)) % 2).astype(bool)
    rgb = np.where(odd[..., None], c1, c0) * inside[..., None]
    rgba = np.concatenate([rgb, inside[..., None].astype(np.float64)], axis=-1)  # (H*ss, W*ss, 4)
    rgba = rgba.reshape(h, ss, w, ss, 4).mean(axis=(1, 3))
    return rgba.astype(np.float32)


# --------------------------------------------------------------------------------------------------------
# 5. Soft-edged layers at any size, for speed benchmarks


def _soft_ellipse(h: int, w: int, centre, radii, edge_width: float) -> np.ndarray:
    """Alpha of an ellipse whose edge is a linear ramp ``edge_width`` pixels wide (measured on its short axis)."""
    yy, xx = np.ogrid[0:h, 0:w]
    rho = np.sqrt(((yy - centre[0]) / radii[0]) ** 2 + ((xx - centre[1]) / radii[1]) ** 2, dtype=np.float32)
    return np.clip((1.0 - rho) * np.float32(min(radii) / edge_width) + np.float32(0.5), 0.0, 1.0)


_LAYER_SHADES = (LIGHT_BLUE, RED, DARK_RED, ((0.05, 0.12, 0.02), (0.45, 0.70, 0.20)))


def layered_scene(
    *,
    shape: tuple[int, int] = (540, 960),
    num_planes: int = 64,
    layers: int = 3,
    view_step: float = 0.5,
    edge_width: float = 3.0,
    seed: int | np.random.Generator = 0,
) -> Sample:
    """Soft-edged textured layers at any size and number of planes, for speed benchmarks (HD, 4K).

    A random-dot backdrop at d = 0 covers the frame; ``layers`` soft-edged random-dot ellipses lie at
    disparities spread over the range, ``round(0.9 (i + 1) / layers (num_planes - 1))`` for layer i, nearer
    ones smaller and further right. K = 5 views ``view_step`` apart (reference 2), so odd disparities shift
    by half pixels when the step is 0.5 (bilinear mixed pixels, as in :func:`transparent_edge_stereogram`).

    The ground-truth stack holds only the occupied planes (the backdrop and the layers), so it stays small
    at 4096 x 2160 with 128 planes; a full stack with empty planes in between renders the same views (the
    empty planes add nothing). Solve it on the whole grid ``np.arange(num_planes)``;
    ``stack.metadata["planes"]`` says how many.

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)``, at least 16 x 16.
    num_planes : int
        The solve's plane count D (disparities 0 .. D - 1); at least ``layers + 1``.
    layers : int
        Soft-edged layers in front of the backdrop, 1 to 4.
    view_step : float
        Distance between neighbouring views, in position units.
    edge_width : float
        Width in pixels of each layer's alpha ramp.
    seed : int or numpy.random.Generator
        Seed of the textures.

    Returns
    -------
    Sample
        ``name = "layered"``; ``stack.disparities`` are the occupied planes only.
    """
    h, w = _check_shape(shape)
    if int(layers) != layers or not 1 <= layers <= len(_LAYER_SHADES):
        raise VfxStereoError(f"layers must be a whole number from 1 to {len(_LAYER_SHADES)}, got {layers}")
    if int(num_planes) != num_planes or num_planes < 2 * layers + 1:
        raise VfxStereoError(f"{layers} layers need at least {2 * layers + 1} planes, got num_planes={num_planes}")
    if not (np.isfinite(view_step) and view_step > 0):
        raise VfxStereoError(f"view_step must be a positive number, got {view_step}")
    if not (np.isfinite(edge_width) and edge_width > 0):
        raise VfxStereoError(f"edge_width must be a positive number of pixels, got {edge_width}")
    rng = np.random.default_rng(seed)
    layers, num_planes = int(layers), int(num_planes)
    occupied = [0.0] + [float(round(0.9 * (i + 1) / layers * (num_planes - 1))) for i in range(layers)]
    rgba = np.zeros((len(occupied), h, w, 4), np.float32)
    rgba[0, ..., :3] = random_dots(rng, (h, w), BLUE_GREEN)
    rgba[0, ..., 3] = 1.0
    for i in range(layers):
        centre = (h * (0.42 + 0.08 * i), w * (0.30 + 0.40 * (i + 1) / (layers + 1)))
        radii = (h * (0.30 - 0.05 * i), w * (0.22 - 0.03 * i))
        alpha = _soft_ellipse(h, w, centre, radii, float(edge_width))
        rgba[i + 1, ..., :3] = random_dots(rng, (h, w), _LAYER_SHADES[i]) * alpha[..., None]
        rgba[i + 1, ..., 3] = alpha
    camera = Camera.from_positions(view_step * np.arange(5, dtype=np.float64), reference=2)
    meta = {
        "sample": "layered",
        "generator": "vfxstereo.samples.layered_scene",
        "seed": seed if isinstance(seed, int) else None,
        "planes": num_planes,
        "edge_width": float(edge_width),
    }
    stack = LayerStack(rgba, np.asarray(occupied), camera, meta)
    description = (
        f"Layered scene for speed: {w}x{h} px (W x H), K=5 views {view_step:g} apart, reference 2, solved on "
        f"planes d=0..{num_planes - 1}. A random-dot backdrop at d=0 and {layers} random-dot ellipses with "
        f"{edge_width:g}-px soft edges at d={', '.join(f'{d:g}' for d in occupied[1:])}."
    )
    return Sample.from_stack(stack, name="layered", description=description)
