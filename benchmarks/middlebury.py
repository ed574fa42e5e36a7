"""Disparity accuracy and held-out views on all 31 Middlebury sets: our default, ``paper`` and OpenCV SGBM.

Sets: every folder of ``../shared/data`` with a ``dataset.json`` and ground truth (tsukuba, venus, teddy,
cones half size, the 27 half-size 2005/2006 scenes). Per set, side by side in one run:

* **ours (K views)** -- ``vfxstereo.solve`` with the default preset on every view of the set, the GT's view as
  the reference; **ours (pair)** -- the same on the classic pair alone (reference and reference +
  ``eval_steps``);
* **paper** -- the ``paper`` preset (Szeliski & Golland as implemented, Sections 4-6) on every view, with the
  plane step and refinement iterations of :data:`PAPER_LIMITS` where the full run does not fit in time;
* **SGBM** -- OpenCV ``StereoSGBM`` on the classic pair (:func:`vfxstereo.baselines.sgbm_disparity`: mode
  HH, block 5, P1 = 8*3*25, P2 = 32*3*25, uniqueness 10, speckle 100/2, disp12MaxDiff 1, invalid pixels
  filled from the farther valid neighbour on the row).

Planes: the GT's range plus 2 published px each side, one published px apart (``1 / eval_steps`` px per view
step). Scores: bad pixels ``|d - gt| * eval_steps > 1`` outside ``border`` where the GT is known (undecided
counts as bad), the same near depth discontinuities (GT jumps of more than 2 published px, dilated 4 px),
split into too near (foreground fattening) and too far, time and the peak resident memory of the process that
solved (each solve runs in a fresh process).

**Held-out view** (the paper's own claim): our default solves without the view just right of the reference,
renders the stack at that view's position (what no layer covers completed from the nearest covered pixel) and
is compared with the real image (PSNR, scene-linear RGB; 8 px at the frame edges and, left and right, the
columns the largest disparity brings in from outside the frame are left out); SGBM's
baseline forward-warps the reference by its disparity (z-buffered, holes filled from the background),
SGBM run on a pair that does not hold the held-out view.

Run ``python benchmarks/middlebury.py [--quick] [--sets tsukuba Art ...] [--no-paper]``; ``--depth-only`` scores
the depth stage alone (the same bad pixels, minutes for the 31 sets), ``--preset`` / ``--config JSON`` set ours.
Figures (error maps of ours and SGBM) go to ``benchmarks/out/middlebury/``.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import multiprocessing as mp
import resource
import sys
import time
from pathlib import Path

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np

SETS = None  # filled by all_sets()
MARGIN_EVAL_PX = 2.0
"""Margin added on both sides of the GT's range, in published (two-frame) pixels."""
DISC_JUMP = 2.0
"""A GT jump of more than this many published px between neighbours is a depth discontinuity."""
DISC_DILATE = 4
EDGE = 8
"""Columns and rows at the frame edge left out of the held-out view PSNR."""
PAPER_LIMITS = {"max_cells": 8e6, "refine_iterations": 10}
"""The ``paper`` preset runs on planes coarse enough that H x W x D stays under ``max_cells`` (its volumes
take ~270 bytes per cell with 7 views) and with this many refinement iterations (its own is 100)."""
FIGURE_SETS = ("tsukuba", "teddy", "Art", "Midd1", "Plastic", "Wood2")
QUICK_SETS = ("tsukuba", "venus", "Wood2")
QUICK_CROP = (192, 256)


def all_sets() -> dict[str, Path]:
    """Set name -> folder of every dataset with ground truth under the data folder."""
    root = common.DATA
    out = {}
    for ds in sorted(root.glob("*/dataset.json")) + sorted(root.glob("*/*/dataset.json")):
        name = ds.parent.name
        name = {"middlebury2001_tsukuba": "tsukuba", "middlebury2001_venus": "venus",
                "middlebury2003_teddy": "teddy", "middlebury2003_cones_halfsize": "cones"}.get(name, name)
        out[name] = ds.parent
    return out


