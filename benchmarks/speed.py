"""Speed and memory of ``vfxstereo.solve`` on HD and 4K plates, each stage against its streaming lower bound.

Plates: :func:`vfxstereo.samples.layered_scene` (a random-dot backdrop and three soft-edged random-dot layers,
K = 5 views half a step apart, so odd disparities shift by half pixels), solved on the planes
``d = 0 .. D-1`` with the configuration ``vfxstereo.solve`` uses when given none (the default preset; or
``--preset``). Cases: 960x540, 1920x1080 and 4096x2160 with 32, 64 and 128 planes (``--quick``: 240x136
and 480x270 with 8 and 16 planes).

Each case runs in a fresh process, so its peak resident memory is its own: ``VmHWM`` of the solve (the peak
is reset after the plates are made; the plates stay resident, as they do in the command), and the solve's
own estimate (``solver.memory_needed``) beside it. A warm-up solve of a 48x32 plate comes first, so numba's
compilation (paid once per process, not per frame) is not in the times. A case the solver refuses for memory
(``solver.check_memory``) is a row "refused: <message>"; a process that dies (killed for memory, a crash, a
``--timeout``) is a row "failed: ...". Neither stops the others.

Lower bounds. The machine's memory bandwidth ``B`` is measured in the same run, as ``np.copyto`` of a large
float32 array (2 bytes moved per byte copied). Each stage's lower bound is the time to stream the bytes it
must touch, ``bytes / B``; the table states each stage's time as a multiple of it (1x: as fast as memory
allows). The byte model, with N = H x W pixels, D planes, K views, 4-byte floats, and the numbers of passes
and iterations taken from the configuration (P = ``visibility_iterations + 1`` passes; S = the statistics
sweeps, P plus one per later pass for the hidden layers when ``hidden_layers`` and ``reference_votes``):

==========  ===============================================================================================
stage       bytes it must touch
==========  ===============================================================================================
sweep       per sweep: the views once (12 K N) and mean, variance and vote weight written (20 D N); every
            sweep after the first also reads the visibilities (4 D K N)
aggregate   per sweep and per diffusion iteration (``aggregation_iterations``): the cost volume read and
            written (8 D N)
select      per sweep: mean and cost read (16 D N), the RGBA volume written (16 D N)
visibility  per pass but the last: the RGBA volume read (16 D N), a visibility per view written (4 D K N)
complete    the RGBA volume read and written and the mean read (44 D N)
refine      per iteration (``refine_iterations``): the RGBA volume read and written (32 D N) and the views
            read (12 K N). The energy re-projects the volume into every view, so an unfused refinement
            streams the volume about K times per iteration: expect a ratio of K or more until it is fused
matting     the RGBA volume read and written once (32 D N); the band it changes is much smaller
subpixel    three cost samples read and the disparity written per pixel (16 N)
==========  ===============================================================================================

The robust path (the default), with P = ``DepthConfig.passes(K)`` matching passes (``visibility_passes_views + 1``
from three views, ``visibility_passes + 1`` for a pair) and L the
planes the stack holds (D, or fewer with ``keep_empty_planes=False``):

============  =============================================================================================
stage         bytes it must touch
============  =============================================================================================
depth.match   per pass: each of the K - 1 other views adds its cost into the cost sum and count (read and
              written, 10 D N); then the mean, the 5x5 window and the flat bias read and write the volume
              (28 D N). The AD-census cost of a cell-view is arithmetic (a 63-bit Hamming distance, two
              bilinear taps, two exponentials from tables): this stage is bound by compute, not memory,
              and its ratio says how far (its ns per cell-view is in the first table)
depth.sgm     per pass: the cost read and the aggregated cost written, by two sweeps of four paths each
              (the fewest that give 8 paths: 2 x (4 + 8) D N), and the winner's search (4 D N)
depth.finish  the disparity maps (16 N)
layers        the stack written once (16 L N) and the views read once (12 K N)
soft-edges    the stack's alpha read (4 L N) and the views read (12 K N); the band it writes is small
============  =============================================================================================

A stage the model does not know (a new stage of the solver) shows its time and ``--`` for the ratio.
Also reported: nanoseconds per cell-view (pixels x planes x views; constant if the cost is linear) and
the share of reference pixels whose disparity is within 1 of the truth (a fast solve must still solve).
The table is printed, saved as ``benchmarks/out/speed.md`` (``speed_quick.md``), and
``benchmarks/out/speed.png`` plots time against pixels x planes x views.

    python benchmarks/speed.py                                  # the 9 cases (tens of minutes to hours)
    python benchmarks/speed.py --quick                          # small plates, about two minutes
    python benchmarks/speed.py --sizes 1920x1080 --planes 64    # one case
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np

from vfxstereo.config import DEFAULT_PRESET

SIZES = ((960, 540), (1920, 1080), (4096, 2160))
PLANES = (32, 64, 128)
QUICK_SIZES = ((240, 136), (480, 270))
QUICK_PLANES = (8, 16)
VIEWS = 5
VIEW_CASES = ((960, 540, 64, 3), (960, 540, 64, 2))
"""Extra cases with fewer views (the central ones of the five), so the plot spans views too."""
QUICK_VIEW_CASES = ((480, 270, 16, 3),)

TARGETS = [
    ((1920, 1080, 64), 120.0, 8.0, "1920x1080, K = 5, 64 planes: solve <= 120 s (goal 20 s), peak <= 8 GiB"),
    ((4096, 2160, 128), None, 16.0, "4096x2160, K = 5, 128 planes: completes, peak <= 16 GiB"),
]
"""The issue's targets: (case, seconds or None, GiB, what)."""
WHY = ("Why stages are above it: *depth.match* is bound by arithmetic, not memory: each cell-view costs a "
       "63-bit Hamming distance, up to four bilinear taps and two table lookups (its ns per cell-view is in the "
       "first table; on two cores it runs at a few ns per cell-view, while streaming its 10 bytes takes about "
       "0.4 ns). *depth.sgm*: 8 paths, each a dependent chain over the planes of every pixel (a min over "
       "D + 2 candidates per cell and path): also arithmetic. *depth.finish*, *layers* and *soft-edges* touch "
       "images, not the volume: per view, the depth map's z-buffer, and per plane that holds hidden cells or a "
       "soft edge's background, each view warped onto it (K x planes x 12 bytes per pixel), so their bound "
       "in volume bytes is far below what they must do; they are small beside depth (see the first table). "
       "*refine* (paper presets): the energy re-projects the volume into every view.")
