"""Reading plates, CG elements and evaluation datasets into scene-linear float32 arrays.

OpenImageIO reads every file (PNG, JPEG, TIFF, EXR, DPX, PPM/PGM, ... whatever it supports), all parts of
a multi-part EXR included. Colour is brought into the working space by :mod:`vfxstereo.io.color`:

===========================  =====================================  ==========================================
file                         default interpretation                 ``colorspace=`` given
===========================  =====================================  ==========================================
8/16-bit integer (PNG, ...)  sRGB-encoded Rec.709, decoded exactly  that colour space (OCIO, else colour-sci.)
float (EXR, float TIFF)      scene-linear Rec.709                   that colour space
===========================  =====================================  ==========================================

The working space is linear Rec.709/sRGB primaries by default, or ACEScg (``working_space="acescg"``);
a file's own colour-space tag (``oiio:ColorSpace``) is not used: pass ``colorspace=`` to override.

Channels: plain ``R,G,B(,A)`` if present, else a grey ``Y`` (made 3-channel), else the ``R,G,B`` of a
layer (a Blender render's ``ViewLayer.Combined`` is preferred), else the first three channels (or the one
channel of a single-channel file, a depth pass included, as grey). Depth is a
``Z`` channel, or one named ``depth.Z`` / ``Depth.Z`` / ``ViewLayer.Depth.Z`` (any layer ending in
``depth.Z``, case-insensitive).

Alpha: PNG (and TIFF with unassociated alpha) store straight colour: :func:`read_element` decodes the colour
first and premultiplies afterwards. EXR and associated-alpha TIFF are premultiplied already.

Multi-view EXR (OpenEXR's multi-view convention, ``ImfMultiView.h``): the views of a stereo or multi-camera
plate in one file per frame, read by :func:`read_view_set` / :func:`read_views` with one path (and
``views=``), described by :func:`describe_plate`.

==============  ==========================================================================================
layout          which channels make view v
==============  ==========================================================================================
single part     the header's ``multiView`` (string vector) lists the views, the first is the default view.
                A channel without a dot (``R``) belongs to the default view; one whose second-to-last
                dotted part is a view name to that view (``right.R``, ``diffuse.right.R``, and ``left.R``
                for the default view ``left``); any other (``diffuse.R``, ``right.diffuse.R``) to no view
multi-part      each part's ``view`` attribute names the view of all its channels (a channel that repeats
                the view as its second-to-last part, ``left.R`` in the part of ``left``, has it removed).
                Views are in the order of ``multiView`` when the file has one, else of their first part
==============  ==========================================================================================

Within a view the channels are named without the view (``left.R`` becomes ``R``, ``diffuse.left.R``
becomes ``diffuse.R``) and the colour is picked as for a plain file (above). A view's size is that of its
first part; other-sized parts of the same view (previews) are skipped. Views of different sizes cannot be
solved together, and are refused.

Shapes: plates ``(H, W, 3)``, elements ``(H, W, 4)`` premultiplied, views ``(K, H, W, 3)``, all float32.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.color import ColourInfo, to_working

_FLOAT_BASETYPES = ("HALF", "FLOAT", "DOUBLE")


# ---------------------------------------------------------------------------------------------------------
# Low level: one file, every channel by name


@dataclass
class _RawImage:
    """A file's channels as stored, by name; integer channels normalised to [0, 1]."""

    path: str
    channels: dict[str, np.ndarray]  # name -> (H, W) float32
    names: list[str]  # in file order
    is_float: bool
    straight: bool  # the file stores unassociated (straight) alpha
    alpha_name: str | None  # OIIO's alpha channel of the first part
    attributes: dict = field(default_factory=dict)  # header attributes of the first part
    view: str | None = None  # the view of a multi-view EXR these channels are

    @property
    def shape(self) -> tuple[int, int]:
        return next(iter(self.channels.values())).shape

    @property
    def label(self) -> str:
        """The file, and the view if there is one, for messages."""
        return self.path if self.view is None else f"{self.path} (view {self.view})"


def _oiio():
    import OpenImageIO as oiio

    return oiio


def _open(path: str):
    """ImageInput with alpha left unassociated (as stored), or a VfxStereoError."""
    oiio = _oiio()
    if not os.path.exists(path):
        raise VfxStereoError(f"file not found: {path}")
    if os.path.isdir(path):
        raise VfxStereoError(f"expected an image file, got a folder: {path}")
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(path, config)
    if inp is None:
        raise VfxStereoError(f"cannot read {path}: {oiio.geterror() or 'unknown format'}")
    return inp


