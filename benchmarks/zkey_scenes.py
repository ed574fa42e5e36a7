"""Z-keying production-like plates: our comp against an SGBM depth key and a true-depth key, side by side.

Scenes: :mod:`vfxstereo.zkey_scenes` -- three or four planar layers each (slanted walls, photo cards, a fence,
hair, fur, plants, a wire mesh with holes, low-texture painted walls from the alpha-matting and Middlebury
sets), per-view exposure gains, vignetting and noise; 320 x 240, disparities 0.1-15 px per view step;
solved on planes 0..16 step 0.5 (33 planes). Every scene is run with K = 5 views and as a stereo rig
(K = 2, the reference the left view). The scenes in :data:`vfxstereo.zkey_scenes.HELD_OUT` were kept out of
tuning: ``--held-out`` scores them (the default run scores the others).

For each element (a full-frame checker card and a centred one, at every element disparity of the scene):

* **ours** -- ``composite.insert(solve(views), element, disparity=D)``, composed into the plate;
* **ours, initial** -- the same from the solver's initial volume (before refinement and edge matting), so
  the later stages can be seen not to make the comp worse;
* **our depth, hard key** -- :func:`vfxstereo.baselines.hard_key` on our disparity map (depth alone);
* **SGBM key** -- a hard key from OpenCV SGBM's disparity on the reference and its right neighbour;
* **true-depth key** -- a hard key from the true front-most disparity (alpha > 0.5);
* **ours from the true depth** (``--true-depth``) -- ours with the depth stage's map replaced by the true one:
  what the later stages would give with exact depth, so how much of the gap is left to the depth stage;

PSNR (dB, scene-linear RGB, peak 1) against the true comp, over the frame and over the soft-edge band
(:meth:`vfxstereo.zkey_scenes.Scene.band`) where the element is (alpha > 0); an element that touches fewer than 50
band pixels is not scored. Means over (scene, K, element) rows; the issue's targets: ours
beats the SGBM key on every row (frame and band) and the true-depth key on the band by >= 1 dB on average
(row PSNRs capped at :data:`CAP` dB in the means).

The summary also says where the band's error is: its squared error split by where our final front surface
(alpha > 0.5) lies against the true depth -- too near, right, or too far by more than 1 px -- for ours and
for the true-depth key. Too near is foreground fattening the soft edges kept solid (sparse hair over the
background: in session 25, about three quarters of our band error); too far, thin structures the depth map
missed.

Run ``python benchmarks/zkey_scenes.py [--held-out | --all] [--scenes a b] [--K 5 2] [--preset robust]``.
Tuning: ``--config '{"soft_edge": {"laplacian": 0.3}}' --depth-cache DIR --jobs 2 --json new.json --compare
old.json`` (settings on top of the preset; the depth stage solved once per scene, rig and depth settings and
reused; fresh processes; ours' change per scene against an earlier run's rows).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import multiprocessing
import os
import subprocess
import sys
from pathlib import Path

import common  # benchmarks/ is on sys.path when run as a script
import numpy as np
from common import configured

from vfxstereo import SolveConfig, baselines, composite, solve
from vfxstereo import zkey_scenes as scenes
from vfxstereo.stack import LayerStack

PLANES = np.arange(0.0, 16.0 + 0.25, 0.5)
"""Planes of the solves: 0..16 px per view step, 0.5 apart (33 planes)."""
CAP = 60.0
"""Row PSNRs above this count as this in the means (an exact comp has an infinite PSNR)."""
TIE = 0.005
"""Rows where ours and the SGBM key are within this many dB tie (both comps the same, e.g. where both depth
maps put the same surfaces in front of the element, or both above :data:`CAP`); the target counts them as not
beating it."""
METHODS = ("ours", "ours, initial", "our depth, hard key", "SGBM key", "true-depth key")
TRUE_DEPTH = "ours from the true depth"
"""With ``--true-depth``: ours' later stages (initial volume, refinement, soft edges) run from the true depth
map instead of the depth stage's -- how far they would go with exact depth, so what is left to the depth stage
(session 26: +1.64 dB over the true-depth key on the band, against -5.10 from our depth)."""
DEPTH_ORACLES = ("ours, too-near at edges set true", "ours, too-near elsewhere set true", "ours, too-far set true")
"""With ``--depth-oracles``: ours' later stages run from our depth map with one class of its errors (more than
1 px) set to the true depth -- the pixels put too near within :data:`ORACLE_EDGE` px of a true depth edge (the
fattening), those put too near farther out, and those put too far: what each class of the depth stage's errors
costs the comp once the soft edges have done what they can (session 58, the 29 synthetic tuning scenes' rows, band dB:
+2.64 / +0.44 / +0.33 at K = 5, +2.76 / +0.95 / +0.81 at K = 2)."""
ORACLE_EDGE = 4
"""Reach (px) of a true depth edge (a step of more than 1 px between neighbours) for :data:`DEPTH_ORACLES`."""
CYCLES = ("sphere_plant", "plush_wall", "fence_dof")
"""Cycles-rendered scenes (benchmarks/cycles_scenes.py); since session 27 all of them are tuning scenes
(``fence_dof`` was held out until then and, like the older held-out scenes, has been used to judge changes)."""
CYCLES_HELD_OUT: tuple[str, ...] = ()
CYCLES_DIR = Path(os.environ.get("VFXSTEREO_CYCLES", common.out_dir() / "cycles"))
"""Where the rendered scenes are (made with the Blender environment when missing)."""


class CyclesScene:
    """A Cycles-rendered scene as the z-key benchmark needs it (the interface of :class:`vfxstereo.zkey_scenes.Scene`).

    The true comp is the render with the element in the scene; the true depth the renderer's depth pass (one
    surface per pixel). The soft-edge band: pixels within 3 px of where the true depth crosses the element's
    disparity, on the element.
    """

    def __init__(self, name: str, K: int):
        from vfxstereo.io import exr

        folder = CYCLES_DIR / name
        meta = json.loads((folder / "scene.json").read_text())
        keep = list(range(5)) if K == 5 else [meta["reference"], meta["reference"] + 1]
        self._views = np.stack([exr.read_image(folder / meta["views"][k])[0][..., :3] for k in keep])
        self.positions = np.asarray(meta["positions"], np.float64)[keep] - meta["positions"][meta["reference"]]
        self.reference = keep.index(meta["reference"])
        element = exr.read_image(folder / "element.exr")[0][..., :4]
        D = float(meta["element_disparity"])
        self.elements = {f"rendered card at d={D:.2f}": (element, D)}
        self._comp = exr.read_image(folder / "comp.exr")[0][..., :3]
        self._disparity = exr.read_image(folder / "disparity.exr")[0][..., 0]
        self.K = K

    def views(self):
        return self._views

    def comp(self, element, D):
        return self._comp

    def gt_disparity(self, threshold: float = 0.5):
        return self._disparity

    def band(self, dilate: int = 3):
        from scipy import ndimage

        D = next(iter(self.elements.values()))[1]
        front = self._disparity > D
        edge = front ^ ndimage.binary_erosion(front) | ~front ^ ndimage.binary_erosion(~front)
        return ndimage.binary_dilation(edge, iterations=dilate)


def ensure_cycles_scenes() -> bool:
    """Render the Cycles scenes with the Blender environment if they are missing; False if they cannot be."""
    if all((CYCLES_DIR / n / "scene.json").is_file() for n in CYCLES):
        return True
    blender_python = common.HERE.parent / ".venv-blender" / "bin" / "python"
    if not blender_python.exists():
        return False
    print(f"  rendering the Cycles scenes into {CYCLES_DIR} (minutes) ...", file=sys.stderr, flush=True)
    done = subprocess.run([str(blender_python), str(common.HERE / "cycles_scenes.py"), "--out", str(CYCLES_DIR)],
                          check=False)
    return done.returncode == 0


def build_scene(name: str, K: int):
    return CyclesScene(name, K) if name in CYCLES else scenes.build(name, K=K)


DEPTH_SOURCES = ("depth.py", "depth_plate.py", "_depth_kernels.py", "matching.py", "sweep.py", "sgm.py",
                 "subpixel.py", "warp.py", "geometry.py", "homography.py", "layers.py")
"""The modules the depth stage's map comes from: a change in any of them makes the cached maps stale (a depth
setting's docstring-only change does too; an edit to the soft edges does not)."""


