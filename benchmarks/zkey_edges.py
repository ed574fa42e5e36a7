"""Z-keying at soft edges: the solved layer stack against a perfect depth map with a hard matte.

Scenes: :func:`vfxstereo.samples.matting_scene` -- a real alpha-matting foreground (hair, fur; exact alpha)
at d = 4 over a Middlebury image as a flat background at d = 0, K = 5 views. A CG element is z-keyed at
``D = 2``, between the two. Three comps of the reference view:

* **GT**: ``composite.insert(gt_stack, element, disparity=D)`` -- the right answer;
* **(a) solved stack**: ``composite.insert(solved_stack, element, disparity=D)``, the stack from
  ``vfxstereo.solve`` on the K views;
* **(b) perfect depth, hard matte**: what a depth-only tool makes from the TRUE disparity map: per pixel, the
  plate (reference view) where the true front-most disparity (``gt_stack.disparity_map(0.5)``) is > D, else
  ``element over plate``.

PSNR (dB, scene-linear RGB, peak 1) of (a) and (b) against GT, over the whole frame and over the soft-edge
band (pixels mixing more than one layer, i.e. 0 < alpha < 1 of the foreground where it is visible, dilated
by :data:`BAND_DILATE` px). The issue's target: (a) beats (b) on the band by >= 1 dB on average.

Two elements: a full-frame checker card (every band pixel has the element behind it: the matte alone
decides) and :func:`vfxstereo.samples.cg_element`, an anti-aliased checker card centred in the frame
(half the band has plate behind it, as in a real shot).

With ``--matting`` the report gains a section on :func:`vfxstereo.matting.matte_edges` (edge matting, past
the paper): the band PSNR of (a) after matting the solved stack, and of the ground-truth stack with its
foreground alpha hardened at 0.5 before and after matting (full-frame card).

Run ``python benchmarks/zkey_edges.py [--quick] [--matting] [--images GT04 ...] [--presets paper fig6a ...]``.
"""

from __future__ import annotations

import argparse
import sys

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np

from vfxstereo import SolveConfig, composite, matting, samples, solve
from vfxstereo.stack import LayerStack

IMAGES = ("GT04", "GT26", "GT25", "GT16", "GT08", "GT03")
"""The six alpha-matting images with the largest share of fractional alpha (0.02 < alpha < 0.98) in their
foreground: hair and fur."""
PRESETS = ("zkey", "paper", "literal", "fig6a", "wta")
"""Solver presets tried: zkey (paper + edge matting), the paper preset, the paper as written, Fig. 6(a), WTA."""
SCALE = 0.4
"""Size of the scenes relative to the matting set's 800 px images (about 320 x 225)."""
FG_DISPARITY, BG_DISPARITY, ELEMENT_DISPARITY = 4.0, 0.0, 2.0
BAND_DILATE = 3
"""Dilation of the soft-edge band, px."""
PRIMARY = "full-frame card"
"""The element of the headline table."""

QUICK = {"images": ("GT04", "GT26"), "presets": ("paper", "wta"), "scale": 0.25, "refine_iterations": 30}


def elements(shape) -> dict[str, np.ndarray]:
    """The CG elements, premultiplied RGBA (H, W, 4), by name."""
    h, w = shape
    full = samples.cg_element((h, w), centre=(h / 2, w / 2), size=2.0 * np.hypot(h, w), angle=20.0,
                              checks=int(2 * np.hypot(h, w) / 24))
    card = samples.cg_element((h, w), centre=(0.5 * h, 0.5 * w), size=0.6 * min(h, w), angle=20.0)
    return {"full-frame card": full, "centred card": card}


def hard_matte_comp(plate: np.ndarray, gt_disparity: np.ndarray, element: np.ndarray, D: float) -> np.ndarray:
    """(b): the plate where the true front-most disparity is > D, else the element over the plate (RGB)."""
    behind = composite.over(element, np.concatenate([plate, np.ones(plate.shape[:2] + (1,), np.float32)], -1))
    return np.where((gt_disparity > D)[..., None], plate, behind[..., :3])


def hardened(sample) -> LayerStack:
    """The ground-truth stack with every layer's alpha thresholded at 0.5 (colour: straight colour times it)."""
    rgba = sample.stack.rgba.copy()
    a = rgba[..., 3]
    straight = rgba[..., :3] / np.maximum(a, 1e-6)[..., None]
    hard = (a >= 0.5).astype(np.float32)
    rgba[..., :3] = straight * hard[..., None]
    rgba[..., 3] = hard
    return LayerStack(rgba, sample.stack.disparities, sample.stack.camera, white=sample.stack.white)


