"""Write the shipped demo sample into samples/demo/ (run again whenever vfxstereo.samples.demo_scene changes).

    .venv/bin/python samples/make_samples.py [--out samples/demo] [--data-dir ../shared/data]

Files (about 2 MB in all):

* ``view0.png`` .. ``view4.png``: the K = 5 views of :func:`vfxstereo.samples.demo_scene`, 16-bit PNG,
  sRGB-encoded (IEC 61966-2-1). 16-bit PNG rather than half EXR because the views are display-range
  ([0, 1]) colour: 16-bit sRGB codes are finer there (at most ~2e-5 linear error against half's ~2.4e-4
  near 1.0), the files open in any viewer, and they have the same form as the shared datasets' views, so
  the demo reads them through the same code path (sRGB decode) real plates take.
* ``disp_gt.png``: the ground-truth disparity of the reference view (front-most layer with alpha > 0.5),
  16-bit, value = 256 * d (``gt_scale`` 1/256; 65535 would mean unknown, but every pixel is known).
* ``element.exr``: :func:`vfxstereo.samples.cg_element` at the frame size, RGBA half, premultiplied,
  scene-linear; the demo z-keys it at ``element_disparity`` (d = 3).
* ``dataset.json``: the shared data's format (views, positions, reference, gt_*) plus the planes, the
  element and a description. ``README.md``: the same in words.

The ground-truth layer stack is not written here: the demo writes it with the EXR stack writer.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from vfxstereo.errors import VfxStereoError
from vfxstereo.io.color import linear_to_srgb
from vfxstereo.samples import DEMO_ELEMENT_DISPARITY, Sample, cg_element, demo_scene

HERE = Path(__file__).resolve().parent
GT_SCALE = 1.0 / 256.0
GT_INVALID = 65535


def _write(path: Path, pixels: np.ndarray, fmt: str, channels: tuple[str, ...], **attrs) -> None:
    """Write ``pixels`` (H, W, C) with OIIO to a temporary name beside ``path``, then rename it into place."""
    if pixels.ndim == 2:
        pixels = pixels[..., None]  # OIIO's write_image misreads a 2-D array as a 1-channel image
    h, w, nch = pixels.shape
    spec = oiio.ImageSpec(w, h, nch, fmt)
    spec.channelnames = channels
    if "A" in channels:
        spec.alpha_channel = channels.index("A")
    for key, value in attrs.items():
        spec.attribute(key, value)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    out = oiio.ImageOutput.create(str(tmp))
    if out is None or not out.open(str(tmp), spec):
        raise VfxStereoError(f"cannot write {path}: {oiio.geterror()}")
    ok = out.write_image(np.ascontiguousarray(pixels))
    out.close()
    if not ok:
        tmp.unlink(missing_ok=True)
        raise VfxStereoError(f"cannot write {path}: {out.geterror()}")
    os.replace(tmp, path)


def srgb16(linear: np.ndarray) -> np.ndarray:
    """Scene-linear [0, 1] colour as 16-bit sRGB codes (uint16)."""
    encoded = np.clip(linear_to_srgb(np.clip(linear, 0.0, 1.0)), 0.0, 1.0)
    return np.round(encoded * 65535.0).astype(np.uint16)


def write_sample(sample: Sample, out_dir: Path, *, element: np.ndarray | None = None,
                 element_disparity: float | None = None, citation: str = "") -> dict:
    """Write the views (16-bit sRGB PNG), GT disparity, optional element (half EXR) and dataset.json."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [f"view{k}.png" for k in range(sample.K)]
    for name, view in zip(names, sample.views, strict=True):
        _write(out_dir / name, srgb16(view), "uint16", ("R", "G", "B"),
               **{"oiio:ColorSpace": "sRGB", "png:compressionLevel": 9})
    gt = sample.gt_disparity()
    codes = np.where(np.isfinite(gt), np.round(gt / GT_SCALE), GT_INVALID).astype(np.uint16)
    _write(out_dir / "disp_gt.png", codes, "uint16", ("Y",), **{"png:compressionLevel": 9})
    spec = {
        "name": sample.name,
        "description": sample.description,
        "views": names,
        "positions": [float(p) for p in sample.positions],
        "reference": int(sample.reference),
        "gt_disparity": "disp_gt.png",
        "gt_scale": GT_SCALE,
        "gt_invalid": GT_INVALID,
        "eval_steps": 1,
        "border": 0,
        "disparities": [float(d) for d in sample.disparities],
        "encoding": "views: 16-bit PNG, sRGB-encoded (IEC 61966-2-1), decode to scene-linear Rec.709; "
                    "disp_gt.png: 16-bit, disparity = value * gt_scale (front-most layer with alpha > 0.5)",
        "generator": "samples/make_samples.py from vfxstereo.samples." + sample.name + "_scene",
        "citation": citation,
    }
    if element is not None:
        _write(out_dir / "element.exr", element.astype(np.float32), "half", ("R", "G", "B", "A"),
               compression="zip")
        spec["element"] = "element.exr"
        spec["element_disparity"] = float(element_disparity)
        spec["element_encoding"] = "RGBA half, premultiplied, scene-linear Rec.709"
    tmp = out_dir / ".dataset.tmp.json"
    tmp.write_text(json.dumps(spec, indent=1) + "\n")
    os.replace(tmp, out_dir / "dataset.json")
    return spec


README = """# Demo sample

Made by `samples/make_samples.py` from `vfxstereo.samples.demo_scene()` and `cg_element()`; do not edit.

{description}

| file | what |
|---|---|
| `view0.png` .. `view{last}.png` | the {K} views, {W}x{H}, 16-bit PNG, sRGB-encoded (decode to linear) |
| `disp_gt.png` | ground-truth disparity of view {ref} (the reference): value / 256 px per view step |
| `element.exr` | CG element (checker card), RGBA half, premultiplied, scene-linear; z-key it at d = {ed:g} |
| `dataset.json` | the same description in the shared datasets' format |

Views are exactly the re-synthesised views of the ground-truth layer stack (planes d = {planes}), so the
stack is the exact answer: `vfxstereo.samples.demo_scene().stack`.

Sources: {citation}
"""

CITATION = ("alpha mattes GT04, GT19: alphamatting.com training set, C. Rhemann et al., A perceptually "
            "motivated online benchmark for image matting, CVPR 2009; background: Middlebury 2003 Teddy im2, "
            "D. Scharstein & R. Szeliski, High-accuracy stereo depth maps using structured light, CVPR 2003.")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "demo", help="output folder (samples/demo)")
    parser.add_argument("--data-dir", type=Path, default=None, help="shared data folder (../shared/data)")
    args = parser.parse_args(argv)
    try:
        sample = demo_scene(data_dir=args.data_dir)
        element = cg_element(sample.shape)
        write_sample(sample, args.out, element=element, element_disparity=DEMO_ELEMENT_DISPARITY,
                     citation=CITATION)
    except VfxStereoError as exc:
        print(f"make_samples: {exc}", file=sys.stderr)
        return 2
    h, w = sample.shape
    (args.out / "README.md").write_text(README.format(
        description=sample.description, last=sample.K - 1, K=sample.K, W=w, H=h, ref=sample.reference,
        ed=DEMO_ELEMENT_DISPARITY, planes=", ".join(f"{d:g}" for d in sample.disparities), citation=CITATION))
    total = sum(f.stat().st_size for f in args.out.iterdir() if f.is_file())
    print(f"wrote {args.out} ({total / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