def _depth_path(cache: Path, name: str, K: int, config: SolveConfig) -> Path:
    """Where the depth stage's disparity for this scene, rig, depth configuration and depth code is kept in
    ``cache``."""
    import vfxstereo

    code = b"".join((Path(vfxstereo.__file__).parent / f).read_bytes() for f in DEPTH_SOURCES)
    key = hashlib.sha1(repr((name, K, PLANES.tolist(), config.depth, config.depth_config)).encode() + code)
    return cache / f"{name}_K{K}_{key.hexdigest()[:16]}.npy"


def solve_cached(solve_it, depth_cache: Path | None, name: str, K: int, config: SolveConfig):
    """``solve_it(disparity)`` (a solve with ``return_details=True``) from the depth map kept in ``depth_cache``
    for this scene, rig and depth code, or from scratch (``disparity=None``), keeping its map there for next time:
    the later stages can then be tuned and traced on stored depth maps. No cache, or a depth stage other than
    "robust": always from scratch."""
    cached = _depth_path(depth_cache, name, K, config) if depth_cache and config.depth == "robust" else None
    res = solve_it(np.load(cached) if cached is not None and cached.is_file() else None)
    if cached is not None and not cached.is_file():
        cached.parent.mkdir(parents=True, exist_ok=True)
        np.save(cached.with_suffix(".tmp.npy"), res.disparity)
        cached.with_suffix(".tmp.npy").replace(cached)
    return res