def _read_raw(path) -> _RawImage:
    oiio = _oiio()
    path = str(path)
    inp = _open(path)
    try:
        channels: dict[str, np.ndarray] = {}
        names: list[str] = []
        first = inp.spec()
        attributes = _header_attributes(first)
        size = (first.height, first.width)
        is_float = first.format.basetype.name in _FLOAT_BASETYPES
        straight = int(first.get_int_attribute("oiio:UnassociatedAlpha", 0)) == 1
        a = first.alpha_channel
        alpha_name = first.channelnames[a] if 0 <= a < first.nchannels else None
        sub = 0
        while inp.seek_subimage(sub, 0):
            spec = inp.spec()
            if spec.deep:
                raise VfxStereoError(f"{path} is a deep image; read deep EXRs with vfxstereo.io.exr")
            if (spec.height, spec.width) != size:
                sub += 1  # parts of another size (previews, proxies) are not pixels of this image
                continue
            pixels = inp.read_image(oiio.FLOAT)
            if pixels is None:
                raise VfxStereoError(f"cannot read {path}: {inp.geterror() or 'corrupt file'}")
            pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
            part = spec.get_string_attribute("name", "")
            for c, name in enumerate(spec.channelnames):
                key = name if name not in channels else f"{part}.{name}"
                channels[key] = pixels[..., c]
                names.append(key)
            sub += 1
    finally:
        inp.close()
    if not channels:
        raise VfxStereoError(f"cannot read {path}: no channels")
    return _RawImage(path, channels, names, is_float, straight, alpha_name, attributes)


def _header_attributes(spec) -> dict:
    return {a.name: a.value for a in spec.extra_attribs}


def _colour_channels(names: list[str], alpha_name: str | None, path: str) -> tuple[list[str], str | None]:
    """Names of the R, G, B channels (a grey channel three times) and of alpha (or None), among ``names``."""
    ch = set(names)
    if all(c in ch for c in "RGB"):
        return ["R", "G", "B"], "A" if "A" in ch else None
    if "Y" in ch:
        return ["Y"] * 3, "A" if "A" in ch else None
    # layers: "<layer>.R/G/B(/A)"; a render's Combined pass first
    layers = [n[:-2] for n in names if n.endswith(".R") and n[:-2] + ".G" in ch and n[:-2] + ".B" in ch]
    if layers:
        layer = next((n for n in layers if "combined" in n.lower()), layers[0])
        return [f"{layer}.{c}" for c in "RGB"], f"{layer}.A" if f"{layer}.A" in ch else None
    colour = [n for n in names if n != alpha_name and not _is_depth(n)]
    if not colour:  # a depth-only file (a separate Z pass) is one grey channel
        colour = [n for n in names if n != alpha_name]
    if len(colour) == 1:
        return colour * 3, alpha_name
    if len(colour) >= 3:
        return colour[:3], alpha_name
    raise VfxStereoError(f"{path} has no colour channels (channels: {', '.join(names)})")


def _is_depth(name: str) -> bool:
    low = name.lower()
    return low == "z" or low == "depth.z" or low.endswith(".depth.z")


def _depth_channel(raw: _RawImage) -> str | None:
    if "Z" in raw.channels:
        return "Z"
    return next((n for n in raw.names if _is_depth(n)), None)


# ---------------------------------------------------------------------------------------------------------
# Plates


@dataclass
class Plate:
    """A decoded plate and what was done to it.

    Attributes
    ----------
    pixels : ndarray of shape (H, W, 3), float32
        Scene-linear colour in the working space.
    path : str
        The file read.
    colour : ColourInfo
        Source colour space, working space, method (recorded in stack metadata by the solver).
    attributes : dict
        Header attributes of the file (of the view's part in a multi-part file), as OIIO reports them.
    view : str or None
        The view, when the plate is one view of a multi-view EXR.
    """

    pixels: np.ndarray
    path: str
    colour: ColourInfo
    attributes: dict = field(default_factory=dict)
    view: str | None = None

    @property
    def working_space(self) -> str:
        """Name of the working space the pixels are in."""
        return self.colour.working_space

    def to_metadata(self) -> dict:
        """Plain-JSON description: path (and view) and colour handling."""
        view = {} if self.view is None else {"view": self.view}
        return {"path": self.path, **view, **self.colour.to_dict()}


