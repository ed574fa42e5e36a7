"""The robust depth stage's whole-plate steps 9-20: the map of :mod:`vfxstereo.depth`'s steps 1-8, corrected.

:func:`vfxstereo.depth.robust_depth` solves steps 1-8 in horizontal strips when the cost volumes exceed
their memory budget; :func:`_reopened` then runs these steps once on the whole plate's map:

9. Optionally (``reopen``, :func:`reopen_gaps`; on in the ``soft`` preset), reopened gaps: on the whole plate,
   a pixel moves back to the farthest surface within 8-64 px where, pixel by pixel (3 x 3), two views see that
   surface with the plate's colour and neither the pixel's own depth nor a nearer surface around explains it
   as well: the gaps of leaves, a canopy or wicker that the window of steps 1-3 filled with the foreground's
   depth. On a stereo pair (``reopen_pair``, off by default), with the pair's one view, keeping only the moved
   groups that the other view's own map (step 6's second match) confirms (:func:`reopen_pair_checked`).
10. Colour reopening (``colour_reopen``, :func:`reopen_by_colour`), on the whole plate: a pixel whose colour is
   far more common among the farther surfaces within 40 px than on its own surface takes the depth of the
   nearest farther pixel of its colour, where the pixels so moved join a farther surface already in the map:
   the rims and gaps the window of steps 1-3 grew over, and a stereo pair's half-occluded strips, where no view
   can place the pixel and its colour is the only evidence left.
11. Thin structures (``thin``, :func:`recover_thin`), on the whole plate, with three or more other views, some on
   each side of the reference: a pixel that every other view sees with the plate's colour on a nearer plane, and no
   view the map says sees its own depth does, takes that plane, in thin or mostly unique groups: a grille's bars,
   a wire or twigs over a textured background, which the window of steps 1-3 and the median gave the
   background's depth (the opposite of steps 9 and 10, and only where all the views agree, since nothing hides a
   near structure from them).
12. Plain joins (``join``, :func:`join_plain`), on the whole plate: inside a plain region of one colour, the
   nearer side of a depth step takes the farther side's depth, flooding from farther pixels whose depth some
   texture nearby supports, except on a surface the map already carries smoothly to that depth (a slope) or
   where the moves outnumber half the surface that had the depth, and wherever the views do not contradict
   the move (:func:`views_confirm`): the plain wall beside a textured subject, or between a grille's bars, that
   the window and SGM gave the subject's depth.
13. Edge ownership (``own``, :func:`own_edges`), on the whole plate: the reverse of step 12. A plain region takes
   the depth of a textured edge beside it that is nearer than the region and than the texture beyond the edge
   (the colour step moves with the plain side, so it belongs to it), where that edge runs over 8 rows or more,
   the region is solid and not at the depth of the texture beyond, and the views do not contradict the move:
   a plain board in front that the flat-surface bias put at the back, where no half-occluded strip tells
   (a stereo pair whose board meets the frame or hides nothing the other view sees).
14. Grille cells (``cells``, :func:`grille_cells`), on the whole plate: a plain region that a
   rival-gated map (one more SGM over the same cost, the flat-surface bias also on pixels a far depth explains
   about as well) puts farther takes that depth where the plain pixels beyond its thin border mostly have its
   colour, and the views do not contradict the move: a plain wall seen through the cells of a grille or fence,
   not a plain subject (beyond whose outline lies something else). Where its colour across the bars already
   lies between it and that depth, on a mostly plain surface of the map (``cells_own``), it takes that depth
   instead: a plain card between the grille and the wall, placed in some of its cells.
15. Spread cells (``cells_spread``, :func:`spread_cells`), on the whole plate: round by round, a plain region
   whose plain pixels across its bars mostly have its colour, some of them farther, takes their depth, where
   the views do not contradict the move: the wall's depth carried from cell to cell across a grille, to the
   cells step 14's map missed.
16. Rims (``colour_again``), around the cells steps 14 and 15 sent back: step 10 once more, with a lower
   ratio: the rim of wall colour the window left around each bar goes back with its cell. Then colour forward
   (``colour_forward``, :func:`reopen_by_colour` of the negated map), on the whole plate: step 10 the other way
   round, where the views do not contradict the move: a pixel whose colour is far more common among the nearer
   surfaces within 40 px than at its own depth takes the depth of the nearest nearer pixel of its colour, where
   the pixels so moved join a nearer surface already in the map: the part of a plain card or board beside a
   textured background, across an edge that matching along the rows cannot place (its top and bottom), that the
   window gave the background's depth.
17. Whole boards (``boards``, :func:`whole_boards`), on the whole plate: a plain surface of one colour that the
   map splits between a near part and a farther rest takes the near part's plane throughout, where that near
   part is the nearest thing around it and the views do not contradict the move: a plain board in front whose
   edges placed part of it, the rest sent back by the flat-surface bias (a stereo pair's sign or panel, where
   steps 6 and 13 found no edge to claim the rest).
18. Level rails (``rails``, :func:`level_rails`), on the whole plate: a thin level line whose crossings the map
   placed nearer than what lies around the line, at four or more places, takes their depth along its length,
   where the line has their colour and the views do not contradict the move: a grille's bar, a rail or a wire
   along a horizontal rig's baseline, which shifts along itself, so that matching along the rows cannot see it.
19. Rim colours (``rim_ratio``, :func:`rim_colours`), on the whole plate, before step 20: a pixel on the near side
   of a depth jump (3 x 3) takes the back's disparity where its colour is nearer the mean colour of the back side
   than of the front side (7 x 7, the pixels at jumps left out) by more than ``rim_ratio`` (3) in distance; two
   rounds.
   The one- and two-pixel rim of background the window of steps 1-3 leaves around a subject on either side
   (on Middlebury four fifths of the bad pixels near depth jumps are too near, and most of those lie within
   2 px of the surface whose depth they took). Not checked against the views: where it acts, the views are
   what put the rim in front. ``DepthConfig.rim_ratio`` has the numbers.
20. Level strips (``strips``, :func:`level_strips`), on the whole plate, after step 19: a strip at most 3 rows tall
   that the map puts nearer than the rows just above and below it, over 15 px or more along the row, and whose
   colour is one side's (within 0.025) and not the other's, takes that side's depth: the top or bottom edge of a
   card or board, level with a horizontal rig's baseline, that semi-global matching gave the depth of a grille's
   bars crossing it (the reverse of step 18). Not checked against the views, as step 19: they put it there.

Where the map's foreground fattening costs the z-key most (session 27, the z-key scenes that were tuning scenes
then, 68 rows): of the near-edge pixels put more than 1 px too near (19 % of the pixels within 4 px of a true
depth edge), a third have a true surface that no other view sees (the holes of wicker and foliage, the gaps
between branches, a stereo pair's half-occluded strips), and setting only those to the truth gains +2.0 /
+2.7 dB frame / band; the fattened pixels the views do see gain +0.9 / +1.1 where clean and +0.3 / +0.8 where
mixed (all of them: +2.8 / +3.8). Matching cannot decide the unseen ones, and on a plain background not the
seen ones either: with the true visibility, the plate's colour at the pixel matches the truth better than the
map's disparity for only a third of the fattened pixels. Hence step 10, which decides by colour. Its first
version also opened islands (moved pixels that join no farther surface: the holes of wicker, the gaps in hair):
+0.3 / +0.9 on those 68 rows, but -1.2 / -0.5 on the 162 rows of the scenes then held out (shelf_grille
-6.7 / -6.1 and -8.5 / -8.0, two_soft_pots K = 5 -8.5 frame, artichoke_books K = 2 -7.0 frame): a few pixels of
a solid subject whose colour is common behind it (a teddy's red stitching, a toy's dark jacket) became islands
of the wall's depth, and the soft edges then opened the subject around each new depth edge, in small-card rows
that were near-exact before. Opening islands only where a view sees the farther surface there with the
pixel's colour added almost nothing (the islands are the unseen ones). Limited to pixels within 3 px of a
farther surface instead, it gave +0.13 / +0.11 and -0.02 / +0.07. Refining edges with ``edge_refine`` puts
more pixels too near, not fewer (19 % -> 21 % of those near-edge pixels).

Where the band's error lies now (session 57, the tuning rows, the head's stacks): setting our front alpha at D to
the truth only where it is off by more than 0.5 takes the rows' mean band PSNR from 30.6 to 35.1 dB; of that, the
clear pixels we hold in front (the fattening, "clear, under an opaque front" in the benchmark's split) give +1.7
alone, the soft pixels +0.9, the solid ones lost +0.5. In eight scenes and rigs traced, 89 % of the fattening's
error lies within 3.5 px of the true front, and 97 % of it was already in the initial volume. Two kinds dominate:
gaps the map filled (a tree's and a lattice's holes, the space between a witch's legs) and plain pockets of the
wall enclosed by a subject and the frame (sheep_duck_wall's bottom corners). Tried on the head's final maps, not
kept: a plain surface (:func:`plain_surfaces`, 30 px or more) whose ring 1-3 px around lies at its depth or nearer
(90 %: enclosed), with 0.5x its size of plain pixels of its colour (within 0.03) farther within 40 px, takes their
median depth. It moved 16 regions over the tuning scenes' 58 maps: 11 wholly right (fur_grey_wall's,
koala_slope's, flowers_fence's pockets, ...), witch_monster's legs' pocket 86 % right at both rigs, 3 wrong (a
plain patch of rabbit_cream_board's near board, of a beanie_grille cell, of curls_wire_midd's card); on the 66 rows
they touch, K = 5 +0.06 / +0.16 dB, K = 2 +0.23 / +0.21 (witch_monster K = 2 d = 3 +1.0 / +3.8, rabbit_cream_board
K = 5 d = 10.5 -4.0 / -1.3, curls_wire_midd K = 2's losing row d = 3 -0.6 / -0.7), about +0.03 / +0.04 dB over the
296 tuning rows of these scenes. At K = 5 a right move can lose (witch_monster, 86 % right, -0.6 / -0.3): the soft
edges had already cleared the pocket from the views, and after the move they leave a wedge of it in front.
sheep_duck_wall's pockets are not one plain surface of the map and did not move.

The same question after the soft edges (session 58): the later stages run again from our map with one class of
its errors set to the truth (the 29 synthetic tuning scenes, 154 rows a rig, mean band dB, K = 5 / K = 2). Ours 27.91 /
25.87; the too-near pixels within 4 px of a true depth edge set right 30.55 / 28.63 (+2.64 / +2.76), the too-near
pixels farther out 28.35 / 26.82 (+0.44 / +0.95), the too-far ones 28.24 / 26.68 (+0.33 / +0.81); the true map
31.57 / 30.62, above the true-depth key's 29.12 by 2.4 / 1.5 dB, so the issue's target is within the later
stages' reach from a right map. From our map, the front's alpha at D set to the truth (our back kept) gives
33.17 / 30.23 and the true back with our alpha 26.75 / 24.80: the comp's error is the alpha's, not the back's
colour. Fixing the fattening near edges gains most on sheep_duck_wall (+8.2 / +7.4), hair_shelves (+8.1 / +6.4),
witch_monster (+5.2 / +5.2), leaves_wire_bowling (+4.9 / +4.8). hair_shelves' worst row (18.6 dB, 27.1 with
the fix) is two gaps between petals that the frame's top edge cuts (91 and 185 px of a textured window, 9.4 px
per view step behind, held at the petals' depth: 45 of the row's 66 units of band error): the views cannot see
through a gap narrower than the parallax, and within step 10's 40 px no farther pixel has the gap's colour (0 of
3 to 1 of 57), so colour cannot open it either. Its wall strip above the plush toy at the frame's right edge (438
px at the toy's depth; step 12's flood of it, 2812 px, 2790 of them right, is withheld by ``join_grow`` as in
session 31) the soft edges clear.

Step 10 on Middlebury (session 27, all 31 sets, ``--depth-only``): 9.53 -> 9.39 % bad pixels (0.48x -> 0.47x
SGBM's; the pair 14.41 -> 14.33), better on 24 sets (tsukuba 3.94 -> 3.65, Art 11.33 -> 10.98, Lampshade1 6.64
-> 6.24, Laundry 17.93 -> 17.49), worse on 5 by at most 0.07 (Plastic 34.45 -> 34.52, Cloth3 2.33 -> 2.37); the
worst ratio to SGBM 0.89x -> 0.88x (Midd1 25.74 -> 25.46). At 1920 x 1080 (z-key maps scaled up, 2 cores) the
step takes 0.8-1.2 s, against the stage's 34 s: a numba kernel over 314 window samples per pixel, run only where
something farther is within reach (25-32 % of the pixels there; 2.5 s over all of them).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from vfxstereo.depth import DepthConfig, DepthResult, local_deviation, view_sides, zbuffer
from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress, report


def _reopened(res: DepthResult, views, warper, reference: int, config: DepthConfig, progress) -> DepthResult:
    """``res`` after the whole-plate steps 9-20.

    Reopen, colour_reopen, thin, join, own, cells, spread, colour again, colour forward, boards, rails, rim colours,
    level strips.
    """
    from vfxstereo.layers import plane_index
    from vfxstereo.sweep import matching_values

    changed = False
    # the plate in sRGB, for the colour tests of steps 10, 12-18 and 20: converted once
    cells = res.cells is not None
    colour = (matching_values(views[reference], "srgb", 1.0)
              if config.colour_reopen or config.join or config.own or cells or config.colour_again > 0
              or config.colour_forward > 0 or config.boards or config.rails or config.strips else None)
    pair, res.pair = res.pair, None  # step 6's map of the pair's other view: step 9's check on a pair, then freed
    if config.reopen and config.reopen_passes > 0 and views.shape[0] - 1 >= config.reopen_views:
        t0 = time.perf_counter()
        res.disparity = reopen_gaps(views, warper, reference, res.disparity, config=config, progress=progress)[0]
        res.timings["reopen"] = time.perf_counter() - t0
        changed = True
    elif config.reopen_pair > 0 and config.reopen_passes > 0 and pair is not None and res.pair_view is not None:
        from dataclasses import replace

        t0 = time.perf_counter()
        pair_config = replace(config, reopen_views=1, reopen_ratio=config.reopen_pair)
        after = reopen_gaps(views, warper, reference, res.disparity, config=pair_config, progress=progress)[0]
        res.disparity = reopen_pair_checked(warper, res.disparity, after, res.pair_view, pair)
        res.timings["reopen"] = time.perf_counter() - t0
        changed = True
    if config.colour_reopen:
        t0 = time.perf_counter()
        res.disparity = reopen_by_colour(res.disparity, colour,
                                         radius=config.colour_radius, stride=config.colour_stride,
                                         like=config.colour_like, ratio=config.colour_ratio,
                                         jump=config.colour_jump)[0]
        res.timings["colour reopen"] = time.perf_counter() - t0
        changed = True
    checks = config.join_check and (config.join or config.own or cells or config.colour_again > 0 or config.boards
                                    or config.rails or config.colour_forward > 0)
    kept: dict = {}  # step 11's view errors of the map, for the checks of steps 12-18 while the map is unchanged
    if config.thin:
        t0 = time.perf_counter()
        thin, moved = recover_thin(views, warper, reference, res.disparity, config=config,
                                   keep=kept if checks else None)
        if moved.any():
            res.disparity = thin
            changed = True
            kept.clear()
        res.timings["thin"] = time.perf_counter() - t0

    def checked(name, t0, proposed, moved):  # steps 12-18: moves the views do not contradict
        nonlocal changed
        if moved.any() and config.join_check:
            proposed = views_confirm(views, warper, reference, res.disparity, proposed, jitter=config.reopen_jitter,
                                     ratio=config.join_ratio, floor=config.join_floor, share=config.join_share,
                                     unseen_floor=config.join_unseen,
                                     gains=kept.get("gains"),
                                     before_errors=(kept["errors"], kept["seen"]) if kept else None)
            moved = proposed != res.disparity
        if moved.any():
            res.disparity = proposed
            changed = True
            kept.clear()
        res.timings[name] = time.perf_counter() - t0

    flat = plain_pixels(colour, config.join_plain) if config.join or config.own or cells or config.boards else None
    if config.join:
        t0 = time.perf_counter()
        checked("join", t0, *join_plain(res.disparity, colour, plain=config.join_plain, like=config.join_like,
                                         jump=config.join_jump, anchor=config.join_anchor, reach=config.join_reach,
                                         grow=config.join_grow, slopes=config.join_slopes, flat=flat))
    if config.own:
        t0 = time.perf_counter()
        checked("own", t0, *own_edges(res.disparity, colour, plain=config.join_plain, like=config.join_like,
                                       jump=config.join_jump, rows=config.own_rows, cover=config.own_cover,
                                       solid=config.own_solid, margin=config.own_margin, flat=flat))
    before_cells = res.disparity
    if cells:
        t0 = time.perf_counter()
        checked("cells", t0, *grille_cells(res.disparity, res.cells, colour, flat, jump=config.cells_jump,
                                           share=config.cells_share, like=config.cells_like,
                                           ring=config.cells_ring, tolerance=1.0, join_like=config.join_like,
                                           across=config.cells_across, own_plain=config.cells_own))
        res.cells = None  # done with: not kept in the result
    if cells and config.cells_spread > 0:
        t0 = time.perf_counter()
        share = config.cells_share if config.spread_share is None else config.spread_share
        like = config.cells_like if config.spread_like is None else config.spread_like
        checked("spread", t0, *spread_cells(res.disparity, colour, flat, jump=config.cells_jump, share=share,
                                            like=like, ring=config.cells_ring,
                                            farther=config.cells_farther, rounds=config.cells_spread,
                                            join_like=config.join_like))
    sent_back = res.disparity != before_cells
    if config.colour_again > 0 and (config.colour_again_near == 0 or sent_back.any()):
        t0 = time.perf_counter()
        again, moved = reopen_by_colour(res.disparity, colour, radius=config.colour_radius,
                                        stride=config.colour_stride, like=config.colour_like,
                                        ratio=config.colour_again, jump=config.colour_jump)
        if config.colour_again_near > 0:  # only around the cells steps 14 and 15 sent back
            from scipy import ndimage

            near = ndimage.binary_dilation(sent_back, iterations=config.colour_again_near)
            moved &= near
            again = np.where(moved, again, res.disparity).astype(np.float32)
        checked("colour again", t0, again, moved)
    if config.colour_forward > 0:  # step 10 the other way: a colour that belongs to a nearer surface beside it
        t0 = time.perf_counter()
        forward, moved = reopen_by_colour(-res.disparity, colour, radius=config.colour_radius,
                                          stride=config.colour_stride, like=config.colour_like,
                                          ratio=config.colour_forward, jump=config.colour_jump)
        checked("colour forward", t0, -forward, moved)  # unmoved pixels: the map itself, negated twice
    if config.boards:
        t0 = time.perf_counter()
        checked("boards", t0, *whole_boards(res.disparity, colour, flat, jump=config.join_jump, like=config.join_like,
                                            share=config.boards_share, far=config.boards_far))
    if config.rails:
        t0 = time.perf_counter()
        checked("rails", t0, *level_rails(res.disparity, colour, jump=config.join_jump, contrast=config.rails_contrast,
                                          pieces=config.rails_pieces))
    if config.rim_ratio > 0 and config.rim_passes > 0:
        t0 = time.perf_counter()
        plate = np.asarray(views[reference][..., :3], np.float32)
        plate = plate / np.maximum(plate.reshape(-1, 3).mean(axis=0), 1e-6)  # the plate's gains weigh no channel
        rims, moved = rim_colours(res.disparity, plate, ratio=config.rim_ratio, passes=config.rim_passes,
                                  radius=config.rim_radius, jump=config.rim_jump, tolerance=config.rim_tolerance)
        if moved.any():
            res.disparity = rims
            changed = True
        res.timings["rim colours"] = time.perf_counter() - t0
    if config.strips:
        t0 = time.perf_counter()
        strips, moved = level_strips(res.disparity, colour)
        if moved.any():
            res.disparity = strips
            changed = True
        res.timings["level strips"] = time.perf_counter() - t0
    if changed:  # the planes of the map the steps left, once
        res.index = plane_index(res.disparity, warper.disparities)
    return res


JITTER_STEPS = 5
"""Samples of ``DepthConfig.reopen_jitter`` (evenly over +- it)."""


def patch_errors(views: np.ndarray, warper, reference: int, disparity: np.ndarray, gains: np.ndarray, *,
                 jitter: float = 0.0, size: int = 3) -> np.ndarray:
    """(K - 1, H, W) colour error of each other view at each reference pixel's disparity, over a small window.

    For view k (in order, the reference left out): ``|g_k I_k(u) - I_ref|^2`` with ``u`` where the pixel's own
    disparity puts it in view k (bilinear), averaged over a ``size`` x ``size`` window, the least over
    disparities within +- ``jitter`` (:data:`JITTER_STEPS` samples); inf where the pixel lands outside view k.
    """
    from scipy import ndimage

    from vfxstereo import _depth_kernels

    views = np.asarray(views, np.float32)
    K, h, w = views.shape[:3]
    ref = np.ascontiguousarray(views[reference])
    d = np.asarray(disparity, np.float32)
    shifts = np.linspace(-jitter, jitter, JITTER_STEPS) if jitter > 0 else np.zeros(1)
    out = np.full((K - 1, h, w), np.inf, np.float32)
    e = np.empty((h, w), np.float32)
    rectified = warper.shifts(reference) is not None
    if rectified:  # Eq. A1 is a shift: no homogeneous coordinates (warper.project), 2x faster at HD
        ys, xs = (g.astype(np.float32) for g in np.mgrid[0:h, 0:w])
    for n, k in enumerate(k for k in range(K) if k != reference):
        view = np.ascontiguousarray(views[k])
        gain = np.asarray(gains[k], np.float32)
        off = warper.camera.view_offset(k).astype(np.float32)
        for j in shifts:
            if rectified:
                dj = d + np.float32(j)
                u, v = xs - dj * off[0], ys - dj * off[1]
            else:
                u, v = warper.project(d + np.float32(j), k)
            inside = (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)  # False where NaN
            _depth_kernels.colour_error(view, ref, gain, u, v, e)
            err = ndimage.uniform_filter(e, size, mode="nearest") if size > 1 else e.copy()
            np.minimum(out[n], np.where(inside, err, np.inf), out=out[n])
    return out


def reopen_gaps(views: np.ndarray, warper, reference: int, disparity: np.ndarray, *,
                config: DepthConfig | None = None, progress: Progress | None = None) -> tuple[np.ndarray, int]:
    """Step 9: pixels the window and SGM gave a nearer surface's depth move back where the views say so.

    Window matching and SGM fill the gaps of a dense foreground (leaves, a canopy, wicker) and grow its
    edges: in a window that straddles a leaf, the leaf's texture wins. Pixel by pixel (3 x 3), the views
    can tell: at a gap pixel's true depth some view sees the surface behind with the plate's colour, while
    at the leaf's depth every view shows a different point of that surface. For each pixel the candidates
    are the farthest disparities within ``reopen_radii`` px (farther than it by ``reopen_jump`` or more); it
    moves to the candidate with the least error where that error, in the ``reopen_views``-th best view, is below
    ``reopen_ratio`` of its own depth's in the best view of the same views (:func:`patch_errors`), and its
    own depth's error is above the noise (``reopen_floor``, ``reopen_relative``); a view where a nearer surface
    of the map hides the pixel's own depth is left out of both; with ``reopen_nearer`` the farther surface
    must also beat the nearer ones around. Pixels only move back.
    Where nothing tells the depths apart (a plain wall) both errors are noise and nothing moves.
    Returns ``(disparity, moved)``.
    """
    from scipy import ndimage

    from vfxstereo.layers import view_gains

    config = config or DepthConfig()
    views = np.asarray(views, np.float32)
    d = np.array(disparity, np.float32, copy=True)
    if views.shape[0] - 1 < config.reopen_views:
        return d, 0
    gains = view_gains(views, warper, reference, d)
    floor = np.maximum(config.reopen_floor, config.reopen_relative * (views[reference] ** 2).sum(axis=2))
    moved = 0
    total = config.reopen_passes * (len(config.reopen_radii) + 1)
    others = [k for k in range(views.shape[0]) if k != reference]
    h, w = d.shape
    for p in range(config.reopen_passes):
        own = patch_errors(views, warper, reference, d, gains, jitter=config.reopen_jitter)
        # a view where a nearer surface hides the pixel's own depth says nothing against it (half-occlusion:
        # beside a thin wire, the one other view of a stereo pair sees the wire there)
        for n, k in enumerate(others):
            u, v = warper.project(d, k)
            ui = np.clip(np.nan_to_num(np.rint(u)), 0, w - 1).astype(np.intp)
            vi = np.clip(np.nan_to_num(np.rint(v)), 0, h - 1).astype(np.intp)
            own[n][zbuffer(warper, d, k, uv=(u, v))[vi, ui] > d + config.reopen_jump] = np.inf
        best = np.full(d.shape, np.inf, np.float32)
        to = d.copy()
        e_near = np.full(d.shape, np.inf, np.float32)  # the best of the nearer surfaces around, in any view
        if config.reopen_nearer:  # a pixel whose own depth fails may belong to a nearer surface it missed
            for r in config.reopen_radii:
                cand = ndimage.maximum_filter(d, 2 * r + 1, mode="nearest")
                nearer = cand >= d + config.reopen_jump
                if nearer.any():
                    err = patch_errors(views, warper, reference, np.where(nearer, cand, d), gains,
                                       jitter=config.reopen_jitter).min(axis=0)
                    np.minimum(e_near, np.where(nearer, err, np.inf), out=e_near)
        for n, r in enumerate(config.reopen_radii):
            cand = ndimage.minimum_filter(d, 2 * r + 1, mode="nearest")
            farther = cand <= d - config.reopen_jump
            if farther.any():
                err = patch_errors(views, warper, reference, np.where(farther, cand, d), gains,
                                   jitter=config.reopen_jitter)
                both = np.isfinite(err) & np.isfinite(own)
                e_back = np.sort(np.where(both, err, np.inf), axis=0)[config.reopen_views - 1]
                e_own = np.where(both, own, np.inf).min(axis=0)
                ok = farther & np.isfinite(e_own) & (e_back < config.reopen_ratio * np.minimum(e_own, e_near))
                ok &= e_own > floor
                ok &= e_back < best
                best[ok] = e_back[ok]
                to[ok] = cand[ok]
            report(progress, "reopen", p * (len(config.reopen_radii) + 1) + n + 2, total)
        move = np.isfinite(best)
        if not move.any():
            break
        moved += int(move.sum())
        d[move] = to[move]
        if move.sum() < config.reopen_settle * d.size:
            break  # the next pass would only see the few neighbours of these
    report(progress, "reopen", total, total)
    return d, moved


def reopen_pair_checked(warper, before: np.ndarray, after: np.ndarray, k: int, pair: np.ndarray, *,
                        share: float = 0.0, island: int = 8) -> np.ndarray:
    """Step 9 on a stereo pair: ``after`` with the moved groups the other view's own map does not confirm put back.

    A group (8-connected pixels where ``after`` differs from ``before``) stays where at least ``share`` of its
    pixels (and at least one) land in view ``k`` (at their new disparity) within one pixel (along the row) of a
    pixel whose own disparity in ``pair`` (view ``k``'s map as a reference of its own) is the new one, within one
    pixel of view ``k``: both views' maps then place those pixels on the farther surface. The pair's one view
    matches a thin structure's or an edge's pixels at a farther depth by chance, and there the other view's map,
    fattened as the reference's is, still has the near surface. A group of fewer than ``island`` pixels must
    also join a farther surface of the map (a pixel beside it at its depth, within a pixel): a few pixels sent
    back inside a solid subject make depth edges that the soft edges then open the subject around.
    """
    from scipy import ndimage

    before = np.asarray(before, np.float32)
    after = np.asarray(after, np.float32)
    moved = after != before
    if not moved.any():
        return after
    h, w = after.shape
    u, v = warper.project(after, k)
    ys, xs = np.nonzero(moved)
    new = after[ys, xs]
    uu, vv = u[ys, xs], v[ys, xs]
    inside = np.isfinite(uu) & np.isfinite(vv) & (vv > -0.5) & (vv < h - 0.5)
    row = np.clip(np.rint(np.nan_to_num(vv)), 0, h - 1).astype(np.int64)
    col = np.rint(np.nan_to_num(uu)).astype(np.int64)
    scale = float(np.abs(warper.camera.view_offset(k)).max())
    agree = np.zeros(len(ys), bool)
    for du in (-1, 0, 1):
        c = col + du
        ok = inside & (c >= 0) & (c < w)
        agree |= ok & (np.abs(pair[row, np.clip(c, 0, w - 1)] - new) * scale <= 1.0)
    labels, n = ndimage.label(moved, structure=np.ones((3, 3), bool))
    size = np.bincount(labels[ys, xs], minlength=n + 1)
    keep = np.bincount(labels[ys, xs][agree], minlength=n + 1) >= np.maximum(share * size, 1)
    small = size < island
    if small[1:].any():  # a few pixels that join no farther surface: an island inside a subject
        far = ndimage.maximum(after, labels, index=np.arange(1, n + 1))  # the group's nearest new depth
        touching = ndimage.maximum_filter(labels, 3)
        by, bx = np.nonzero(~moved & (touching > 0))
        group = touching[by, bx]
        joins = np.zeros(n + 1, bool)
        joins[np.unique(group[before[by, bx] <= far[group - 1] + 1.0])] = True
        keep &= ~small | joins
    keep[0] = False
    return np.where(keep[labels], after, before).astype(np.float32)


def colour_offsets(radius: int, stride: int) -> np.ndarray:
    """The window of :func:`reopen_by_colour`: (dy, dx) on a ``stride`` grid within ``radius``, nearest first."""
    r = np.arange(-radius, radius + 1, stride)
    dy, dx = np.meshgrid(r, r, indexing="ij")
    keep = dy ** 2 + dx ** 2 <= radius ** 2
    off = np.stack([dy[keep], dx[keep]], axis=1).astype(np.int64)
    return np.ascontiguousarray(off[np.argsort((off ** 2).sum(axis=1), kind="stable")])


def colour_shares_reference(disparity: np.ndarray, colour: np.ndarray, offsets: np.ndarray, like: float,
                            jump: float) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy :func:`vfxstereo._depth_kernels.colour_shares`, the reference its kernel is tested against."""
    d = np.asarray(disparity, np.float64)
    c = np.asarray(colour, np.float64)
    h, w = d.shape
    target = np.full((h, w), np.nan)
    counts = np.zeros((h, w, 4), np.int64)
    for oy, ox in offsets:
        ys, xs = np.arange(h) + oy, np.arange(w) + ox
        iy, ix = (ys >= 0) & (ys < h), (xs >= 0) & (xs < w)
        inside = iy[:, None] & ix[None, :]
        dq = np.full((h, w), np.nan)
        dq[np.ix_(iy, ix)] = d[np.ix_(ys[iy], xs[ix])]
        cq = np.full(c.shape, np.inf)
        cq[np.ix_(iy, ix)] = c[np.ix_(ys[iy], xs[ix])]
        alike = inside & (np.abs(cq - c) < like).all(axis=-1)
        back = inside & (dq < d - jump)
        same = inside & ~back & (np.abs(dq - d) <= 0.5 * jump)
        counts[..., 0] += back & alike
        counts[..., 1] += back
        counts[..., 2] += same & alike
        counts[..., 3] += same
        first = back & alike & np.isnan(target)
        target[first] = dq[first]
    return target, counts


def reopen_by_colour(disparity: np.ndarray, colour: np.ndarray, *, radius: int = 40, stride: int = 4,
                     like: float = 0.04, ratio: float = 4.0, jump: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """Move a pixel to the farther surface beside it when its colour belongs there and not to its own surface.

    Over a window of ``radius`` px (sampled every ``stride``): the pixel's colour (every channel within ``like``)
    must be more than ``ratio`` times as common among the pixels farther than it by more than ``jump`` as among
    those at its own depth. It then takes the disparity of the nearest farther pixel of its colour -- never a
    nearer one. Only moves that join a farther surface already in the map are kept: a connected group of moved
    pixels must border a pixel farther than the group's front by ``jump`` (an island inside a surface would make
    a new depth edge there that nothing else supports). Returns ``(disparity, moved)``.
    """
    from scipy import ndimage

    from vfxstereo import _depth_kernels

    d = np.ascontiguousarray(disparity, np.float32)
    h, w = d.shape
    target = np.empty((h, w), np.float32)
    counts = np.empty((h, w, 4), np.int32)
    # only pixels with something farther within reach can move (a square of the window's reach: a superset)
    active = d - ndimage.minimum_filter(d, 2 * radius + 1, mode="nearest") > jump
    _depth_kernels.colour_shares(d, np.ascontiguousarray(colour, np.float32), colour_offsets(radius, stride),
                                 np.float32(like), np.float32(jump), active, target, counts)
    nb, NB, nf, NF = (counts[..., i].astype(np.float64) for i in range(4))
    move = (nb > 0) & (nb / np.maximum(NB, 1) > ratio * nf / np.maximum(NF, 1)) & np.isfinite(target)
    labels, n = ndimage.label(move, structure=np.ones((3, 3), bool))
    if n:
        front = ndimage.minimum(d, labels, index=np.arange(1, n + 1))
        touching = ndimage.maximum_filter(labels, 3)  # a border pixel next to two groups: the later one's label
        ys, xs = np.nonzero(~move & (touching > 0))
        group = touching[ys, xs]
        keep = np.zeros(n + 1, bool)
        keep[np.unique(group[d[ys, xs] < front[group - 1] - jump])] = True
        move &= keep[labels]
    return np.where(move, target, d).astype(np.float32), move


def rim_sides(d: np.ndarray, jump: float) -> tuple[np.ndarray, np.ndarray]:
    """The 3 x 3 minimum of ``d`` and the pixels at a jump (3 x 3 range >= ``jump``): step 19's inputs.

    The z-key benchmark measures its errors' distance to a depth jump from the same pixels.
    """
    from scipy import ndimage

    lo = ndimage.minimum_filter(d, size=3, mode="nearest")
    return lo, ndimage.maximum_filter(d, size=3, mode="nearest") - lo >= jump


def rim_colours(disparity: np.ndarray, colour: np.ndarray, *, ratio: float = 3.0, passes: int = 2,
                radius: int = 3, jump: float = 1.5, tolerance: float = 0.5,
                least: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Step 19: the near-side rim of each depth jump goes to the back where its colour is the back's.

    A pixel whose 3 x 3 neighbourhood holds a disparity ``jump`` or more below its own (the near side of a jump)
    takes that farthest disparity where its colour is nearer the back side's mean colour than the front side's
    by more than ``ratio`` (distances). The sides: the pixels of the (2 ``radius`` + 1)^2 window that are not at
    a jump themselves, within ``tolerance`` of the pixel's disparity (front) or of the back's; each needs
    ``least`` pixels. ``passes`` rounds (a fattened rim 2 px wide goes in two). Pixels only move back.
    Returns ``(disparity, moved)``.
    """
    from vfxstereo import _depth_kernels

    before = np.ascontiguousarray(disparity, np.float32)
    c = np.ascontiguousarray(colour, np.float32)
    d = before
    for _ in range(passes):
        lo, edge = rim_sides(d, jump)
        out = np.empty_like(d)
        _depth_kernels.rim_colours(d, lo, edge, c, np.float32(jump), np.float32(tolerance), float(ratio),
                                   int(radius), int(least), out)
        if np.array_equal(out, d):
            break
        d = out
    return d, d != before


def rim_colours_reference(disparity: np.ndarray, colour: np.ndarray, *, ratio: float = 3.0, passes: int = 2,
                          radius: int = 3, jump: float = 1.5, tolerance: float = 0.5,
                          least: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy :func:`rim_colours`, the reference its kernel is tested against."""
    before = np.asarray(disparity, np.float32)
    c = np.asarray(colour, np.float64)
    d = before.copy()
    for _ in range(passes):
        lo, edge = rim_sides(d, jump)
        new = d.copy()
        for y, x in zip(*np.nonzero(d - lo >= jump), strict=True):
            f, b = d[y, x], lo[y, x]
            win = (slice(max(y - radius, 0), y + radius + 1), slice(max(x - radius, 0), x + radius + 1))
            off = ~edge[win]
            front, back = off & (np.abs(d[win] - f) <= tolerance), off & (np.abs(d[win] - b) <= tolerance)
            if front.sum() < least or back.sum() < least:
                continue
            ef = np.linalg.norm(c[y, x] - c[win][front].mean(axis=0))
            eb = np.linalg.norm(c[y, x] - c[win][back].mean(axis=0))
            if ratio * eb < ef:
                new[y, x] = b
        d = new
    return d, d != before


THIN_CHUNK = 65536
"""Candidate pixels :func:`recover_thin` scores at a time (their errors on every plane: D x 256 KiB)."""


def recover_thin(views: np.ndarray, warper, reference: int, disparity: np.ndarray, *,
                 config: DepthConfig | None = None, gains: np.ndarray | None = None,
                 keep: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Step 11: bring back thin near structures the map lost (``DepthConfig.thin``).

    A grille's bar or a wire a few px wide over a textured background is outvoted in the census window and the
    SGM paths by the background around it, and the median removes what is left: the map gives it the
    background's depth, and a z-keyed element between them shows over the bar. Pixel by pixel the views still
    tell: on the bar's plane *every* other view sees the plate's colour (nothing is in front of a near
    structure), while at the map's depth none of the views that the map says see that point does.

    For each pixel seen at its own disparity (the map's z-buffers, two plane steps of tolerance) by a view on
    each side of the reference: ``e_own``, the least over those views of ``|g_k I_k - I_ref|^2`` at its disparity
    (bilinear, within ``reopen_jitter``; ``g_k`` :func:`vfxstereo.layers.view_gains`); and per plane the
    *largest* such error over all other views (:func:`plane_errors`). The best plane nearer by ``thin_jump``
    wins where ``e_own > thin_ratio * best + thin_floor``. Groups of such pixels are kept when they are thin
    (``thin_width``) or mostly unique (``thin_unique``, ``thin_share``), and not smaller than ``thin_size``.
    Only rectified rigs with ``thin_views`` other views on both sides; otherwise nothing moves.
    Returns ``(disparity, moved)``; the input is not modified. ``keep``, if given, receives the ``gains`` and
    :func:`seen_errors` (``errors``, ``seen``) of the input map where they were computed, for
    :func:`views_confirm` to reuse while the map stays as it is.
    """
    from scipy import ndimage

    from vfxstereo.layers import view_gains

    config = config or DepthConfig()
    d0 = np.ascontiguousarray(disparity, np.float32)
    K, h, w = views.shape[:3]
    moved = np.zeros((h, w), bool)
    others = [k for k in range(K) if k != reference]
    side = view_sides(warper.camera, reference)
    if (warper.shifts(reference) is None or len(others) < config.thin_views
            or not {-1, 1} <= {side[k] for k in others}):
        return d0, moved
    views = np.asarray(views, np.float32)
    d = np.asarray(warper.disparities, np.float64)
    gains = view_gains(views, warper, reference, d0) if gains is None else np.asarray(gains, np.float32)
    errors, seen = seen_errors(views, warper, reference, d0, gains, jitter=config.reopen_jitter)
    if keep is not None:
        keep.update(gains=gains, errors=errors, seen=seen)
    sides = np.array([side[k] for k in others])
    both = seen[sides < 0].any(axis=0) & seen[sides > 0].any(axis=0)
    own = np.where(seen, errors, np.inf).min(axis=0)
    cand = both & np.isfinite(own) & (own > config.thin_floor)
    if not cand.any():
        return d0, moved
    cy, cx = np.nonzero(cand)
    best_i = np.empty(len(cy), np.int64)
    unique = np.zeros((h, w), bool)
    planes = np.arange(len(d))[:, None]
    for a in range(0, len(cy), THIN_CHUNK):  # (D, chunk) errors at a time: bounded memory at 4K x 128 planes
        y, x = cy[a:a + THIN_CHUNK], cx[a:a + THIN_CHUNK]
        per_plane = plane_errors(views, warper, reference, y, x, gains, jitter=config.reopen_jitter,
                                 min_views=config.thin_views)
        bi = np.where(d[:, None] > d0[y, x][None, :] + config.thin_jump, per_plane, np.inf).argmin(axis=0)
        best = per_plane[bi, np.arange(len(y))]
        second = np.where(np.abs(planes - bi[None, :]) >= 2, per_plane, np.inf).min(axis=0)
        go = np.isfinite(best) & (own[y, x] > config.thin_ratio * best + config.thin_floor)
        unique[y, x] = go & (second > config.thin_unique * best + config.thin_floor)
        moved[y[go], x[go]] = True
        best_i[a:a + THIN_CHUNK] = bi
    labels, n = ndimage.label(moved, structure=np.ones((3, 3), bool))
    if n == 0:
        return d0, moved
    size = np.bincount(labels.ravel(), minlength=n + 1)
    width = np.asarray(ndimage.maximum(ndimage.distance_transform_edt(moved), labels, np.arange(n + 1)))
    keep = (size >= config.thin_size) & ((np.bincount(labels.ravel(), unique.ravel(), minlength=n + 1)
                                          >= config.thin_share * size) | (width <= config.thin_width))
    keep[0] = False
    moved = keep[labels]
    target = np.full((h, w), np.nan, np.float32)
    target[cy, cx] = d[best_i]
    return np.where(moved, target, d0).astype(np.float32), moved


def plane_errors(views: np.ndarray, warper, reference: int, ys: np.ndarray, xs: np.ndarray, gains: np.ndarray,
                 *, jitter: float = 0.0, min_views: int = 1) -> np.ndarray:
    """(D, N) how well each plane explains reference pixels ``(ys, xs)`` in all the other views (step 11).

    Per view: ``|g_k I_k(u) - I_ref|^2`` with ``u`` where the plane puts the pixel in view k (bilinear), the
    least over the plane's disparity within +- ``jitter`` (:data:`JITTER_STEPS` samples) that lands inside the
    view; per plane, the largest of those over the views, inf where fewer than ``min_views`` views have one.
    Rectified rigs only (a numba kernel; :func:`plane_errors_reference` is its plain numpy reference).
    """
    from vfxstereo import _depth_kernels

    if warper.shifts(reference) is None:
        raise VfxStereoError("plane_errors: rectified rigs only")
    K = views.shape[0]
    others = np.array([k for k in range(K) if k != reference], np.int64)
    offsets = np.array([warper.camera.view_offset(k) for k in range(K)], np.float64).reshape(K, 2)
    shifts = np.linspace(-jitter, jitter, JITTER_STEPS) if jitter > 0 else np.zeros(1)
    out = np.empty((warper.D, len(ys)), np.float32)
    # the views as they are (no copy when float32 and contiguous: called per chunk, 0.4 GB a copy at 4K x 5)
    _depth_kernels.plane_errors(np.ascontiguousarray(views, np.float32), int(reference), others,
                                np.ascontiguousarray(gains, np.float32), offsets, np.asarray(ys, np.int64),
                                np.asarray(xs, np.int64), np.asarray(warper.disparities, np.float64), shifts,
                                int(min_views), out)
    return out


def plane_errors_reference(views: np.ndarray, warper, reference: int, ys: np.ndarray, xs: np.ndarray,
                           gains: np.ndarray, *, jitter: float = 0.0, min_views: int = 1) -> np.ndarray:
    """Plain numpy :func:`plane_errors`: :func:`patch_errors` of a constant map per plane (whole plate)."""
    h, w = views.shape[1:3]
    out = np.empty((warper.D, len(ys)), np.float32)
    for i, di in enumerate(warper.disparities):
        e = patch_errors(views, warper, reference, np.full((h, w), di, np.float32), gains, jitter=jitter, size=1)
        e = e[:, ys, xs]
        fin = np.isfinite(e)
        out[i] = np.where(fin.sum(axis=0) >= min_views, np.where(fin, e, 0.0).max(axis=0), np.inf)
    return out


def anchored(disparity: np.ndarray, textured: np.ndarray, reach: int, tolerance: float = 1.0) -> np.ndarray:
    """(H, W) bool: pixels with a ``textured`` pixel within ``tolerance`` of their disparity around them.

    The window is the (2 ``reach`` + 1)-px square: a depth some texture nearby supports, not only the smoothness
    and the flat-surface bias that carry a depth over plain pixels.
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32)
    out = np.zeros(d.shape, bool)
    size = 2 * int(reach) + 1
    for v in np.unique(np.rint(d)):
        here = np.abs(d - v) <= 0.5
        if not here.any():
            continue
        support = (textured & (np.abs(d - v) <= tolerance)).astype(np.float32)
        near = ndimage.uniform_filter(support, size, mode="constant") > 0.5 / size ** 2
        out |= here & near
    return out


def _along_row(mask: np.ndarray, step: int, reach: int = 3) -> np.ndarray:
    """``mask`` true at x + step, x + 2 step, ... or x + ``reach`` step along the row (``step`` +1 or -1)."""
    out = np.zeros_like(mask)
    for k in range(1, reach + 1):
        if step > 0:
            out[:, :-k] |= mask[:, k:]
        else:
            out[:, k:] |= mask[:, :-k]
    return out


WEDGE = 8
"""Step 13 seeds its flood up to this far (px) from a ridge along the row, past the plain pixels the window already
gave the ridge's depth."""


def edge_ridges(disparity: np.ndarray, flat: np.ndarray, *, radius: int = 4, share: float = 0.5,
                beyond: tuple[int, int] = (3, 12), jump: float = 1.5, far: float = 0.6
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 13's claiming edges: ``(ridge, side, behind)``, (H, W) bool, int8 and float32.

    A ridge pixel is a textured (not ``flat``) pixel with a flat pixel within 3 px on one side of its row and
    texture within 3 px on the other (``side``: +1 where the texture is to the right, -1 to the left), whose depth
    less than ``share`` of the textured pixels within ``radius`` px share (within 1 px), and beyond which, ``beyond``
    px along the row on the textured side, at least 3 pixels are textured and at least ``far`` of them lie
    farther than it by more than ``jump``: an edge matched nearer than the texture it borders. ``behind``: the
    median depth of those textured pixels beyond (NaN off the ridge). A numba kernel; its numpy version is
    :func:`edge_ridges_reference`.
    """
    from vfxstereo import _depth_kernels

    d = np.ascontiguousarray(disparity, np.float32)
    ridge = np.zeros(d.shape, bool)
    side = np.zeros(d.shape, np.int8)
    behind = np.full(d.shape, np.nan, np.float32)
    _depth_kernels.edge_ridges(d, np.ascontiguousarray(flat, bool), int(radius), float(share), int(beyond[0]),
                               int(beyond[1]), np.float32(jump), float(far), ridge, side, behind)
    return ridge, side, behind


def edge_ridges_reference(disparity: np.ndarray, flat: np.ndarray, *, radius: int = 4, share: float = 0.5,
                          beyond: tuple[int, int] = (3, 12), jump: float = 1.5, far: float = 0.6
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plain numpy :func:`edge_ridges`, the reference its kernel is tested against."""
    d = np.asarray(disparity, np.float32)
    flat = np.asarray(flat, bool)
    tex = ~flat
    H, W = d.shape
    right = _along_row(flat, -1) & ~_along_row(flat, 1) & _along_row(tex, 1)  # plain left, texture right
    left = _along_row(flat, 1) & ~_along_row(flat, -1) & _along_row(tex, -1)
    ys, xs = np.nonzero(tex & (right | left))
    side = np.where(right[ys, xs], 1, -1).astype(np.int8)
    dv = d[ys, xs]
    same = np.zeros(len(ys), np.int32)
    count = np.zeros(len(ys), np.int32)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            yy, xx = ys + dy, xs + dx
            inside = (yy >= 0) & (yy < H) & (xx >= 0) & (xx < W)
            yy, xx = np.clip(yy, 0, H - 1), np.clip(xx, 0, W - 1)
            t = inside & tex[yy, xx]
            count += t
            same += t & (np.abs(d[yy, xx] - dv) <= 1.0)
    steps = np.arange(beyond[0], beyond[1] + 1)
    bx = xs[:, None] + side[:, None] * steps[None, :]
    binside = (bx >= 0) & (bx < W)
    bx = np.clip(bx, 0, W - 1)
    bt = binside & tex[ys[:, None], bx]
    bd = np.where(bt, d[ys[:, None], bx], np.nan)
    nb = bt.sum(axis=1)
    nfar = (bt & (bd < dv[:, None] - jump)).sum(axis=1)
    ok = (same < share * np.maximum(count, 1)) & (nb >= 3) & (nfar >= far * np.maximum(nb, 1))
    ridge = np.zeros((H, W), bool)
    ridge[ys[ok], xs[ok]] = True
    sides = np.zeros((H, W), np.int8)
    sides[ys[ok], xs[ok]] = side[ok]
    behind = np.full((H, W), np.nan, np.float32)
    if ok.any():
        with np.errstate(all="ignore"):
            behind[ys[ok], xs[ok]] = np.nanmedian(bd[ok], axis=1)
    return ridge, sides, behind


def own_edges(disparity: np.ndarray, colour: np.ndarray, *, plain: float = 3.0, like: float = 0.04,
              jump: float = 1.5, rows: int = 8, cover: float = 0.15, solid: float = 0.9, margin: float = 1.0,
              flat: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Step 13: a plain region takes the depth of a textured edge beside it that only the plain side explains.

    Returns ``(disparity, moved)``. The flat-surface bias puts a plain surface at the back; a plain board in
    front has no texture inside to say otherwise, and where its left edge is the frame (or, on a stereo pair, its
    edges hide nothing the other view sees) no half-occluded strip does either. Its edges against the texture
    beside it do: the colour step moves with the board, so the window matches it at the board's depth, nearer
    than the board's interior in the map and nearer than the texture beyond it, which has its own, farther
    depth (:func:`edge_ridges`). Such a ridge can only belong to the plain side. From the plain pixels within
    3 px of a ridge on its plain side, the ridge's depth floods (:func:`join_plain`'s kernel, towards nearer
    depths) over plain pixels (``plain``) whose colour stays within ``like`` of the colour it started from and
    that lie farther by more than ``jump``. A group of moved pixels (4-connected where their new depths differ by
    at most 1 px: one claim) stays only where

    * its seeds -- those still holding their ridge's depth after the flood: a seed a nearer claim flooded over
      supports that claim no longer -- lie on at least ``rows`` rows (an edge, not a speck), and on at least
      ``cover`` of the rows where it has texture within 3 px beside it (a board whose edge claims it, not a wall
      behind a furry subject, claimed by a few strands along a long outline);
    * it fills at least ``solid`` of its outline with the holes filled (a plain surface, not the flat specks of a
      textured one);
    * the texture beyond its ridges (their median ``behind``) is not within ``margin`` of the group's own depth
      (the median of the map over it): a plain region at the depth of the texture beyond a near line is more
      simply a plain part of that surface, seen past a thin near structure -- a stem, a wire, a strand of hair.

    ``flat``: :func:`plain_pixels` of ``colour`` and ``plain``, where the caller has them already.
    """
    from scipy import ndimage

    from vfxstereo import _depth_kernels

    d0 = np.ascontiguousarray(disparity, np.float32)
    col = np.ascontiguousarray(colour, np.float32)
    flat = plain_pixels(col, plain) if flat is None else np.asarray(flat, bool)
    ridge, sides, behind = edge_ridges(d0, flat, jump=jump)
    moved = np.zeros(d0.shape, bool)
    if not ridge.any():
        return d0.copy(), moved
    H, W = d0.shape
    # seeds: on the ridge's row, on its plain side, the first plain pixel farther than it by more than jump,
    # within 3 px of the ridge or past plain pixels the window already gave the ridge's depth (within jump)
    neg = -d0  # the kernel floods towards smaller values: nearer depths, negated
    source = np.zeros(d0.shape, bool)
    seed_behind = np.full(d0.shape, np.nan, np.float32)
    ys, xs = np.nonzero(ridge)
    step = -sides[ys, xs].astype(np.int64)
    dr = d0[ys, xs]
    going = np.ones(len(ys), bool)
    for k in range(1, WEDGE + 1):
        x = xs + step * k
        going &= (x >= 0) & (x < W)
        x = np.clip(x, 0, W - 1)
        plain_here = flat[ys, x]
        going &= plain_here | (k <= 3)
        seed = going & plain_here & (d0[ys, x] < dr - jump)
        y, sx, r = ys[seed], x[seed], xs[seed]
        nearer = -dr[seed] < neg[y, sx]  # where two ridges seed one pixel, the nearer claim (and its texture) holds
        y, sx, r = y[nearer], sx[nearer], r[nearer]
        neg[y, sx] = -d0[y, r]
        seed_behind[y, sx] = behind[y, r]
        source[y, sx] = True
        going &= ~seed & (~plain_here | (np.abs(d0[ys, x] - dr) <= jump))
    if not source.any():
        return d0.copy(), moved
    seeded = -neg  # what each seed claims
    carried = col.copy()
    _depth_kernels.join_plain_flood(neg, source, carried, col, flat, np.float32(like), np.float32(jump), 0)
    d = -neg
    moved = d != d0
    source &= d == seeded  # a seed a nearer claim flooded over supports that claim no longer
    # groups: moved pixels 4-connected where their new depths differ by at most 1 px (one claim each)
    # (like = 2: colours 0-1 never split a group; seeds that hold their claim moved, so they are in a group)
    labels, n = plain_surfaces(d, col, moved, tolerance=1.0, like=2.0)
    labels += 1

    def rows_of(mask):  # per group, the rows where ``mask`` has a pixel of it
        ys, xs = np.nonzero(mask)
        return np.bincount(np.unique(labels[ys, xs].astype(np.int64) * H + ys) // H, minlength=n + 1)

    nrows = rows_of(source)
    outline = rows_of(moved & (_along_row(~flat, 1) | _along_row(~flat, -1)))  # meets texture within 3 px
    index = np.arange(1, n + 1)
    candidates = index[(nrows[1:] >= rows) & (nrows[1:] >= cover * outline[1:])]
    keep = np.zeros(n + 1, bool)
    if len(candidates):
        own_depth = np.full(n + 1, np.nan, np.float32)  # the map's depth over what moved
        own_depth[candidates] = ndimage.median(d0, labels, candidates)
        beyond = np.full(n + 1, np.nan, np.float32)  # the texture beyond the group's ridges
        sb = source & np.isfinite(seed_behind)
        with np.errstate(all="ignore"):
            beyond[candidates] = ndimage.median(np.where(sb, seed_behind, 0.0), np.where(sb, labels, 0), candidates)
        objects = ndimage.find_objects(labels)
        for i in candidates:
            group = labels[objects[i - 1]] == i
            keep[i] = (group.sum() >= solid * ndimage.binary_fill_holes(group).sum() and np.isfinite(beyond[i])
                       and abs(beyond[i] - own_depth[i]) > margin)
    back = moved & ~keep[labels]
    d[back] = d0[back]
    moved &= ~back
    return d.astype(np.float32), moved


def _region_window(labels: np.ndarray, objects: list, i: int, ring: int):
    """Steps 14 and 15's window on plain surface ``i``: ``(ys, xs, lab, region, around)``.

    The surface's box grown by ``ring`` px, the labels there, the surface, and the ring 2 to ``ring`` px around it.
    """
    from scipy import ndimage

    h, w = labels.shape
    sl = objects[i]
    ys = slice(max(sl[0].start - ring, 0), min(sl[0].stop + ring, h))
    xs = slice(max(sl[1].start - ring, 0), min(sl[1].stop + ring, w))
    lab = labels[ys, xs]
    region = lab == i
    around = ndimage.binary_dilation(region, iterations=ring) & ~ndimage.binary_dilation(region, iterations=1)
    return ys, xs, lab, region, around


def _of_its_colour(colour: np.ndarray, region: np.ndarray, others: np.ndarray, like: float,
                   share: float) -> np.ndarray | None:
    """The pixels of ``others`` within ``like`` of ``region``'s median colour (every channel), or None.

    None where there are fewer than 10 others, or such pixels are under ``share`` of them (``colour``: the window's).
    """
    if others.sum() < 10:
        return None
    c = np.median(colour[region], axis=0)
    same = (np.abs(colour - c).max(axis=-1) < like) & others
    return same if same.sum() >= share * others.sum() else None


def grille_cells(disparity: np.ndarray, rival_map: np.ndarray, colour: np.ndarray, flat: np.ndarray, *,
                 jump: float = 1.5, share: float = 0.7, like: float = 0.02, ring: int = 8, tolerance: float = 1.0,
                 join_like: float = 0.04, across: bool = False, own_plain: float = 0.0,
                 own_quantile: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Step 14: ``(proposed map, moved)``: plain regions seen through a grille take the rival-gated map's depth.

    The regions are :func:`plain_surfaces` of ``disparity`` (``flat`` pixels, ``tolerance``, ``join_like``). A
    region with pixels that ``rival_map`` puts farther by more than ``jump`` moves there (those pixels only)
    where, of the plain pixels of *other* regions 2 to ``ring`` px around it, at least ``share`` are within
    ``like`` of its median colour in every channel: the same wall again beyond a thin bar. A plain subject sees
    another surface beyond its outline and stays.

    ``own_plain`` > 0: where some of its colour across the bars lies farther than the region by more than
    ``jump`` (10 px or more), at a depth (their ``own_quantile`` quantile) nearer than the rival-gated map's by
    more than ``jump``, on a surface of the map (4-connected, steps of at most 1 px, any colour) that is at least
    ``own_plain`` plain, the region takes that depth instead of the rival's: the same plain card seen in the
    cells beside it, placed there by its texture or its edges, in front of the farthest plane its colour allows
    (where the rival map sends it). A wall's colour beside a textured subject, at the subject's depth (the
    window's fattening), lies on a mostly textured surface and does not count.

    Where it goes wrong (session 57, hat_slats_lampshade, the losing card row at d = 4.4 at both rigs): a plain
    blue-grey card at d = 6.8 seen through slats tilted 8 degrees from level (d = 14.7), over a photo wall at 2.1.
    After step 8 98.6 % of the card's visible pixels hold the slats' depth (its cells are plain: nothing inside
    them to match); this step then sends 55 % of them to the rival map's 2.1 (step 15 carries that to 66 %,
    step 16's rims to 82 %, step 18 to 87 %), and none to 6.8, because no pixel of the card's colour is at 6.8
    anywhere in the map: the only evidence of 6.8 is the card's right edge against the wall (its top and bottom
    edges are level: matching along the rows cannot place them), and before this step (K = 5) the map holds 6.8 there
    on 42-47 of the edge's 160 rows, on the *wall's* side (the 5 px beyond the card), against 5-16 rows on the
    card's own last 4 columns, which mostly hold the slats' depth (143-155 rows). So neither step 13 (a ridge of
    texture beside a plain region, claimed only towards a nearer depth) nor ``own_plain`` (a seed of the card's
    colour at its depth) has anything to act on; a step 13 for cells would first need the edge matched on the
    card's side.
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32)
    candidate = flat & (rival_map < d - jump)
    proposed = d.copy()
    if not candidate.any():
        return proposed, np.zeros(d.shape, bool)
    labels, _ = plain_surfaces(d, colour, flat, tolerance=tolerance, like=join_like)
    if across:  # the plain surfaces of the colour alone: a region's own surface, wherever the map split it
        apart, _ = plain_surfaces(np.zeros_like(d), colour, flat, tolerance=1.0, like=join_like)
    if own_plain > 0:  # the map's surfaces, any colour, and how plain each is
        surfaces, n_surfaces = plain_surfaces(d, colour, np.ones(d.shape, bool), tolerance=1.0, like=2.0)
        surface_size = np.bincount(surfaces.ravel(), minlength=n_surfaces).astype(np.float64)
        surface_plain = np.bincount(surfaces.ravel(), weights=flat.ravel().astype(np.float64), minlength=n_surfaces)
    ids = np.unique(labels[candidate & (labels >= 0)])
    objects = ndimage.find_objects(labels + 1)
    for i in ids:
        ys, xs, lab, region, around = _region_window(labels, objects, i, ring)
        move = region & candidate[ys, xs]
        others = around & flat[ys, xs] & (lab != i)
        rival = float(np.median(rival_map[ys, xs][move]))
        if across:  # of its own colour surface, only what the map already has at the depth the region would take
            own = np.isin(apart[ys, xs], np.unique(apart[ys, xs][region]))
            others &= ~own | (np.abs(d[ys, xs] - rival) <= jump)
        same = _of_its_colour(colour[ys, xs], region, others, like, share)
        if same is None:
            continue
        target = None
        if own_plain > 0:  # its colour across a bar, farther than the region but nearer than the rival's depth
            far = same & (d[ys, xs] < float(np.median(d[ys, xs][region])) - jump)
            if far.sum() >= 10:
                t = float(np.quantile(d[ys, xs][far], own_quantile))
                under = np.unique(surfaces[ys, xs][far & (np.abs(d[ys, xs] - t) <= jump)])
                if t > rival + jump and surface_plain[under].sum() >= own_plain * surface_size[under].sum():
                    target = t
        if target is None:
            proposed[ys, xs][move] = rival_map[ys, xs][move]
        else:
            move &= d[ys, xs] > target + jump
            proposed[ys, xs][move] = target
    return proposed, proposed != d


def spread_cells(disparity: np.ndarray, colour: np.ndarray, flat: np.ndarray, *, jump: float = 1.5,
                 share: float = 0.7, like: float = 0.02, ring: int = 12, farther: float = 0.3, rounds: int = 8,
                 join_like: float = 0.04, size: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Step 15: ``(proposed map, moved)``: grille cells take the depth of the cells beyond their bars.

    Step 14 moves a cell only where the rival-gated map has it farther; a cell that map missed keeps the bars'
    depth while the cells beside it, across a bar, show the same wall farther back. Each round, a plain surface
    (:func:`plain_surfaces` of the current proposal, at least ``size`` px) whose plain pixels across a bar, 2 to
    ``ring`` px around it, mostly (``share``) have its colour (within ``like``), and of those at least
    ``farther`` lie farther than it by ``jump``, takes their median depth. Only pixels of *other* plain surfaces
    of the colour alone count (a surface the map split into depths sees its own colour around each part). Up
    to ``rounds`` rounds, so the wall's depth spreads cell by cell across the grille.
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32).copy()
    d0 = d.copy()
    apart, _ = plain_surfaces(np.zeros_like(d), colour, flat, tolerance=1.0, like=join_like)
    for _ in range(max(0, rounds)):
        labels, _ = plain_surfaces(d, colour, flat, tolerance=1.0, like=join_like)
        low = ndimage.minimum_filter(np.where(flat, d, np.inf), 2 * ring + 1, mode="nearest")
        ids = np.unique(labels[flat & (low < d - jump) & (labels >= 0)])
        if ids.size == 0:
            break
        objects = ndimage.find_objects(labels + 1)
        new = d.copy()
        for i in ids:
            ys, xs, lab, region, around = _region_window(labels, objects, i, ring)
            if region.sum() < size:
                continue
            own = np.isin(apart[ys, xs], np.unique(apart[ys, xs][region]))
            same = _of_its_colour(colour[ys, xs], region, around & flat[ys, xs] & (lab != i) & ~own, like, share)
            if same is None:
                continue
            dr = float(np.median(d[ys, xs][region]))
            far = same & (d[ys, xs] < dr - jump)
            if far.sum() < max(1, farther * same.sum()):
                continue
            target = np.float32(np.median(d[ys, xs][far]))
            move = region & (d[ys, xs] > target + jump)
            new[ys, xs][move] = target
        if (new == d).all():
            break
        d = new
    return d, d != d0


def whole_boards(disparity: np.ndarray, colour: np.ndarray, flat: np.ndarray, *, jump: float = 1.5,
                 like: float = 0.04, share: float = 0.2, size: int = 200, ring: tuple[int, int] = (4, 12),
                 far: float = 0.8) -> tuple[np.ndarray, np.ndarray]:
    """Step 17: ``(proposed map, moved)``: a plain board in front, split by the map, made whole at its near depth.

    The flat-surface bias sends a plain surface back; a plain board in front whose edges placed part of it (the
    map's near part) keeps the rest at the back. Each plain surface of one colour (:func:`plain_surfaces` of the
    colour alone, ``flat`` pixels within ``like``, at least ``size`` px) whose pixels within 1 px of its near
    depth (the 90th percentile of the map over it) are at least ``share`` of it, where the map has the rest
    farther by more than ``jump``, and where at least ``far`` of the pixels ``ring`` px around that near part
    (any but the surface's own) lie farther by more than ``jump``: the board is the nearest thing there, so its
    near part is not a strip the window grew from a neighbour at that depth (a subject's fattening, a grille's
    bars). Its farther pixels take the plane through its near part (least squares, or the near part's median
    where the plane leaves more than 0.5 px RMS), within 2 px of its near depth.
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32)
    proposed = d.copy()
    apart, n = plain_surfaces(np.zeros_like(d), colour, flat, tolerance=1.0, like=like)
    sizes = np.bincount(apart[apart >= 0], minlength=n)
    objects = ndimage.find_objects(apart + 1)
    h, w = d.shape
    for i in np.nonzero(sizes >= size)[0]:
        sl = objects[i]
        ys = slice(max(sl[0].start - ring[1] - 1, 0), min(sl[0].stop + ring[1] + 1, h))
        xs = slice(max(sl[1].start - ring[1] - 1, 0), min(sl[1].stop + ring[1] + 1, w))
        region = apart[ys, xs] == i
        dw = d[ys, xs]
        top = float(np.percentile(dw[region], 90))
        near = region & (np.abs(dw - top) <= 1.0)
        back = region & (dw < top - jump)
        if near.sum() < share * region.sum() or not back.any():
            continue
        around = (ndimage.binary_dilation(near, iterations=ring[1])
                  & ~ndimage.binary_dilation(near, iterations=ring[0]) & ~region)
        if not around.any() or (dw[around] < top - jump).mean() < far:
            continue
        gy, gx = np.nonzero(near)
        a = np.stack([np.ones(gx.size), gx, gy], axis=1).astype(np.float64)
        coef = np.linalg.lstsq(a, dw[near].astype(np.float64), rcond=None)[0]
        if np.sqrt(np.mean((a @ coef - dw[near]) ** 2)) > 0.5:
            coef = np.array([np.median(dw[near]), 0.0, 0.0])
        by, bx = np.nonzero(back)
        fill = np.clip(coef[0] + coef[1] * bx + coef[2] * by, top - 2.0, top + 2.0)
        proposed[ys, xs][by, bx] = fill.astype(np.float32)
    return proposed, proposed != d


def level_rails(disparity: np.ndarray, colour: np.ndarray, *, jump: float = 1.5, contrast: float = 0.1,
                height: int = 3, run: int = 15, bridge: int = 3, length: int = 24, pieces: int = 4,
                gap: int = 8, like: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Step 18: ``(proposed map, moved)``: thin level lines whose crossings the map placed nearer take that depth.

    A bar, rail or wire along the rig's baseline looks the same from every view of a horizontal rig (its shift
    runs along itself), so matching along the rows gives it the depth of what lies behind it, except where it
    crosses something the views do see move: the other bars of its grille, posts. The lines: pixels at most
    ``height`` px tall that stand out from the rows above and below by more than ``contrast`` in some channel
    (sRGB ``colour``; a vertical top-hat), in runs of at least ``run`` px along the row, joined across gaps of up
    to ``bridge`` px (the crossings themselves do not stand out vertically), at least ``length`` px long. A line
    whose map, at ``pieces`` or more places ``gap`` px apart, lies nearer by more than ``jump`` than the map just
    above and below it (the median over ``gap`` px either way along it: a crossing bar is narrower), and there
    agrees within 1 px (70 % of those pixels), and whose own colour (the median of
    its stronger half away from those places) is within ``like`` of theirs in every channel (one material: the
    crossings of a grille's bars), takes the median of those depths wherever the map has it farther by more than
    ``jump``. Fewer crossings are not enough: a texture line in a photo that a wire fence crosses two or three
    times within 100 px has them (bear_pillar, wire_plant_laundry).
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32)
    c = np.asarray(colour, np.float32)
    size = (height + 2, 1)
    top_hat = np.zeros(d.shape, np.float32)
    for ch in range(c.shape[-1]):
        x = c[..., ch]
        top_hat = np.maximum(top_hat, np.maximum(x - ndimage.grey_opening(x, size=size),
                                                 ndimage.grey_closing(x, size=size) - x))
    line = ndimage.binary_opening(top_hat > contrast, structure=np.ones((1, run), bool))  # runs along the row
    line |= ndimage.binary_closing(line, structure=np.ones((1, 2 * bridge + 1), bool))
    labels, _ = ndimage.label(line, structure=np.ones((3, 3), bool))
    proposed = d.copy()
    h = d.shape[0]
    for i, sl in enumerate(ndimage.find_objects(labels), 1):
        if sl is None or sl[1].stop - sl[1].start < length or sl[0].stop - sl[0].start > height + 2:
            continue
        ys = slice(max(sl[0].start - 3, 0), min(sl[0].stop + 3, h))
        comp = labels[ys, sl[1]] == i
        dw = d[ys, sl[1]]
        cy, cx = np.nonzero(comp)
        # what lies just above and below the line, over a window along it: a crossing bar is narrower than that,
        # a surface the line runs in front of is not
        outside = (ndimage.binary_dilation(comp, structure=np.ones((3, 1), bool), iterations=3) & ~comp
                   & ~line[ys, sl[1]])
        rows = np.pad(np.where(outside, dw, np.nan), ((0, 0), (gap, gap)), constant_values=np.nan)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # columns with nothing above or below: NaN
            around = np.nanmedian(np.lib.stride_tricks.sliding_window_view(rows, 2 * gap + 1, axis=1), axis=(0, 2))
        near = np.isfinite(around[cx]) & (dw[cy, cx] > around[cx] + jump)
        if not near.any():
            continue
        xs = np.unique(cx[near])
        if len(np.split(xs, np.nonzero(np.diff(xs) > gap)[0] + 1)) < pieces:
            continue
        depths = dw[cy[near], cx[near]]
        target = np.float32(np.median(depths))
        if np.mean(np.abs(depths - target) <= 1.0) < 0.7 or near.all():
            continue
        strength = top_hat[ys, sl[1]][cy, cx]
        core = ~near & (strength >= np.median(strength[~near]))
        cw = c[ys, sl[1]]
        if np.abs(np.median(cw[cy[core], cx[core]], axis=0) - np.median(cw[cy[near], cx[near]], axis=0)).max() >= like:
            continue
        move = dw[cy, cx] < target - jump
        proposed[ys, sl[1]][cy[move], cx[move]] = target
    return proposed, proposed != d


def level_strips(disparity: np.ndarray, colour: np.ndarray, *, jump: float = 1.5, height: int = 3,
                 length: int = 15, like: float = 0.025) -> tuple[np.ndarray, np.ndarray]:
    """Step 20: ``(map, moved)``: thin level strips nearer than both sides, of one side's colour, join that side.

    A strip is up to ``height`` rows whose map agrees within 1 px in each column and lies nearer by more than
    ``jump`` than the row just above it and the row just below it; the strips' pixels are grouped (8-connected)
    and a group at least ``length`` px wide whose mean colour (sRGB ``colour``) is within ``like`` of the mean of
    the rows on one side (every channel) and not of the other's takes, column by column, that side's depth. A
    level edge (the top of a card) shifts along itself under a horizontal rig, so semi-global matching carries
    along it the depth of whatever crosses it (a grille's bars): a line of the bars' depth, in the card's colour.
    A real rail or bar has its own colour and stays (step 18 brings those forward). Measured in session 57, on the
    head's final maps of the z-key tuning scenes (58 maps, the later stages run again from them): 12 groups moved,
    10 wholly or mostly right (curls_wire_midd's Midd2 card, petals_grille_plastic's Plastic card, beanie_grille,
    duck_monster_baby's Baby3 card), the other 2 (hat_slats_lampshade's card, whose map is itself wrong) onto
    their own surface; see :attr:`vfxstereo.depth.DepthConfig.strips` for the z-key and Middlebury numbers.
    """
    from scipy import ndimage

    d = np.asarray(disparity, np.float32)
    c = np.asarray(colour, np.float32)
    h, w = d.shape
    strip = np.zeros((h, w), bool)
    above = np.full((h, w), -1, np.int64)  # the row just above / below the strip a pixel belongs to
    below = np.full((h, w), -1, np.int64)
    for k in range(1, height + 1):  # strips of k rows, y .. y+k-1 for y = 1 .. h-k-1
        n = h - k - 1
        if n < 1:
            break
        blocks = np.stack([d[1 + j:1 + j + n] for j in range(k)])  # (k, n, w): the strip's rows
        lo, hi = blocks.min(axis=0), blocks.max(axis=0)
        ok = (hi - lo <= 1.0) & (lo > d[:n] + jump) & (lo > d[1 + k:1 + k + n] + jump)
        ys, xs = np.nonzero(ok)  # y - 1
        for j in range(k):
            strip[ys + 1 + j, xs] = True
            above[ys + 1 + j, xs] = ys
            below[ys + 1 + j, xs] = ys + 1 + k
    out = d.copy()
    if not strip.any():
        return out, np.zeros((h, w), bool)
    labels, _ = ndimage.label(strip, structure=np.ones((3, 3), bool))
    for i, sl in enumerate(ndimage.find_objects(labels), 1):
        if sl is None or sl[1].stop - sl[1].start < length:
            continue
        ys, xs = np.nonzero(labels[sl] == i)
        ys, xs = ys + sl[0].start, xs + sl[1].start
        own = c[ys, xs].mean(axis=0)
        ya, yb = above[ys, xs], below[ys, xs]
        da = np.abs(own - c[ya, xs].mean(axis=0)).max()
        db = np.abs(own - c[yb, xs].mean(axis=0)).max()
        if min(da, db) >= like or max(da, db) < like:
            continue
        out[ys, xs] = d[ya, xs] if da < db else d[yb, xs]
    return out, out != d


def plain_pixels(colour: np.ndarray, plain: float = 3.0) -> np.ndarray:
    """(H, W) bool: steps 12 and 13's plain pixels.

    Those where the local deviation of the grey of ``colour`` (sRGB-encoded 0-1, as 8-bit, over 5 x 5) is below
    ``plain``.

    Tried in session 49: the deviation along the rows only (1 x 5, averaged over 5 rows), so that a surface
    textured only across the baseline (wood grain along a horizontal rig, which matching cannot place) counts
    as plain: beanie_grille K = 5's grained floor cell behind the grille, at the bars' depth, became 90 % plain
    but no step moved it (its colour spread is wider than the steps' colour tests); z-key tuning rows K = 5
    -0.14 / -0.09 dB, K = 2 -0.28 / -0.14. Separately, widening steps 14 and 15's colour test to a region's own
    spread (its 0.9 quantile): K = 5 +0.02 / +0.02, K = 2 -0.02 / -0.01, rows losing 7 / 6 -> 10 / 8.
    """
    return local_deviation(np.asarray(colour, np.float32).mean(axis=-1) * 255.0, 5) < plain


def join_plain(disparity: np.ndarray, colour: np.ndarray, *, plain: float = 3.0, like: float = 0.04,
               jump: float = 1.5, anchor: int = 8, reach: int = 0, grow: float = 0.0,
               slopes: bool = False, flat: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Step 12: inside a plain region of one colour the nearer side of a depth step joins the farther one.

    Such a step has no colour edge under it. Returns ``(disparity, moved)``.

    A plain wall beside a textured subject, or seen through a grille, matches about as well at the subject's
    depth as at its own, and semi-global matching carries the subject's depth into it: the map then steps from
    the subject's depth back to the wall's somewhere inside the wall, where the plate shows no edge at all. Here
    the farther depth floods back over the plain pixels (local deviation of the grey, 8-bit sRGB, over 5 x 5
    below ``plain``) from a farther plain pixel whose depth texture within ``anchor`` px supports
    (:func:`anchored`; a depth only the flat-surface bias put there, or a rim the background grew into a near
    board, does not spread), step by step between 4-neighbours, as long as each pixel's colour (``colour``,
    sRGB-encoded 0-1) stays within ``like`` of the colour the flood started from in every channel, and only to
    pixels nearer than that depth by more than ``jump``. Nothing moves nearer, and a colour edge (a textured
    pixel) stops it. A plain near surface whose colour continues, unbroken, into a farther one of the same colour
    (a pale board on a wall of its colour, no edge between) goes back with it: the plate cannot tell them apart.

    Then, on the plain surfaces (:func:`plain_surfaces`): with ``slopes``, moved pixels go back where the surface
    they lay on in ``disparity`` already reaches the flood's depth (within 1 px) somewhere it did not move: the
    map carries it there smoothly, so it is a slope or one surface, and the step was a glitch on it. With
    ``grow`` > 0, the moves on a surface of the new map go back where they are more than ``grow`` times the
    pixels of that surface that did not move: a strip grown over a wall is a small part of the wall, while a
    board that followed a wrong rim, or a sofa back that followed a wrong patch, is most of its surface.
    ``flat``: :func:`plain_pixels` of ``colour`` and ``plain``, where the caller has them already.
    """
    from vfxstereo import _depth_kernels

    d0 = np.ascontiguousarray(disparity, np.float32)
    col = np.ascontiguousarray(colour, np.float32)
    flat = plain_pixels(col, plain) if flat is None else np.asarray(flat, bool)
    source = anchored(d0, ~flat, anchor) & flat
    d = d0.copy()
    carried = col.copy()
    _depth_kernels.join_plain_flood(d, source, carried, col, flat, np.float32(like), np.float32(jump), int(reach))
    moved = d != d0
    if slopes and moved.any():
        # a surface the map already carries, smoothly, to the flood's depth is a slope, not a step: it stays
        labels, n = plain_surfaces(d0, col, flat, like=like)
        on = labels >= 0
        farthest = np.full(n, np.inf, np.float32)
        np.minimum.at(farthest, labels[on & ~moved], d0[on & ~moved])
        back = moved & on & (farthest[np.maximum(labels, 0)] <= d + 1.0)
        d[back] = d0[back]
        moved &= ~back
    if grow > 0 and moved.any():
        labels, n = plain_surfaces(d, col, flat, like=like)
        on = labels >= 0
        more = np.bincount(labels[on & moved], minlength=n)
        had = np.bincount(labels[on & ~moved], minlength=n)
        back = moved & on & (more > grow * had)[np.maximum(labels, 0)]
        d[back] = d0[back]
        moved &= ~back
    return d, moved


def plain_surfaces(disparity: np.ndarray, colour: np.ndarray, flat: np.ndarray, *, tolerance: float = 1.0,
                   like: float = 0.04) -> tuple[np.ndarray, int]:
    """``(labels, n)``: the plain surfaces of a map, (H, W) int32 labels (-1 where not ``flat``) and their number.

    A surface is a 4-connected set of ``flat`` pixels whose neighbours differ by at most ``tolerance`` in
    disparity and by less than ``like`` in every colour channel: a plain wall, board or sofa back at one depth
    (or a smooth slope), split where the map steps or the colour changes. Numbered in raster order of their
    first pixel (a numba union-find, 8 bytes per pixel; :func:`plain_surfaces_reference` is its plain version).
    """
    from vfxstereo import _depth_kernels

    d = np.ascontiguousarray(disparity, np.float32)
    labels = np.empty(d.shape, np.int32)
    n = _depth_kernels.plain_surfaces(d, np.ascontiguousarray(colour, np.float32), np.ascontiguousarray(flat, bool),
                                      np.float32(tolerance), np.float32(like), labels)
    return labels, int(n)


def plain_surfaces_reference(disparity: np.ndarray, colour: np.ndarray, flat: np.ndarray, *,
                             tolerance: float = 1.0, like: float = 0.04) -> tuple[np.ndarray, int]:
    """:func:`plain_surfaces` as a graph's connected components (scipy), the reference its kernel is tested against.

    The same partition, other numbers (and ``n`` counts the pixels that are not flat as well).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    d = np.asarray(disparity, np.float32)
    col = np.asarray(colour, np.float32)
    h, w = d.shape
    index = np.arange(h * w).reshape(h, w)
    rows, cols = [], []
    for a, b in (((slice(None), slice(0, -1)), (slice(None), slice(1, None))),
                 ((slice(0, -1), slice(None)), (slice(1, None), slice(None)))):
        joined = (flat[a] & flat[b] & (np.abs(d[a] - d[b]) <= tolerance)
                  & (np.abs(col[a] - col[b]) < like).all(axis=-1))
        rows.append(index[a][joined])
        cols.append(index[b][joined])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(h * w, h * w))
    n, labels = connected_components(graph, directed=False)
    return np.where(flat, labels.reshape(h, w), -1), n


def seen_errors(views: np.ndarray, warper, reference: int, disparity: np.ndarray, gains: np.ndarray, *,
                jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """``(errors, seen)``, each (K - 1, H, W): the other views' errors and visibility at the map's disparities.

    ``errors``: each other view's :func:`patch_errors` (1 px) at each reference pixel's disparity; ``seen``:
    whether the map's z-buffer in that view (two plane steps of tolerance) lets the view see the pixel there
    (the z-buffer's own projection of the map says where each pixel lands).
    """
    from scipy import ndimage

    d0 = np.asarray(disparity, np.float32)
    errors = patch_errors(views, warper, reference, d0, gains, jitter=jitter, size=1)
    seen = np.zeros(errors.shape, bool)
    for n, k in enumerate(k for k in range(views.shape[0]) if k != reference):
        u, v = warper.project(d0, k)
        zb = zbuffer(warper, d0, k, uv=(u, v))
        zk = ndimage.map_coordinates(zb, [np.nan_to_num(v), np.nan_to_num(u)], order=0, mode="nearest")
        seen[n] = zk <= d0 + 2.0 * warper.step
    return errors, seen


def views_confirm(views: np.ndarray, warper, reference: int, before: np.ndarray, after: np.ndarray, *,
                  gains: np.ndarray | None = None, jitter: float = 0.5, ratio: float = 4.0, floor: float = 0.002,
                  share: float = 0.1, before_errors: tuple[np.ndarray, np.ndarray] | None = None,
                  unseen_floor: float | None = None) -> np.ndarray:
    """``after`` with the groups of moved pixels the views contradict put back to ``before``.

    A group (8-connected pixels where the maps differ) is contradicted where more than ``share`` of its pixels
    that some view sees at their new depth (:func:`seen_errors`, within ``jitter``) are seen there with an error
    (least over those views) above ``ratio`` times the error at their old depth (least over the views that see
    them there; 0 where none does) plus ``floor`` (``unseen_floor``, where given, for the pixels whose old depth
    no view sees: nothing to compare with there, only whether the views see the new depth badly). A plain
    surface moved behind a near one it is not part of passes (the views see plain colour there too); one moved
    where the views see its edge, or another surface, does not. ``before_errors``: :func:`seen_errors` of
    ``before`` with these ``gains`` and ``jitter``, where they are known already (:func:`recover_thin`'s
    ``keep``).
    """
    from scipy import ndimage

    from vfxstereo.layers import view_gains

    before = np.asarray(before, np.float32)
    after = np.asarray(after, np.float32)
    moved = after != before
    if not moved.any():
        return after
    views = np.asarray(views, np.float32)
    gains = view_gains(views, warper, reference, before) if gains is None else np.asarray(gains, np.float32)
    e0, s0 = seen_errors(views, warper, reference, before, gains, jitter=jitter) if before_errors is None \
        else before_errors
    e1, s1 = seen_errors(views, warper, reference, after, gains, jitter=jitter)
    old = np.where(s0, e0, np.inf).min(axis=0)
    new = np.where(s1, e1, np.inf).min(axis=0)
    seen = np.isfinite(new) & moved
    limit = np.where(np.isfinite(old), ratio * old + floor, floor if unseen_floor is None else unseen_floor)
    bad = seen & (new > limit)
    labels, n = ndimage.label(moved, structure=np.ones((3, 3), bool))
    keep = np.bincount(labels[bad], minlength=n + 1) <= share * np.maximum(np.bincount(labels[seen],
                                                                                       minlength=n + 1), 1)
    keep[0] = False
    return np.where(keep[labels], after, before).astype(np.float32)


def join_plain_reference(disparity: np.ndarray, colour: np.ndarray, flat: np.ndarray, source: np.ndarray,
                         like: float, jump: float, reach: int = 0) -> np.ndarray:
    """Plain numpy flood of :func:`join_plain`, the reference its kernel is tested against.

    All pixels at once per round, each taking the farthest valid neighbour; the same map as the kernel's where
    the flood's colours do not compete.
    """
    d = np.asarray(disparity, np.float64).copy()
    carried, source = np.asarray(colour, np.float64).copy(), np.asarray(source, bool).copy()
    col = np.asarray(colour, np.float64)
    h, w = d.shape
    rounds = 0
    while reach <= 0 or rounds < reach:
        rounds += 1
        best, best_c, best_s = d.copy(), carried.copy(), source.copy()
        for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            p = (slice(max(-dy, 0), h - max(dy, 0)), slice(max(-dx, 0), w - max(dx, 0)))
            q = (slice(max(dy, 0), h - max(-dy, 0)), slice(max(dx, 0), w - max(-dx, 0)))
            ok = (flat[p] & source[q] & flat[q] & (d[q] < d[p] - jump) & (d[q] < best[p])
                  & (np.abs(col[p] - carried[q]) < like).all(axis=-1))
            best[p] = np.where(ok, d[q], best[p])
            best_c[p] = np.where(ok[..., None], carried[q], best_c[p])
            best_s[p] |= ok
        if np.array_equal(best, d):
            return d
        d, carried, source = best, best_c, best_s
    return d