def oracle_maps(disparity: np.ndarray, exact: np.ndarray) -> dict[str, np.ndarray]:
    """:data:`DEPTH_ORACLES`' maps: ``disparity`` with one class of its errors set to ``exact`` (the true map
    clipped to the planes, as ``--true-depth`` solves from it)."""
    from scipy import ndimage

    t = np.asarray(exact, np.float32)
    d = np.asarray(disparity, np.float32)
    near, far = d > t + 1, d < t - 1
    jump = np.zeros(t.shape, bool)
    jump[:, 1:] |= np.abs(np.diff(t, axis=1)) > 1
    jump[1:, :] |= np.abs(np.diff(t, axis=0)) > 1
    edge = ndimage.binary_dilation(jump, iterations=ORACLE_EDGE)
    fixed = (near & edge, near & ~edge, far)
    return {m: np.where(f, t, d).astype(np.float32) for m, f in zip(DEPTH_ORACLES, fixed, strict=True)}


def run_scene(name: str, K: int, preset: str, *, figures: bool = True, overrides: dict | None = None,
              depth_cache: Path | None = None, true_depth: bool = False, oracles: bool = False) -> list[dict]:
    """Solve one scene with one rig size and score every element; one row per element.

    ``overrides``: settings on top of the preset (:func:`configured`); ``depth_cache``: a folder where the depth
    stage's disparity maps are kept and reused (``solve(disparity=...)``); ``true_depth``: also score the later
    stages run from the true depth map (:data:`TRUE_DEPTH`); ``oracles``: also from our map with one class of its
    errors set right (:data:`DEPTH_ORACLES`).
    """
    scene = build_scene(name, K)
    views = scene.views()
    plate = views[scene.reference]
    config = configured(preset, overrides)

    def solve_it(disparity=None):
        return solve(views, positions=scene.positions, reference=scene.reference, disparities=PLANES,
                     config=config, return_details=True, keep_initial=True, disparity=disparity)

    with common.Stopwatch() as sw:
        res = solve_cached(solve_it, depth_cache, name, K, config)
    stack = res.stack
    initial = LayerStack(res.initial, stack.disparities, stack.camera, white=stack.white, plate=plate)
    right = scene.reference + 1
    d_sgbm = baselines.sgbm_disparity(plate, views[right], float(scene.positions[right]
                                                                   - scene.positions[scene.reference]), PLANES)
    d_true = scene.gt_disparity(0.5)
    extra = {}  # later stages from other maps
    exact = np.clip(d_true, PLANES[0], PLANES[-1]).astype(np.float32)  # the true map on the planes' range
    if true_depth:  # the later stages from an exact depth map: what is left to the depth stage
        extra[TRUE_DEPTH] = solve_it(exact).stack
    if oracles:  # ... and from ours with one class of its errors set right
        extra.update({m: solve_it(d).stack for m, d in oracle_maps(res.disparity, exact).items()})
    band = scene.band()
    # where our final front surface (alpha > 0.5) lies against the truth: too near, right, too far (> 1 px)
    ours_front = np.nan_to_num(stack.disparity_map(0.5), nan=-np.inf)
    depth_class = np.where(ours_front > d_true + 1, 0, np.where(ours_front < d_true - 1, 2, 1))
    by_jump = jump_distance_class(res.disparity)
    rows = []
    for el_name, (element, D) in scene.elements.items():
        truth = scene.comp(element, D)
        comps = {
            "ours": composite.insert(stack, element, disparity=D)[..., :3],
            "ours, initial": composite.insert(initial, element, disparity=D)[..., :3],
            "our depth, hard key": baselines.hard_key(plate, res.disparity, element, D),
            "SGBM key": baselines.hard_key(plate, d_sgbm, element, D),
            "true-depth key": baselines.hard_key(plate, d_true, element, D),
        }
        for m, other in extra.items():
            comps[m] = composite.insert(other, element, disparity=D)[..., :3]
        row = {"scene": name, "K": K, "element": el_name, "D": D, "seconds": sw.seconds}
        on_band = band & (element[..., 3] > 0)  # soft edges the element shows through or around
        if on_band.sum() < 50:
            continue  # the element misses the soft edges: nothing to score there
        for m, c in comps.items():
            row[m] = (common.psnr(c, truth), common.psnr(c, truth, on_band))
        sq = {m: ((comps[m] - truth) ** 2).mean(axis=-1) for m in ("ours", "true-depth key")}
        row["band error by depth"] = {m: [float(sq[m][on_band & (depth_class == k)].sum()) for k in range(3)]
                                      for m in sq}
        row["band error by depth"]["pixels"] = [int((on_band & (depth_class == k)).sum()) for k in range(3)]
        near = on_band & (depth_class == 0)
        row["band too-near error by jump distance"] = {
            "ours": [float(sq["ours"][near & (by_jump == k)].sum()) for k in range(len(JUMP_BINS))],
            "pixels": [int((near & (by_jump == k)).sum()) for k in range(len(JUMP_BINS))]}
        classes = alpha_classes(true_front_alpha(scene, D, d_true), composite.holdout(stack, D))
        row["band error by alpha"] = {m: [float(sq[m][on_band & (classes == k)].sum())
                                          for k in range(len(ALPHA_CLASSES))] for m in sq}
        row["band error by alpha"]["pixels"] = [int((on_band & (classes == k)).sum())
                                                for k in range(len(ALPHA_CLASSES))]
        rows.append(row)
        if figures and el_name.startswith("full"):
            _figure(common.out_dir("zkey_scenes") / f"{name}_K{K}_D{D:g}.png", truth, comps, band)
    return rows