def read_plate(path, *, view: str | None = None, colorspace: str | None = None,
               working_space: str | None = None, return_info: bool = False):
    """Read an image file (or one view of a multi-view EXR) as scene-linear RGB in the working space.

    Parameters
    ----------
    path : str or Path
        Any file OpenImageIO reads. Alpha, if any, is ignored (the colour is taken as stored).
    view : str, optional
        A view of a multi-view EXR (module docstring); default: the file's own colour channels (the
        default view of a multi-view file).
    colorspace : str, optional
        The file's colour space (the CLI's ``--input-colorspace``): an OCIO name from ``$OCIO`` or the
        built-in config, ``"linear"``, or a colour-science name (see :mod:`vfxstereo.io.color`).
        None: 8/16-bit files are sRGB-encoded, float files scene-linear Rec.709.
    working_space : str, optional
        ``"lin_rec709"`` (default) or ``"acescg"``.
    return_info : bool
        Return a :class:`Plate` (pixels plus what was done) instead of the bare array.

    Returns
    -------
    ndarray of shape (H, W, 3), float32, scene-linear; or a :class:`Plate` with ``return_info=True``.

    Raises
    ------
    VfxStereoError
        Missing, unreadable or corrupt file; unknown colour space; a view the file does not hold.
    """
    if view is None:
        raw = _read_default_view(path)
    else:
        layout = describe_plate(path)
        raw = _read_views_raw(layout, layout.select([view], at_least=1))[0]
    plate = _decode_plate(raw, colorspace, working_space)
    return plate if return_info else plate.pixels


def _read_default_view(path) -> _RawImage:
    """A plain file's channels, or the default view's of a multi-view EXR."""
    layout = describe_plate(path)
    if not layout.views:
        return _read_raw(path)
    return _read_views_raw(layout, layout.select(layout.views[:1], at_least=1))[0]


def _decode_plate(raw: _RawImage, colorspace: str | None, working_space: str | None) -> Plate:
    rgb_names, _ = _colour_channels(raw.names, raw.alpha_name, raw.label)
    rgb = np.stack([raw.channels[n] for n in rgb_names], axis=-1)
    pixels, info = to_working(rgb, colorspace, encoded=not raw.is_float, working=working_space)
    return Plate(np.ascontiguousarray(pixels, dtype=np.float32), raw.path, info, raw.attributes, raw.view)


def read_element(path, *, colorspace: str | None = None, working_space: str | None = None,
                 return_info: bool = False):
    """Read a CG element: premultiplied scene-linear RGBA and its depth channel, if it has one.

    Straight-alpha files (PNG; TIFF with unassociated alpha) are decoded to linear first, then premultiplied.
    Premultiplied integer files (associated-alpha TIFF) are unpremultiplied, decoded and premultiplied again.
    Premultiplied float files (EXR) keep their colour as stored; a ``colorspace=`` conversion is then applied
    to the premultiplied colour (right for the usual linear-to-linear conversions). A file without alpha
    is opaque (alpha 1).

    Parameters
    ----------
    path : str or Path
        Any file OpenImageIO reads.
    colorspace, working_space : str, optional
        As for :func:`read_plate`.
    return_info : bool
        Also return the :class:`~vfxstereo.io.color.ColourInfo`.

    Returns
    -------
    rgba : ndarray of shape (H, W, 4), float32, premultiplied, scene-linear
    z : ndarray of shape (H, W), float32, or None
        The ``Z`` / ``depth.Z`` / ``...Depth.Z`` channel as stored (scene units; no colour conversion).
    info : ColourInfo
        Only with ``return_info=True``.

    Raises
    ------
    VfxStereoError
        Missing, unreadable or corrupt file; unknown colour space; NaN or infinite values.
    """
    raw = _read_raw(path)
    rgb_names, alpha_name = _colour_channels(raw.names, raw.alpha_name, raw.label)
    H, W = raw.shape
    rgba = np.empty((H, W, 4), dtype=np.float32)
    for c, n in enumerate(rgb_names):
        rgba[..., c] = raw.channels[n]
    rgba[..., 3] = raw.channels[alpha_name] if alpha_name else 1.0
    alpha = rgba[..., 3:4]
    encoded = not raw.is_float
    if alpha_name and not raw.straight and encoded:
        # premultiplied in the encoded space: unpremultiply before decoding
        rgba[..., :3] = np.where(alpha > 0, rgba[..., :3] / np.where(alpha > 0, alpha, 1), 0)
    rgba, info = to_working(rgba, colorspace, encoded=encoded, working=working_space)
    if alpha_name and (raw.straight or encoded):
        rgba[..., :3] *= rgba[..., 3:4]  # decode first, premultiply after
    z_name = _depth_channel(raw)
    z = None if z_name is None else np.ascontiguousarray(raw.channels[z_name], dtype=np.float32)
    bad = int(np.count_nonzero(~np.isfinite(rgba).all(axis=-1)))
    if bad:
        raise VfxStereoError(f"element {path} has {bad} pixels with NaN or infinite colour or alpha")
    rgba = np.ascontiguousarray(rgba)
    return (rgba, z, info) if return_info else (rgba, z)