def disparity_range(gt: np.ndarray, eval_steps: int, *, margin: float = MARGIN_EVAL_PX) -> np.ndarray:
    """Planes over the GT's range plus ``margin`` published px each side, step ``1 / eval_steps`` per step."""
    step = 1.0 / eval_steps
    m = margin / eval_steps
    lo = np.floor((np.nanmin(gt) - m) / step) * step
    hi = np.ceil((np.nanmax(gt) + m) / step) * step
    return np.arange(max(lo, 0.0), hi + step / 2, step)


def discontinuities(gt: np.ndarray, eval_steps: int) -> np.ndarray:
    """Pixels near a depth discontinuity of the GT."""
    from scipy import ndimage

    g = np.nan_to_num(gt, nan=np.nanmin(gt)) * eval_steps
    jump = np.zeros(gt.shape, bool)
    jump[:, 1:] |= np.abs(np.diff(g, axis=1)) > DISC_JUMP
    jump[:, :-1] |= np.abs(np.diff(g, axis=1)) > DISC_JUMP
    jump[1:] |= np.abs(np.diff(g, axis=0)) > DISC_JUMP
    jump[:-1] |= np.abs(np.diff(g, axis=0)) > DISC_JUMP
    return ndimage.binary_dilation(jump, iterations=DISC_DILATE)


def score(d: np.ndarray, gt: np.ndarray, eval_steps: int, border: int) -> dict:
    """Bad-pixel rates (%) of ``d`` against ``gt`` (both px per step); undecided (NaN) counts as bad."""
    h, w = gt.shape
    inside = np.zeros((h, w), bool)
    inside[border:h - border, border:w - border] = True
    scored = inside & np.isfinite(gt)
    with np.errstate(invalid="ignore"):
        bad = scored & ~(np.abs(d - gt) * eval_steps <= 1.0)
    disc = scored & discontinuities(gt, eval_steps)
    n = max(disc.sum(), 1)
    with np.errstate(invalid="ignore"):
        near = bad & disc & (d > gt)  # the nearer surface spread over the farther one: foreground fattening
        far = bad & disc & (d < gt)
    return {"bad": 100.0 * bad.sum() / scored.sum(), "disc": 100.0 * (bad & disc).sum() / n,
            "disc_near": 100.0 * near.sum() / n, "disc_far": 100.0 * far.sum() / n,
            "bad_mask": bad, "scored": scored}


# --------------------------------------------------------------------------------------------------------
# One job per fresh process (peak memory is the child's own)


