"""Colour management: the sRGB transfer functions, OpenColorIO conversions and the working space.

Every image vfxstereo computes with is **scene-linear float32 in the working space**. The working space
is linear Rec.709 / sRGB primaries (D65) by default, or ACEScg (:data:`WORKING_SPACES`).

Where colour spaces come from (first match wins)
    1. **OpenColorIO**: the config named by ``$OCIO`` (the pipeline convention) or, without ``$OCIO``, OCIO's
       built-in ``ocio://default`` (the ACES cg-config). Names, aliases and roles are resolved by OCIO,
       case-insensitively (``"ACEScg"``, ``"sRGB - Texture"``, ``"lin_rec709"``, ``"Raw"``, ...).
    2. ``"linear"`` (or ``"lin"``): already scene-linear in the working space, nothing is done.
    3. **colour-science**: a name of ``colour.RGB_COLOURSPACES`` (``"sRGB"``, ``"ITU-R BT.709"`` -- also
       spelled ``"Rec.709"`` --, ``"Display P3"``, ``"ALEXA Wide Gamut"``, ...): its decoding transfer
       function, then its primaries to the working space's (Bradford adaptation, which is what the OCIO
       configs use; the two agree to about 1e-4).

8- and 16-bit files without an explicit colour space are sRGB-encoded Rec.709 (decoded by
:func:`srgb_to_linear`, the exact IEC 61966-2-1 curve); float files are linear Rec.709. Both are then
converted to the working space by a 3x3 matrix (an identity for the default working space).

======================  ===============  ==========================================
value                   range            encoding
======================  ===============  ==========================================
scene-linear            [0, inf)         what the solver and the EXRs hold
sRGB-encoded (display)  [0, 1]           8-bit files, PNG previews
======================  ===============  ==========================================
"""

from __future__ import annotations

import functools
import importlib
import os
import warnings
from dataclasses import asdict, dataclass

import numpy as np

from vfxstereo.errors import VfxStereoError


def import_quietly(name: str):
    """Import a module, silencing the DeprecationWarnings its own imports raise.

    colour-science imports matplotlib, whose import raises pyparsing deprecation warnings with some
    pyparsing versions (the Blender environment): not ours to fix, and fatal under ``-W error``.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return importlib.import_module(name)


# ---------------------------------------------------------------------------------------------------------
# sRGB transfer functions (IEC 61966-2-1)

SRGB_LINEAR_CUT = 0.0031308
"""Linear value below which the sRGB encoding is the straight line ``12.92 * L``."""
SRGB_ENCODED_CUT = 0.04045
"""Encoded value below which the sRGB decoding is the straight line ``V / 12.92``."""


def srgb_to_linear(encoded) -> np.ndarray:
    """Decode sRGB-encoded values to linear: the exact piecewise IEC 61966-2-1 curve.

    ``V / 12.92`` for ``V <= 0.04045``, else ``((V + 0.055) / 1.055) ** 2.4``. Values below 0 follow the
    straight segment (no NaN); values above 1 follow the power curve.

    Parameters
    ----------
    encoded : array_like
        sRGB-encoded values in [0, 1] (any shape; 8-bit codes must be divided by 255 first).

    Returns
    -------
    ndarray of the same shape, float32, linear.
    """
    v = np.asarray(encoded, dtype=np.float32)
    base = (np.maximum(v, SRGB_ENCODED_CUT) + np.float32(0.055)) / np.float32(1.055)
    curve = np.power(base, np.float32(2.4))
    return np.where(v <= SRGB_ENCODED_CUT, v / np.float32(12.92), curve).astype(np.float32, copy=False)


def linear_to_srgb(linear) -> np.ndarray:
    """Encode linear values to sRGB: the exact IEC 61966-2-1 curve, the inverse of :func:`srgb_to_linear`.

    ``12.92 * L`` for ``L <= 0.0031308``, else ``1.055 * L ** (1 / 2.4) - 0.055``. Values are not clipped.

    Parameters
    ----------
    linear : array_like
        Linear values (any shape).

    Returns
    -------
    ndarray of the same shape, float32, sRGB-encoded.
    """
    v = np.asarray(linear, dtype=np.float32)
    curve = np.float32(1.055) * np.power(np.maximum(v, SRGB_LINEAR_CUT), np.float32(1 / 2.4))
    curve -= np.float32(0.055)
    return np.where(v <= SRGB_LINEAR_CUT, v * np.float32(12.92), curve).astype(np.float32, copy=False)


# ---------------------------------------------------------------------------------------------------------
# Working spaces


@dataclass(frozen=True)
class WorkingSpace:
    """A scene-linear working space and how to find it in OCIO configs and in colour-science."""

    key: str
    """Short name, as given on the command line."""
    name: str
    """Name recorded in metadata (the cg-config name)."""
    ocio_names: tuple[str, ...]
    """Names (or aliases) that denote this space in OCIO configs, tried in order."""
    colour_name: str
    """The colour-science RGB colourspace with these primaries (used linearly)."""


WORKING_SPACES: dict[str, WorkingSpace] = {
    "lin_rec709": WorkingSpace(
        "lin_rec709", "Linear Rec.709 (sRGB)",
        ("Linear Rec.709 (sRGB)", "lin_rec709", "lin_srgb", "Utility - Linear - sRGB", "Linear"), "sRGB"),
    "acescg": WorkingSpace("acescg", "ACEScg", ("ACEScg", "ACES - ACEScg", "lin_ap1"), "ACEScg"),
}
"""The working spaces: linear Rec.709/sRGB primaries (the default) and ACEScg (AP1 primaries)."""

DEFAULT_WORKING_SPACE = "lin_rec709"
"""Key of the default working space."""

_WORKING_ALIASES = {
    "lin_rec709": "lin_rec709", "linear rec.709 (srgb)": "lin_rec709", "lin_srgb": "lin_rec709",
    "linear": "lin_rec709", "rec709": "lin_rec709", "srgb": "lin_rec709",
    "acescg": "acescg", "lin_ap1": "acescg", "aces - acescg": "acescg",
}


def working_space(name: str | WorkingSpace | None = None) -> WorkingSpace:
    """The :class:`WorkingSpace` called ``name`` (case-insensitive; None gives the default).

    Raises
    ------
    VfxStereoError
        If the name is not a working space.
    """
    if isinstance(name, WorkingSpace):
        return name
    key = _WORKING_ALIASES.get((name or DEFAULT_WORKING_SPACE).strip().lower())
    if key is None:
        raise VfxStereoError(f"unknown working space {name!r}; choose one of: {', '.join(WORKING_SPACES)}")
    return WORKING_SPACES[key]


# ---------------------------------------------------------------------------------------------------------
# OpenColorIO

BUILTIN_CONFIG = "ocio://default"
"""OCIO's built-in config, used when ``$OCIO`` is not set."""