ALPHA_CLASSES = ("clear, under an opaque front", "clear, under a partial front", "soft", "solid, made see-through",
                 "solid, lost", "right")
"""Band pixels by the true front's alpha over the element (clear < 0.02, soft, solid >= 0.98) and ours
(:func:`vfxstereo.composite.holdout`: opaque > 0.9, partial 0.1-0.9, lost < 0.1): where the band's error lies
(``band error by alpha`` in the rows). "right": clear pixels ours leaves nearly clear, and solid ones it keeps
opaque."""


def true_front_alpha(scene, D: float, d_true: np.ndarray) -> np.ndarray:
    """Alpha of what lies in front of disparity ``D`` in the reference view: the layers' (synthetic scenes) or
    the true depth map's 0/1 (rendered scenes, one surface per pixel)."""
    if hasattr(scene, "split"):
        return scene.split(D)[0][..., 3]
    return (np.nan_to_num(d_true, nan=-np.inf) > D).astype(np.float32)


def alpha_classes(true_a: np.ndarray, ours_a: np.ndarray) -> np.ndarray:
    """Index into :data:`ALPHA_CLASSES` of each pixel."""
    out = np.full(true_a.shape, 5, np.int8)
    clear, solid = true_a < 0.02, true_a >= 0.98
    out[clear & (ours_a > 0.9)] = 0
    out[clear & (ours_a >= 0.1) & (ours_a <= 0.9)] = 1
    out[~clear & ~solid] = 2
    out[solid & (ours_a >= 0.1) & (ours_a <= 0.9)] = 3
    out[solid & (ours_a < 0.1)] = 4
    return out