def _job(kind: str, name: str, quick: bool, preset: str | None = None, overrides: dict | None = None,
         depth_only: bool = False) -> dict:
    """Run one method on one set in this (fresh) process; returns scores, time and peak RSS.

    ``preset`` and ``overrides`` (:func:`common.configured`) are ours (default: the default preset);
    ``depth_only``: ours and the pair run the depth stage alone (``vfxstereo.depth.robust_depth``), whose map is
    what the bad pixels score, without the layers and soft edges the full solve builds after it.
    """
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from vfxstereo import SolveConfig, baselines, solve
    from vfxstereo.config import DEFAULT_PRESET
    from vfxstereo.io.plates import load_dataset

    ds = load_dataset(all_sets()[name])
    views = ds.read_views()
    gt = ds.gt
    border = ds.border
    if quick:
        h, w = gt.shape
        ch, cw = min(QUICK_CROP[0], h), min(QUICK_CROP[1], w)
        y0, x0 = (h - ch) // 2, (w - cw) // 2
        views, gt = views[:, y0:y0 + ch, x0:x0 + cw], gt[y0:y0 + ch, x0:x0 + cw]
        border = min(border, 4)
    ref, es = ds.reference, ds.eval_steps
    pos = np.asarray(ds.positions, np.float64)
    planes = disparity_range(gt, es)
    note = ""
    out = {"kind": kind, "name": name}
    ours = common.configured(preset or DEFAULT_PRESET, overrides)  # ours, the pair and the held-out view
    t0 = time.perf_counter()
    if kind in ("ours", "pair", "paper"):
        keep = list(range(len(views))) if kind != "pair" else [ref, ref + es]
        config = ours if kind != "paper" else SolveConfig.preset("paper")
        if kind == "paper":
            cells = gt.size * len(planes)
            if cells > PAPER_LIMITS["max_cells"]:
                step = (planes[1] - planes[0]) * int(np.ceil(cells / PAPER_LIMITS["max_cells"]))
                planes = np.arange(planes[0], planes[-1] + step / 2, step)
                note = f"step {step:g}"
            config = config.replace(refine_iterations=PAPER_LIMITS["refine_iterations"])
        if depth_only and kind != "paper" and config.depth == "robust":
            from vfxstereo.depth import robust_depth
            from vfxstereo.geometry import Camera
            from vfxstereo.warp import Warper

            warper = Warper(Camera.from_positions(pos[keep], keep.index(ref)), planes, gt.shape)
            d = np.asarray(robust_depth(views[keep], warper, keep.index(ref), config=config.depth_config).disparity,
                           np.float64)
        else:
            res = solve(views[keep], positions=pos[keep], reference=keep.index(ref), disparities=planes,
                        config=config, return_details=True)
            d = np.asarray(res.disparity, np.float64)
    elif kind == "sgbm":
        d = baselines.sgbm_disparity(views[ref], views[ref + es], float(pos[ref + es] - pos[ref]), planes)
    elif kind in ("heldout_ours", "heldout_sgbm"):
        held = ref + 1
        target = views[held]
        offset = float(pos[held] - pos[ref])
        if kind == "heldout_ours":
            keep = [k for k in range(len(views)) if k != held]
            res = solve(views[keep], positions=pos[keep], reference=keep.index(ref), disparities=planes,
                        config=ours, return_details=True)
            rendered = res.stack.render(pos[held])
            image = fill_holes(rendered)
        else:
            other = ref + es if ref + es != held else ref + 2 * es
            if other >= len(views):
                other = ref + 2
            d_s = baselines.sgbm_disparity(views[ref], views[other], float(pos[other] - pos[ref]), planes)
            image = baselines.forward_warp(views[ref], d_s, offset)
        e = EDGE + int(np.ceil(planes[-1] * abs(offset)))  # content entering the frame is nobody's
        out["psnr"] = common.psnr(image[EDGE:-EDGE, e:-e], target[EDGE:-EDGE, e:-e])
        out["seconds"] = time.perf_counter() - t0
        out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        return out
    else:  # pragma: no cover
        raise ValueError(kind)
    out["seconds"] = time.perf_counter() - t0
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    s = score(d, gt, es, border)
    out.update(bad=s["bad"], disc=s["disc"], disc_near=s["disc_near"], disc_far=s["disc_far"], note=note,
               planes=len(planes), views=len(views), shape=gt.shape)
    if name in FIGURE_SETS and kind in ("ours", "sgbm"):
        out["figure"] = str(error_map(name, kind, views[ref], gt, d, s, quick))
    return out


def fill_holes(rgba: np.ndarray) -> np.ndarray:
    """RGB of a rendered premultiplied view, what no layer covers (alpha < 1) completed with the straight colour
    of the nearest fully covered pixel."""
    from scipy import ndimage

    rgb = rgba[..., :3].astype(np.float32)
    a = rgba[..., 3:4]
    solid = rgba[..., 3] > 0.98
    if solid.all() or not solid.any():
        return rgb
    iy, ix = ndimage.distance_transform_edt(~solid, return_distances=False, return_indices=True)
    near = rgb[iy, ix] / np.maximum(a[iy, ix], 1e-6)
    return rgb + (1.0 - a) * near


def error_map(name, kind, reference, gt, d, s, quick) -> Path:
    """Reference, GT, estimate and error map side by side (PNG)."""
    from vfxstereo.io import preview

    lo, hi = np.nanmin(gt), np.nanmax(gt)
    err = np.zeros(gt.shape + (3,), np.float32)
    err[s["scored"]] = 0.85
    err[s["bad_mask"]] = (0.85, 0.1, 0.1)
    tiles = [preview.to_display(np.concatenate([reference, np.ones(gt.shape + (1,), np.float32)], -1)),
             preview.disparity_preview(gt, lo, hi), preview.disparity_preview(d, lo, hi),
             (err * 255).astype(np.uint8)]
    path = common.out_dir("middlebury") / f"{name}_{kind}{'_quick' if quick else ''}.png"
    preview.write_display(path, np.concatenate([t[..., :3] for t in tiles], axis=1))
    return path.relative_to(common.HERE.parent)


