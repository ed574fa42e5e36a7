"""Shared fixtures. bpy must never write to the user's config or cache: point both at a temp folder first."""

import os
import tempfile
from pathlib import Path

_BL_TMP = tempfile.mkdtemp(prefix="vfxstereo-bl-")
os.environ.setdefault("BLENDER_USER_RESOURCES", os.path.join(_BL_TMP, "user"))
os.environ.setdefault("XDG_CACHE_HOME", os.path.join(_BL_TMP, "cache"))

import numpy as np  # noqa: E402
import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = (REPO / ".." / "shared" / "data").resolve()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the repository (CI has it there too)."""
    if not (SHARED_DATA / "README.md").exists():
        pytest.fail(f"shared data not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1999)


def write_multiview_exr(path, views: dict, layout: str = "single", *, header: dict | None = None):
    """Write a multi-view EXR of ``views`` ({name: (H, W, 3) float32}, the first is the default view).

    ``layout``: ``"single"`` (OpenEXR.File: ``multiView`` header, default view as ``R,G,B``, others as
    ``<view>.R``; plus a depth channel per view and an unrelated ``tmp.Z`` that belongs to no view),
    ``"single-named"`` (OpenImageIO: every view as ``<view>.R``, the default one too), or ``"multipart"``
    (OpenEXR.File: one part per view, named ``rgba.<view>``, with a ``view`` attribute and plain
    ``R,G,B,A``). ``header``: extra attributes (OpenEXR.File types, e.g. ``Fraction`` for framesPerSecond).
    """
    import OpenEXR

    names = list(views)
    extra = dict(header or {})
    if layout == "single":
        channels = {"tmp.Z": np.zeros(next(iter(views.values())).shape[:2], np.float32)}
        for k, (name, rgb) in enumerate(views.items()):
            prefix = "" if k == 0 else f"{name}."
            for c, comp in enumerate("RGB"):
                channels[prefix + comp] = np.ascontiguousarray(rgb[..., c])
            channels[prefix + "Z"] = np.full(rgb.shape[:2], 10.0 + k, np.float32)
        hdr = {"multiView": names, "type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION,
               **extra}
        with OpenEXR.File(hdr, channels) as f:
            f.write(str(path))
    elif layout == "multipart":
        parts = []
        h0, w0 = next(iter(views.values())).shape[:2]
        display = (np.array([0, 0], np.int32), np.array([w0 - 1, h0 - 1], np.int32))  # shared by all parts
        for name, rgb in views.items():
            rgba = np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), np.float32)], axis=-1)
            hdr = {"view": name, "type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION,
                   "displayWindow": display, **extra}
            parts.append(OpenEXR.Part(hdr, {"RGBA": np.ascontiguousarray(rgba)}, f"rgba.{name}"))
        with OpenEXR.File(parts) as f:
            f.write(str(path))
    elif layout == "single-named":
        import OpenImageIO as oiio

        h, w = next(iter(views.values())).shape[:2]
        spec = oiio.ImageSpec(w, h, 3 * len(views), "float")
        spec.channelnames = tuple(f"{name}.{c}" for name in names for c in "RGB")
        spec.attribute("multiView", oiio.TypeDesc(f"string[{len(names)}]"), tuple(names))
        for key, value in extra.items():
            spec.attribute(key, value)
        out = oiio.ImageOutput.create(str(path))
        assert out.open(str(path), spec), oiio.geterror()
        assert out.write_image(np.ascontiguousarray(np.concatenate(list(views.values()), axis=-1)))
        out.close()
    else:
        raise ValueError(layout)
    return Path(path)


@pytest.fixture(scope="session")
def multiview_exr():
    """:func:`write_multiview_exr`, for tests in any folder."""
    return write_multiview_exr