JUMP_BINS = ("0-1", "1-3", "3-8", "8-16", "16+")
"""Distance bins (px) of :func:`jump_distance_class`: a too-near pixel next to a depth jump of our map is a rim
(the window's fattening), one far from every jump lies on a whole surface placed too near."""


def jump_distance_class(disparity: np.ndarray, jump: float = 1.5) -> np.ndarray:
    """Index into :data:`JUMP_BINS` of each pixel: its distance to the nearest pixel at a depth jump of
    ``disparity`` (3 x 3 range >= ``jump``, as step 19 finds them; those pixels themselves are at 0)."""
    from scipy import ndimage

    from vfxstereo.depth_plate import rim_sides

    at = rim_sides(np.asarray(disparity, np.float32), jump)[1]
    dist = ndimage.distance_transform_edt(~at) if at.any() else np.full(at.shape, np.inf)
    return np.digitize(dist, [1.0, 3.0, 8.0, 16.0]).astype(np.int8)


def _band_without(row: dict, k: int) -> float:
    """The row's band PSNR for ours (capped) with class ``k``'s error (:data:`ALPHA_CLASSES`) the true-depth
    key's instead."""
    split = row["band error by alpha"]
    sse = sum(split["ours"])
    if not sse > 0:
        return min(row["ours"][1], CAP)
    n = sse * 10.0 ** (row["ours"][1] / 10.0)  # the band's pixel count (PSNR = 10 log10(n / sse), peak 1)
    new = sse - split["ours"][k] + split["true-depth key"][k]
    return min(CAP, 10.0 * np.log10(n / new)) if new > 0 else CAP


def _figure(path, truth, comps, band) -> None:
    """Truth, ours, SGBM key and their error maps (x4) side by side."""
    from vfxstereo.io import preview

    def enc(x):
        return preview.to_display(np.concatenate([x, np.ones(x.shape[:2] + (1,), np.float32)], -1))

    def err(x):
        e = np.clip(4.0 * np.abs(x - truth).max(axis=-1, keepdims=True), 0, 1)
        return enc(np.repeat(e, 3, -1))

    top = np.concatenate([enc(truth), enc(comps["ours"]), enc(comps["SGBM key"]), enc(comps["true-depth key"])], 1)
    bot = np.concatenate([enc(np.repeat(band[..., None].astype(np.float32), 3, -1)), err(comps["ours"]),
                          err(comps["SGBM key"]), err(comps["true-depth key"])], 1)
    preview.write_display(path, np.concatenate([top, bot], 0))