"""Footnote of the ratio table: why a stage is above its streaming bound."""
STAGE_FACTOR = 4.0
"""The issue's target for each stage: within this multiple of its streaming lower bound."""


# --------------------------------------------------------------------------------------------------------
# The byte model (see the module docstring)


def _counts(settings: dict) -> dict:
    """Passes, sweeps and iterations of a configuration (``SolveConfig.to_dict()``), with the paper's defaults."""
    passes = int(settings.get("visibility_iterations", 1)) + 1
    hidden = passes - 1 if settings.get("hidden_layers", True) and settings.get("reference_votes", True) else 0
    aggregation = settings.get("aggregation", "szeliski1999")
    return {
        "passes": passes,
        "sweeps": passes + hidden,
        "weighted_sweeps": passes - 1 + hidden,
        "aggregation_iterations": int(settings.get("aggregation_iterations", 1)) if aggregation == "szeliski1999"
        else 1,
        "refine_iterations": int(settings.get("refine_iterations", 0)),
    }


def stage_bytes(stage: str, *, n: int, d: int, k: int, settings: dict, layers: int | None = None) -> float | None:
    """Bytes ``stage`` must touch in one solve of ``n`` pixels, ``d`` planes, ``k`` views (None: no model);
    ``layers``: the planes the stack holds (robust depth; default ``d``)."""
    c = _counts(settings)
    if settings.get("depth") == "robust":
        from vfxstereo.depth import DepthConfig

        dc = settings.get("depth_config", {})
        passes = DepthConfig(**{f: dc[f] for f in ("visibility_passes", "visibility_passes_views")
                                if f in dc}).passes(k)
        lay = d if layers is None else layers
        robust = {
            "depth.match": passes * ((k - 1) * 10 * d * n + 28 * d * n),
            "depth.sgm": passes * 28 * d * n,
            "depth.finish": 16 * n,
            "layers": 16 * lay * n + 12 * k * n,
            "soft-edges": 4 * lay * n + 12 * k * n,
        }
        robust["depth"] = robust["depth.match"] + robust["depth.sgm"] + robust["depth.finish"]
        return float(robust[stage]) if stage in robust else None
    model = {
        "sweep": c["sweeps"] * (12 * k * n + 20 * d * n) + c["weighted_sweeps"] * 4 * d * k * n,
        "aggregate": c["sweeps"] * c["aggregation_iterations"] * 8 * d * n,
        "select": c["sweeps"] * 32 * d * n,
        "visibility": (c["passes"] - 1) * (16 * d * n + 4 * d * k * n),
        "complete": 44 * d * n,
        "refine": c["refine_iterations"] * (32 * d * n + 12 * k * n),
        "matting": 32 * d * n,
        "subpixel": 16 * n,
    }
    return float(model[stage]) if stage in model else None


