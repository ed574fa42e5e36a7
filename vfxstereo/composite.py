"""Compositing with a layer stack: over, flatten, an element between the layers, holdouts, novel views.

This is the z-keying of Szeliski & Golland (1999), Section 1 and Section 5: once a scene is a stack of
premultiplied RGBA layers at disparity planes, a synthetic element is composited *between* the layers with
the over operator (Eq. 6), without a blue screen. Pure numpy in and out, no file I/O (that is
:mod:`vfxstereo.io`).

Conventions (those of :mod:`vfxstereo.stack`):

* arrays are ``[row, col]``; images are ``(H, W, 4)`` RGBA, float32, scene-linear;
* RGBA is **premultiplied** in and out of every function here, except :func:`premultiply`'s input and
  :func:`unpremultiply`'s output, which are straight (unpremultiplied);
* larger disparity is nearer the camera.

Where an element goes (the tie rule, used by every function here)
    An element at disparity ``D`` lies **in front of** every layer with ``d <= D`` and **behind** every layer
    with ``d > D``. An element exactly on a plane is therefore composited over that plane's layer. ``D`` may
    fall between two planes (any real number) and may be one number for the whole element or one per pixel.

==============  ============  ==============================================================
name            shape         meaning
==============  ============  ==============================================================
``element``     (H, W, 4)     premultiplied RGBA in the reference camera's frame
``depth``       (H, W)        the element's depth per pixel (a CG depth pass), scene units
``disparity``   () or (H, W)  the element's disparity, one number or one per pixel
``holdout``     (H, W)        alpha of everything in front of the element, in [0, 1]
==============  ============  ==============================================================
"""

from __future__ import annotations

import numpy as np

from vfxstereo import stack as _stack
from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.stack import LayerStack, composite_back_to_front

__all__ = [
    "element_disparity_from_depth",
    "flatten",
    "holdout",
    "insert",
    "insert_into_plate",
    "over",
    "premultiply",
    "render_view",
    "split",
    "unpremultiply",
]

# The mapping of a stack without a camera: Z = 1 / d (the deep EXR's Z for the same stack).
_NO_CAMERA = Camera(positions=[0.0], reference=0.0)


# --------------------------------------------------------------------------------------------------------
# Validation helpers


def _check_stack(stack) -> LayerStack:
    if not isinstance(stack, LayerStack):
        raise VfxStereoError(f"expected a vfxstereo.LayerStack, got {type(stack).__name__}")
    return stack


def _check_rgba(name: str, img, hw: tuple[int, int] | None = None) -> np.ndarray:
    """``img`` as float32 (H, W, 4); its (H, W) must equal ``hw`` when given."""
    a = np.asarray(img)
    if a.ndim != 3 or a.shape[-1] != 4:
        raise VfxStereoError(f"{name} must be an (H, W, 4) RGBA image, got shape {a.shape}")
    if hw is not None and a.shape[:2] != tuple(hw):
        raise VfxStereoError(
            f"{name} is {a.shape[1]}x{a.shape[0]} (WxH) but the layer stack is {hw[1]}x{hw[0]}"
        )
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise VfxStereoError(f"{name} must hold numbers, got {a.dtype}")
    a = a.astype(np.float32, copy=False)
    if not np.all(np.isfinite(a)):
        raise VfxStereoError(f"{name} holds {int(np.count_nonzero(~np.isfinite(a)))} NaN or infinite values")
    return a


def _check_map(name: str, m, hw: tuple[int, int]) -> np.ndarray:
    """A per-pixel map as float64 (H, W); (H, W, 1) is accepted."""
    a = np.asarray(m, dtype=np.float64)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    if a.shape != tuple(hw):
        shape = f"{a.shape[1]}x{a.shape[0]} (WxH)" if a.ndim == 2 else f"of shape {a.shape}"
        raise VfxStereoError(f"{name} is {shape} but the layer stack is {hw[1]}x{hw[0]}")
    return a