@dataclass
class ViewSet:
    """The K views of a plate, read to be solved together, and where each came from.

    Attributes
    ----------
    pixels : ndarray of shape (K, H, W, 3), float32
        Scene-linear colour in the working space, views in baseline order.
    files : list of str
        The file of each view (the one multi-view EXR K times, or K files).
    views : list of str or None
        The view names inside a multi-view EXR; None for one file per view.
    colour : list of ColourInfo
        How each view was decoded.
    attributes : list of dict
        Each view's header attributes, as OIIO reports them.
    """

    pixels: np.ndarray
    files: list[str]
    views: list[str] | None
    colour: list[ColourInfo]
    attributes: list[dict]

    def metadata(self, reference: int | None = None) -> dict:
        """Stack metadata naming the sources; :func:`vfxstereo.io.exr.write_stack` writes it to the header.

        Parameters
        ----------
        reference : int, optional
            Index of the reference view: its frame rate and time code are taken first; views without them
            are skipped.

        Returns
        -------
        dict
            ``source_files`` (one per view), ``source_views`` (multi-view EXR only), and where a view's file
            has them, ``frames_per_second`` (``[n, d]``) and ``time_code`` (``[timeAndFlags, userData]``).
        """
        out: dict = {"source_files": list(self.files)}
        if self.views is not None:
            out["source_views"] = list(self.views)
        order = list(range(len(self.files)))
        if reference is not None and 0 <= int(reference) < len(order):
            order.insert(0, order.pop(int(reference)))
        for k in order:
            for key, value in _timing(self.attributes[k]).items():
                out.setdefault(key, value)
        return out


def _timing(attributes: dict) -> dict:
    """``frames_per_second`` and ``time_code`` of a header, when it has them."""
    out = {}
    fps = attributes.get("framesPerSecond", attributes.get("FramesPerSecond"))
    if isinstance(fps, tuple | list) and len(fps) == 2 and int(fps[1]) > 0:
        out["frames_per_second"] = [int(fps[0]), int(fps[1])]
    elif isinstance(fps, int | float) and fps > 0:  # some formats (DPX) store a float rate
        rate = Fraction(float(fps)).limit_denominator(1001)
        out["frames_per_second"] = [rate.numerator, rate.denominator]
    code = attributes.get("smpte:TimeCode")
    if isinstance(code, tuple | list) and len(code) == 2:
        out["time_code"] = [int(code[0]), int(code[1])]
    return out