def bandwidth(megabytes: int = 512, repeat: int = 5) -> float:
    """Memory bandwidth in bytes per second: ``np.copyto`` of a ``megabytes`` float32 array, 2 bytes per byte."""
    src = np.random.default_rng(0).random(megabytes * 2**20 // 4, dtype=np.float32)
    dst = np.empty_like(src)
    seconds = common.best_time(lambda: np.copyto(dst, src), repeat=repeat)
    return 2.0 * src.nbytes / seconds


# --------------------------------------------------------------------------------------------------------
# One case, in a process of its own


def _status_bytes(key: str) -> int | None:
    """A memory figure of this process from /proc/self/status (``VmHWM``: peak since the last reset,
    ``VmRSS``: resident now), or None without /proc."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _reset_peak() -> bool:
    """Start ``VmHWM`` again from the current resident size (Linux: write 5 to /proc/self/clear_refs)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def run_case(width: int, height: int, planes: int, *, preset: str | None = None, drop: bool = False,
             views: int = VIEWS) -> dict:
    """Make the plates and solve them here; what :func:`main` prints as JSON with ``--case``.

    ``drop``: solve with ``keep_empty_planes=False`` (robust depth). ``views``: how many of the five views,
    the central ones (the reference stays the middle view).
    """
    import resource

    from vfxstereo import samples, solver
    from vfxstereo.config import SolveConfig
    from vfxstereo.errors import VfxStereoError

    config = solver.fit_to_memory(SolveConfig.preset(preset or DEFAULT_PRESET))
    if drop:
        config = config.replace(keep_empty_planes=False)
    memory = solver.memory_settings(config)
    estimate = solver.memory_needed((height, width), planes, views, **memory)
    result = {"width": width, "height": height, "planes": planes, "views": views,
              "settings": config.to_dict(), "estimate": estimate, "drop": drop}
    try:
        solver.check_memory((height, width), planes, views, **memory)
    except VfxStereoError as exc:
        return {**result, "refused": str(exc)}
    t0 = time.perf_counter()
    scene = samples.layered_scene(shape=(height, width), num_planes=planes)
    plates, positions, reference, truth = scene.views, scene.positions, scene.reference, scene.gt_disparity()
    if views < len(plates):  # the central views, the reference among them
        first = min(max(0, reference - views // 2), len(plates) - views)
        plates, positions = plates[first:first + views], positions[first:first + views]
        reference -= first
    del scene
    result["plates_seconds"] = time.perf_counter() - t0
    warm = samples.layered_scene(shape=(32, 48), num_planes=8)  # JIT compilation and caches: not timed
    solver.solve(warm.views, positions=warm.positions, reference=warm.reference, disparities=np.arange(8.0),
                 config=config)
    del warm
    result["peak_reset"] = _reset_peak()
    result["start"] = _status_bytes("VmRSS")  # libraries and plates, resident before the solve
    progress = None
    if sys.stderr.isatty():
        from vfxstereo.shot import ProgressBars

        progress = ProgressBars(prefix=f"{width}x{height} D={planes} ")
    t0 = time.perf_counter()
    try:
        solved = solver.solve(plates, positions=positions, reference=reference,
                              disparities=np.arange(planes, dtype=np.float64), config=config, progress=progress,
                              return_details=True)
    except VfxStereoError as exc:  # the solver's own check, at the moment it ran
        return {**result, "refused": str(exc)}
    finally:
        if progress is not None:
            progress.close()
    result["seconds"] = time.perf_counter() - t0
    result["timings"] = dict(solved.timings)
    result["layers"] = solved.stack.depth
    memory["layers"] = solved.stack.depth
    result["estimate"] = solver.memory_needed((height, width), planes, views, **memory)
    result["peak"] = _status_bytes("VmHWM")
    result["maxrss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux
    result["good"] = float(np.mean(np.abs(solved.disparity - truth) <= 1.0))
    return result


def _spawn(width: int, height: int, planes: int, *, preset: str | None, timeout: float | None,
           drop: bool = False, views: int = VIEWS) -> dict:
    """:func:`run_case` in a fresh interpreter; a death or a timeout becomes ``{"failed": why}``."""
    argv = [sys.executable, os.path.abspath(__file__), "--case", f"{width}x{height}", str(planes),
            "--views", str(views)]
    argv += ["--preset", preset] if preset else []
    argv += ["--drop-empty-planes"] if drop else []
    case = {"width": width, "height": height, "planes": planes, "views": views, "drop": drop}
    try:
        proc = subprocess.run(argv, stdout=subprocess.PIPE, stderr=None, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {**case, "failed": f"no result within --timeout {timeout:g} s"}
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        why = (f"killed by signal {-proc.returncode}" + (" (out of memory?)" if proc.returncode == -9 else "")
               if proc.returncode < 0 else f"exit status {proc.returncode}")
        return {**case, "failed": why}
    return json.loads(lines[-1])


# --------------------------------------------------------------------------------------------------------
# Tables and the plot


def _gib(value) -> float | None:
    return None if value is None else value / 2**30


def _stages(results: list[dict]) -> list[str]:
    order = ["sweep", "aggregate", "select", "visibility", "complete", "refine", "matting", "subpixel"]
    seen = {s for r in results for s in r.get("timings", {})}
    return [s for s in order if s in seen] + sorted(seen - set(order))


def _label(r: dict) -> str:
    return (f"{r['width']}x{r['height']}" + (f", K = {r['views']}" if r.get("views", VIEWS) != VIEWS else "")
            + (" (empty planes dropped)" if r.get("drop") else ""))


def _status(r: dict) -> str | None:
    if "refused" in r:
        return f"refused: {r['refused']}"
    if "failed" in r:
        return f"failed: {r['failed']}"
    return None


def tables(results: list[dict], bytes_per_second: float) -> str:
    """The Markdown report: times and memory, ratios to the lower bounds, targets."""
    stages = _stages(results)
    rows, ratio_rows = [], []
    for r in results:
        head = [_label(r), r["planes"]]
        status = _status(r)
        if status is not None:
            rows.append(head + [status] + [None] * (len(stages) + 5))
            ratio_rows.append(head + [status] + [None] * (len(stages) + 1))
            continue
        n, d, k = r["width"] * r["height"], r["planes"], r["views"]
        cell_views = n * d * k
        times = [r["timings"].get(s) for s in stages]
        rows.append(head + [r["seconds"]] + times
                    + [_gib(r["peak"]), _gib(r.get("start")), _gib(r["estimate"]), r["seconds"] / cell_views * 1e9,
                       100 * r["good"]])
        bounds = [stage_bytes(s, n=n, d=d, k=k, settings=r["settings"], layers=r.get("layers")) for s in stages]
        ratios = [None if t is None or b is None or b == 0 else t / (b / bytes_per_second)
                  for t, b in zip(times, bounds, strict=True)]
        # the total's bound: the top-level stages only ("depth" holds "depth.match" and the others)
        known = [b for st, t, b in zip(stages, times, bounds, strict=True)
                 if t is not None and b is not None and "." not in st]
        ratio_rows.append(head + [sum(known) / 2**30] + ratios
                          + [r["seconds"] / (sum(known) / bytes_per_second) if known else None])
    out = common.section(
        "Solve time per stage (s), peak memory, cost per cell-view",
        common.markdown_table(["plate", "planes", "total s", *stages, "peak GiB", "start GiB", "estimate GiB",
                               "ns per cell-view", "good %"], rows, digits=2)
        + "\n\n*peak*: VmHWM of the solve's process, reset after the plates were made; *start*: "
          "what was resident then (libraries and plates), so the solve itself added peak - start; *estimate*: "
          "`solver.memory_needed`, the solve's own estimate of that; *good*: reference pixels within 1 of the "
          "true disparity.")
    out += common.section(
        f"Each stage as a multiple of its streaming lower bound (memory bandwidth {bytes_per_second / 1e9:.1f} "
        "GB/s, np.copyto)",
        common.markdown_table(["plate", "planes", "GiB touched", *stages, "total"], ratio_rows, digits=1)
        + f"\n\nThe byte model is in `benchmarks/speed.py`; the issue's target is each stage within "
          f"{STAGE_FACTOR:g}x, or a stated reason. {WHY}")
    lines = []
    by_case = {(r["width"], r["height"], r["planes"]): r for r in results}
    for case, seconds, gib, what in TARGETS:
        r = by_case.get(case)
        if r is None:
            continue
        if _status(r) is not None:
            lines.append(f"- {what}: NOT MET ({_status(r)})")
            continue
        ok_time = seconds is None or r["seconds"] <= seconds
        ok_mem = r["peak"] is not None and r["peak"] <= gib * 2**30
        peak = "unknown" if r["peak"] is None else f"{_gib(r['peak']):.1f} GiB"
        how = ", empty planes dropped (the full stack was refused)" if r.get("drop") else ""
        lines.append(f"- {what}: {'MET' if ok_time and ok_mem else 'NOT MET'} ({r['seconds']:.0f} s, peak {peak}"
                     f"{how})")
    if lines:
        out += common.section("Targets (issue 8)", "\n".join(lines))
    return out


def plot(results: list[dict], path) -> None:
    """Total and per-stage time against pixels x planes x views (log-log), with a line of slope 1."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    done = [r for r in results if _status(r) is None]
    fig, ax = plt.subplots(figsize=(7, 5))
    if done:
        x = np.array([r["width"] * r["height"] * r["planes"] * r["views"] for r in done], float)
        y = np.array([r["seconds"] for r in done])
        ax.loglog(x, y, "o", color="k", label="total")
        for r, xi, yi in zip(done, x, y, strict=True):
            ax.annotate(f"{_label(r)} D={r['planes']}", (xi, yi), fontsize=7, xytext=(4, -10),
                        textcoords="offset points")
        for stage in _stages(done):
            pts = [(xi, r["timings"][stage]) for r, xi in zip(done, x, strict=True) if stage in r["timings"]]
            if pts and max(t for _, t in pts) > 0.02 * y.max():
                ax.loglog(*zip(*pts, strict=True), ".", alpha=0.6, label=stage)
        xs = np.array([x.min(), x.max()])
        ax.loglog(xs, xs * np.median(y / x), "--", color="grey", label="linear (slope 1)")
    ax.set_xlabel("pixels x planes x views")
    ax.set_ylabel("seconds")
    ax.set_title("vfxstereo.solve: time against problem size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# --------------------------------------------------------------------------------------------------------


def run(*, quick: bool = False, sizes=None, planes=None, preset: str | None = None,
        timeout: float | None = None, drop: bool = False, views: bool = True) -> str:
    """Run every case (each in its own process) and return the Markdown report; write it and the plot."""
    from tqdm import tqdm

    sizes = sizes or (QUICK_SIZES if quick else SIZES)
    planes = planes or (QUICK_PLANES if quick else PLANES)
    b = bandwidth(128 if quick else 512)
    results = []
    cases = [(w, h, d, VIEWS) for (w, h) in sizes for d in planes]
    if views:
        cases += [(w, h, d, k) for (w, h, d, k) in (QUICK_VIEW_CASES if quick else VIEW_CASES)]
    with tqdm(cases, desc="speed cases", file=sys.stderr, dynamic_ncols=True) as bar:
        for w, h, d, k in bar:
            bar.set_postfix_str(f"{w}x{h} D={d} K={k}")
            results.append(_spawn(w, h, d, preset=preset, timeout=timeout, drop=drop, views=k))
            if "refused" in results[-1] and not drop and results[-1]["settings"].get("depth") == "robust":
                # a full stack that cannot fit: the same plate with only the planes that hold something
                results.append(_spawn(w, h, d, preset=preset, timeout=timeout, drop=True, views=k))
    config = f"preset `{preset}`" if preset else f"the default preset (`{DEFAULT_PRESET}`)"
    head = (f"Plates: `samples.layered_scene`, K = {VIEWS} unless the plate column says otherwise; {config} "
            f"(each case's settings are in the JSON beside this table). Memory bandwidth {b / 1e9:.1f} GB/s "
            "(np.copyto, this run).")
    report = common.section("Speed and memory of solve (issue 8)", head) + tables(results, b)
    name = "speed_quick" if quick else "speed"
    out = common.out_dir()
    (out / f"{name}.md").write_text(report)
    (out / f"{name}.json").write_text(json.dumps({"bandwidth": b, "cases": results}, indent=1, default=str))
    plot(results, out / f"{name}.png")
    return report


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a size is WIDTHxHEIGHT, got {text!r}") from None
    return w, h


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small plates only (240x136, 480x270; 8, 16 planes)")
    parser.add_argument("--sizes", type=lambda t: [_size(s) for s in t.split(",")],
                        help="plate sizes, e.g. 960x540,1920x1080")
    parser.add_argument("--planes", type=lambda t: [int(p) for p in t.split(",")], help="plane counts, e.g. 32,64")
    parser.add_argument("--preset", help="a SolveConfig preset (default: the default preset, what solve uses)")
    parser.add_argument("--timeout", type=float, help="seconds a case may take before it is reported as failed")
    parser.add_argument("--drop-empty-planes", action="store_true",
                        help="solve with keep_empty_planes=False (by default only cases refused otherwise are)")
    parser.add_argument("--no-views", action="store_true", help="skip the cases with fewer views")
    parser.add_argument("--views", type=int, default=VIEWS, help=argparse.SUPPRESS)  # with --case
    parser.add_argument("--case", nargs=2, metavar=("WxH", "PLANES"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:
        w, h = _size(args.case[0])
        print(json.dumps(run_case(w, h, int(args.case[1]), preset=args.preset, drop=args.drop_empty_planes,
                                  views=args.views), default=str))
        return 0
    print(run(quick=args.quick, sizes=args.sizes, planes=args.planes, preset=args.preset, timeout=args.timeout,
              drop=args.drop_empty_planes, views=not (args.no_views or args.sizes or args.planes)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