def _check_disparity(disparity, hw: tuple[int, int]) -> float | np.ndarray:
    """A scalar disparity as float, or a per-pixel one as float64 (H, W); NaN is refused."""
    if np.ndim(disparity) == 0:
        D = float(disparity)
        if np.isnan(D):
            raise VfxStereoError("the element's disparity must be a number, got NaN")
        return D
    D = _check_map("the element's disparity map", disparity, hw)
    if np.isnan(D).any():
        raise VfxStereoError(f"the element's disparity map holds {int(np.isnan(D).sum())} NaN values")
    return D


# --------------------------------------------------------------------------------------------------------
# Operators


def over(fg: np.ndarray, bg: np.ndarray) -> np.ndarray:
    """Porter-Duff over of premultiplied RGBA: ``fg + (1 - fg.a) * bg`` (Section 5, the over operator).

    Wraps :func:`vfxstereo.stack.over` with a shape check.

    Parameters
    ----------
    fg, bg : ndarray of shape (..., 4)
        Premultiplied RGBA of the same shape; ``fg`` is in front.

    Returns
    -------
    ndarray of the same shape, premultiplied.

    Raises
    ------
    VfxStereoError
        If the shapes differ or are not RGBA.
    """
    fg, bg = np.asarray(fg), np.asarray(bg)
    if fg.shape != bg.shape or fg.shape[-1:] != (4,):
        raise VfxStereoError(f"over needs two RGBA images of the same shape, got {fg.shape} and {bg.shape}")
    return _stack.over(fg, bg)


def flatten(stack: LayerStack) -> np.ndarray:
    """The reference view: every layer composited back to front, largest disparity on top (Eq. 6).

    Returns
    -------
    ndarray of shape (H, W, 4), float32, premultiplied.
    """
    return _check_stack(stack).flatten()


def premultiply(rgba_straight: np.ndarray) -> np.ndarray:
    """Straight (unpremultiplied) RGBA to premultiplied: colour times alpha, alpha unchanged.

    Parameters
    ----------
    rgba_straight : ndarray of shape (..., 4)
        Straight RGBA, as straight-alpha PNG/TIFF elements are stored. Integer input is converted to float32
        without rescaling (decode 8-bit images to [0, 1] first).

    Returns
    -------
    ndarray of shape (..., 4), premultiplied; float32, or the input's floating dtype.
    """
    a = np.asarray(rgba_straight)
    if a.shape[-1:] != (4,):
        raise VfxStereoError(f"premultiply needs RGBA (..., 4), got shape {a.shape}")
    out = a.astype(a.dtype if np.issubdtype(a.dtype, np.floating) else np.float32, copy=True)
    out[..., :3] *= out[..., 3:4]
    return out


def unpremultiply(rgba: np.ndarray) -> np.ndarray:
    """Premultiplied RGBA to straight: colour divided by alpha where alpha > 0.

    Safe at alpha 0: those pixels keep their colour unchanged (OpenImageIO's ``unpremult`` rule), so
    ``premultiply(unpremultiply(x)) == x`` wherever alpha > 0 or the colour is 0, and no NaN or inf appears.

    Parameters
    ----------
    rgba : ndarray of shape (..., 4)
        Premultiplied RGBA.

    Returns
    -------
    ndarray of shape (..., 4), straight (unpremultiplied); float32, or the input's floating dtype.
    """
    a = np.asarray(rgba)
    if a.shape[-1:] != (4,):
        raise VfxStereoError(f"unpremultiply needs RGBA (..., 4), got shape {a.shape}")
    out = a.astype(a.dtype if np.issubdtype(a.dtype, np.floating) else np.float32, copy=True)
    alpha = out[..., 3:4]
    pos = alpha > 0
    out[..., :3] = np.where(pos, out[..., :3] / np.where(pos, alpha, 1), out[..., :3])
    return out


# --------------------------------------------------------------------------------------------------------
# Between the layers


