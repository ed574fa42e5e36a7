"""``solve``: the stages of Szeliski & Golland (1999) in order, from K views to a LayerStack.

1. geometry     -- :class:`vfxstereo.warp.Warper` (shift path or homographies, Eq. A1)
2. sweep        -- :func:`vfxstereo.sweep.sweep` (Eq. 1), visibility-weighted once V_k is known
3. aggregate    -- :func:`vfxstereo.aggregate.aggregate` (Eq. 2)
4. select       -- :func:`vfxstereo.select.select` (thresholded winner-take-all, footnote 6)
5. visibility   -- :mod:`vfxstereo.visibility` (Eqs. 5-8), then back to 2 (Section 5); from the second
                   pass on, the front surface is selected on a sweep in which the reference view votes at
                   every depth, and the hidden layers behind it (:func:`vfxstereo.select.select_behind`) on
                   a sweep in which it does not
6. complete     -- :func:`vfxstereo.select.complete`: fill undecided pixels, continue the background
                   behind edges, soften the edges (the refinement's start)
7. refine       -- :func:`vfxstereo.refine.refine` (Eqs. 9-13, A2)
8. sub-pixel    -- :func:`vfxstereo.subpixel.subpixel_disparity` (Section 8.1)

Steps marked in :mod:`vfxstereo.config` as beyond the paper are settings; the ``literal`` preset turns
them off. What each one buys, measured on the synthetic scenes, is in :mod:`vfxstereo.config`,
:mod:`vfxstereo.sweep` and :mod:`vfxstereo.select`.

Results on the synthetic scenes of :mod:`vfxstereo.samples` (64 x 64, K = 5, seeds 0-4) are asserted by
``tests/test_solver.py`` and tabulated in its docstring.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from vfxstereo.config import DEFAULT_PRESET, SolveConfig
from vfxstereo.errors import VfxStereoError
from vfxstereo.geometry import Camera
from vfxstereo.progress import Progress, report
from vfxstereo.stack import LayerStack
from vfxstereo.warp import Warper

# Bytes held per (x, y, d) cell while solving: selected, initial and refined RGBA volumes, mean colour,
# variance, aggregated variance and vote weight of the front and hidden sweeps, gradient and Hessian of the
# refinement (3 * 4 + 2 * (3 + 1 + 1 + 1) + 4 + 4 float32), and per view the visibility volume and one warped
# RGBA layer stack during refinement (1 + 4 float32 per view).
_BYTES_PER_CELL = 4 * 32
_BYTES_PER_CELL_PER_VIEW = 4 * 5
# The robust path (depth="robust"), in two phases that do not overlap. The depth stage holds its cost volumes
# (depth.bytes_per_cell per cell of the strip it solves, at most DepthConfig.strip_memory GiB: see
# depth.strip_plan); then the layers are built in place in the stack's one RGBA volume (16 bytes per cell of the
# planes it holds), with images per pixel beside it (z-buffers and grown z-buffers per view, the soft edges'
# backgrounds and masks, the hidden layers' sums for the planes that have them, and in the soft edges' later
# passes the relabelled depth map, its z-buffers and the last pass's edges beside them: 384 bytes per pixel). Per
# pixel and view, both phases hold the views and their matching images (census code, colour, grey: 32 bytes).
# Measured against tracemalloc's peak in tests/test_solver.py (0.8-1.2x at 240x136 x 24 planes, K = 5) and
# against the resident peak by benchmarks/speed.py (HD and 4K).
_ROBUST_STACK_BYTES_PER_CELL = 16
_ROBUST_LAYER_BYTES_PER_PIXEL = 384
_ROBUST_BYTES_PER_PIXEL_PER_VIEW = 32
# The depth stage's whole-plate steps after the strips (step 12's flood, plain surfaces and views check: measured
# at 4096x2160 as the peak RSS they add, 52 B/px for the join, 92 and 147 B/px for the check with K = 2 and 5;
# step 13's edge ownership 91 B/px on a plate of plain and textured stripes, then the same check): they run one
# after another, between the strips' volumes and the stack, so they count in the maximum, not on top.
_JOIN_BYTES_PER_PIXEL = 100
_JOIN_BYTES_PER_PIXEL_PER_VIEW = 12


def memory_needed(shape: tuple[int, int], n_planes: int, n_views: int, *, depth: str = "robust",
                  strip_memory: float | None = None, layers: int | None = None, soft_edge=None) -> int:
    """Estimated peak bytes of :func:`solve` for views of ``shape`` (H, W) with the ``depth`` method.

    Robust depth: ``strip_memory`` (GiB, default :class:`~vfxstereo.depth.DepthConfig`'s) bounds the depth
    stage's volumes; ``layers`` is the number of planes the stack holds (default all ``n_planes``);
    ``soft_edge`` the soft edges' settings (:class:`~vfxstereo.softedge.SoftEdgeParams`, default its defaults),
    whose last matting step adds one tile's Laplacian (:func:`vfxstereo.softedge.laplacian_bytes`).
    """
    pixels = int(shape[0]) * int(shape[1])
    cells = pixels * int(n_planes)
    if depth == "robust":
        from vfxstereo.depth import DepthConfig, bytes_per_cell

        budget = (DepthConfig().strip_memory if strip_memory is None else strip_memory) * 2**30
        depth_stage = min(cells * bytes_per_cell(DepthConfig()), budget)
        from vfxstereo.softedge import laplacian_bytes

        stack = pixels * ((n_planes if layers is None else int(layers)) * _ROBUST_STACK_BYTES_PER_CELL
                          + _ROBUST_LAYER_BYTES_PER_PIXEL) + laplacian_bytes(shape, soft_edge)
        steps = pixels * (_JOIN_BYTES_PER_PIXEL + _JOIN_BYTES_PER_PIXEL_PER_VIEW * (int(n_views) - 1))
        return int(pixels * n_views * _ROBUST_BYTES_PER_PIXEL_PER_VIEW + max(depth_stage, stack, steps))
    return cells * (_BYTES_PER_CELL + _BYTES_PER_CELL_PER_VIEW * int(n_views))


def available_memory() -> int:
    """Bytes the machine can give us now (MemAvailable), or physical memory where /proc is missing."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    import os

    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def fit_to_memory(config: SolveConfig) -> SolveConfig:
    """``config`` with the robust depth stage's strip budget lowered to 40 % of the memory free now, if less.

    On this 24 GiB machine the default (6 GiB) stands; a smaller machine solves in more, thinner strips
    instead of refusing (the results differ only near the strips' seams: ``DepthConfig.strip_margin``).
    """
    import dataclasses

    if config.depth != "robust":
        return config
    free = 0.4 * available_memory() / 2**30
    if free >= config.depth_config.strip_memory:
        return config
    return config.replace(depth_config=dataclasses.replace(config.depth_config, strip_memory=max(0.25, free)))


def memory_settings(config: SolveConfig) -> dict:
    """The keyword arguments of :func:`memory_needed` and :func:`check_memory` for a solve with ``config``.

    Before the depth map is known: the robust path's strip budget (:func:`fit_to_memory`), and with
    ``keep_empty_planes=False`` one layer (the solve checks again once it knows which planes are used).
    """
    config = fit_to_memory(config)
    if config.depth != "robust":
        return {"depth": config.depth}
    return {"depth": "robust", "strip_memory": config.depth_config.strip_memory,
            "layers": None if config.keep_empty_planes else 1, "soft_edge": _soft_edge_memory(config)}


def _soft_edge_memory(config: SolveConfig):
    """The soft-edge settings :func:`memory_needed` counts for ``config`` (no matting step without soft edges)."""
    return config.soft_edge if config.soft_edges else dataclasses.replace(config.soft_edge, laplacian=0.0)


def check_memory(shape: tuple[int, int], n_planes: int, n_views: int, *, depth: str = "robust",
                 strip_memory: float | None = None, layers: int | None = None, soft_edge=None) -> None:
    """Raise VfxStereoError, saying how much is needed, when a solve cannot fit in memory.

    The arguments are :func:`memory_needed`'s.
    """
    need = memory_needed(shape, n_planes, n_views, depth=depth, strip_memory=strip_memory, layers=layers,
                         soft_edge=soft_edge)
    have = available_memory()
    if need > 0.8 * have:
        raise VfxStereoError(
            f"{n_planes} disparity planes at {shape[1]}x{shape[0]} with {n_views} views need about "
            f"{need / 2**30:.1f} GiB, but only {have / 2**30:.1f} GiB is available; use fewer planes "
            f"(a coarser --disparities step or a narrower range) or smaller plates"
        )


@dataclass
class SolveResult:
    """Everything :func:`solve` computed, for callers that want more than the stack."""

    stack: LayerStack
    disparity: np.ndarray
    """(H, W) float32 sub-pixel disparity of the reference camera (NaN where undecided)."""
    winners: np.ndarray
    """(H, W) int index of the front plane of the last selection (-1 = undecided)."""
    initial: np.ndarray | None
    """(D, H, W, 4) the refinement's start: the selected volume after completion (premultiplied). Robust depth:
    the volume before the soft edges, kept only with ``keep_initial`` (else None)."""
    selected: np.ndarray | None = None
    """(D, H, W, 4) the volume as the last selection made it (front and hidden cells, opacity 0/1)."""
    hidden: np.ndarray | None = None
    """(H, W) int index of the hidden plane selected behind the front one (-1 = none), or None."""
    timings: dict = field(default_factory=dict)
    """Seconds per stage."""


def _check_views(views) -> np.ndarray:
    v = np.asarray(views)
    if v.ndim == 3:
        v = v[..., None]
    if v.ndim != 4:
        raise VfxStereoError(f"views must be (K, H, W, 3) images, got shape {v.shape}")
    if v.shape[0] < 2:
        raise VfxStereoError(f"solving needs at least two views, got {v.shape[0]}")
    if v.shape[-1] == 1:
        v = np.repeat(v, 3, axis=-1)
    if v.shape[-1] != 3:
        raise VfxStereoError(f"views must have 3 colour channels, got {v.shape[-1]}")
    if not np.issubdtype(v.dtype, np.floating):
        raise VfxStereoError("views must be scene-linear floating-point images (decode them with io.plates)")
    v = np.ascontiguousarray(v, dtype=np.float32)
    bad = ~np.isfinite(v)
    if bad.any():
        k = int(np.argmax(bad.reshape(len(v), -1).any(axis=1)))
        raise VfxStereoError(f"view {k} holds {int(bad[k].any(axis=-1).sum())} NaN or infinite pixels")
    return v


def _check_disparities(disparities) -> np.ndarray:
    d = np.asarray(disparities, dtype=np.float64).reshape(-1)
    if d.size < 2:
        raise VfxStereoError(f"solving needs at least two disparity planes, got {d.size}")
    if not np.all(np.isfinite(d)) or not np.all(np.diff(d) > 0):
        raise VfxStereoError("disparities must be finite and strictly increasing")
    return d


def check_soft_rounds(rounds, name: str = "soft_rounds") -> None:
    """VfxStereoError unless ``rounds`` (``SolveConfig.soft_rounds``, given as ``name``) is a whole number >= 1."""
    if isinstance(rounds, bool) or not (isinstance(rounds, int | np.integer) and rounds >= 1):
        raise VfxStereoError(f"{name} must be a whole number of 1 or more, got {rounds!r}")


def _reference_index(camera: Camera) -> int:
    """The view the virtual camera coincides with, or the nearest one."""
    if camera.reference_index is not None:
        return int(camera.reference_index)
    return int(np.argmin(np.linalg.norm(camera.positions - camera.reference, axis=1)))


def border_weights(warper: Warper) -> np.ndarray:
    """w_k(u, v) of Eq. (9): 1 where view k's pixel lies inside the reference frame on every plane, else 0.

    Near the frame edge a view sees scene content that no plane of the reference camera holds; asking C1 to
    explain it only drags colour and opacity in from the edge.
    """
    h, w = warper.shape
    ones = np.ones((h, w), dtype=np.float32)
    weights = np.ones((warper.K, h, w), dtype=np.float32)
    for k in range(warper.K):
        for i in range(warper.D):
            np.minimum(weights[k], warper.to_view(ones, k, i), out=weights[k])
    return (weights > 1.0 - 1e-6).astype(np.float32)


def solve(views, *, positions=None, reference: int | None = None, disparities, config: SolveConfig | None = None,
          progress: Progress | None = None, camera: Camera | None = None, return_details: bool = False,
          keep_initial: bool = False, on_soft_pass=None, disparity=None):
    """Recover a stack of premultiplied RGBA layers from K views (Szeliski & Golland 1999, all stages).

    Parameters
    ----------
    views : ndarray of shape (K, H, W, 3)
        Scene-linear float views, ordered as ``positions``.
    positions : sequence of float or of (x, y) pairs, optional
        Camera positions along the baseline in view steps; default ``0 .. K-1``.
    reference : int, optional
        Index of the view the virtual camera sits at; default the middle view.
    disparities : array_like of shape (D,)
        Increasing disparities of the planes, px per view step.
    config : SolveConfig, optional
        Settings; default the :data:`~vfxstereo.config.DEFAULT_PRESET` (``robust``) preset.
    progress : callable, optional
        ``progress(stage, done, total)`` for every stage and iteration; stages ``"passes"``, ``"sweep"``
        (per plane), ``"aggregate"``, ``"select"``, ``"visibility"``, ``"complete"``, ``"refine"`` (per
        step) and ``"subpixel"``, as far as the configuration runs them.
    camera : Camera, optional
        A full camera description (general matrices, focal, baseline); replaces ``positions``/``reference``.
    return_details : bool
        Return a :class:`SolveResult` (stack, sub-pixel disparity, front and hidden winners, selected and
        initial volumes, timings).
    keep_initial : bool
        Robust depth: keep the volume before the soft edges in ``SolveResult.initial`` (a copy of the stack's
        size; without it ``initial`` is None and the soft edges are written in place).
    on_soft_pass : callable, optional
        Robust depth: handed to :func:`vfxstereo.softedge.soften_edges_passes` as ``on_pass`` (diagnostics).
    disparity : ndarray of shape (H, W), optional
        Robust depth: the reference camera's disparity (px per view step, finite everywhere) to build the layers
        from instead of the depth stage's -- a depth map from another tool, or one solved before
        (``SolveResult.disparity``: the same settings then give the same stack).

    Returns
    -------
    LayerStack, or SolveResult with ``return_details``.
    """
    from vfxstereo import aggregate, refine, select, subpixel, sweep, visibility

    config = fit_to_memory(config or SolveConfig.preset(DEFAULT_PRESET))
    views = _check_views(views)
    disparities = _check_disparities(disparities)
    n_views, h, w = views.shape[:3]
    if camera is None:
        pos = list(range(n_views)) if positions is None else positions
        if len(pos) != n_views:
            raise VfxStereoError(f"{n_views} views need {n_views} positions, got {len(pos)}")
        camera = Camera.from_positions(pos, reference)
    elif camera.K != n_views:
        raise VfxStereoError(f"the camera describes {camera.K} views, but {n_views} were given")
    check_memory((h, w), len(disparities), n_views, **memory_settings(config))
    warper = Warper(camera, disparities, (h, w))
    ref = views[_reference_index(camera)]
    ref_view = camera.reference_index  # the view the virtual camera is, if any
    white = max(1.0, float(views.max()))
    timings: dict[str, float] = {}

    def timed(stage, fn, *args, **kwargs):
        t0 = time.perf_counter()
        out = fn(*args, **kwargs)
        timings[stage] = timings.get(stage, 0.0) + time.perf_counter() - t0
        return out

    check_soft_rounds(config.soft_rounds)
    if config.depth == "robust":
        return _solve_robust(views, warper, camera, disparities, config, progress=progress, white=white,
                             disparity=disparity,
                             timed=timed, timings=timings, return_details=return_details,
                             keep_initial=keep_initial, on_soft_pass=on_soft_pass)
    if config.depth != "variance":
        raise VfxStereoError(f"unknown depth method {config.depth!r}; choose 'variance' or 'robust'")
    if disparity is not None:
        raise VfxStereoError("a given disparity map needs the robust depth stage (preset 'robust'); the paper's "
                             "depth decides the layers itself")
    agg_settings = ({"a": config.a, "b": config.b, "c": config.c, "sigma_max": config.sigma_max,
                     "iterations": config.aggregation_iterations, "limit_centre": config.limit_centre,
                     "progress": progress}
                    if config.aggregation == "szeliski1999" else dict(config.extra.get("aggregation", {})))
    sel_settings = {"theta_min": config.theta_min, "theta_s": config.theta_s,
                    "require_clear": config.require_clear, "clear_ratio": config.clear_ratio,
                    "matching": config.matching}

    def statistics(vis):
        stats = timed("sweep", sweep.sweep, views, warper, visibility=vis, matching=config.matching,
                      min_votes=config.min_votes, tolerant=config.tolerant_matching, progress=progress)
        return stats, timed("aggregate", aggregate.aggregate, stats.var, method=config.aggregation,
                            **agg_settings)

    vis = None
    hidden = hstats = None
    passes = int(config.visibility_iterations) + 1
    for p in range(passes):
        report(progress, "passes", p, passes)
        front_vis = vis
        if vis is not None and config.reference_votes and ref_view is not None:
            front_vis = list(vis)  # the reference votes at every depth of its own pixel (see config)
            front_vis[ref_view] = np.ones_like(vis[ref_view])
        stats, cost = statistics(front_vis)
        sel = timed("select", select.select, stats.mean, cost, ref, **sel_settings)
        report(progress, "select", 1, 1)
        rgba = sel.rgba
        hidden = None
        if vis is not None and config.hidden_layers:
            if front_vis is vis:  # the paper's weighting already keeps the reference out of hidden cells
                hstats, hcost = stats, cost
            else:
                hid_vis = list(vis)
                hid_vis[ref_view] = np.zeros_like(vis[ref_view])  # the reference cannot see behind its front
                hstats, hcost = statistics(hid_vis)
            hsel = timed("select", select.select_behind, hstats.mean, hcost, sel.winner, ref, **sel_settings)
            hidden = hsel.winner
            rgba = rgba + hsel.rgba  # disjoint cells: hidden ones lie strictly behind the front winner
        if p < passes - 1:  # Section 5: visibility by re-projection feeds the next sweep
            vis, _ = timed("visibility", visibility.view_visibilities, rgba, warper,
                           simple=config.binary_visibility)
            report(progress, "visibility", p + 1, passes - 1)
    report(progress, "passes", passes, passes)
    selected = rgba
    initial = selected
    if config.fill_undecided or config.extend_background > 0 or config.soft_alpha < 1.0:
        initial, _ = timed("complete", select.complete, selected, sel.winner, stats.mean,
                           behind_mean=None if hidden is None else hstats.mean,
                           behind_weight=None if hidden is None else hstats.weight,
                           fill=config.fill_undecided, extend=int(config.extend_background),
                           soft_alpha=float(config.soft_alpha))
        report(progress, "complete", 1, 1)
    rgba = initial
    if config.refine_iterations > 0 and any(config.lambdas):
        weights = timed("refine", border_weights, warper) if config.border_weights else None
        rgba = timed("refine", refine.refine, initial, disparities, views, warper,
                     config.refine_config(white=white), view_weights=weights, progress=progress)
    if config.edge_matting:  # beyond the paper: per-pixel (colour, alpha) of the soft-edge band
        from vfxstereo import matting

        rgba = timed("matting", matting.matte_edges, rgba, disparities, views, warper, white=white,
                     progress=progress)

    stack = LayerStack(rgba, disparities, camera, metadata={
        "solver": "szeliski-golland-1999",
        "settings": config.to_dict(),
        "selected_fraction": float(sel.fraction),
        "hidden_cells": 0 if hidden is None else int((hidden >= 0).sum()),
        "colorspace": "scene-linear Rec.709",
    }, white=white, plate=ref if ref_view is not None else None)
    # Reported disparity: the selection's winner, or where it left the column undecided, the front-most
    # opaque layer of the refined stack; then the parabola of Section 8.1 through the aggregated variance.
    index = sel.winner.copy()
    front = stack.disparity_map(0.5)
    fill = (index < 0) & np.isfinite(front)
    index[fill] = np.searchsorted(disparities, front[fill])
    if config.subpixel:
        disparity = timed("subpixel", subpixel.subpixel_disparity, cost, disparities, index)
        report(progress, "subpixel", 1, 1)
    else:
        disparity = np.where(index >= 0, disparities[np.maximum(index, 0)], np.nan).astype(np.float32)
    if not return_details:
        return stack
    return SolveResult(stack=stack, disparity=disparity, winners=sel.winner, initial=initial, selected=selected,
                       hidden=hidden, timings=timings)


def soft_front(rgba: np.ndarray, disparities: np.ndarray, index: np.ndarray, planes: np.ndarray | None = None, *,
               which: bool = False) -> np.ndarray:
    """Where the soft edges moved the front surface (``SolveConfig.soft_rounds``).

    (H, W) bool: the pixels whose front-most layer with alpha > 0.5 is not the plane ``index`` of the map they
    started from; with ``which``, that layer's plane index into ``disparities`` (``index`` where no layer is
    above 0.5). ``planes``: the stack's planes, where it keeps only some (None: all of ``disparities``).
    """
    from vfxstereo.layers import topmost

    front = topmost(rgba[..., 3] > 0.5, index, planes)
    return front if which else front != index


def _solve_robust(views, warper, camera, disparities, config, *, progress, white, timed, timings, return_details,
                  keep_initial, on_soft_pass=None, disparity=None):
    """``solve`` with the robust depth stage (:mod:`vfxstereo.depth`) in place of the paper's sections 4-5.

    depth -> initial volume (front surface and hidden layers, :mod:`vfxstereo.layers`) -> refinement (Eqs.
    9-13, A2, if the configuration asks for it) -> edge matting.
    """
    from vfxstereo import depth, layers, refine

    ref_view = camera.reference_index
    if ref_view is None:
        raise VfxStereoError("the robust depth stage needs the virtual camera at one of the views "
                             "(a reference view); use the paper's depth (preset 'paper') for a virtual camera")
    plate = views[ref_view]
    if disparity is None:
        res = timed("depth", depth.robust_depth, views, warper, ref_view, config=config.depth_config,
                    progress=progress)
    else:
        given = np.asarray(disparity, np.float32)
        finite = bool(np.isfinite(given).all())
        if given.shape != plate.shape[:2] or not finite:
            raise VfxStereoError(f"the disparity map must be {plate.shape[0]}x{plate.shape[1]} and finite "
                                 f"everywhere, got {'x'.join(map(str, given.shape))}"
                                 f"{'' if finite else ' with NaN or inf'}")
        res = depth.DepthResult(disparity=given, index=layers.plane_index(given, disparities),
                                reliable=np.ones(given.shape, bool))
    for name, seconds in res.timings.items():
        timings[f"depth.{name}"] = seconds
    index = res.index
    planes = None  # all
    if not config.keep_empty_planes and config.refine_iterations == 0 and not config.edge_matting:
        planes = np.unique(index[index >= 0])  # hidden cells and soft edges lie on the depth map's planes too
    n_layers = len(disparities) if planes is None else len(planes)
    check_memory(views.shape[1:3], len(disparities), views.shape[0], depth="robust",
                 strip_memory=config.depth_config.strip_memory, layers=n_layers, soft_edge=_soft_edge_memory(config))
    zbuffers = [depth.zbuffer(warper, res.disparity, k) for k in range(views.shape[0])]  # hidden layers, edges
    gains = timed("layers", layers.view_gains, views, warper, ref_view, res.disparity)
    initial = timed("layers", layers.initial_volume, views, warper, ref_view, res.disparity, index, gains=gains,
                    zbuffers=zbuffers, planes=planes, white=white)
    report(progress, "layers", 1, 1)
    hidden_cells = int(sum(((layer[..., 3] > 0) & (i < index)).sum() for i, layer in
                           zip(np.arange(len(disparities)) if planes is None else planes, initial, strict=True)))
    rgba = initial
    refining = config.refine_iterations > 0 and any(config.lambdas)  # it starts from the volume before soft edges
    in_place = config.soft_edges and not (keep_initial or refining)
    if config.soft_edges:
        from vfxstereo import softedge

        rgba, info, _ = timed("soft-edges", softedge.soften_edges_passes, rgba, views, warper, ref_view,
                              res.disparity, index, params=config.soft_edge, gains=gains, zbuffers=zbuffers,
                              progress=progress, inplace=in_place, planes=planes, white=white,
                              on_pass=on_soft_pass, third_layer=False)
        layers.clamp(rgba, white)
        # later rounds: the layers and soft edges again, from the front surface the passes left (the views'
        # gains stay the first map's); the result's disparity stays the depth stage's
        d_round, i_round = res.disparity, index
        for _ in range((config.soft_rounds if views.shape[0] >= 3 else 1) - 1):
            front = soft_front(rgba, disparities, i_round, planes, which=True)
            moved = front != i_round
            if not moved.any():
                break
            i_round = front
            d_round = np.where(moved, disparities[np.maximum(front, 0)], d_round).astype(np.float32)
            zbuffers = [depth.zbuffer(warper, d_round, k) for k in range(views.shape[0])]
            rgba = timed("layers", layers.initial_volume, views, warper, ref_view, d_round, i_round,
                         gains=gains, zbuffers=zbuffers, planes=planes, white=white, out=rgba)  # no second volume
            rgba, info, _ = timed("soft-edges", softedge.soften_edges_passes, rgba, views, warper, ref_view,
                                  d_round, i_round, params=config.soft_edge, gains=gains, zbuffers=zbuffers,
                                  progress=progress, inplace=True, planes=planes, white=white, third_layer=False)
            layers.clamp(rgba, white)
        # the third layer last: a later round would read its soft middle surface as a front that moved
        timed("soft-edges", softedge.write_middle_layer, rgba, info, views, warper, ref_view, i_round,
              params=config.soft_edge, planes=planes)
        layers.clamp(rgba, white)
    if refining:
        rgba = timed("refine", refine.refine, initial, disparities, views, warper,
                     config.refine_config(white=white), progress=progress)
    if config.edge_matting:
        from vfxstereo import matting

        rgba = timed("matting", matting.matte_edges, rgba, disparities, views, warper, white=white,
                     progress=progress)
    stack = LayerStack(rgba, disparities if planes is None else disparities[planes], camera, metadata={
        "solver": "vfxstereo-robust",
        "settings": config.to_dict(),
        "hidden_cells": hidden_cells,
        "colorspace": "scene-linear Rec.709",
    }, white=white, plate=plate)
    if not return_details:
        return stack
    initial = None if in_place else initial
    return SolveResult(stack=stack, disparity=res.disparity, winners=index, initial=initial, selected=initial,
                       hidden=None, timings=timings)