def ocio_config_source() -> str:
    """Where the OCIO config comes from: ``$OCIO`` if set and not empty, else :data:`BUILTIN_CONFIG`."""
    return os.environ.get("OCIO", "").strip() or BUILTIN_CONFIG


@functools.lru_cache(maxsize=8)
def _load_config(source: str):
    import PyOpenColorIO as ocio

    try:
        return ocio.Config.CreateFromFile(source)
    except Exception as exc:  # OCIO raises its own Exception type for every failure
        raise VfxStereoError(f"cannot load the OCIO config {source!r}: {exc}") from None


def ocio_config(source: str | None = None):
    """The OCIO config (cached): ``source`` if given, else :func:`ocio_config_source`.

    Raises
    ------
    VfxStereoError
        If the config cannot be loaded (for example ``$OCIO`` names a missing file).
    """
    return _load_config(source or ocio_config_source())


def ocio_colorspace(name: str, source: str | None = None) -> str | None:
    """The canonical name of colour space (or alias, or role) ``name`` in the OCIO config, or None."""
    cs = ocio_config(source).getColorSpace(name)
    return None if cs is None else cs.getName()


@functools.lru_cache(maxsize=64)
def _cpu_processor(source: str, src: str, dst: str):
    return _load_config(source).getProcessor(src, dst).getDefaultCPUProcessor()


def ocio_processor(src: str, dst: str, source: str | None = None):
    """The cached OCIO CPU processor from colour space ``src`` to ``dst`` (canonical or alias names).

    Raises
    ------
    VfxStereoError
        If either name is unknown to the config (the message lists the known names).
    """
    source = source or ocio_config_source()
    names = []
    for name in (src, dst):
        canonical = ocio_colorspace(name, source)
        if canonical is None:
            raise VfxStereoError(_unknown_message(name, ocio_only=True, source=source))
        names.append(canonical)
    return _cpu_processor(source, *names)