def read_view_set(paths, *, views=None, colorspace: str | None = None,
                  working_space: str | None = None) -> ViewSet:
    """Read the K views of a plate, from K files or from one multi-view EXR, checking they solve together.

    Parameters
    ----------
    paths : str, Path or sequence of them
        K view files ordered along the baseline (K >= 2); or one multi-view EXR (module docstring).
    views : sequence of str, optional
        With one multi-view EXR: the views to read, in baseline order (default: all, in the file's order).
    colorspace, working_space : str, optional
        As for :func:`read_plate`; the same for every view.

    Returns
    -------
    ViewSet

    Raises
    ------
    VfxStereoError
        Fewer than two views; a missing, unreadable or corrupt file (named); ``views`` with several files,
        or naming a view the file does not hold (the message lists the views it has); views of different
        sizes (both sizes); NaN or infinite pixels (the file, the view and how many pixels).
    """
    if isinstance(paths, str | os.PathLike):
        paths = [paths]
    paths = [str(p) for p in paths]
    if isinstance(views, str):
        views = views.split(",")
    if not paths:
        raise VfxStereoError("need at least two views, got 0")
    for p in paths:
        if not os.path.isfile(p):
            raise VfxStereoError(f"view not found: {p}")
    if len(paths) == 1 or views is not None:
        if len(paths) != 1:
            raise VfxStereoError(f"views {', '.join(views)} are picked inside one multi-view EXR, but "
                                 f"{len(paths)} files were given")
        layout = describe_plate(paths[0])
        if not layout.views and views is None:
            raise VfxStereoError(f"need at least two views, got 1: {paths[0]} is not a multi-view EXR (no "
                                 "multiView header and no part with a view attribute)")
        names = layout.select(views)
        raws = _read_views_raw(layout, names)
    else:
        names = None
        raws = [_read_default_view(p) for p in paths]
    plates = []
    for raw in raws:
        plate = _decode_plate(raw, colorspace, working_space)
        first = plates[0].pixels if plates else plate.pixels
        if plate.pixels.shape != first.shape:
            h, w = plate.pixels.shape[:2]
            raise VfxStereoError(f"view {raw.label} is {w}x{h} but {raws[0].label} is {first.shape[1]}x"
                                 f"{first.shape[0]} (width x height); all views must be the same size")
        bad = int(np.count_nonzero(~np.isfinite(plate.pixels).all(axis=-1)))
        if bad:
            raise VfxStereoError(f"view {raw.label} has {bad} pixels with NaN or infinite values")
        plates.append(plate)
    return ViewSet(np.stack([pl.pixels for pl in plates]), [pl.path for pl in plates], names,
                   [pl.colour for pl in plates], [pl.attributes for pl in plates])


def read_views(paths, *, views=None, colorspace: str | None = None, working_space: str | None = None,
               return_info: bool = False):
    """Read the K views of a plate into one array (:func:`read_view_set` without the bookkeeping).

    Parameters
    ----------
    paths : str, Path or sequence of them
        The view files, ordered along the baseline (at least two); or one multi-view EXR.
    views : sequence of str, optional
        With one multi-view EXR: the views to read, in baseline order (default: all, in the file's order).
    colorspace, working_space : str, optional
        As for :func:`read_plate`; the same for every view.
    return_info : bool
        Also return one :class:`~vfxstereo.io.color.ColourInfo` per view.

    Returns
    -------
    views : ndarray of shape (K, H, W, 3), float32, scene-linear
    infos : list of ColourInfo
        Only with ``return_info=True``.

    Raises
    ------
    VfxStereoError
        As :func:`read_view_set`.
    """
    view_set = read_view_set(paths, views=views, colorspace=colorspace, working_space=working_space)
    return (view_set.pixels, view_set.colour) if return_info else view_set.pixels


# ---------------------------------------------------------------------------------------------------------
# Multi-view EXR: which channels make which view (module docstring)


@dataclass
class PlatePart:
    """One part (OIIO subimage) of an image file, from its header.

    Attributes
    ----------
    index : int
    name : str
        The part's name ("" when it has none).
    view : str or None
        Its ``view`` attribute (multi-part multi-view files).
    width, height : int
        Size of its data window.
    channels : tuple of str
        Channel names as stored.
    is_float : bool
    deep : bool
    attributes : dict
        Its header attributes, as OIIO reports them.
    """

    index: int
    name: str
    view: str | None
    width: int
    height: int
    channels: tuple[str, ...]
    is_float: bool
    deep: bool
    attributes: dict = field(default_factory=dict, repr=False)


