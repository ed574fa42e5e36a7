"""Speed of the compositing operators and the solver stages, as ratios to baselines timed in the same run.

Absolute times depend on the machine and on what else runs on it; ratios to a baseline measured side by side
(same process, same array sizes, best of several runs) are what can be compared from one machine to another.

Baselines
---------
* ``np.add(b, c, out=a)`` -- two reads and one write per element: the machine's memory (or cache) bandwidth
  over the same bytes. An over-composite ``fg + (1 - fg.a) bg`` moves the same bytes, so 1.0x would be a
  perfect, bandwidth-bound flatten.
* ``np.copyto(dst, src)`` of the same array -- for the shift warp, which at best reads and writes each pixel
  once (a whole-pixel shift) or reads two and writes one (a bilinear shift).
* ``np.add`` per RGBA float32 pixel ("pixel-add") -- the unit of the solver's per-cell costs: a stage that
  costs 20 pixel-adds per cell and view takes as long as twenty RGBA additions per cell and view.

Run ``python benchmarks/throughput.py [--quick]``.
"""

from __future__ import annotations

import argparse
import sys

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np

from vfxstereo import composite
from vfxstereo.geometry import Camera, shift_bilinear
from vfxstereo.stack import LayerStack

FULL = {"shape": (288, 384), "planes": 16, "views": 5, "big": (1080, 1920), "repeat": 5}
QUICK = {"shape": (144, 192), "planes": 8, "views": 5, "big": None, "repeat": 3}


def _rng():
    return np.random.default_rng(1999)


def _random_stack(shape, planes) -> LayerStack:
    """A stack with partial alpha everywhere (premultiplied, valid)."""
    rng = _rng()
    h, w = shape
    alpha = rng.random((planes, h, w, 1), dtype=np.float32)
    rgb = rng.random((planes, h, w, 3), dtype=np.float32) * alpha
    rgba = np.concatenate([rgb, alpha], axis=-1)
    cam = Camera.from_positions(np.arange(5, dtype=np.float64), reference=2)
    return LayerStack(rgba, np.arange(planes, dtype=np.float64), cam)


def _add_time(shape, repeat) -> float:
    a, b, c = (np.random.default_rng(i).random(shape, dtype=np.float32) for i in range(3))
    return common.best_time(lambda: np.add(b, c, out=a), repeat=repeat, min_time=0.02)


def _copy_time(shape, repeat) -> float:
    src = _rng().random(shape, dtype=np.float32)
    dst = np.empty_like(src)
    return common.best_time(lambda: np.copyto(dst, src), repeat=repeat, min_time=0.02)


def _gbps(nbytes: float, seconds: float) -> float:
    return nbytes / seconds / 1e9


# --------------------------------------------------------------------------------------------------------
# Compositing: flatten, insert, shift


