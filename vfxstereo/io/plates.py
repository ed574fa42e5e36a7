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

Shapes: plates ``(H, W, 3)``, elements ``(H, W, 4)`` premultiplied, views ``(K, H, W, 3)``, all float32.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
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

    @property
    def shape(self) -> tuple[int, int]:
        return next(iter(self.channels.values())).shape


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
    return _RawImage(path, channels, names, is_float, straight, alpha_name)


def _colour_channels(raw: _RawImage) -> tuple[list[str], str | None]:
    """Names of the R, G, B channels (a grey channel three times) and of alpha (or None)."""
    ch = raw.channels
    if all(c in ch for c in "RGB"):
        return ["R", "G", "B"], "A" if "A" in ch else None
    if "Y" in ch:
        return ["Y"] * 3, "A" if "A" in ch else None
    # layers: "<layer>.R/G/B(/A)"; a render's Combined pass first
    layers = [n[:-2] for n in raw.names if n.endswith(".R") and n[:-2] + ".G" in ch and n[:-2] + ".B" in ch]
    if layers:
        layer = next((n for n in layers if "combined" in n.lower()), layers[0])
        return [f"{layer}.{c}" for c in "RGB"], f"{layer}.A" if f"{layer}.A" in ch else None
    colour = [n for n in raw.names if n != raw.alpha_name and not _is_depth(n)]
    if not colour:  # a depth-only file (a separate Z pass) is one grey channel
        colour = [n for n in raw.names if n != raw.alpha_name]
    if len(colour) == 1:
        return colour * 3, raw.alpha_name
    if len(colour) >= 3:
        return colour[:3], raw.alpha_name
    raise VfxStereoError(f"{raw.path} has no colour channels (channels: {', '.join(raw.names)})")


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
    """

    pixels: np.ndarray
    path: str
    colour: ColourInfo

    @property
    def working_space(self) -> str:
        """Name of the working space the pixels are in."""
        return self.colour.working_space

    def to_metadata(self) -> dict:
        """Plain-JSON description: path and colour handling."""
        return {"path": self.path, **self.colour.to_dict()}


def read_plate(path, *, colorspace: str | None = None, working_space: str | None = None,
               return_info: bool = False):
    """Read an image file as scene-linear RGB in the working space.

    Parameters
    ----------
    path : str or Path
        Any file OpenImageIO reads. Alpha, if any, is ignored (the colour is taken as stored).
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
        Missing, unreadable or corrupt file; unknown colour space.
    """
    raw = _read_raw(path)
    rgb_names, _ = _colour_channels(raw)
    rgb = np.stack([raw.channels[n] for n in rgb_names], axis=-1)
    pixels, info = to_working(rgb, colorspace, encoded=not raw.is_float, working=working_space)
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    return Plate(pixels, str(path), info) if return_info else pixels


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
    rgb_names, alpha_name = _colour_channels(raw)
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


def read_views(paths, *, colorspace: str | None = None, working_space: str | None = None,
               return_info: bool = False):
    """Read the K views of a plate into one array, checking they can be solved together.

    Parameters
    ----------
    paths : sequence of str or Path
        The view files, ordered along the baseline (at least two).
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
        Fewer than two views; a missing, unreadable or corrupt file (named); views of different sizes (the
        first mismatching file and both sizes); NaN or infinite pixels (the file and how many pixels).
    """
    if isinstance(paths, str | os.PathLike):
        paths = [paths]
    paths = [str(p) for p in paths]
    if len(paths) < 2:
        raise VfxStereoError(f"need at least two views, got {len(paths)}")
    for p in paths:
        if not os.path.isfile(p):
            raise VfxStereoError(f"view not found: {p}")
    views = None
    infos = []
    for k, p in enumerate(paths):
        plate = read_plate(p, colorspace=colorspace, working_space=working_space, return_info=True)
        px = plate.pixels
        if views is None:
            views = np.empty((len(paths),) + px.shape, dtype=np.float32)
        elif px.shape != views.shape[1:]:
            raise VfxStereoError(
                f"view {p} is {px.shape[1]}x{px.shape[0]} but {paths[0]} is {views.shape[2]}x{views.shape[1]}"
                " (width x height); all views must be the same size")
        bad = int(np.count_nonzero(~np.isfinite(px).all(axis=-1)))
        if bad:
            raise VfxStereoError(f"view {p} has {bad} pixels with NaN or infinite values")
        views[k] = px
        infos.append(plate.colour)
    return (views, infos) if return_info else views


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