def tables(rows: list[dict], title: str) -> str:
    """The per-row table and the summary."""
    methods = METHODS + tuple(m for m in (TRUE_DEPTH, *DEPTH_ORACLES) if rows and all(m in r for r in rows))
    headers = ["scene", "K", "element", *[f"{m} (frame / band)" for m in methods], "s"]
    body = []
    for r in rows:
        body.append([r["scene"], r["K"], r["element"],
                     *[f"{r[m][0]:.2f} / {r[m][1]:.2f}" for m in methods], f"{r['seconds']:.1f}"])
    out = common.section(title, common.markdown_table(headers, body))
    n = len(rows)
    mean = {m: (np.mean([min(r[m][0], CAP) for r in rows]), np.mean([min(r[m][1], CAP) for r in rows]))
            for m in methods}
    def tally(i):  # rows ours beats the SGBM key on, ties with (the same capped PSNR to TIE dB) and loses
        diff = [min(r["ours"][i], CAP) - min(r["SGBM key"][i], CAP) for r in rows]
        return sum(x >= TIE for x in diff), sum(abs(x) < TIE for x in diff), sum(x <= -TIE for x in diff)

    (wins_frame, ties_frame, lost_frame), (wins_band, ties_band, lost_band) = tally(0), tally(1)
    def exact(i):  # ties where both comps are above CAP: both exact, nothing left to beat
        return sum(min(r["ours"][i], r["SGBM key"][i]) >= CAP for r in rows)
    worse = sum(min(r["ours"][0], CAP) < min(r["ours, initial"][0], CAP) - 0.05 for r in rows)
    gap = mean["ours"][1] - mean["true-depth key"][1]
    summary = [
        "| method | mean frame dB | mean band dB |", "|---|---|---|",
        *[f"| {m} | {mean[m][0]:.2f} | {mean[m][1]:.2f} |" for m in methods],
        "",
        f"ours beats the SGBM key on {wins_frame}/{n} rows over the frame (ties {ties_frame}, {exact(0)} of them "
        f"with both above {CAP:g} dB; loses {lost_frame}) and {wins_band}/{n} on the band (ties {ties_band}, "
        f"{exact(1)} of them both above {CAP:g} dB; loses {lost_band}); "
        f"band vs the true-depth key: {gap:+.2f} dB (target >= +1: {'MET' if gap >= 1 else 'NOT MET'}); "
        f"later stages worse than the initial volume (frame, > 0.05 dB) on {worse}/{n} rows.",
    ]
    if TRUE_DEPTH in methods:
        summary.append(
            f"From the true depth, ours scores {mean[TRUE_DEPTH][1] - mean['true-depth key'][1]:+.2f} dB against "
            f"the true-depth key on the band (ours from our depth: {gap:+.2f}); its later stages are worse than "
            f"its initial volume (the true-depth key, frame, > 0.05 dB) on "
            f"{sum(min(r[TRUE_DEPTH][0], CAP) < min(r['true-depth key'][0], CAP) - 0.05 for r in rows)}/{n} rows.")
    if DEPTH_ORACLES[0] in methods:
        for K in sorted({r["K"] for r in rows}):
            sub = [r for r in rows if r["K"] == K]
            base = np.mean([min(r["ours"][1], CAP) for r in sub])
            parts = [f"{m.split(', ', 1)[1]} {np.mean([min(r[m][1], CAP) for r in sub]) - base:+.2f}"
                     for m in DEPTH_ORACLES]
            summary.append(f"K = {K}: ours' later stages from our map with one class of its errors set to the truth "
                           f"(band dB against ours): " + "; ".join(parts) + ".")
    split = [r["band error by depth"] for r in rows if "band error by depth" in r]
    if split:
        ours = np.sum([b["ours"] for b in split], axis=0)
        key = np.sum([b["true-depth key"] for b in split], axis=0)
        px = np.sum([b["pixels"] for b in split], axis=0)
        summary.append(
            "Band squared error by where our final front surface (alpha > 0.5) lies against the true depth "
            f"(too near / right / too far by > 1 px; {px[0] / px.sum():.0%} / {px[1] / px.sum():.0%} / "
            f"{px[2] / px.sum():.0%} of the band's pixels): ours {ours[0]:.0f} / {ours[1]:.0f} / {ours[2]:.0f}, "
            f"the true-depth key {key[0]:.0f} / {key[1]:.0f} / {key[2]:.0f} (summed over the rows).")
    split = [r["band too-near error by jump distance"] for r in rows if "band too-near error by jump distance" in r]
    if split:
        ours = np.sum([b["ours"] for b in split], axis=0)
        parts = [f"{b} {o / max(ours.sum(), 1e-12):.0%}" for b, o in zip(JUMP_BINS, ours, strict=True)]
        summary.append("Ours' too-near band error by distance (px) from the nearest depth jump of our map (rims near "
                       "0, whole surfaces placed too near far out): " + "; ".join(parts) + ".")
    rows_split = [r for r in rows if "band error by alpha" in r]
    split = [r["band error by alpha"] for r in rows_split]
    if split:
        ours = np.sum([b["ours"] for b in split], axis=0)
        key = np.sum([b["true-depth key"] for b in split], axis=0)
        px = np.sum([b["pixels"] for b in split], axis=0)
        parts = [f"{c} {o:.0f} / {k:.0f} ({p / px.sum():.0%})"
                 for c, o, k, p in zip(ALPHA_CLASSES, ours, key, px, strict=True)]
        summary.append("Band squared error by the true front's alpha and ours (summed over the rows; ours / the "
                       "true-depth key, share of the band's pixels): " + "; ".join(parts) + ".")
        base = np.mean([min(r["ours"][1], CAP) for r in rows_split])
        gains = [np.mean([_band_without(r, k) for r in rows_split]) - base for k in range(len(ALPHA_CLASSES) - 1)]
        parts = [f"{c} {g:+.2f}" for c, g in zip(ALPHA_CLASSES[:-1], gains, strict=True)]
        summary.append("Ours' mean band dB if one class's error were the true-depth key's (what fixing it alone would "
                       "give): " + "; ".join(parts) + ".")
    for K in sorted({r["K"] for r in rows}):
        sub = [r for r in rows if r["K"] == K]
        def m(key, sub=sub):
            return np.mean([min(r[key][1], CAP) for r in sub])

        summary.append(f"K = {K}: ours {m('ours'):.2f} dB band, SGBM key {m('SGBM key'):.2f}, true-depth key "
                       f"{m('true-depth key'):.2f}.")
    return out + "\n" + "\n".join(summary) + "\n"