@dataclass
class PlateLayout:
    """What an image file holds, from its headers alone: its parts, its views and the channels of each view.

    Attributes
    ----------
    path : str
    parts : list of PlatePart
    views : list of str
        The views, in the file's order, the default view first; empty when the file is not multi-view.
    view_channels : dict
        ``view -> [(part index, channel as stored, channel name within the view), ...]``.
    """

    path: str
    parts: list[PlatePart]
    views: list[str]
    view_channels: dict[str, list[tuple[int, str, str]]]

    @property
    def multi_view(self) -> bool:
        """True when the file holds views (a ``multiView`` header or parts with a ``view``)."""
        return bool(self.views)

    @property
    def attributes(self) -> dict:
        """Header attributes of the first part."""
        return self.parts[0].attributes

    def _have(self) -> str:
        return f"the views of {self.path}: {', '.join(self.views) if self.views else 'none'}"

    def view_size(self, view: str) -> tuple[int, int]:
        """``(height, width)`` of ``view``."""
        chans = self.view_channels.get(view)
        if not chans:
            raise VfxStereoError(f"view {view!r} has no channels in {self.path} ({self._have()})")
        part = self.parts[chans[0][0]]
        return part.height, part.width

    def select(self, views=None, *, at_least: int = 2) -> list[str]:
        """The views to read, checked: all views by default, else ``views`` (names), in that order.

        Raises
        ------
        VfxStereoError
            The file is not multi-view; a name it does not hold, or one given twice; fewer than
            ``at_least`` views; views of different sizes. The message lists the views the file has.
        """
        if not self.views:
            raise VfxStereoError(f"{self.path} is not a multi-view EXR (no multiView header and no part with a "
                                 f"view attribute): {self._have()}")
        names = list(self.views) if views is None else [str(v).strip() for v in views]
        for i, v in enumerate(names):
            if v not in self.views:
                raise VfxStereoError(f"{self.path} has no view {v!r}; {self._have()}")
            if v in names[:i]:
                raise VfxStereoError(f"view {v!r} is asked for twice; {self._have()}")
        if len(names) < at_least:
            raise VfxStereoError(f"need at least {at_least} views, got {len(names)} "
                                 f"({', '.join(names) or 'none'}); {self._have()}")
        h0, w0 = self.view_size(names[0])
        for v in names[1:]:
            h, w = self.view_size(v)
            if (h, w) != (h0, w0):
                raise VfxStereoError(f"view {v} is {w}x{h} but view {names[0]} is {w0}x{h0} (width x height) "
                                     f"inside {self.path}; the views of a plate must be the same size "
                                     f"({self._have()})")
        return names

    def to_dict(self) -> dict:
        """Plain-JSON description (what ``vfxstereo info`` prints for a plate)."""
        views = []
        for v in self.views:
            chans = self.view_channels.get(v, [])
            entry = {"name": v, "default": v == self.views[0], "channels": [c for _, c, _ in chans]}
            if chans:
                h, w = self.view_size(v)
                names = [n for _, _, n in chans]
                try:
                    colour, _ = _colour_channels(names, "A" if "A" in names else None, self.path)
                except VfxStereoError:
                    colour = []
                stored = dict((n, c) for _, c, n in chans)
                entry.update(width=w, height=h, colour=[stored[n] for n in colour])
            views.append(entry)
        parts = [{"index": p.index, "name": p.name, "view": p.view, "width": p.width, "height": p.height,
                  "channels": list(p.channels), "deep": p.deep} for p in self.parts]
        return {"file": self.path, "multi_view": self.multi_view, "multi_part": len(self.parts) > 1,
                "views": views, "parts": parts}


def describe_plate(path) -> PlateLayout:
    """Parts, views and channels of an image file, from its headers (no pixels are read).

    Raises
    ------
    VfxStereoError
        Missing or unreadable file.
    """
    path = str(path)
    inp = _open(path)
    parts: list[PlatePart] = []
    declared: list[list[str]] = []  # each part's multiView list
    try:
        sub = 0
        while inp.seek_subimage(sub, 0):
            spec = inp.spec()
            attributes = _header_attributes(spec)
            listed = attributes.get("multiView") or ()
            declared.append([listed] if isinstance(listed, str) else [str(v) for v in listed])
            parts.append(PlatePart(sub, spec.get_string_attribute("name", ""),
                                   spec.get_string_attribute("view", "") or None, spec.width, spec.height,
                                   tuple(spec.channelnames), spec.format.basetype.name in _FLOAT_BASETYPES,
                                   bool(spec.deep), attributes))
            sub += 1
    finally:
        inp.close()
    if not parts:
        raise VfxStereoError(f"cannot read {path}: no image in it")
    views = list(next((d for d in declared if d), []))
    view_channels: dict[str, list[tuple[int, str, str]]] = {}
    for part, listed in zip(parts, declared, strict=True):
        if part.deep:
            continue
        for stored in part.channels:
            view, name = _view_of_channel(stored, part.view, listed)
            if view is None:
                continue
            chans = view_channels.setdefault(view, [])
            if chans and (parts[chans[0][0]].height, parts[chans[0][0]].width) != (part.height, part.width):
                continue  # a preview or proxy part of another size
            if any(n == name for _, _, n in chans):
                name = f"{part.name}.{name}"
            chans.append((part.index, stored, name))
    views += [v for v in view_channels if v not in views]
    return PlateLayout(path, parts, views, view_channels)