def _crop_window(band: np.ndarray, size=(96, 128)) -> tuple[slice, slice]:
    """The window of ``size`` holding the most band pixels."""
    from scipy.ndimage import uniform_filter

    h, w = band.shape
    ch, cw = min(size[0], h), min(size[1], w)
    density = uniform_filter(band.astype(np.float32), size=(ch, cw), mode="constant")
    y, x = np.unravel_index(np.argmax(density), density.shape)
    y0 = int(np.clip(y - ch // 2, 0, h - ch))
    x0 = int(np.clip(x - cw // 2, 0, w - cw))
    return slice(y0, y0 + ch), slice(x0, x0 + cw)


def figure(path, gt, a, b, band, title) -> None:
    """Crops of the edge band: GT, (a), (b) comps and their errors (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vfxstereo.io.preview import to_display

    ys, xs = _crop_window(band)
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.8), dpi=100, layout="constrained")
    for ax, img, t in zip(axes[0], (gt, a, b), ("ground truth comp", "(a) solved stack",
                                               "(b) perfect depth, hard matte"), strict=True):
        ax.imshow(to_display(img[ys, xs]))
        ax.set_title(t)
    axes[1, 0].imshow(band[ys, xs], cmap="gray")
    axes[1, 0].set_title(f"soft-edge band (dilated {BAND_DILATE} px)")
    for ax, img, t in ((axes[1, 1], a, "|(a) - GT| x 4"), (axes[1, 2], b, "|(b) - GT| x 4")):
        err = np.abs(img[ys, xs] - gt[ys, xs]).mean(-1)
        ax.imshow(np.clip(4 * err, 0, 1), cmap="magma", vmin=0, vmax=1)
        ax.set_title(t)
    for ax in axes.ravel():
        ax.set_axis_off()
    fig.suptitle(title)
    fig.savefig(path)
    plt.close(fig)


def run(*, quick: bool = False, images=None, presets=None, scale=None, refine_iterations=None,
        verbose: bool = True, edge_matting: bool = False) -> str:
    """Every scene with every preset; the Markdown report."""
    images = tuple(images or (QUICK["images"] if quick else IMAGES))
    presets = tuple(presets or (QUICK["presets"] if quick else PRESETS))
    scale = float(scale or (QUICK["scale"] if quick else SCALE))
    if refine_iterations is None and quick:
        refine_iterations = QUICK["refine_iterations"]
    D = ELEMENT_DISPARITY
    rows: list[dict] = []  # one per (image, preset, element)
    mrows: list[dict] = []  # edge matting: one per (image, preset) and per image for the hardened GT
    comps: dict[tuple[str, str], tuple] = {}  # (image, preset) -> (gt, a, b, band), full-frame card
    sizes = []
    for image in images:
        sample = samples.matting_scene(image, scale=scale, fg_disparity=FG_DISPARITY,
                                       bg_disparity=BG_DISPARITY, K=5)
        sizes.append(sample.shape)
        band = sample.soft_edge_mask(BAND_DILATE)
        plate = sample.reference_view
        gt_disp = sample.gt_disparity(0.5)
        gt_hold = composite.holdout(sample.stack, D)
        hard_hold = (gt_disp > D).astype(np.float32)
        elems = elements(sample.shape)
        if edge_matting:
            full = elems[PRIMARY]
            gt = composite.insert(sample.stack, full, disparity=D)[..., :3]
            hard = hardened(sample)
            with common.Stopwatch() as sw:
                hard_m = matting.matte_stack(hard, sample.views)
            before = composite.insert(hard, full, disparity=D)[..., :3]
            after = composite.insert(hard_m, full, disparity=D)[..., :3]
            b = hard_matte_comp(plate, gt_disp, full, D)
            mrows.append({"image": image, "start": "GT, alpha hardened", "before": common.psnr(before, gt, band),
                          "after": common.psnr(after, gt, band), "b_band": common.psnr(b, gt, band),
                          "alpha_before": float(np.abs(composite.holdout(hard, D) - gt_hold)[band].mean()),
                          "alpha_after": float(np.abs(composite.holdout(hard_m, D) - gt_hold)[band].mean()),
                          "seconds": sw.seconds})
        for preset in presets:
            config = SolveConfig.preset(preset)
            if refine_iterations is not None and config.refine_iterations > 0:
                config = config.replace(refine_iterations=refine_iterations)
            with common.Stopwatch() as sw:
                stack = solve(sample.views, positions=sample.positions, reference=sample.reference,
                              disparities=sample.disparities, config=config)
            hold = composite.holdout(stack, D)
            alpha_a = float(np.abs(hold - gt_hold)[band].mean())
            alpha_b = float(np.abs(hard_hold - gt_hold)[band].mean())
            for ename, element in elems.items():
                gt = composite.insert(sample.stack, element, disparity=D)[..., :3]
                a = composite.insert(stack, element, disparity=D)[..., :3]
                b = hard_matte_comp(plate, gt_disp, element, D)
                rows.append({"image": image, "preset": preset, "element": ename, "seconds": sw.seconds,
                             "a_frame": common.psnr(a, gt), "a_band": common.psnr(a, gt, band),
                             "b_frame": common.psnr(b, gt), "b_band": common.psnr(b, gt, band),
                             "alpha_a": alpha_a, "alpha_b": alpha_b})
                if ename == PRIMARY:
                    comps[(image, preset)] = (gt, a, b, band)
            if edge_matting:
                full = elems[PRIMARY]
                with common.Stopwatch() as msw:
                    mstack = matting.matte_stack(stack, sample.views)
                gt = composite.insert(sample.stack, full, disparity=D)[..., :3]
                after = composite.insert(mstack, full, disparity=D)[..., :3]
                r = next(r for r in rows[::-1] if r["preset"] == preset and r["element"] == PRIMARY
                         and r["image"] == image)
                mrows.append({"image": image, "start": f"solved `{preset}`", "before": r["a_band"],
                              "after": common.psnr(after, gt, band), "b_band": r["b_band"],
                              "alpha_before": alpha_a,
                              "alpha_after": float(np.abs(composite.holdout(mstack, D) - gt_hold)[band].mean()),
                              "seconds": msw.seconds})
                if verbose:
                    print(f"  zkey {image}/{preset}: edge matting band PSNR {r['a_band']:.2f} -> "
                          f"{mrows[-1]['after']:.2f} dB, {msw.seconds:.1f} s", file=sys.stderr, flush=True)
            if verbose:
                r = rows[-len(elems)]
                print(f"  zkey {image}/{preset}: band PSNR (a) {r['a_band']:.2f} dB vs (b) {r['b_band']:.2f} dB, "
                      f"{sw.seconds:.1f} s", file=sys.stderr, flush=True)
    text, best = report(rows, images, presets, sizes, scale, refine_iterations, quick)
    if mrows:
        text += matting_report(mrows)
    tag = "_quick" if quick else ""
    for image in images:
        gt, a, b, band = comps[(image, best)]
        figure(common.out_dir() / f"zkey_{image}_{best}{tag}.png", gt, a, b, band,
               f"{image}, preset {best}: element at d={D:g} behind the foreground (d={FG_DISPARITY:g}); band "
               f"PSNR (a) {common.psnr(a, gt, band):.2f} dB, (b) {common.psnr(b, gt, band):.2f} dB")
    return text


def _mean(rows, key) -> float:
    return float(np.mean([r[key] for r in rows]))


def report(rows, images, presets, sizes, scale, refine_iterations, quick) -> tuple[str, str]:
    """The Markdown report and the best preset (highest mean band PSNR of (a), full-frame card)."""
    def select(preset, element):
        return [r for r in rows if r["preset"] == preset and r["element"] == element]

    best = max(presets, key=lambda p: _mean(select(p, PRIMARY), "a_band"))
    table = []
    for r in select(best, PRIMARY):
        table.append([r["image"], r["a_frame"], r["b_frame"], r["a_band"], r["b_band"], r["a_band"] - r["b_band"],
                      r["alpha_a"], r["alpha_b"]])
    mean = np.mean(np.array([t[1:] for t in table], dtype=np.float64), axis=0)
    table.append(["**mean**", *mean])
    head = ["scene", "frame (a) dB", "frame (b) dB", "band (a) dB", "band (b) dB", "band (a)-(b) dB",
            "band alpha MAE (a)", "band alpha MAE (b)"]
    verdict = "MET" if mean[4] >= 1.0 else "NOT MET"
    parts = [common.section(
        f"Z-key at soft edges: {PRIMARY}, best preset `{best}`",
        common.markdown_table(head, table)
        + f"\n\nTarget (band: (a) beats (b) by >= 1 dB on average): **{verdict}** ({mean[4]:+.2f} dB; "
          f"{int(sum(t[5] >= 1.0 for t in table[:-1]))}/{len(table) - 1} scenes reach +1 dB).")]
    srows = []
    for ename in dict.fromkeys(r["element"] for r in rows):
        for p in presets:
            rs = select(p, ename)
            wins = sum(r["a_band"] - r["b_band"] >= 1.0 for r in rs)
            srows.append([ename, p, _mean(rs, "a_frame"), _mean(rs, "b_frame"), _mean(rs, "a_band"),
                          _mean(rs, "b_band"), _mean(rs, "a_band") - _mean(rs, "b_band"), _mean(rs, "alpha_a"),
                          f"{wins}/{len(rs)}", _mean(rs, "seconds")])
    parts.append(common.section(
        "Z-key at soft edges: every preset tried (means over the scenes)",
        common.markdown_table(["element", "preset", "frame (a)", "frame (b)", "band (a)", "band (b)",
                               "band (a)-(b)", "alpha MAE (a)", "scenes >= +1 dB", "solve s"], srows)))
    h = sorted({s[0] for s in sizes})
    w = sorted({s[1] for s in sizes})
    notes = [
        f"Scenes: samples.matting_scene(image, scale={scale:g}) for {', '.join(images)} "
        f"({min(w)}-{max(w)} x {min(h)}-{max(h)} px), foreground at d={FG_DISPARITY:g}, background at "
        f"d={BG_DISPARITY:g}, K=5 views; the solve uses the scene's planes d = 0..{FG_DISPARITY:g} (step 1).",
        f"Element z-keyed at D = {ELEMENT_DISPARITY:g}. (a) = insert into the solved stack; (b) = plate "
        "where the TRUE front-most disparity (alpha > 0.5) > D, else element over plate; both against "
        "insert into the GT stack.",
        f"PSNR (dB) on scene-linear RGB, peak 1. Band = mixed pixels of the GT stack dilated by {BAND_DILATE} "
        "px (Sample.soft_edge_mask). 'inf' = identical to GT. Band alpha MAE: mean |holdout - GT holdout| "
        "over the band, holdout = alpha of everything in front of D (composite.holdout; (b): 0 or 1).",
        "Presets: " + ", ".join(f"`{p}`" for p in presets)
        + (f"; presets that refine ran {refine_iterations} iterations" if refine_iterations is not None
           else "; each preset's own refinement iterations (paper: 100)") + ".",
    ]
    if quick:
        notes.append("--quick: fewer scenes, smaller scale, fewer refinement iterations; indicative only.")
    parts.append("\n" + "\n".join(f"- {n}" for n in notes) + f"\n\nFigures: `benchmarks/out/zkey_*_{best}*.png` "
                 "(crops of the edge band, full-frame card, best preset).\n")
    return "".join(parts), best


def matting_report(mrows) -> str:
    """The edge-matting section: per start and scene, band PSNR before and after matte_edges."""
    table = []
    for start in dict.fromkeys(r["start"] for r in mrows):
        rs = [r for r in mrows if r["start"] == start]
        for r in rs:
            table.append([start, r["image"], r["before"], r["after"], r["b_band"], r["after"] - r["b_band"],
                          r["alpha_before"], r["alpha_after"], r["seconds"]])
        table.append([start, "**mean**", _mean(rs, "before"), _mean(rs, "after"), _mean(rs, "b_band"),
                      _mean(rs, "after") - _mean(rs, "b_band"), _mean(rs, "alpha_before"),
                      _mean(rs, "alpha_after"), _mean(rs, "seconds")])
    head = ["start", "scene", "band before dB", "band after dB", "band (b) dB", "after-(b) dB",
            "alpha MAE before", "alpha MAE after", "matting s"]
    return common.section(
        f"Edge matting (vfxstereo.matting.matte_edges, defaults), {PRIMARY}",
        common.markdown_table(head, table)
        + "\n\nBand PSNR of the z-key comp before and after `matting.matte_stack` on the start stack; (b) = the "
          "hard matte cut from the true depth. 'GT, alpha hardened' = the ground-truth stack with alpha "
          "thresholded at 0.5 (colour = straight colour x hardened alpha); the background is re-estimated "
          "from the views either way.\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two scenes, smaller, paper and wta only")
    parser.add_argument("--images", nargs="+", default=None, help=f"alpha-matting images (default {IMAGES})")
    parser.add_argument("--presets", nargs="+", default=None, help=f"SolveConfig presets (default {PRESETS})")
    parser.add_argument("--scale", type=float, default=None, help=f"scene scale (default {SCALE})")
    parser.add_argument("--refine-iterations", type=int, default=None,
                        help="override the refinement iterations of the presets that refine")
    parser.add_argument("--matting", action="store_true",
                        help="also report edge matting (vfxstereo.matting) on the solved and hardened-GT stacks")
    args = parser.parse_args(argv)
    print(run(quick=args.quick, images=args.images, presets=args.presets, scale=args.scale,
              refine_iterations=args.refine_iterations, edge_matting=args.matting))
    return 0


if __name__ == "__main__":
    sys.exit(main())