def _apply_processor(cpu, pixels: np.ndarray) -> np.ndarray:
    """Apply an OCIO CPU processor to a copy of ``pixels`` (..., 3 or 4); float32 out."""
    import PyOpenColorIO as ocio

    a = np.array(pixels, dtype=np.float32, order="C", copy=True)
    if a.ndim < 1 or a.shape[-1] not in (3, 4):
        raise VfxStereoError(f"colour conversion needs RGB or RGBA (..., 3|4), got shape {a.shape}")
    if a.size == 0:
        return a
    channels = a.shape[-1]
    width = a.shape[-2] if a.ndim >= 2 else 1
    height = a.size // (channels * width)
    cpu.apply(ocio.PackedImageDesc(a, width, height, channels))  # in place
    return a


def convert(pixels, src: str, dst: str, *, config: str | None = None) -> np.ndarray:
    """Convert colour from OCIO colour space ``src`` to ``dst``.

    Uses the OCIO config :func:`ocio_config` (``$OCIO`` or the built-in one) unless ``config`` names another
    (a file path or an ``ocio://`` URI). RGBA input keeps its alpha unchanged; the conversion is applied to
    the colour channels as they are (convert premultiplied colour only by linear transforms).

    Parameters
    ----------
    pixels : array_like of shape (..., 3) or (..., 4)
        Colour in ``src``.
    src, dst : str
        Colour space names, aliases or roles of the config.
    config : str, optional
        OCIO config to use instead of ``$OCIO`` / the built-in one.

    Returns
    -------
    ndarray of the same shape, float32, in ``dst``.

    Raises
    ------
    VfxStereoError
        Unknown colour space (the message lists the known ones) or a config that cannot be loaded.
    """
    return _apply_processor(ocio_processor(src, dst, config), pixels)


# ---------------------------------------------------------------------------------------------------------
# colour-science fallback

_COLOUR_ALIASES = {"rec.709": "ITU-R BT.709", "rec709": "ITU-R BT.709", "bt.709": "ITU-R BT.709",
                   "bt709": "ITU-R BT.709", "rec.2020": "ITU-R BT.2020", "rec2020": "ITU-R BT.2020",
                   "bt.2020": "ITU-R BT.2020", "bt2020": "ITU-R BT.2020"}
_LINEAR_NAMES = ("linear", "lin")


def _colour_colourspace(name: str):
    colour = import_quietly("colour")

    key = _COLOUR_ALIASES.get(name.strip().lower(), name.strip())
    try:
        return colour.RGB_COLOURSPACES[key]
    except KeyError:
        return None


@functools.lru_cache(maxsize=32)
def _colour_matrix(src: str, dst: str) -> np.ndarray:
    colour = import_quietly("colour")

    R = colour.RGB_COLOURSPACES
    return np.asarray(colour.matrix_RGB_to_RGB(R[src], R[dst], "Bradford"), dtype=np.float32)


@functools.lru_cache(maxsize=32)
def _same_primaries(src: str, dst: str) -> bool:
    """True when two colour-science spaces share primaries and white point (BT.709 and sRGB do)."""
    colour = import_quietly("colour")
    a, b = colour.RGB_COLOURSPACES[src], colour.RGB_COLOURSPACES[dst]
    same_white = np.allclose(a.whitepoint, b.whitepoint, atol=1e-6)
    return bool(same_white and np.allclose(a.primaries, b.primaries, atol=1e-6))


def rgb_matrix(src: str, dst: str) -> np.ndarray:
    """3x3 matrix from the linear primaries of colour-science space ``src`` to ``dst`` (Bradford), float32."""
    return _colour_matrix(src, dst)


def _apply_matrix(pixels: np.ndarray, M: np.ndarray) -> np.ndarray:
    out = np.array(pixels, dtype=np.float32, copy=True)
    out[..., :3] = out[..., :3] @ M.T
    return out


# ---------------------------------------------------------------------------------------------------------
# Names and error messages


def colorspace_names(source: str | None = None) -> list[str]:
    """Every colour space name :func:`to_working` accepts: OCIO's, then ``linear``, then colour-science's."""
    colour = import_quietly("colour")

    names = list(ocio_config(source).getColorSpaceNames())
    names.append("linear")
    names += [n for n in colour.RGB_COLOURSPACES if n not in names]
    return names


def _unknown_message(name: str, *, ocio_only: bool = False, source: str | None = None,
                     limit: int = 12) -> str:
    source = source or ocio_config_source()
    known = list(ocio_config(source).getColorSpaceNames()) if ocio_only else colorspace_names(source)
    shown = ", ".join(repr(n) for n in known[:limit])
    more = f", ... ({len(known) - limit} more)" if len(known) > limit else ""
    where = f"OCIO config {source}" + ("" if ocio_only else " or colour-science")
    return f"unknown colour space {name!r} (in the {where}); known: {shown}{more}"