def _scene_job(args) -> list[dict]:
    name, K, preset, figures, overrides, depth_cache, true_depth, oracles = args
    return run_scene(name, K, preset, figures=figures, overrides=overrides, depth_cache=depth_cache,
                     true_depth=true_depth, oracles=oracles)


def run(*, names=None, held_out: bool = False, every: bool = True, Ks=(5, 2), preset: str = "robust",
        figures: bool = True, quick: bool = False, overrides: dict | None = None, depth_cache: Path | None = None,
        jobs: int = 1, rows_out: list | None = None, true_depth: bool = False, oracles: bool = False) -> str:
    """Score the scenes (``make bench``: all of them; the script's own default: the tuning scenes).

    ``jobs`` > 1 solves (scene, K) pairs in that many processes, each pair in a fresh one; ``rows_out``
    receives the rows."""
    given = names
    if quick:
        names, Ks = names or ["trolls_art", "fur_grey_wall"], (5,)
    if names is None:
        held = set(scenes.HELD_OUT) | set(CYCLES_HELD_OUT)
        names = [n for n in list(scenes.SCENES) + list(CYCLES) if every or ((n in held) == held_out)]
    if any(n in CYCLES for n in names) and not ensure_cycles_scenes():
        print("  no Cycles scenes (no .venv-blender to render them): scored without them", file=sys.stderr)
        names = [n for n in names if n not in CYCLES]
    tasks = [(name, K, preset, figures, overrides, depth_cache, true_depth, oracles) for name in names for K in Ks]
    if jobs > 1:
        pool = multiprocessing.get_context("spawn").Pool(jobs, maxtasksperchild=1)
        results = pool.imap(_scene_job, tasks)
    else:
        pool, results = None, map(_scene_job, tasks)
    rows = []
    try:
        for (name, K, *_), got in zip(tasks, results, strict=True):
            rows += got
            if got:
                r = got[-1]
                print(f"  {name} K={K}: ours {r['ours'][1]:.2f} band, SGBM {r['SGBM key'][1]:.2f}, "
                      f"true {r['true-depth key'][1]:.2f} ({r['seconds']:.1f} s)", file=sys.stderr, flush=True)
    finally:
        if pool is not None:
            pool.terminate()
    if rows_out is not None:
        rows_out.extend(rows)
    if given is not None:
        which = "scenes " + ", ".join(given)
    else:
        which = "all scenes" if every else ("held-out scenes" if held_out else "tuning scenes")
    settings = f", settings {json.dumps(overrides)}" if overrides else ""
    return tables(rows, f"Z-key on production-like plates ({which}, preset {preset}{settings}, "
                        f"{common.machine_line()})")


