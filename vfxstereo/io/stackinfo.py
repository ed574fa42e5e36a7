"""A stack file without reading all of it: the header, and one layer at a time.

:func:`vfxstereo.io.exr.read_stack` reads every layer into memory (``D * H * W * 16`` bytes: 9 GiB for 64
layers of 4K). Tools that only place or wire layers (the Blender add-on: planes, compositor trees) need the
header, and then the pixels of one layer at a time. The file layout is :mod:`vfxstereo.io.exr`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.io import exr


@dataclass(frozen=True)
class StackInfo:
    """What a stack file's header says.

    Attributes
    ----------
    path : Path
    width, height : int
        Frame size in pixels.
    disparities : ndarray of shape (D,)
        Exact disparities (float64), increasing; layer ``i`` is ``layer_names[i]``.
    layer_names : tuple of D str
        Layer names in the file (``L03_d2p50``); Blender's Image node lists them in its ``layer`` menu.
    camera : Camera or None
    metadata : dict
    white : float
    plate_layer : str or None
        Name of the plate's layer (``"plate"``) when the file holds the reference view, else None.
    """

    path: Path
    width: int
    height: int
    disparities: np.ndarray
    layer_names: tuple[str, ...]
    camera: Camera | None
    metadata: dict = field(default_factory=dict)
    white: float = 1.0
    plate_layer: str | None = None

    @property
    def depth(self) -> int:
        """Number of layers D."""
        return len(self.layer_names)


def read_stack_info(path) -> StackInfo:
    """The header of a stack written by :func:`vfxstereo.io.exr.write_stack`; no pixels are read.

    Raises
    ------
    VfxStereoError
        If the file is missing, unreadable, not a vfxstereo layer stack, or lacks a channel its header lists.
    """
    inp, spec = exr._open_input(path)
    try:
        exr._check_kind(spec, path, "layerstack", "write one with vfxstereo solve")
        if spec.deep:
            raise VfxStereoError(f"{path} is a deep image, not a multilayer layer stack")
        layers = exr._layers_header(spec, path)
        camera, metadata, white = exr._stack_extras(spec, path)
        plate = spec.get_string_attribute("vfxstereo/plate", "") or None
        names = set(spec.channelnames)
        for layer in [*layers, *([plate] if plate else [])]:
            for c in "RGBA":
                if f"{layer}.{exr.PASS_NAME}.{c}" not in names:
                    raise VfxStereoError(f"{path} lacks the channel {layer}.{exr.PASS_NAME}.{c} its header lists")
        disparities = np.array([float(d) for d in layers.values()], dtype=np.float64)
        if disparities.size > 1 and not np.all(np.diff(disparities) > 0):
            raise VfxStereoError(f"{path}: the disparities in its header are not increasing")
        return StackInfo(Path(path), spec.width, spec.height, disparities, tuple(layers), camera, metadata,
                         white, plate)
    finally:
        inp.close()


def read_stack_layer(path, layer) -> np.ndarray:
    """The pixels of one layer of a stack file, or of its plate.

    Parameters
    ----------
    path : str or Path
    layer : int or str
        A layer index (0 is furthest back), a layer name, or the plate's layer name.

    Returns
    -------
    ndarray of shape (H, W, 4), float32
        Premultiplied scene-linear RGBA, top row first (the plate's alpha is 1).

    Raises
    ------
    VfxStereoError
        For a missing or unreadable file, or a layer the file does not hold.
    """
    oiio = exr._oiio()
    info = read_stack_info(path)
    if isinstance(layer, (int, np.integer)):
        if not -info.depth <= int(layer) < info.depth:
            raise VfxStereoError(f"{path} has {info.depth} layers, there is no layer {int(layer)}")
        name = info.layer_names[int(layer)]
    else:
        name = str(layer)
        if name not in info.layer_names and name != info.plate_layer:
            raise VfxStereoError(f"{path} has no layer {name!r}; it has {', '.join(info.layer_names)}"
                                 + (f" and {info.plate_layer}" if info.plate_layer else ""))
    inp, spec = exr._open_input(path)
    try:
        index = {n: c for c, n in enumerate(spec.channelnames)}
        chans = [index[f"{name}.{exr.PASS_NAME}.{c}"] for c in "RGBA"]
        lo, hi = min(chans), max(chans) + 1  # OIIO keeps a layer's channels together, R,G,B,A first
        pixels = inp.read_image(0, 0, lo, hi, oiio.FLOAT)
        if pixels is None or inp.has_error:
            raise VfxStereoError(f"cannot read {path}: {exr._one_line(inp.geterror()) or 'corrupt file'}")
    finally:
        inp.close()
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, hi - lo)
    return np.ascontiguousarray(pixels[..., [c - lo for c in chans]])