# ---------------------------------------------------------------------------------------------------------
# Decoding a file's pixels to the working space


@dataclass(frozen=True)
class ColourInfo:
    """What was done to bring an image into the working space (recorded in stack metadata)."""

    source: str
    """Colour space the file was taken to be in."""
    working_space: str
    """Name of the working space the pixels are now in."""
    method: str
    """``"builtin"`` (sRGB curve and/or matrix), ``"ocio"``, ``"colour-science"`` or ``"none"``."""
    config: str | None = None
    """The OCIO config used (``"ocio"`` method only)."""

    def to_dict(self) -> dict:
        """Plain-JSON form."""
        return asdict(self)


DEFAULT_INTEGER_SOURCE = "sRGB Encoded Rec.709 (sRGB)"
"""What 8- and 16-bit files are taken to be without an explicit colour space."""
DEFAULT_FLOAT_SOURCE = "Linear Rec.709 (sRGB)"
"""What float files (EXR, float TIFF) are taken to be without an explicit colour space."""


def to_working(pixels, colorspace: str | None = None, *, encoded: bool,
               working: str | WorkingSpace | None = None) -> tuple[np.ndarray, ColourInfo]:
    """Bring a file's colour into the scene-linear working space.

    Parameters
    ----------
    pixels : ndarray of shape (..., 3) or (..., 4)
        The file's values: integer files normalised to [0, 1]; straight (unpremultiplied) colour for any
        non-linear source encoding. A 4th channel (alpha) is passed through unchanged.
    colorspace : str, optional
        The source colour space (see the module docstring for where names are looked up). None: sRGB-encoded
        Rec.709 when ``encoded``, else linear Rec.709.
    encoded : bool
        True for 8- and 16-bit integer files (only used when ``colorspace`` is None).
    working : str or WorkingSpace, optional
        Working space key (``"lin_rec709"``, the default, or ``"acescg"``).

    Returns
    -------
    pixels : ndarray, float32, scene-linear in the working space
    info : ColourInfo

    Raises
    ------
    VfxStereoError
        Unknown colour space or working space, or an OCIO config that has no colour space for the working
        space while the source is only known to it.
    """
    ws = working_space(working)
    pixels = np.asarray(pixels, dtype=np.float32)
    if colorspace is None or not str(colorspace).strip():
        out = np.array(pixels, dtype=np.float32, copy=True)
        if encoded:
            out[..., :3] = srgb_to_linear(out[..., :3])
        if ws.colour_name != "sRGB":
            out = _apply_matrix(out, _colour_matrix("sRGB", ws.colour_name))
        source = DEFAULT_INTEGER_SOURCE if encoded else DEFAULT_FLOAT_SOURCE
        return out, ColourInfo(source, ws.name, "builtin")

    name = str(colorspace).strip()
    source = ocio_config_source()
    # 1. OpenColorIO
    canonical = ocio_colorspace(name, source)
    if canonical is not None:
        dst = next((ocio_colorspace(n, source) for n in ws.ocio_names if ocio_colorspace(n, source)), None)
        if dst is not None:
            out = _apply_processor(_cpu_processor(source, canonical, dst), pixels)
            return out, ColourInfo(canonical, ws.name, "ocio", source)
        if _colour_colourspace(name) is None:
            raise VfxStereoError(
                f"the OCIO config {source} knows {name!r} but has no colour space for the working space "
                f"{ws.name!r} (tried {', '.join(ws.ocio_names)})")
    # 2. already linear in the working space
    if name.lower() in _LINEAR_NAMES:
        return np.array(pixels, dtype=np.float32, copy=True), ColourInfo(ws.name, ws.name, "none")
    # 3. colour-science
    cs = _colour_colourspace(name)
    if cs is None:
        raise VfxStereoError(_unknown_message(name, source=source))
    out = np.array(pixels, dtype=np.float32, copy=True)
    if cs.cctf_decoding is not None:
        out[..., :3] = np.asarray(cs.cctf_decoding(out[..., :3]), dtype=np.float32)
    if not _same_primaries(cs.name, ws.colour_name):
        out = _apply_matrix(out, _colour_matrix(cs.name, ws.colour_name))
    return out, ColourInfo(cs.name, ws.name, "colour-science")