def compositing_table(cfg) -> str:
    h, w = cfg["shape"]
    D, rep = cfg["planes"], cfg["repeat"]
    stack = _random_stack((h, w), D)
    element = stack.rgba[D // 2].copy()
    per_layer_bytes = 3 * h * w * 4 * 4  # the over of one layer: read layer + acc, write acc

    t_add_stack = _add_time((D, h, w, 4), rep)  # same bytes as one over pass over the whole stack
    t_flat = common.best_time(stack.flatten, repeat=rep)
    t_ins = common.best_time(lambda: composite.insert(stack, element, disparity=D / 2 - 0.5), repeat=rep)
    dmap = np.full((h, w), D / 2 - 0.5)
    dmap[:, : w // 2] = D / 4
    t_ins_map = common.best_time(lambda: composite.insert(stack, element, element_disparity=dmap), repeat=rep)
    t_hold = common.best_time(lambda: composite.holdout(stack, D / 2 - 0.5), repeat=rep)

    rows = [
        ["np.add(b, c, out=a), (D,H,W,4) (baseline)", t_add_stack / D * 1e3, 1.0,
         _gbps(per_layer_bytes * D, t_add_stack)],
        ["LayerStack.flatten", t_flat / D * 1e3, t_flat / t_add_stack, _gbps(per_layer_bytes * D, t_flat)],
        ["composite.insert, one disparity", t_ins / (D + 1) * 1e3, t_ins / t_add_stack * D / (D + 1),
         _gbps(per_layer_bytes * (D + 1), t_ins)],
        ["composite.insert, per-pixel disparity", t_ins_map / (D + 1) * 1e3,
         t_ins_map / t_add_stack * D / (D + 1), _gbps(per_layer_bytes * (D + 1), t_ins_map)],
        ["composite.holdout (alpha only)", t_hold / D * 1e3, t_hold / t_add_stack, None],
    ]
    table = common.markdown_table(["operation (per layer)", "ms / layer", "x np.add", "GB/s moved"], rows)
    notes = (f"Stack ({D}, {h}, {w}, 4) float32 with random partial alpha; per layer = total / layers "
             "(insert: / (layers + 1), the element being one more layer). 'GB/s moved' counts the bytes "
             "an ideal over moves (read layer and accumulator, write accumulator: "
             f"{per_layer_bytes / 1e6:.2f} MB per layer). 1.0x = as fast as a bandwidth-bound np.add over "
             "the same bytes.")
    return table + "\n\n" + notes


def shift_table(cfg) -> str:
    shapes = [cfg["shape"]] + ([cfg["big"]] if cfg["big"] else [])
    rows = []
    for h, w in shapes:
        rep = cfg["repeat"] if h * w < 1e6 else max(2, cfg["repeat"] - 2)
        img = _rng().random((h, w, 4), dtype=np.float32)
        t_copy = _copy_time((h, w, 4), rep)
        label = f"{w}x{h}x4"
        rows.append([f"np.copyto (baseline), {label}", t_copy * 1e3, 1.0, _gbps(2 * img.nbytes, t_copy)])
        for name, sx, sy in (("whole-pixel x shift (3, 0)", 3.0, 0.0),
                             ("sub-pixel x shift (2.5, 0)", 2.5, 0.0),
                             ("sub-pixel x+y shift (2.5, 1.25)", 2.5, 1.25)):
            t = common.best_time(lambda img=img, sx=sx, sy=sy: shift_bilinear(img, sx, sy), repeat=rep)
            rows.append([f"shift_bilinear {name}, {label}", t * 1e3, t / t_copy, _gbps(2 * img.nbytes, t)])
    table = common.markdown_table(["operation", "ms", "x np.copyto", "GB/s (in+out)"], rows)
    notes = ("geometry.shift_bilinear (the rectified warp of sweep, visibility and refinement) against a "
             "copy of the same float32 RGBA array. 'GB/s' counts one read and one write of the image.")
    return table + "\n\n" + notes


# --------------------------------------------------------------------------------------------------------
# Solver stages, per cell


def _stage_setup(cfg):
    from vfxstereo import samples
    from vfxstereo.warp import Warper

    h, w = cfg["shape"]
    sample = samples.random_dot_stereogram(shape=(h, w), num_planes=cfg["planes"])
    warper = Warper(sample.camera, sample.disparities, (h, w))
    return sample, warper


def stage_table(cfg) -> str:
    from vfxstereo import aggregate, refine, select, sweep, visibility

    sample, warper = _stage_setup(cfg)
    (h, w), D, K = sample.shape, len(sample.disparities), sample.K
    cells = D * h * w
    rep = max(2, cfg["repeat"] - 2)
    t_pix = _add_time((h, w, 4), cfg["repeat"]) / (h * w)  # one RGBA float32 pixel-add

    stats = sweep.sweep(sample.views, warper)
    t_sweep = common.best_time(lambda: sweep.sweep(sample.views, warper), repeat=rep)
    t_agg = common.best_time(lambda: aggregate.aggregate(stats.var, iterations=1), repeat=rep)
    cost = aggregate.aggregate(stats.var)
    t_sel = common.best_time(lambda: select.select(stats.mean, cost, sample.reference_view), repeat=rep)
    sel = select.select(stats.mean, cost, sample.reference_view)
    t_vis = common.best_time(lambda: visibility.view_visibilities(sel.rgba, warper), repeat=rep)
    vis, _ = visibility.view_visibilities(sel.rgba, warper)
    t_sweep_v = common.best_time(lambda: sweep.sweep(sample.views, warper, visibility=vis), repeat=rep)

    def run_refine(n):
        return refine.refine(sel.rgba, sample.disparities, sample.views, warper, iterations=n)

    t1 = common.best_time(lambda: run_refine(1), repeat=rep)
    t3 = common.best_time(lambda: run_refine(3), repeat=rep)
    t_step = max(t3 - t1, 1e-9) / 2  # one more step = one more evaluation of C and its gradient

    rows = []
    for name, t, per in (
        ("sweep (Eq. 1), no visibility", t_sweep, cells * K),
        ("sweep, visibility-weighted (Section 5)", t_sweep_v, cells * K),
        ("aggregate, one Eq. (2) iteration", t_agg, cells),
        ("select (thresholded WTA)", t_sel, cells),
        ("visibility (Eqs. 5-8), all views", t_vis, cells * K),
        ("refine, one gradient step (Eqs. 9-13, A2)", t_step, cells * K),
    ):
        unit = "cell x view" if per == cells * K else "cell"
        rows.append([name, unit, t * 1e3, t / per * 1e9, t / per / t_pix])
    table = common.markdown_table(["stage", "per", "ms total", "ns per", "pixel-adds per"], rows, digits=2)
    notes = (f"Random-dot stereogram {w}x{h}, D = {D} planes, K = {K} views ({cells / 1e6:.2f} M cells). "
             f"Baseline: one RGBA float32 np.add per pixel = {t_pix * 1e9:.2f} ns. The refinement step is "
             "(time of 3 steps - time of 1 step) / 2, so set-up is excluded.")
    return table + "\n\n" + notes


def solve_table(cfg) -> str:
    from vfxstereo import SolveConfig, solve

    sample, _ = _stage_setup(cfg)
    (h, w), D, K = sample.shape, len(sample.disparities), sample.K
    iters = 10
    config = SolveConfig.preset("paper").replace(refine_iterations=iters)
    with common.Stopwatch() as sw:
        res = solve(sample.views, positions=sample.positions, reference=sample.reference,
                    disparities=sample.disparities, config=config, return_details=True)
    t_pix = _add_time((h, w, 4), cfg["repeat"]) / (h * w)
    cells = D * h * w
    rows = []
    for stage, t in res.timings.items():
        rows.append([stage, t * 1e3, t / cells * 1e9, t / cells / t_pix])
    t = sw.seconds
    rows.append(["total (wall clock)", t * 1e3, t / cells * 1e9, t / cells / t_pix])
    table = common.markdown_table(["solve stage", "ms", "ns per cell", "pixel-adds per cell"], rows)
    return table + (f"\n\n`solve` with the `paper` preset but {iters} refinement iterations, on the same "
                    f"stereogram ({w}x{h}, D = {D}, K = {K}); one run, stage times from "
                    "`SolveResult.timings`.")


def run(*, quick: bool = False) -> str:
    """All throughput tables as Markdown."""
    cfg = QUICK if quick else FULL
    parts = [
        common.section("Throughput: compositing against memory bandwidth", compositing_table(cfg)),
        common.section("Throughput: shift warp against a copy", shift_table(cfg)),
        common.section("Throughput: solver stages per cell", stage_table(cfg)),
        common.section("Throughput: one solve, per stage", solve_table(cfg)),
    ]
    return "".join(parts)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller arrays, fewer repeats")
    args = parser.parse_args(argv)
    print(f"Machine: {common.machine_line()}\n" + run(quick=args.quick))
    return 0


if __name__ == "__main__":
    sys.exit(main())