def element_disparity_from_depth(stack: LayerStack, depth, *, camera: Camera | None = None) -> np.ndarray:
    """Per-pixel disparity of a depth map, by the mapping of the deep EXR.

    ``d = focal * baseline / Z`` when the camera knows ``focal`` and ``baseline``, else ``d = 1 / Z``
    (:meth:`vfxstereo.Camera.disparity_from_depth`); ``Z = inf`` is disparity 0.

    Parameters
    ----------
    stack : LayerStack
        Gives the frame size and, unless ``camera`` is given, the camera.
    depth : ndarray of shape (H, W)
        Depth in scene units, positive; ``inf`` for infinitely far.
    camera : Camera, optional
        Overrides ``stack.camera``. Without either, ``d = 1 / Z``.

    Returns
    -------
    ndarray of shape (H, W), float64.

    Raises
    ------
    VfxStereoError
        On a size that differs from the stack's, or NaN / non-positive depth.
    """
    stack = _check_stack(stack)
    hw = stack.shape[1:]
    z = _check_map("the element's depth", depth, hw)
    bad = np.isnan(z) | (z <= 0)
    if bad.any():
        raise VfxStereoError(
            f"the element's depth must be positive, found {int(bad.sum())} NaN or <= 0 values"
        )
    cam = camera if camera is not None else (stack.camera if stack.camera is not None else _NO_CAMERA)
    if not isinstance(cam, Camera):
        raise VfxStereoError("camera must be a vfxstereo.Camera")
    return cam.disparity_from_depth(z)


def split(stack: LayerStack, disparity) -> tuple[np.ndarray, np.ndarray]:
    """The flattened layers in front of and behind disparity ``disparity``.

    ``front`` composites (Eq. 6) the layers with ``d > disparity``, ``back`` those with ``d <= disparity``, so
    ``over(front, over(element, back)) == insert(stack, element, disparity=disparity)`` for any element.

    Parameters
    ----------
    stack : LayerStack
    disparity : float or ndarray of shape (H, W)
        One disparity for the frame, or one per pixel (the split is then made pixel by pixel).

    Returns
    -------
    front, back : ndarray of shape (H, W, 4), float32, premultiplied
        Either is all zero when no layer falls on its side.
    """
    stack = _check_stack(stack)
    hw = stack.shape[1:]
    D = _check_disparity(disparity, hw)
    d = stack.disparities
    if np.ndim(D) == 0:
        n_back = int(np.count_nonzero(d <= D))  # d is increasing: the first n_back layers are behind
        layers = stack.rgba  # iterated, not indexed by a mask, so no copy of the stack is made
        empty = np.zeros((*hw, 4), np.float32)
        back = composite_back_to_front(layers[:n_back]) if n_back else empty  # Eq. (6)
        front = composite_back_to_front(layers[n_back:]) if n_back < len(d) else empty.copy()  # Eq. (6)
        return front, back
    # Per pixel: one pass back to front with one accumulator. Layers are sorted, so at each pixel the layers
    # with d <= D come first; when the pass reaches that pixel's first layer with d > D, the accumulator
    # holds `back` there: move it out and start `front` from zero.
    first_in_front = np.searchsorted(d, D, side="right")  # (H, W): number of layers with d <= D
    acc = np.zeros((*hw, 4), np.float32)
    back = np.zeros((*hw, 4), np.float32)
    for i in range(len(d) + 1):
        sel = first_in_front == i
        if sel.any():
            back[sel] = acc[sel]
            acc[sel] = 0.0
        if i < len(d):
            acc = _stack.over(stack.rgba[i], acc)  # Eq. (6)
    return acc, back