def _run_all(jobs, quick, **options):
    ctx = mp.get_context("spawn")
    results = []
    with cf.ProcessPoolExecutor(max_workers=1, mp_context=ctx, max_tasks_per_child=1) as pool:
        futures = [pool.submit(_job, kind, name, quick, **options) for kind, name in jobs]
        for fut, (kind, name) in zip(futures, jobs, strict=True):
            try:
                r = fut.result()
            except Exception as exc:  # a failed job is a row that says so
                r = {"kind": kind, "name": name, "error": f"{type(exc).__name__}: {exc}"}
            results.append(r)
            extra = (f"bad {r['bad']:.2f} %" if "bad" in r else f"psnr {r.get('psnr', float('nan')):.2f}"
                     if "error" not in r else r["error"])
            print(f"  middlebury {name}/{kind}: {extra} ({r.get('seconds', 0):.1f} s)", file=sys.stderr,
                  flush=True)
    return results


def run(*, quick: bool = False, sets=None, paper: bool = True, heldout: bool = True, preset: str | None = None,
        overrides: dict | None = None, depth_only: bool = False) -> str:
    """Every method on every set (see the module docstring); ``depth_only``: no paper and no held-out views."""
    names = list(sets) if sets else (list(QUICK_SETS) if quick else list(all_sets()))
    if depth_only:
        paper = heldout = False
    kinds = ["ours", "pair", "sgbm"] + (["paper"] if paper else []) + (["heldout_ours", "heldout_sgbm"]
                                                                       if heldout else [])
    results = _run_all([(k, n) for n in names for k in kinds], quick, preset=preset, overrides=overrides,
                       depth_only=depth_only)
    by = {(r["kind"], r["name"]): r for r in results}
    return tables(names, kinds, by, quick)


