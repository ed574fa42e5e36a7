"""Pictures people look at: 8-bit sRGB previews, layer contact sheets, colour-mapped disparity maps.

Everything here is **display-referred output**: scene-linear input is encoded with the exact sRGB curve
(:func:`vfxstereo.io.color.linear_to_srgb`), clipped to [0, 1] and rounded to 8 bits. Alpha is coverage and
is not encoded. These files are for eyes, never for further compositing (that is what the EXRs are for).

==========================  ===================  =====================================================
function                    input                output
==========================  ===================  =====================================================
:func:`to_display`          (H, W, 3|4) linear   (H, W, 3|4) uint8 sRGB; RGBA unpremultiplied (straight)
:func:`contact_sheet`       (D, H, W, 4) stack   (H', W', 3) uint8 sRGB, layers over a checkerboard
:func:`disparity_preview`   (H, W) disparity     (H, W, 3) uint8, matplotlib colour map, NaN black
==========================  ===================  =====================================================
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.color import import_quietly, linear_to_srgb, srgb_to_linear

CHECKER_SIZE = 8
"""Side of a checkerboard square, in pixels."""
CHECKER_GREYS = (0.4, 0.6)
"""Display (sRGB-encoded) grey levels of the two checkerboard squares."""
SHEET_GAP_GREY = 24
"""8-bit grey of the gaps between contact-sheet tiles."""
NO_ALPHA_FORMATS = (".jpg", ".jpeg", ".bmp")
"""Preview formats without alpha: RGBA is composited over black (the premultiplied colour) for them."""


# ---------------------------------------------------------------------------------------------------------
# Backgrounds and display encoding


def checkerboard(height: int, width: int, *, size: int = CHECKER_SIZE, greys=CHECKER_GREYS) -> np.ndarray:
    """A grey checkerboard, scene-linear (the ``greys`` are display values, decoded with the sRGB curve).

    Returns
    -------
    ndarray of shape (height, width, 3), float32, linear; the top-left square is ``greys[0]``.
    """
    rows = (np.arange(height) // size)[:, None]
    cols = (np.arange(width) // size)[None, :]
    levels = srgb_to_linear(np.asarray(greys, dtype=np.float32))
    board = levels[(rows + cols) % 2]
    return np.repeat(board[..., None], 3, axis=-1).astype(np.float32)


def _background(background, height: int, width: int) -> np.ndarray:
    """Linear (H, W, 3) background: "checker", "black", "white", a grey level or an RGB triple (linear)."""
    if isinstance(background, str):
        name = background.lower()
        if name == "checker":
            return checkerboard(height, width)
        if name in ("black", "white"):
            return np.full((height, width, 3), 0.0 if name == "black" else 1.0, dtype=np.float32)
        raise VfxStereoError(f"unknown background {background!r}; use checker, black, white or a colour")
    colour = np.asarray(background, dtype=np.float32).reshape(-1)
    if colour.size == 1:
        colour = np.repeat(colour, 3)
    if colour.size != 3 or not np.all(np.isfinite(colour)):
        raise VfxStereoError(f"a background colour is a grey level or 3 linear values, got {background!r}")
    return np.broadcast_to(colour, (height, width, 3)).astype(np.float32)


def over_background(rgba, background="checker") -> np.ndarray:
    """Premultiplied RGBA over an opaque background: ``rgb + (1 - a) * bg``, scene-linear.

    Parameters
    ----------
    rgba : ndarray of shape (H, W, 4)
        Premultiplied, scene-linear.
    background : str, float or sequence of 3 floats
        ``"checker"`` (:func:`checkerboard`), ``"black"``, ``"white"``, a grey level or a linear RGB colour.

    Returns
    -------
    ndarray of shape (H, W, 3), float32, scene-linear.
    """
    rgba = np.asarray(rgba, dtype=np.float32)
    if rgba.ndim != 3 or rgba.shape[-1] != 4:
        raise VfxStereoError(f"expected an RGBA image (H, W, 4), got shape {rgba.shape}")
    bg = _background(background, rgba.shape[0], rgba.shape[1])
    return rgba[..., :3] + (1.0 - rgba[..., 3:4]) * bg


def _encode8(values: np.ndarray) -> np.ndarray:
    """Display values in [0, 1] (clipped; NaN as 0) to uint8 by rounding."""
    values = np.nan_to_num(np.asarray(values, dtype=np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    return np.rint(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def to_display(pixels, *, background=None) -> np.ndarray:
    """Scene-linear RGB or premultiplied RGBA to 8-bit sRGB for display.

    RGB: sRGB-encode, clip to [0, 1], round to 8 bits. RGBA without ``background``: unpremultiply (colour
    divided by alpha where alpha > 0), sRGB-encode the colour, keep alpha as coverage (not encoded); the
    result is straight RGBA, as PNG stores it. RGBA with ``background``: composite over it in linear light
    first (:func:`over_background`), giving RGB.

    Parameters
    ----------
    pixels : ndarray of shape (H, W, 3) or (H, W, 4)
        Scene-linear; RGBA premultiplied.
    background : str, float or sequence of 3 floats, optional
        See :func:`over_background`.

    Returns
    -------
    ndarray of shape (H, W, 3) or (H, W, 4), uint8, sRGB-encoded (display-referred).
    """
    px = np.asarray(pixels, dtype=np.float32)
    if px.ndim == 2:
        px = np.repeat(px[..., None], 3, axis=-1)
    if px.ndim != 3 or px.shape[-1] not in (3, 4):
        raise VfxStereoError(f"expected an image (H, W), (H, W, 3) or (H, W, 4), got shape {px.shape}")
    if px.shape[-1] == 3:
        return _encode8(linear_to_srgb(px))
    if background is not None:
        return _encode8(linear_to_srgb(over_background(px, background)))
    alpha = px[..., 3:4]
    straight = np.where(alpha > 0, px[..., :3] / np.where(alpha > 0, alpha, 1.0), 0.0)
    return np.concatenate([_encode8(linear_to_srgb(straight)), _encode8(alpha)], axis=-1)


# ---------------------------------------------------------------------------------------------------------
# Writing


def write_display(path, image8) -> Path:
    """Write an already display-encoded 8-bit image (PNG, JPEG, TIFF, ...) atomically.

    Parameters
    ----------
    path : str or Path
        Output file; OpenImageIO picks the format from the extension.
    image8 : ndarray of shape (H, W), (H, W, 3) or (H, W, 4), uint8
        sRGB-encoded; RGBA is straight (unpremultiplied), as PNG stores it.

    Returns
    -------
    Path of the written file.
    """
    import OpenImageIO as oiio

    from vfxstereo.io.exr import open_output

    img = np.ascontiguousarray(image8)
    if img.dtype != np.uint8:
        raise VfxStereoError(f"display images are uint8, got {img.dtype}")
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[-1] not in (1, 3, 4):
        raise VfxStereoError(f"expected an image (H, W, 1|3|4), got shape {img.shape}")
    path = Path(path)
    if img.shape[-1] == 4 and path.suffix.lower() in NO_ALPHA_FORMATS:
        raise VfxStereoError(f"{path.suffix} cannot hold alpha: write RGB (composite over a background)")
    H, W, C = img.shape
    spec = oiio.ImageSpec(W, H, C, "uint8")
    if C == 4:
        spec.attribute("oiio:UnassociatedAlpha", 1)  # the colour is straight already: write it as it is
    spec.attribute("oiio:ColorSpace", "sRGB")
    with open_output(path, spec) as out:
        if not out.write_image(img):
            raise VfxStereoError(f"cannot write {path}: {out.geterror()}")
    return path


def write_png(path, pixels_linear, *, background=None) -> Path:
    """Write scene-linear pixels as an 8-bit sRGB preview (PNG, or JPEG/TIFF by extension), atomically.

    The conversion is :func:`to_display`: sRGB encoding (exact IEC 61966-2-1 curve), clip, round; RGBA is
    written as straight-alpha RGBA unless ``background`` is given (then composited over it, RGB). Formats
    without alpha (JPEG) get RGBA composited over black when no background is given. A uint8 array is taken
    as display-encoded already (the output of :func:`contact_sheet`, :func:`disparity_preview`,
    :func:`to_display`) and written as it is.

    Parameters
    ----------
    path : str or Path
    pixels_linear : ndarray of shape (H, W), (H, W, 3) or (H, W, 4)
        Scene-linear float, RGBA premultiplied; or uint8 display values (RGBA straight).
    background : str, float or sequence of 3 floats, optional
        See :func:`over_background`.

    Returns
    -------
    Path of the written file.
    """
    px = np.asarray(pixels_linear)
    if px.dtype == np.uint8:
        return write_display(path, px)
    no_alpha = Path(path).suffix.lower() in NO_ALPHA_FORMATS
    if px.ndim == 3 and px.shape[-1] == 4 and background is None and no_alpha:
        background = "black"
    return write_display(path, to_display(px, background=background))


# ---------------------------------------------------------------------------------------------------------
# Contact sheet of a layer stack


def _label(tile: np.ndarray, text: str) -> None:
    """Draw ``text`` in the top-left corner of an 8-bit tile, white on a black outline, in place."""
    import cv2

    H, W = tile.shape[:2]
    if min(H, W) < 16:
        return
    scale = max(0.3, min(H, W) / 256.0)
    thick = max(1, round(scale * 1.5))
    (_, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
    org = (max(2, round(4 * scale)), min(H - 2, th + max(2, round(4 * scale))))
    cv2.putText(tile, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), thick + 2, cv2.LINE_AA)
    cv2.putText(tile, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), thick, cv2.LINE_AA)


def sheet_shape(depth: int, height: int, width: int, *, columns: int | None = None,
                gap: int = 4) -> tuple[int, int, int, int]:
    """Layout of a contact sheet: ``(rows, columns, sheet_height, sheet_width)``.

    ``columns`` defaults to ``ceil(sqrt(depth))``; tiles are ``gap`` pixels apart, with no outer margin.
    """
    if depth < 1:
        raise VfxStereoError("a contact sheet needs at least one layer")
    cols = int(columns) if columns else math.ceil(math.sqrt(depth))
    if cols < 1:
        raise VfxStereoError(f"columns must be at least 1, got {columns}")
    cols = min(cols, depth)
    rows = math.ceil(depth / cols)
    return rows, cols, rows * height + (rows - 1) * gap, cols * width + (cols - 1) * gap


def contact_sheet(stack, *, columns: int | None = None, label: bool = True, background="checker",
                  gap: int = 4, disparities=None) -> np.ndarray:
    """Every layer of a stack side by side, over a background so alpha is visible, for display.

    Layers are laid out in reading order from the back (smallest disparity) to the front. Each tile is the
    layer composited over ``background`` in linear light, then sRGB-encoded to 8 bits; with ``label``, it is
    labelled ``d=<disparity>``.

    Parameters
    ----------
    stack : LayerStack or ndarray of shape (D, H, W, 4)
        Premultiplied, scene-linear layers.
    columns : int, optional
        Tiles per row; default ``ceil(sqrt(D))``.
    label : bool
        Write each layer's disparity on its tile (when the disparities are known).
    background : str, float or sequence of 3 floats
        See :func:`over_background`; ``"checker"`` by default.
    gap : int
        Pixels between tiles (dark grey).
    disparities : sequence of float, optional
        Labels for a bare array (a LayerStack brings its own).

    Returns
    -------
    ndarray of shape (rows * H + (rows - 1) * gap, columns * W + (columns - 1) * gap, 3), uint8, sRGB.
    """
    rgba = getattr(stack, "rgba", stack)
    if disparities is None:
        disparities = getattr(stack, "disparities", None)
    rgba = np.asarray(rgba, dtype=np.float32)
    if rgba.ndim != 4 or rgba.shape[-1] != 4:
        raise VfxStereoError(f"a contact sheet needs layers (D, H, W, 4), got shape {rgba.shape}")
    D, H, W = rgba.shape[:3]
    if disparities is not None and len(disparities) != D:
        raise VfxStereoError(f"{D} layers but {len(disparities)} disparities")
    gap = max(0, int(gap))
    rows, cols, sheet_h, sheet_w = sheet_shape(D, H, W, columns=columns, gap=gap)
    sheet = np.full((sheet_h, sheet_w, 3), SHEET_GAP_GREY, dtype=np.uint8)
    bg = _background(background, H, W)
    for i in range(D):
        tile = _encode8(linear_to_srgb(rgba[i, ..., :3] + (1.0 - rgba[i, ..., 3:4]) * bg))
        if label and disparities is not None:
            _label(tile, f"d={float(disparities[i]):.4g}")
        r, c = divmod(i, cols)
        y, x = r * (H + gap), c * (W + gap)
        sheet[y:y + H, x:x + W] = tile
    return sheet


def write_contact_sheet(path, stack, **kwargs) -> Path:
    """Write :func:`contact_sheet` of ``stack`` to ``path`` (8-bit sRGB PNG/JPEG), atomically."""
    return write_display(path, contact_sheet(stack, **kwargs))


# ---------------------------------------------------------------------------------------------------------
# Disparity maps


def disparity_preview(dmap, vmin=None, vmax=None, *, cmap: str = "turbo") -> np.ndarray:
    """A disparity (or any scalar) map through a matplotlib colour map, for display.

    Values are mapped linearly from ``[vmin, vmax]`` to the colour map (clipped outside); NaN and infinite
    values are black. The colour maps are defined in display space: the result is written without further
    encoding.

    Parameters
    ----------
    dmap : ndarray of shape (H, W)
        Disparity in px per view step (NaN where unknown).
    vmin, vmax : float, optional
        Ends of the range; default the finite minimum and maximum.
    cmap : str
        A matplotlib colour map name (``"turbo"``, ``"viridis"``, ``"gray"``, ...).

    Returns
    -------
    ndarray of shape (H, W, 3), uint8, display-referred.
    """
    matplotlib = import_quietly("matplotlib")
    d = np.asarray(dmap, dtype=np.float64)
    if d.ndim != 2:
        raise VfxStereoError(f"a disparity map is (H, W), got shape {d.shape}")
    try:
        colormap = matplotlib.colormaps[cmap]
    except KeyError:
        raise VfxStereoError(f"unknown colour map {cmap!r}") from None
    finite = np.isfinite(d)
    if vmin is None:
        vmin = float(d[finite].min()) if finite.any() else 0.0
    if vmax is None:
        vmax = float(d[finite].max()) if finite.any() else 1.0
    span = float(vmax) - float(vmin)
    t = np.clip((np.where(finite, d, vmin) - vmin) / (span if span > 0 else 1.0), 0.0, 1.0)
    out = colormap(t, bytes=True)[..., :3]
    out[~finite] = 0
    return np.ascontiguousarray(out, dtype=np.uint8)


def write_disparity_preview(path, dmap, vmin=None, vmax=None, *, cmap: str = "turbo") -> Path:
    """Write :func:`disparity_preview` of ``dmap`` to ``path`` (8-bit PNG/JPEG), atomically."""
    return write_display(path, disparity_preview(dmap, vmin, vmax, cmap=cmap))
