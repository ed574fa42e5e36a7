"""The demo behind ``make demo``: the whole chain on the shipped sample, through the real command line.

solve -> stack EXR + deep EXR + disparity EXR -> z-key the shipped CG element between the layers -> comp EXR
and PNG previews (comp, holdout, contact sheet of layers, disparity map). The shipped sample was made from
exact ground truth (samples/make_samples.py), so the demo also says how close the comp is to the true one.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from vfxstereo import baselines, cli, composite, samples
from vfxstereo.io import exr, plates, preview

HERE = Path(__file__).resolve().parent
SAMPLE = HERE / "demo"
OUT = HERE.parent / "out" / "demo"


def run(*argv: str) -> None:
    print("$ vfxstereo " + " ".join(argv), flush=True)
    status = cli.main(list(argv))
    if status != 0:
        sys.exit(status)


def psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    err = (a - b) ** 2
    err = err[mask] if mask is not None else err
    return float(10 * np.log10(1.0 / max(float(err.mean()), 1e-12)))


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    meta = json.loads((SAMPLE / "dataset.json").read_text())
    d_lo, d_hi = meta["disparities"][0], meta["disparities"][-1]
    element_d = meta["element_disparity"]
    t0 = time.perf_counter()
    run("solve", "--dataset", str(SAMPLE), "--disparities", f"{d_lo:g}:{d_hi:g}",
        "-o", str(OUT / "stack.exr"), "--deep-out", str(OUT / "stack_deep.exr"),
        "--disparity-out", str(OUT / "disparity.exr"), "--previews", str(OUT), "--overwrite")
    run("zkey", str(OUT / "stack.exr"), str(SAMPLE / meta["element"]), "--disparity", f"{element_d:g}",
        "-o", str(OUT / "comp.exr"), "--holdout-out", str(OUT / "holdout.exr"),
        "--front-out", str(OUT / "front.exr"), "--back-out", str(OUT / "back.exr"))
    run("info", str(OUT / "stack.exr"))

    # Pictures, and how close the comp is to the one made from the ground-truth stack.
    stack = exr.read_stack(OUT / "stack.exr")
    comp, _, _ = exr.read_image(OUT / "comp.exr")
    holdout, _, _ = exr.read_image(OUT / "holdout.exr")
    disparity, _, _ = exr.read_image(OUT / "disparity.exr")
    element, _ = plates.read_element(SAMPLE / meta["element"])
    preview.write_png(OUT / "comp.png", comp)
    preview.write_png(OUT / "holdout.png", np.repeat(holdout[..., :1], 3, axis=-1))
    preview.write_png(OUT / "layers.png", preview.contact_sheet(stack))
    preview.write_png(OUT / "disparity.png", preview.disparity_preview(disparity[..., 0], d_lo, d_hi))
    truth = samples.demo_scene()
    true_comp = composite.insert(truth.stack, element, disparity=element_d)
    band = truth.soft_edge_mask()
    preview.write_png(OUT / "comp_truth.png", true_comp)

    print()
    print(f"done in {time.perf_counter() - t0:.1f} s; outputs in {OUT}:")
    rows = [
        ("stack.exr", f"{stack.depth} premultiplied RGBA layers (d = {d_lo:g}..{d_hi:g}); Blender/Nuke multilayer"),
        ("stack_deep.exr", "the same layers as deep samples (R,G,B,A,Z,ZBack); oiiotool --flatten reads it"),
        ("disparity.exr / .png", "sub-pixel disparity of the reference camera (channel Z) and a colour map"),
        ("comp.exr / comp.png", f"the CG card z-keyed at d = {element_d:g}: behind the hair, in front of the pumpkin"),
        ("holdout.exr / .png", "matte of everything in front of the card (multiply a CG render by 1 - holdout)"),
        ("front.exr, back.exr", "flattened layers in front of / behind the card: front over card over back = comp"),
        ("layers.png", "contact sheet of every layer over a checkerboard"),
        ("comp_truth.png", "the comp made from the ground-truth stack, for comparison"),
    ]
    for name, what in rows:
        print(f"  {name:24s} {what}")
    print(f"comp vs ground-truth comp: {psnr(comp, true_comp):.1f} dB over the frame, "
          f"{psnr(comp, true_comp, band):.1f} dB on the soft-edge band (hair)")
    # what a compositor would do instead: a hard key from OpenCV SGBM's two-view depth
    views = truth.views
    ref = truth.reference
    d_sgbm = baselines.sgbm_disparity(views[ref], views[ref + 1], 1.0, meta["disparities"])
    key = baselines.hard_key(views[ref], d_sgbm, element, element_d)
    print(f"a hard key from OpenCV SGBM depth:  {psnr(key, true_comp[..., :3]):.1f} dB over the frame, "
          f"{psnr(key, true_comp[..., :3], band):.1f} dB on the band")
    return 0


if __name__ == "__main__":
    sys.exit(main())
