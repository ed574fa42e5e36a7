"""What the soft-edge passes move, pass by pass, against the z-key scenes' ground truth (issue 7, section 3).

The passes (:func:`vfxstereo.softedge.soften_edges_passes`) send near-side edge pixels whose matte came out
below 0.5 back to the surface behind them. Most of those moves undo the depth map's fattening; some eat into
a surface that is truly solid there. For every moved pixel this counts:

* **off solid**: the pixel was on a surface that is solid there in the truth (its disparity within 1 px of
  the true front-most disparity at alpha > 0.95) and moved more than 1 px behind it -- a move that is wrong
  whatever the alpha;
* whether the background the views see around it is **plain** (``SoftEdges.plain_back``) or textured;
* its distance from the depth map's original edges.

Rows per (scene, K) and per pass, and a summary by K x plain/textured x pass. Only the default
configuration's depth and passes are run (``--preset``). It reads no held-out scene unless asked
(``--scenes`` or ``--all``): a held-out scene looked at here no longer counts as untouched.

Run ``python benchmarks/softedge_passes.py [--scenes a b] [--all] [--K 5 2] [--preset robust]
[--depth-cache DIR]``.
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np
import zkey_scenes as bench
from scipy import ndimage

from vfxstereo import SolveConfig, layers, softedge, solve
from vfxstereo import zkey_scenes as scenes


def trace(name: str, K: int, preset: str, depth_cache=None) -> list[dict]:
    """One record per pass: pixels moved, of them off a solid surface, by plain / textured background.

    ``depth_cache``: the folder of stored depth maps ``zkey_scenes.py --depth-cache`` uses (read, and filled
    where a map is missing), so that tracing the passes does not solve the depth again."""
    scene = bench.build_scene(name, K)
    config = SolveConfig.preset(preset)
    solid = scene.gt_disparity(0.95)
    jump = softedge._jump_planes(config.soft_edge, bench.PLANES)
    far = None  # distance from the depth map's original edges, from the first pass's input
    records = []

    def on_pass(n, before, after, info):
        nonlocal far
        if far is None:
            far = ndimage.distance_transform_edt(~softedge._edges(layers.plane_index(before, bench.PLANES), jump))
        moved = after != before
        off_solid = moved & (np.abs(before - solid) < 1.0) & (solid > after + 1.0)
        plain = info.plain_back
        for kind, where in (("plain", plain), ("textured", ~plain)):
            m = moved & where
            wrong = off_solid & where
            records.append({"scene": name, "K": K, "pass": n + 1, "background": kind, "moved": int(m.sum()),
                            "off_solid": int(wrong.sum()), "far": int((m & (far > 8)).sum()),
                            "far_off_solid": int((wrong & (far > 8)).sum())})

    def solve_it(disparity):
        return solve(scene.views(), positions=scene.positions, reference=scene.reference, disparities=bench.PLANES,
                     config=config, on_soft_pass=on_pass, return_details=True, disparity=disparity)

    bench.solve_cached(solve_it, depth_cache, name, K, config)
    return records


def tables(records: list[dict], title: str) -> str:
    def share(a, b):
        return f"{100.0 * a / b:.0f} %" if b else "-"

    per_scene = defaultdict(lambda: [0, 0, 0])
    for r in records:
        s = per_scene[(r["scene"], r["K"])]
        s[0] += r["moved"]
        s[1] += r["off_solid"]
        s[2] = max(s[2], r["pass"])
    body = [[n, K, m, share(o, m), p] for (n, K), (m, o, p) in per_scene.items()]
    out = common.section(title, common.markdown_table(["scene", "K", "moved", "off solid", "passes"], body))
    by = defaultdict(lambda: [0, 0, 0, 0])
    for r in records:
        s = by[(r["K"], r["background"], r["pass"])]
        s[0] += r["moved"]
        s[1] += r["off_solid"]
        s[2] += r["far"]
        s[3] += r["far_off_solid"]
    body = [[K, bg, p, m, share(o, m), f, share(fo, f)] for (K, bg, p), (m, o, f, fo) in sorted(by.items())]
    out += "\n" + common.markdown_table(["K", "background", "pass", "moved", "off solid", "moved > 8 px from the "
                                         "original edges", "of those off solid"], body)
    return out


def run(*, names=None, Ks=(5, 2), preset: str = "robust", every: bool = False, quick: bool = False,
        depth_cache=None) -> str:
    """The tables (``make bench``: the tuning scenes; ``quick``: two of them at K = 5)."""
    if quick:
        names, Ks = names or ["fur_grey_wall", "trolls_art"], (5,)
    names = names or [n for n in list(scenes.SCENES) + list(bench.CYCLES)
                      if every or n not in set(scenes.HELD_OUT) | set(bench.CYCLES_HELD_OUT)]
    if any(n in bench.CYCLES for n in names) and not bench.ensure_cycles_scenes():
        names = [n for n in names if n not in bench.CYCLES]
    records = []
    for name in names:
        for K in Ks:
            records += trace(name, K, preset, depth_cache)
            print(f"  {name} K={K}", file=sys.stderr, flush=True)
    return tables(records, f"Soft-edge passes: what they move ({preset}, {common.machine_line()})")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="*")
    p.add_argument("--all", action="store_true", help="every scene, the held-out ones too")
    p.add_argument("--K", nargs="*", type=int, default=[5, 2])
    p.add_argument("--preset", default="robust")
    p.add_argument("--depth-cache", type=Path, default=None, metavar="DIR",
                   help="stored depth maps, shared with zkey_scenes.py --depth-cache (filled where missing)")
    a = p.parse_args(argv)
    text = run(names=a.scenes, Ks=tuple(a.K), preset=a.preset, every=a.all, depth_cache=a.depth_cache)
    print(text)
    (common.out_dir() / "softedge_passes.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