def _view_of_channel(channel: str, part_view: str | None, listed: list[str]) -> tuple[str | None, str]:
    """``(view, name within the view)`` of a stored channel, by OpenEXR's multi-view rules."""
    comps = channel.split(".")
    if part_view:
        if len(comps) >= 2 and comps[-2] == part_view:
            return part_view, ".".join(comps[:-2] + comps[-1:])
        return part_view, channel
    if listed:
        if len(comps) == 1:
            return listed[0], channel  # no dot: the default view
        if comps[-2] in listed:
            return comps[-2], ".".join(comps[:-2] + comps[-1:])
    return None, channel  # "tmp.R", "right.diffuse.R": no view at all (OpenEXR's viewFromChannelName)


def _read_views_raw(layout: PlateLayout, views: list[str]) -> list[_RawImage]:
    """The channels of each of ``views``, named within the view; every part needed is read once."""
    oiio = _oiio()
    needed = sorted({p for v in views for p, _, _ in layout.view_channels[v]})
    pixels: dict[int, np.ndarray] = {}
    inp = _open(layout.path)
    try:
        for p in needed:
            if not inp.seek_subimage(p, 0):
                raise VfxStereoError(f"cannot read {layout.path}: part {p} is missing")
            spec = inp.spec()
            data = inp.read_image(oiio.FLOAT)
            if data is None or inp.has_error:
                raise VfxStereoError(f"cannot read {layout.path}: {inp.geterror() or 'corrupt file'}")
            pixels[p] = np.asarray(data, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    finally:
        inp.close()
    raws = []
    for v in views:
        chans = layout.view_channels[v]
        channels = {n: pixels[p][..., layout.parts[p].channels.index(c)] for p, c, n in chans}
        first = layout.parts[chans[0][0]]
        raws.append(_RawImage(layout.path, channels, [n for _, _, n in chans], first.is_float, False,
                              "A" if "A" in channels else None, first.attributes, v))
    return raws


# ---------------------------------------------------------------------------------------------------------
# Evaluation datasets (/work/shared/data/*/dataset.json)


@dataclass
class Dataset:
    """A multi-view evaluation set described by a ``dataset.json`` (see ``shared/data/README.md``).

    Attributes
    ----------
    name : str
    root : Path
        The folder holding ``dataset.json``.
    views : list of Path
        View files, ordered along the baseline (resolved against ``root``).
    positions : ndarray of shape (K,), float64
        Camera positions along the baseline, in view steps.
    reference : int
        Index of the view the ground truth belongs to (the virtual camera).
    gt : ndarray of shape (H, W), float32, or None
        Ground-truth disparity in px per view step (file value times ``gt_scale``); NaN where unknown.
    eval_steps : int
        View steps the published scores are measured over.
    border : int
        Frame-edge pixels the published scores ignore.
    citation : str
    """

    name: str
    root: Path
    views: list[Path]
    positions: np.ndarray
    reference: int
    gt: np.ndarray | None
    eval_steps: int = 1
    border: int = 0
    citation: str = ""
    raw: dict = field(default_factory=dict, repr=False)

    @property
    def reference_position(self) -> float:
        """Baseline position of the reference view."""
        return float(self.positions[self.reference])

    def read_views(self, **kwargs) -> np.ndarray:
        """The views as ``(K, H, W, 3)`` scene-linear float32 (:func:`read_views`; keywords passed on)."""
        return read_views(self.views, **kwargs)


def read_raw_values(path, *, channel: int = 0) -> np.ndarray:
    """One channel of a file as its stored numbers (no colour decoding, no normalisation), float32 (H, W).

    8-bit files give 0..255, 16-bit files 0..65535, float files their values. ``.npz`` / ``.npy`` files give
    their (first) array.
    """
    path = str(path)
    if path.lower().endswith((".npz", ".npy")):
        if not os.path.isfile(path):
            raise VfxStereoError(f"file not found: {path}")
        try:
            data = np.load(path)
            if hasattr(data, "files"):  # .npz: the first array
                with data:
                    arr = data[data.files[0]]
            else:
                arr = data
        except (OSError, ValueError, IndexError, EOFError) as exc:
            raise VfxStereoError(f"cannot read {path}: {exc}") from None
        arr = np.asarray(arr, dtype=np.float32)
        if arr.ndim == 3:
            arr = arr[..., channel]
        if arr.ndim != 2:
            raise VfxStereoError(f"{path} holds an array of shape {arr.shape}, expected (H, W)")
        return arr
    oiio = _oiio()
    inp = _open(path)
    try:
        spec = inp.spec()
        if not 0 <= channel < spec.nchannels:
            raise VfxStereoError(f"{path} has {spec.nchannels} channel(s); channel {channel} asked for")
        pixels = inp.read_image(0, 0, channel, channel + 1, oiio.UNKNOWN)  # native type: raw values
        if pixels is None:
            raise VfxStereoError(f"cannot read {path}: {inp.geterror() or 'corrupt file'}")
    finally:
        inp.close()
    return np.asarray(pixels).reshape(spec.height, spec.width).astype(np.float32)


def image_size(path) -> tuple[int, int]:
    """``(height, width)`` of an image file, from its header (the first part of a multi-part file).

    Raises
    ------
    VfxStereoError
        Missing or unreadable file.
    """
    inp = _open(str(path))
    try:
        spec = inp.spec()
        return spec.height, spec.width
    finally:
        inp.close()


def load_dataset(path) -> Dataset:
    """Read a ``dataset.json`` and its ground-truth disparity.

    Parameters
    ----------
    path : str or Path
        The dataset folder, or its ``dataset.json``.

    Returns
    -------
    Dataset
        Views are paths (read them with :meth:`Dataset.read_views`); ``gt`` is loaded: the GT file's raw
        values (8/16-bit PNG/PGM are NOT colour-decoded; ``gt_channel`` picks a channel; ``.npz`` supported)
        equal to ``gt_invalid`` or not finite become NaN, the rest are multiplied by ``gt_scale``.

    Raises
    ------
    VfxStereoError
        Missing ``dataset.json`` or files, bad keys, positions that do not match the views, a GT of another
        size than the reference view.
    """
    path = Path(path)
    json_path = path / "dataset.json" if path.is_dir() else path
    if not json_path.is_file():
        raise VfxStereoError(f"no dataset.json at {json_path}")
    try:
        spec = json.loads(json_path.read_text())
    except (OSError, ValueError) as exc:
        raise VfxStereoError(f"cannot read {json_path}: {exc}") from None
    root = json_path.parent
    try:
        views = [root / v for v in spec["views"]]
        positions = np.asarray(spec.get("positions", list(range(len(views)))), dtype=np.float64)
        reference = int(spec.get("reference", 0))
    except (KeyError, TypeError, ValueError) as exc:
        raise VfxStereoError(f"{json_path}: bad or missing key {exc}") from None
    if positions.shape != (len(views),):
        raise VfxStereoError(f"{json_path}: {len(views)} views but {positions.size} positions")
    if not 0 <= reference < len(views):
        raise VfxStereoError(f"{json_path}: reference {reference} is not a view index (0..{len(views) - 1})")
    for v in views:
        if not v.is_file():
            raise VfxStereoError(f"{json_path}: view not found: {v}")
    gt = None
    if spec.get("gt_disparity"):
        raw = read_raw_values(root / spec["gt_disparity"], channel=int(spec.get("gt_channel") or 0))
        invalid = ~np.isfinite(raw)
        if spec.get("gt_invalid") is not None:
            invalid |= raw == float(spec["gt_invalid"])
        gt = (raw * np.float32(spec.get("gt_scale", 1.0))).astype(np.float32)
        gt[invalid] = np.nan
        ref_size = image_size(views[reference])
        if gt.shape != ref_size:
            raise VfxStereoError(f"{json_path}: ground truth is {gt.shape[1]}x{gt.shape[0]} but the "
                                 f"reference view is {ref_size[1]}x{ref_size[0]}")
    return Dataset(
        name=str(spec.get("name", root.name)), root=root, views=views, positions=positions,
        reference=reference, gt=gt, eval_steps=int(spec.get("eval_steps", 1)),
        border=int(spec.get("border", 0)), citation=str(spec.get("citation", "")), raw=spec)