def compare(rows: list[dict], before: list[dict]) -> str:
    """Per (scene, K): the mean change of ours (frame / band dB, capped) from ``before``'s rows for the same
    elements, and over all of them."""
    old = {(r["scene"], r["K"], r["element"]): r for r in before}
    per: dict = {}
    for r in rows:
        b = old.get((r["scene"], r["K"], r["element"]))
        if b is not None:
            per.setdefault((r["scene"], r["K"]), []).append(
                [min(r["ours"][i], CAP) - min(b["ours"][i], CAP) for i in (0, 1)])
    if not per:
        return "no rows in common with the earlier run\n"
    def change(d):
        return f"{np.mean([x[0] for x in d]):+.2f} / {np.mean([x[1] for x in d]):+.2f}"

    every = [x for d in per.values() for x in d]
    body = [[s, K, len(d), change(d)] for (s, K), d in per.items()] + [["all", "", len(every), change(every)]]
    return common.section("Ours against the earlier run", common.markdown_table(
        ["scene", "K", "rows", "change, frame / band dB"], body))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="*")
    p.add_argument("--held-out", action="store_true", help="score the scenes kept out of tuning")
    p.add_argument("--all", action="store_true", help="score every scene")
    p.add_argument("--K", nargs="*", type=int, default=[5, 2])
    p.add_argument("--preset", default="robust")
    p.add_argument("--config", type=json.loads, default=None, metavar="JSON",
                   help='settings on top of the preset, e.g. \'{"soft_edge": {"laplacian": 0.3}}\'')
    p.add_argument("--depth-cache", type=Path, default=None, metavar="DIR",
                   help="keep the depth stage's disparity maps here and reuse them (same depth settings and code)")
    p.add_argument("--jobs", type=int, default=1, help="(scene, K) pairs solved in parallel processes")
    p.add_argument("--json", type=Path, default=None, help="write the rows here")
    p.add_argument("--compare", type=Path, default=None, metavar="JSON",
                   help="rows of an earlier run (--json): print ours' change per scene")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--true-depth", action="store_true",
                   help="also score ours' later stages run from the true depth map (what is left to the depth stage)")
    p.add_argument("--depth-oracles", action="store_true",
                   help="also score them from our map with one class of its errors set to the truth (3 more solves)")
    a = p.parse_args(argv)
    rows: list[dict] = []
    text = run(names=a.scenes, held_out=a.held_out, every=a.all and not a.held_out, Ks=tuple(a.K), preset=a.preset,
               figures=not a.no_figures, overrides=a.config, depth_cache=a.depth_cache, jobs=a.jobs,
               rows_out=rows, true_depth=a.true_depth, oracles=a.depth_oracles)
    if a.compare is not None:
        text += "\n" + compare(rows, json.loads(a.compare.read_text()))
    print(text)
    if a.json is not None:
        a.json.write_text(json.dumps(rows))
    suffix = "_heldout" if a.held_out else ("_all" if a.all else "")
    (common.out_dir() / f"zkey_scenes{suffix}.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