def tables(names, kinds, by, quick) -> str:
    def cell(kind, name, key, fmt="{:.2f}"):
        r = by.get((kind, name), {})
        if "error" in r:
            return "failed"
        v = r.get(key)
        return "" if v is None else fmt.format(v)

    def side(kind, name):  # the disc column's bad pixels split: too near / too far
        near, far = cell(kind, name, "disc_near", "{:.1f}"), cell(kind, name, "disc_far", "{:.1f}")
        return f"{near} / {far}" if near and far and near != "failed" else ""

    rows = []
    for n in names:
        o, s = by.get(("ours", n), {}), by.get(("sgbm", n), {})
        ratio = o.get("bad", np.nan) / s.get("bad", np.nan) if s.get("bad") else np.nan
        rows.append([n, o.get("views", ""), f"{o.get('shape', ('', ''))[1]}x{o.get('shape', ('', ''))[0]}",
                     o.get("planes", ""), cell("ours", n, "bad"), cell("pair", n, "bad"),
                     cell("paper", n, "bad") + (f" ({by[('paper', n)]['note']})"
                                                if by.get(("paper", n), {}).get("note") else ""),
                     cell("sgbm", n, "bad"), f"{ratio:.2f}", cell("ours", n, "disc"), cell("sgbm", n, "disc"),
                     side("ours", n), side("sgbm", n),
                     cell("heldout_ours", n, "psnr"), cell("heldout_sgbm", n, "psnr"),
                     cell("ours", n, "seconds", "{:.1f}"), cell("sgbm", n, "seconds", "{:.2f}"),
                     cell("ours", n, "peak_mb", "{:.0f}")])
    table = common.markdown_table(
        ["set", "K", "size", "D", "ours bad %", "ours pair bad %", "paper bad %", "SGBM bad %", "ours / SGBM",
         "ours disc %", "SGBM disc %", "ours disc near / far %", "SGBM disc near / far %", "held-out PSNR ours",
         "held-out PSNR SGBM warp", "ours s", "SGBM s", "ours peak MB"], rows)

    def mean(kind, key):
        v = [by[(kind, n)][key] for n in names if key in by.get((kind, n), {})]
        return float(np.mean(v)) if v else float("nan")

    ratios = [by[("ours", n)]["bad"] / by[("sgbm", n)]["bad"] for n in names
              if "bad" in by.get(("ours", n), {}) and by.get(("sgbm", n), {}).get("bad")]
    worse = [n for n in names if "bad" in by.get(("ours", n), {}) and "bad" in by.get(("sgbm", n), {})
             and by[("ours", n)]["bad"] > by[("sgbm", n)]["bad"]]
    summary = (
        f"Mean bad %: ours {mean('ours', 'bad'):.2f} (K views), {mean('pair', 'bad'):.2f} (pair), paper "
        f"{mean('paper', 'bad'):.2f}, SGBM {mean('sgbm', 'bad'):.2f}. Ours / SGBM: mean "
        f"{np.mean(ratios):.3f}, worst {np.max(ratios):.2f} (target: <= 1 on every set, <= 0.7 on average); "
        f"near depth jumps, too near / too far: ours {mean('ours', 'disc_near'):.2f} / "
        f"{mean('ours', 'disc_far'):.2f}, "
        f"SGBM {mean('sgbm', 'disc_near'):.2f} / {mean('sgbm', 'disc_far'):.2f} %; "
        f"sets where ours loses to SGBM: {', '.join(worse) or 'none'}. All views vs the pair: "
        f"{mean('ours', 'bad'):.2f} vs {mean('pair', 'bad'):.2f} % bad. Held-out view PSNR: ours "
        f"{mean('heldout_ours', 'psnr'):.2f} dB, SGBM warp {mean('heldout_sgbm', 'psnr'):.2f} dB.")
    notes = [
        "Bad pixel: |d - gt| * eval_steps > 1 (1 px of the published two-frame pair), outside the set's border, "
        "where the GT is known; ours and SGBM decide every pixel. disc: the same near GT depth jumps of more than "
        f"{DISC_JUMP:g} published px (dilated {DISC_DILATE} px); near / far: of those pixels, the bad ones whose "
        "disparity is above the GT's (a nearer surface spread over a farther one: foreground fattening) and below "
        "it (a farther surface eating into a nearer one).",
        "paper: " + (f"planes coarsened where H x W x D > {PAPER_LIMITS['max_cells']:.0e} (step shown), "
                     f"{PAPER_LIMITS['refine_iterations']} refinement iterations (the preset's own: 100)."),
        "Peak MB: the resident peak of the fresh process that solved (Python, numpy and numba included).",
    ]
    if quick:
        notes.append(f"--quick: centre crops {QUICK_CROP[1]}x{QUICK_CROP[0]}, not comparable to full sets.")
    figs = sorted({by[k]["figure"] for k in by if "figure" in by[k]})
    return (common.section(f"Middlebury, {len(names)} sets ({common.machine_line()})", table)
            + "\n" + summary + "\n\n" + "\n".join(f"- {n}" for n in notes) + "\n\nError maps: "
            + ", ".join(f"`{f}`" for f in figs) + "\n")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help=f"{', '.join(QUICK_SETS)}, centre crops")
    p.add_argument("--sets", nargs="+", help="set names (default: all 31)")
    p.add_argument("--no-paper", action="store_true", help="skip the paper preset (the slow one)")
    p.add_argument("--no-heldout", action="store_true", help="skip the held-out view comparison")
    p.add_argument("--preset", help="our preset (default: the default one)")
    p.add_argument("--config", type=json.loads, metavar="JSON",
                   help='settings on top of the preset, e.g. \'{"depth_config": {"far_bias": 0.5}}\'')
    p.add_argument("--depth-only", action="store_true",
                   help="ours and the pair: the depth stage alone (the map the bad pixels score; minutes instead "
                        "of an hour for the 31 sets); no paper, no held-out views")
    a = p.parse_args(argv)
    text = run(quick=a.quick, sets=a.sets, paper=not a.no_paper, heldout=not a.no_heldout, preset=a.preset,
               overrides=a.config, depth_only=a.depth_only)
    print(text)
    (common.out_dir() / ("middlebury_quick.md" if a.quick else "middlebury.md")).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