def holdout(stack: LayerStack, disparity) -> np.ndarray:
    """Matte of everything in front of ``disparity``: alpha of the flattened layers with ``d > disparity``.

    Equal to ``1 - prod_{d > disparity} (1 - alpha_d)``, one minus the transmittance of Eq. (7). A compositor
    multiplies a premultiplied CG render by ``1 - holdout`` and adds the front layers' colour (``split``'s
    ``front``) to place it behind them.

    Parameters
    ----------
    stack : LayerStack
    disparity : float or ndarray of shape (H, W)
        One disparity for the frame, or one per pixel (e.g. from a CG depth pass).

    Returns
    -------
    ndarray of shape (H, W), float32, in [0, 1].
    """
    stack = _check_stack(stack)
    D = _check_disparity(disparity, stack.shape[1:])
    transmit = np.ones(stack.shape[1:], np.float32)
    for layer, d_i in zip(stack.rgba, stack.disparities, strict=True):
        if np.ndim(D) == 0:
            if d_i > D:
                transmit *= 1.0 - layer[..., 3]  # Eq. (7)
        else:
            transmit *= 1.0 - np.where(d_i > D, layer[..., 3], np.float32(0))  # Eq. (7), per pixel
    return (1.0 - transmit).astype(np.float32)


def insert_into_plate(plate: np.ndarray, front: np.ndarray, element: np.ndarray, back: np.ndarray) -> np.ndarray:
    """Compose ``element`` into the *plate*, between the ``front`` and ``back`` of a stack.

    The plate holds ``front + (1 - A_F) * back`` (what the camera saw); the element goes between them::

        comp = plate + (1 - A_F) * E - A_E * min((1 - A_F) * B, plate)

    This is ``front over element over back`` written around the plate: wherever the element is empty
    (``E = 0``, ``A_E = 0``) the comp *is* the plate, bit for bit, whatever errors the stack's re-synthesis
    has (bilinear blur, colour means, seams), and elsewhere only the part of the back the element covers is
    replaced. ``min(., plate)`` (per channel) keeps an over-estimated back from taking out more than the
    plate holds. With ``plate = over(front, back)`` it equals ``over(front, over(element, back))``, the comp
    of the stack alone.

    Parameters
    ----------
    plate : ndarray of shape (H, W, 3) or (H, W, 4)
        The reference view, scene-linear; RGB is taken as opaque (alpha 1).
    front, element, back : ndarray of shape (H, W, 4)
        Premultiplied RGBA: the layers in front of the element flattened (``A_F`` its alpha), the element
        (``E``, ``A_E``), and the layers behind it flattened (``B``), as :func:`split` makes them.

    Returns
    -------
    ndarray of shape (H, W, 4), float32, premultiplied.
    """
    plate = np.asarray(plate, dtype=np.float32)
    if plate.ndim == 3 and plate.shape[-1] == 3:
        plate = np.concatenate([plate, np.ones((*plate.shape[:2], 1), np.float32)], axis=-1)
    hw = plate.shape[:2]
    plate = _check_rgba("the plate", plate, hw)
    front, element, back = (_check_rgba(n, x, hw) for n, x in (("front", front), ("the element", element),
                                                                ("back", back)))
    see_back = 1.0 - front[..., 3:4]  # (1 - A_F): how much of the back the plate shows
    seen = np.minimum(see_back * back, plate)  # the back's share of the plate
    return plate + see_back * element - element[..., 3:4] * seen


def insert(
    stack: LayerStack,
    element: np.ndarray,
    *,
    disparity=None,
    depth=None,
    element_disparity=None,
    camera: Camera | None = None,
    into: str = "plate",
    plate: np.ndarray | None = None,
) -> np.ndarray:
    """Composite ``element`` between the layers of ``stack`` (z-keying) and return the frame.

    Give exactly one of:

    * ``disparity=D`` -- the whole element at disparity D (any real number, between planes too): the layers
      with ``d > D`` over the element over the layers with ``d <= D`` (the tie rule: an element exactly on
      a plane goes over that plane's layer);
    * ``depth=Z`` -- the element's per-pixel depth (a CG render's depth pass), turned into disparity by the
      deep EXR's mapping (:func:`element_disparity_from_depth`); each pixel of the element then goes where its
      disparity falls among the layers (a deep merge), so an element can pass through the scene;
    * ``element_disparity=E`` -- the per-pixel disparity directly.

    By default (``into="plate"``) the element is composed into the plate the stack was solved from
    (:func:`insert_into_plate`): the comp equals the plate exactly wherever the element is empty, as
    compositors expect, and only the covered part of the back is replaced. ``into="stack"`` gives the comp
    of the stack alone, ``front over element over back`` -- the re-synthesised frame with the element in
    it. A stack without a plate (and no ``plate=``) composes into its own flattened layers, which is the
    same as ``into="stack"``.

    Parameters
    ----------
    stack : LayerStack
    element : ndarray of shape (H, W, 4)
        Premultiplied RGBA in the reference camera's frame, the stack's size.
    disparity : float, optional
    depth : ndarray of shape (H, W), optional
        Positive depth in scene units (``inf`` allowed); read only where the element is not empty.
    element_disparity : ndarray of shape (H, W), optional
    camera : Camera, optional
        For ``depth``: overrides ``stack.camera``. Without either camera, ``d = 1 / Z``.
    into : {"plate", "stack"}
        Compose into the plate (default) or into the stack's own re-synthesis.
    plate : ndarray of shape (H, W, 3), optional
        The plate to compose into; default ``stack.plate``.

    Returns
    -------
    ndarray of shape (H, W, 4), float32, premultiplied.

    Raises
    ------
    VfxStereoError
        If not exactly one placement is given, or the element, plate, depth or disparity map differs in size
        from the stack (the message names both sizes), or holds NaN.
    """
    stack = _check_stack(stack)
    hw = stack.shape[1:]
    placements = {"disparity": disparity, "depth": depth, "element_disparity": element_disparity}
    given = [name for name, value in placements.items() if value is not None]
    if len(given) != 1:
        raise VfxStereoError(
            "insert needs exactly one of disparity=, depth= or element_disparity=, got "
            + (", ".join(given) if given else "none")
        )
    if camera is not None and depth is None:
        raise VfxStereoError("camera= only applies with depth=")
    if into not in ("plate", "stack"):
        raise VfxStereoError(f"into= must be 'plate' or 'stack', got {into!r}")
    element = _check_rgba("the element", element, hw)
    if depth is not None:
        z = _check_map("the element's depth", depth, hw)
        empty = ~np.any(element != 0, axis=-1)
        z = np.where(empty, np.inf, z)  # depth is not read where the element holds nothing
        D = element_disparity_from_depth(stack, z, camera=camera)
    else:
        D = _check_disparity(disparity if disparity is not None else element_disparity, hw)
    front, back = split(stack, D)
    if into == "plate":
        if plate is None:
            plate = stack.plate
        if plate is not None:
            plate = np.asarray(plate)
            if plate.ndim != 3 or plate.shape[:2] != tuple(hw) or plate.shape[-1] not in (3, 4):
                raise VfxStereoError(f"the plate must be an (H, W, 3) image of the stack's size "
                                     f"{hw[1]}x{hw[0]} (WxH), got shape {plate.shape}")
            return insert_into_plate(plate, front, element, back)
    return _stack.over(front, _stack.over(element, back))  # Eq. (6) with the element as one more sample


def render_view(stack: LayerStack, position) -> np.ndarray:
    """A novel view from a camera at baseline ``position`` (Eqs. 5-6): wraps :meth:`LayerStack.render`.

    Each layer is shifted by ``d * (position - p_ref)`` (bilinear, zero outside the frame) and composited
    back to front. Interpolated and extrapolated positions both work. Areas no layer covers in the new view
    (disocclusions at the frame edge and behind foreground objects the solve never saw behind) come out with
    alpha < 1; the holes are left as they are -- composite the result over a clean plate or fill them
    downstream.

    Parameters
    ----------
    stack : LayerStack
    position : float or (float, float)
        Camera position in view steps, in the coordinates of ``stack.camera.positions``.

    Returns
    -------
    ndarray of shape (H, W, 4), float32, premultiplied.
    """
    stack = _check_stack(stack)
    p = np.asarray(position, dtype=np.float64)
    if p.size not in (1, 2) or not np.all(np.isfinite(p)):
        raise VfxStereoError(f"a view position must be one number or an (x, y) pair, got {position!r}")
    return stack.render(position)
