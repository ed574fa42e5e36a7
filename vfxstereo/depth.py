"""The robust depth stage: one disparity per reference pixel from all K views (beyond the paper).

Szeliski & Golland decide depth by thresholded winner-take-all on the colour variance across views
(Section 4), which on real plates leaves most pixels undecided and puts flat surfaces on the wrong planes.
This stage gives the layered model a dependable front surface instead, from classical multi-view stereo:

1. **Matching** (:mod:`vfxstereo.matching`): AD-census cost of the reference against each view, on every
   plane, each view's costs centred per pixel (``centre``), averaged over the views that see the cell.
   Census is robust to exposure and vignetting differences between cameras; each view's term saturates, so
   an occluded view cannot outvote the rest.
2. **Window** (``aggregation``): the cost filtered over a small window by the reference's colour guided filter
   (:func:`guided_filter`; a plain box with ``aggregation="box"``), which steadies flat surfaces without
   carrying a textured surface's costs across colour edges; then the flat-surface bias (``far_bias``,
   :func:`flat_bias`), given to pixels whose cost curve is flat (and with ``rival_jump``, the ``grille``
   preset, to pixels that two far-apart depths explain alike: a plain wall seen through a grille). The bias
   assumes a plain surface is at the back; ``flat_guard`` checks it per region (:func:`own_surfaces`): a
   plain region whose unbiased depth ends at its own edges in front of farther surfaces keeps that depth.
3. **Semi-global matching** (:mod:`vfxstereo.sgm`): 8 paths, P2 lowered at image edges.
4. **Winner and sub-pixel**: the plane of least aggregated cost, refined by a parabola (Section 8.1).
5. **Visibility** (the paper's Section 5 made from a depth map): the disparity map is forward-projected
   into every view (a z-buffer: the nearest disparity landing on each view pixel), the pixels whose depth the
   pass decided only (``visibility_decided``, :func:`decided`: a clear least cost, or a plain surface placed by
   its edges; a pixel semi-global matching placed without evidence of its own hides nothing); a cell is hidden
   in view k when something nearer by more than ``visibility_tolerance`` planes lands where it would be seen.
   Steps 1-4 run again with those views left out of each hidden cell's mean (twice with three views or more,
   ``visibility_passes_views``; once for a stereo pair, ``visibility_passes``): occluded pixels are then matched
   by the views that see them (Kang, Szeliski & Chai, CVPR 2001, choose views by left/right subsets; measured
   here, explicit visibility beats a subset minimum, which on a rig with one view on one side and five on
   the other picks the noisy lone view: see :data:`SUBSETS_MEASURED`).
6. **Unreliable pixels**: those whose winning cell no other view sees (``fill_occluded``) and, for a stereo
   pair, those the consistency check rejects (``consistency``: the disparity of the view
   ``consistency_view`` steps away is read off the aggregated volume by a diagonal search, Hirschmueller
   2008, and compared with the reference's by re-projection) are filled from the farther of their reliable
   neighbours (:func:`fill_unreliable`), never by inventing a nearer surface. (The check's second match is
   made from the other view as a reference of its own, ``consistency_method="rematch"``, by default.) Where
   the other view's map is the farther one and that view sees its depth with the wrong colour, that map is
   the wrong one (``consistency_contradict``, :func:`consistent`): a plain board both views' flat-surface
   biases sent back keeps the part the reference's map placed from its edge.
   Then a surface that reaches the strip along a frame edge that no other view sees continues across it
   (``frame_edges``, :func:`extend_to_frame_edges`): no view can say anything there.
7. A 3x3 median.
8. Optionally (``edge_refine``), the pixels near depth edges are re-decided between their neighbourhood's
   front and back disparity by a pixelwise cost with colour-adaptive support weights over the views that see
   the back candidate (:func:`refine_edges`), against the foreground fattening of steps 1-3.

Steps 9-20, run once on the whole plate's map after the strips (gaps and colours reopened, thin near
structures brought back, plain joins, edge ownership, grille cells, whole boards, level rails, rim colours, level
strips), are in :mod:`vfxstereo.depth_plate`.

Measured (``benchmarks/middlebury.py``, all 31 sets, one published px apart, the GT's view as reference):
0.47x OpenCV SGBM's bad pixels on average (9.21 % against 19.50 % in session 45; from the classic pair alone
14.33 %), at most 0.83x. Near the depth jumps, 20.6 % of the pixels too near (foreground fattening) and 5.5 %
too far, SGBM 29.5 % and 10.8 %: fattening is four fifths of the edge error, mostly a rim of 1-2 px on either
side of the front (the window, not one-sided occlusion). Earlier: 9.4 %, at most 0.88x (Midd1); per set
tsukuba 3.7 %, venus 1.4 %, teddy 5.3 %, cones 10.3 %, Art 11.0 %, Midd1 25.5 % (before step 10, session 26: 9.5 %,
0.49x; tsukuba 3.9, teddy 5.4, cones 10.4, Art 11.3, Midd1 25.7). (With the box window, until session
20: 9.8 %, 0.50x; from the classic pair alone 14.9 %, 18.1 % before the rematch check and the frame-edge step;
held-out view PSNR 37.8 dB against the SGBM warp's 34.2.)
(With ``flat_window`` 31 and ``far_bias`` 0.25, until session 15: 9.6 %, 0.49x, worst 0.91x.)
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from vfxstereo import matching
from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress, report
from vfxstereo.subpixel import parabola_vertex

SUBSETS_MEASURED = """Prototype on 10 Middlebury sets (AD-census, 5x5 window, SGM P1 = 0.5, P2 = 6): the minimum
of the left-views and right-views mean costs (Kang et al.) scored a mean of 1.10x OpenCV SGBM's bad pixels
(Wood2 4.5x: the 2005/2006 sets have one view left of the reference and five right of it); the mean over all
views 0.69x; the mean with one visibility pass 0.66x (and 0.56x over all 31 sets)."""

VISIBILITY_DECIDED_MEASURED = """Session 53, ``DepthConfig.visibility_decided`` (rival gap at least 0.25 against
planes 2 px or more away, or plain below 3 over 5 x 5) against every pixel in the z-buffer. Z-key benchmark (frame /
band dB): all 362 rows 32.49 / 26.05 -> 32.82 / 26.38, band against the true-depth key -2.95 -> -2.63 dB; tuning
rows K = 5 34.68 / 27.57 -> 34.67 / 27.71, K = 2 31.63 / 25.44 -> 32.10 / 25.82; held-out rows (scored with this
value and with the rival gap alone, no other) K = 5 30.56 / 25.14 -> 31.09 / 25.53, K = 2 27.71 / 22.37 -> 28.90 /
23.31. Rows losing to the SGBM key 9 / 6 -> 9 / 8: fur_pillar_monopoly K = 2's card at d = 3.4 (-3.1 -> +7.0 frame)
and petals_grille_plastic K = 2's at d = 8 (band) turn to winning; panel_hair_books K = 5's full card at d = 11
(frame 53.5 -> 16.4 dB: step 14 now sends the plain panel at the right back, from a map that differs in a few
undecided pixels along its edge), fur_pillar_monopoly K = 5's card at d = 3.4 (band 80.8 -> 51.9, both nearly exact)
and artichoke_books K = 2's at d = 4 (band -0.06) turn to losing. Bad pixels of the depth: lattice_leaves K = 2 23.5
-> 19.4 %, K = 5 14.4 -> 10.7 %, tree_cloth K = 2 18.5 -> 14.1 %, beanie_grille K = 2 20.8 -> 17.0 %; koala_slope K
= 2 20.2 -> 29.3 % (the pencil cup's mesh, periodic and so undecided, no longer hides the slope behind it, and the
slope between the pencils takes the cup's depth). Middlebury, all 31 sets, bad pixels: from all views 9.17 -> 8.65 %
(0.466x -> 0.438x SGBM, the worst set 0.82x -> 0.80x, none losing; Monopoly 12.3 -> 10.1, Midd1 23.9 -> 21.5,
Laundry 17.0 -> 15.8), from the classic pair 14.27 -> 13.82 % (Monopoly's 16.7 -> 18.2, Books' 23.1 -> 23.5);
held-out views (tsukuba, teddy, Cloth1, Plastic, Wood2) 37.88 -> 37.90 dB (tsukuba 33.76 -> 34.36, Plastic 39.37 ->
38.99). Tried: the rival gap alone (no plain pixels): +0.25 dB band over all rows, but plain boards lost their depth
(rabbit_cream_board K = 5 -40 dB, sign_plant_aloe K = 2 -33 dB, plank_toy_wood K = 5 -39 dB on near-exact rows: a
plain board's far candidates were no longer hidden by the board itself); tuning rows, frame / band against the head,
K = 5 ; K = 2: gap 0.15 +0.01 / +0.20 ; +0.31 / +0.32, 0.25 -0.01 / +0.14 ; +0.46 / +0.38, 0.35 -0.06 / +0.11 ;
+0.58 / +0.30, plain below 5 -0.10 / +0.10 ; +0.42 / +0.21. On lattice_leaves K = 2: no z-buffer at all
(``visibility_passes`` 0) 21.3 % bad, two visibility passes of the old rule 26.3 %, two of the new 19.3 %
(koala_slope K = 2 26.0 %, tree_cloth 14.5 %)."""

VISIBILITY_PASSES_MEASURED = """Session 54, ``DepthConfig.visibility_passes_views`` 2 (three matching passes with
three or more views) against 1. Z-key benchmark (frame / band dB), all 362 rows 32.82 / 26.38 -> 33.02 / 26.42 (band
against the true-depth key -2.63 -> -2.59 dB); K = 5 tuning rows 34.67 / 27.71 -> 35.12 / 27.79, held out 31.09 /
25.53 -> 31.19 / 25.64; the K = 2 rows unchanged. Rows losing to the SGBM key 9 / 8 -> 9 / 7. panel_hair_books K = 5:
its plain panel in front of the books, which one pass sent back (the full card at d = 11 +37 dB frame, at d = 6.8
+20), bad pixels 22.5 -> 6.9 %; rabbit_cream_board's full card at d = 10.5 +5.8 dB; ostrich_grille's full card at d =
6 -4.5 / -3.0, board_fence_toy's card at d = 3 -4.0 / -3.2. Bad pixels of the K = 5 depth maps, mean of 36 scenes
11.50 -> 10.98 % (wicker_wall 7.9 -> 5.5, fence_dof 37.2 -> 32.8; plush_wall 43.1 -> 46.3, ostrich_grille 9.2 ->
11.0, doll_plaster 14.0 -> 15.6). Middlebury, all 31 sets from all views: 8.65 -> 8.19 % bad (0.438x -> 0.421x SGBM,
the worst set 0.80x, none losing; 25 sets better, 3 worse: Monopoly 10.1 -> 6.8, Plastic 32.8 -> 29.8, Midd2 14.6 ->
11.9; Midd1 21.5 -> 23.2, tsukuba 3.05 -> 3.16); held-out views (tsukuba, teddy, Cloth1, Plastic, Wood2) 37.90 ->
37.99 dB (Plastic 38.99 -> 39.53, tsukuba 34.36 -> 34.25). On a stereo pair a second visibility pass lost 0.85 / 0.44
dB over the 151 K = 2 tuning rows (12 rows losing on the frame against 5): with one other view, a wrong first map has
nothing to correct it and a further pass only confirms it. Cost: the depth stage at 1920 x 1080 x 64 planes, K = 5
(``samples.layered_scene``), 1.24x the time of one pass (matching 13 -> 19 s, SGM 3.7 -> 5.4 s; the stage 28 -> 35 s,
side by side, alternating, two runs each); memory unchanged (the passes reuse the volumes). Tried with it, on the
tuning rows against it (frame / band dB, K = 5 ; K = 2): ``guided_radius`` 1 -0.91 / -0.39 ; -1.71 / -1.07, 3 -0.50 /
-0.19 ; +0.06 / +0.17; ``guided_eps`` 3e-4 +0.08 / +0.07 ; +0.23 / -0.00 (held out -0.06 / -0.06 ; -0.20 / -0.14),
1e-4 +0.11 / +0.05 ; -0.22 / -0.26 (sign_plant_aloe K = 2 -33 dB: its plain sign went back); ``visibility_tolerance``
2 planes -0.19 / -0.08 ; -0.95 / -0.38; at K = 5 only, ``visibility_passes_views`` 3 -0.06 / +0.01,
``visibility_decided`` 0 (every pixel in the z-buffer) -0.17 / -0.06, 0.35 -0.11 / -0.03. None kept."""

EDGE_ZBUFFERS = ("confident", "all", "sided")
"""The values of :attr:`DepthConfig.edge_zbuffer`."""


@dataclass(frozen=True)
class DepthConfig:
    """Settings of :func:`robust_depth`.

    The functions of steps 9-20 that the notes below name (``reopen_gaps``, ``reopen_by_colour``, ``join_plain``,
    ``views_confirm``, ...) are in :mod:`vfxstereo.depth_plate`.
    """

    matching: matching.MatchingParams = field(default_factory=matching.MatchingParams)
    box: int = 5
    """Side of the square window the cost is averaged over before SGM (1: none; ``aggregation="box"``)."""
    aggregation: str = "guided"
    """Step 2's window: "guided" (:func:`guided_filter`: the colour guided filter of the reference,
    ``guided_radius`` and ``guided_eps``; the flat-surface bias still reads the box's cost gap) or "box" (the mean
    over ``box`` x ``box``; until session 20). A box spills a textured surface's costs over a weaker neighbour
    (foreground fattening); the guided filter stops at colour edges. Measured side by side (session 20; radius
    and eps chosen on the tuning scenes only: radius 4 gave 30.34 / 21.82 there, and without the box's gap for
    the bias Monopoly's plain board went from 12.3 to 17.7 % bad pixels):

    * z-key benchmark, 170 rows, frame / band dB: 27.57 / 20.87 -> 27.85 / 21.06; tuning K = 5 30.77 / 22.63 ->
      30.99 / 22.78, K = 2 29.35 / 21.31 -> 29.57 / 21.37; held-out K = 5 27.57 / 20.97 -> 27.78 / 21.35, K = 2
      25.12 / 19.69 -> 25.54 / 19.77 (hair_shelves K = 2 +3.5 / +1.2, shelf_grille K = 5 +0.9 / +1.9 but K = 2
      -0.1 / -1.7, koala_slope K = 2 -0.6 / -0.9, trolls_art K = 5 -0.3 / -0.4);
    * the hard key from our depth alone, 56 tuning rows: 27.27 / 17.69 -> 28.34 / 18.15 (radius 4);
    * Middlebury, 31 sets: 9.76 -> 9.53 % bad (tsukuba 4.43 -> 3.94, Laundry 19.13 -> 17.93; worse only
      Monopoly 12.29 -> 12.52 and Bowling2 8.52 -> 8.54, both far below SGBM's 34.8 and 23.9).
    """
    guided_radius: int = 2
    """Half-side of the guided filter's window (2: 5 x 5, the box's)."""
    guided_eps: float = 1e-3
    """The guided filter's regulariser (colour^2, sRGB-encoded values in [0, 1])."""
    P1: float = 0.5
    """SGM penalty of a one-plane step (:mod:`vfxstereo.sgm`)."""
    P2: float = 6.0
    """SGM penalty of a larger jump on a flat guide."""
    sigma: float = 10.0
    """Guide difference (8-bit grey) that halves P2."""
    paths: int = 8
    """SGM path directions, 8 or 4."""
    visibility_passes: int = 1
    """Passes of step 5 for a stereo pair: re-match with the views that see each cell (0: none)."""
    visibility_passes_views: int | None = 2
    """Passes of step 5 with three or more views (None: ``visibility_passes``). With views on both sides the
    second pass's z-buffers come from a map that already saw the occlusions of the first; on a pair, a wrong
    first map has no other view to correct it and a further pass only confirms it. Measured: see
    ``VISIBILITY_PASSES_MEASURED``."""
    visibility_tolerance: float = 4.0
    """A cell is hidden in a view when a disparity larger by more than this many plane steps lands on its
    view pixel."""
    visibility_decided: float = 0.25
    """Step 5's z-buffer holds only the pixels whose depth the pass before decided (:func:`decided`): their cost
    (after the window and the flat-surface bias, before semi-global matching) has a rival gap
    (:func:`rival_gap`, against planes ``visibility_rival`` px or more away) of at least this, or they are
    plain (``visibility_plain``). 0: every pixel (the rule until session 53).

    A pixel semi-global matching placed without evidence of its own must not hide the cells behind it: the
    weakly textured wall seen through a lattice's cells, on a stereo pair, took the bars' depth in the first
    pass (the strip each bar hides in the other view matches best at the bars' depth, and the rest of the cell
    says little), and the z-buffer of that map then hid the wall's own depth in the other view, so the second
    pass confirmed the mistake. Plain pixels still occlude: a plain board's depth comes from its edges, and
    its own z-buffer keeps the wall behind it from matching its plain face.

    Measured (session 53; the z-key benchmark's 362 rows, frame / band dB, and bad pixels of the depth against
    the truth): see ``VISIBILITY_DECIDED_MEASURED``."""
    visibility_rival: float = 2.0
    """:func:`decided`'s rival planes lie at least this far (px) from the winner."""
    visibility_plain: float = 3.0
    """:func:`decided`'s plain pixels: grey deviation (8-bit sRGB) over 5 x 5 below this (0: none)."""
    fill_occluded: bool = True
    """After the visibility pass, pixels whose winning cell no other view sees (occluded in all of them) are
    unreliable and filled (step 6's fill)."""
    frame_edges: bool = True
    """Step 6b: a surface that reaches the strip along the frame edge that no other view sees (the left edge of
    the left view of a stereo pair, as wide as the surface's disparity) continues across it, as long as it is
    nearer than what the strip found (:func:`extend_to_frame_edges`). Matching cannot see a near surface
    there and would take the background; SGBM's row-wise fill extends the surface the same way. Measured
    (z-key tuning scenes, K = 2): tassels_room, strands crossing the frame edge, 5.05 -> 3.23 % of pixels
    off by more than 1 px (SGBM 3.67), its full-card comps 25.12 -> 27.51 dB mean frame; doll_plant +0.8 dB;
    wicker_wall -0.2 dB, where the wicker's wall strip is now wicker. With views on both sides of the reference
    nothing changes (every strip pixel is seen by a view)."""
    consistency: bool | None = None
    """Step 6: check against the disparity of another view and fill what disagrees. None: on for a stereo pair
    (K = 2), off with more views, as measured: on the classic pairs of tsukuba, teddy, Art and Baby3 it takes
    the mean bad-pixel rate from 17.8 to 16.4 %; with all views of six sets it helps three and hurts three.
    Session 54, with two visibility passes: on at K = 5, z-key tuning rows -0.52 / -0.05 dB frame / band."""
    consistency_view: int | None = None
    """Steps from the reference to the view of the check (default: the farthest view on the side with more)."""
    consistency_contradict: float = 0.05
    """Step 6 keeps pixels the other view's map puts farther where that view sees the farther depth with a colour
    error above this more than twice their own depth's (sRGB, mean over channels; 0: never): that map is the
    wrong one there (:func:`consistent`).

    Found on sign_plant_aloe K = 2: both views' maps send its plain sign back (the flat-surface bias), the
    reference's keeps the part its right edge places, and the check threw that away, since the other map had
    the wall there. Measured in session 38 against 0 (z-key benchmark, frame / band dB; rows losing to the SGBM
    key, frame / band; the depth stage's maps at K = 5 are unchanged, the check runs for a stereo pair):

    * all 338 rows: 30.35 / 24.34 -> 30.39 / 24.37, losing 14 / 7 -> 10 / 7 (sign_plant_aloe K = 2's four
      frame rows turn to winning, +1.26 / +0.67 over its rows; sphere_plant K = 2 +1.33 / +1.11, ostrich_grille
      K = 2 +0.13 / +0.15; worst row leaves_wire_bowling K = 2 -0.11 / -0.15); the held-out rows of then
      (60) 27.72 / 21.77 -> 27.76 / 21.81, none losing;
    * the first version, without the frame-edge guard and the colour test, lost on two of those held-out scenes
      (duck_monster_baby K = 2 -1.26 / -1.02: the other view's edge strip showed a subject beyond the
      reference's frame; leaves_wire_bowling K = 2 -0.18 / -0.16: a wire's halo passed with the wire), which
      then retired; two new held-out scenes, scored once with and without: within 0.03 on every row;
    * Middlebury, depth only: from all views 9.20 % either way; from the classic pair 14.33 % either way
      (tsukuba 5.36 -> 5.30, Aloe 8.94 -> 9.02, no other set moves by more than 0.01)."""
    consistency_region: int = 10
    """... and the pixels of their colour rejected for the same reason in their connected region of one plane,
    where at least this many of its pixels are contradicted so (:func:`consistent`)."""
    consistency_method: str = "rematch"
    """How step 6 gets the other view's disparity: "diagonal" reads it off the reference's aggregated volume
    (cheap, but it inherits the reference's fattening: a half-occluded strip that took the near surface's
    disparity finds the same winners along the diagonals and passes); "rematch" solves the other view as a
    reference of its own (steps 1-7; twice the depth stage's time). Rematch is the default, measured at K = 2
    (where the check runs by default): Middlebury classic pairs 17.0 -> 14.9 % bad pixels (8 sets); z-key
    tuning scenes, K = 2, mean band 17.05 -> 17.27 dB, rows beating the SGBM key 17 -> 20 of 28 (frame) and
    17 -> 18 (band); trolls_art +1.4 / +1.0 dB, plush_wall +0.8 / +0.9; the plain walls (wicker_wall,
    fur_grey_wall) and sphere_plant -0.2 to -0.65 dB, where it flags more wall pixels and the fill sends them
    back. Held-out scenes (scored once, after the choice), K = 2: mean band 19.61 -> 19.93 dB (SGBM key
    18.22)."""
    median: int = 3
    """Side of the final median filter (0 or 1: none)."""
    subset_penalty: float | None = None
    """Occlusion-robust combination (Kang, Szeliski & Chai 2001): a cell's cost is the least of the mean over all
    views that see it and the means over the views on either side of the reference plus this penalty (cost
    units), so one side's views take over where the other side's are occluded, and only then. None: the mean
    over all views."""
    centre: bool = True
    """Centre each view's costs per pixel before the mean over views (:func:`vfxstereo.matching.accumulate`)."""
    same_views: bool = False
    """Where some view sees a reference pixel at every plane, compare its planes over those views only
    (:func:`partial_views`; a stereo pair is unchanged: its one other view never sees the strip at every plane).
    Near a frame edge the views that lose a pixel at the near planes drop out of those planes' mean, and a mean
    of fewer centred costs reaches lower minima (the fault ``flat_guard`` records on boards_rocks), so a plain
    wall at the frame edge takes a nearer subject's depth: within 8 px of the left or right edge 13.3 % of the
    z-key tuning maps' pixels are more than 1 px off at K = 5 (8.0 % beyond 64 px), and those maps with the two
    16 px strips set to the truth gain +0.52 / +0.32 dB (frame / band, K = 5) and +0.47 / +0.29 (K = 2).

    Off: measured in session 60 (K = 5, the z-key tuning scenes' maps solved again): bad pixels within 32 px of
    the frame edges 10.48 -> 9.64 %, farther in 8.35 -> 8.07 %; but the z-key tuning rows (157) 35.27 / 27.98 ->
    35.16 / 27.94 dB (sheep_duck_wall's full card at d = 10.5 +14.8 / +8.8, ostrich_grille +1.2 / +0.7;
    rabbit_cream_board's full card at d = 10.5 -10.4 / -2.2, fur_grey_wall -4.2 / -3.0), rows losing to the SGBM
    key unchanged; Middlebury's 31 sets from all views 8.2 -> 8.55 % bad (Midd1 and Midd2 -2.1, cones +2.9,
    Monopoly +1.8; none losing to SGBM). Most of the strips' excess over the inside (1.6 of 2.1 points) stays: it is
    not the mean's."""
    far_bias: float = 0.35
    """Where the cost curve is flat (a surface without texture), add up to this much cost, growing linearly
    from the farthest plane to the nearest, so that an undecided surface goes back rather than taking the
    depth of a nearer textured object next to it (see :func:`flat_bias`). Measured with ``flat_window``:
    see there."""
    flat_gap: float = 0.04
    """Cost gap (mean over the planes minus the minimum) below which a pixel counts as flat: the bias weight is
    ``exp(-gap / flat_gap)``."""
    flat_window: int = 9
    """Side of the window the cost gap is averaged over (px): only surfaces flat over a region get the bias, not
    a weakly textured strip or the rows along the frame edge. A wide window keeps the bias away from the plain
    wall next to a textured object, where the object's depth then spreads: measured depth-only (bad pixels at
    the truth cut at alpha 0.5, 6 z-key tuning scenes at K = 5 and 2 / 10 Middlebury sets incl. the plain
    Wood2, Midd1, Baby3, Plastic, Monopoly): window 31 with bias 0.25 (until now) 11.87 / 12.95 %; 15: 10.92 /
    12.97; 9: 10.54 / 13.02; 9 with bias 0.35: 9.41 / 13.22; 9 with 0.5: 8.99 / 14.84 (Monopoly 12.2 ->
    20.3); 5 with 0.35: 9.31 / 13.32. All 31 Middlebury sets with 9 and 0.35: 9.76 % (9.64 before), no set
    above SGBM's (Baby3 8.51 against 10.19, Midd1 26.0 against 29.1). Z-key tuning scenes (full solve, frame /
    band dB): 27.19 / 19.48 -> 27.84 / 19.70, fur_grey_wall +2.2 / +1.4 at K = 2."""
    rival_jump: float = 0.0
    """The flat-surface bias also reaches pixels where a depth at least this far from the winner (px per view
    step) matches about as well (:func:`rival_gap`; 0: the cost gap alone decides; 3 in the ``grille`` preset).
    A plain wall seen through a grille, a fence or wicker matches at its own depth and at the grille's, but its
    cost curve is not flat: at the planes between, the bars pass over it in the other views. Semi-global
    matching then carries the grille's depth into the holes, and the element is hidden behind a wall that is
    not there. Cells no other view sees are no rival: at the frame edge of a stereo pair the far planes leave
    the other view and cost 0 (counted as rivals: fur_grey_wall K = 2 frame -4.2 dB).

    Off by default, because what it really does is widen the flat gate to weakly textured surfaces, and sends
    them back: right for the plain walls behind the z-key scenes' subjects, wrong for Middlebury's plain objects.
    Measured in session 23 against no rival (``rival_scale`` 0.25 unless said):

    * z-key benchmark, all 194 rows, frame / band dB: 27.98 / 21.33 -> 28.90 / 22.30 (tuning 56 rows +0.58 /
      +0.53, held-out 138 rows about +1.0 / +1.1: koala_slope +3.8 / +1.1 and +5.1 / +1.4 at K = 5 / 2,
      doll_plaster +3.1 / +6.2, hair_shelves K = 5 +5.4 / +3.9, ostrich_grille +2.2 / +1.2 and +2.4 / +1.3,
      fence_dof +3.5 / +1.7 and +3.3 / +3.3; sheep_duck_wall K = 2 -4.0 / +2.0, doll_plant K = 2 -3.4 / +0.2,
      hair_shelves K = 2 -1.9 / -0.1: a weakly textured near surface whose cost is noise at every plane goes
      back); rows losing to the SGBM key on the band 10 -> 6;
    * Middlebury's 31 sets, depth alone: 9.53 -> 12.88 % bad (SGBM 19.50); Midd1 25.7 -> 49.1, Midd2 17.4 ->
      49.2, Lampshade2 6.9 -> 19.8, Monopoly 12.5 -> 23.9, Plastic 34.5 -> 42.3, Bowling1 12.4 -> 20.6, Baby3
      8.3 -> 11.1 (Midd1, Midd2 and Baby3 above SGBM's 29.1, 35.3 and 10.2); Art 11.3 -> 10.6;
    * ``rival_scale`` 0.5: tuning +0.44 / +0.34, 194 rows +0.71 / +0.73, Middlebury 12.29 % (Midd1 47.2);
      1.0: tuning +0.18 / +0.08 (Baby3 8.49); 0.15, and ``rival_jump`` 2: below 0 (fur_grey_wall K = 2 -12
      and -10 dB on the frame: the setting is sharp there);
    * safe on Middlebury only with the rival's bias capped at 0.05 (Midd1 25.81, Monopoly 12.17), where it
      no longer does anything on the z-key scenes (+0.04 / -0.02);
    * the rival's gap relative to the curve's spread instead (two clean minima, not noise): +0.03 / -0.08; a
      bonus on the rival plane instead of the ramp to the back: tsukuba 3.94 -> 5.58 %.

    Cost: the depth stage at 1920x1080 x 64 planes (K = 5, ``samples.layered_scene``), side by side, best of 2:
    1.15x (28.3 against 24.7 s)."""
    rival_scale: float = 0.25
    """The rival's cost gap counts this many times against ``flat_gap`` (the bias weight is
    ``exp(-min(gap, rival_scale * rival) / flat_gap)``, averaged over ``flat_window``)."""
    flat_guard: bool = True
    """Give plain regions the flat-surface bias sent back their nearer depth when they are a surface of their own
    in front of a farther one (:func:`own_surfaces`): semi-global matching runs a second time, without the
    bias, and each region it moved is judged by its ring -- farther, unlike surfaces around it (a plain board
    in front of a textured wall) against as-near, unlike ones it may have taken its depth from (a grille's bars
    around a hole, a subject beside a plain wall). Measured in session 24 against no guard:

    * z-key benchmark, all 206 rows, frame / band dB: 27.54 / 21.22 -> 27.83 / 21.27; tuning (68 rows) 29.20 /
      22.29 -> 30.11 / 22.42, all of it boards_rocks K = 5 (+10.2 / +1.4: the plain board from 56 % of its
      pixels too far to 0.4 %); held-out (138 rows) 26.72 / 20.70 -> 26.71 / 20.70, no scene changed by more
      than 0.05 dB but doll_plaster K = 5 (+0.05 / +0.14). At K = 2 boards_rocks gains only +0.15 / 0.0: with
      one view to one side, the plain board's edges are half-occluded or horizontal, and even unbiased matching
      puts most of it back;
    * the first version, without the grown ring (``guard_carry``): tuning +0.88 / +0.14, but held-out
      doll_plaster K = 2 -10.8 / -8.1 and hair_shelves K = 5 -6.2 / -1.1 (a plain wall between a near subject
      and a farther card came forward with the subject's depth);
    * with the rival gate of the ``grille`` preset, tuning +1.24 / +0.57 against neither; Middlebury's plain
      objects still go back under the rival gate (12.87 % bad against 12.88 without the guard: they are
      surrounded by their own textured parts at the same depth, which the ring counts as lenders);
    * Middlebury: the first version, depth alone, all 31 sets 9.53 -> 9.50 % bad (Baby3 8.31 -> 7.48, no set
      worse by more than 0.09); this one changed none of the 24 sets its full run scored by 0.01.

    Cost: a second SGM in the last pass and one more volume (:func:`bytes_per_cell`). The depth stage at
    1920x1080 x 64 planes (K = 5, ``samples.layered_scene``), side by side, best of 2: 1.07x the time (41.9
    against 39.2 s, on a loaded machine), peak traced memory 2.77 against 2.27 GiB. (In every pass: 1.40x.)

    Still needed with steps 9-19 (session 49, off against on, z-key tuning rows, frame / band dB): K = 5 -1.01 /
    -0.22, K = 2 -0.87 / -0.52, rows losing to the SGBM key 7 / 6 -> 12 / 8 (sign_plant_aloe's sign and
    panel_hair_books' panel go back: -15 to -36 dB on their cards). Its one known fault: boards_rocks K = 5's
    board keeps a 25 px strip along the left frame edge at the nearest plane (too near by 3 px), which the
    biased and the unbiased maps both put there: only the two views left of the reference see that strip at
    the near planes, and a mean cost over fewer views reaches lower minima (the strip's cost at 12-13 px from
    one view: -0.55, the board's own range about +-0.2). Without the guard the board goes back whole and
    steps 13 and 17 bring it forward again, strip and all (its bad pixels 5.8 -> 2.8 %), but the other boards
    do not come back. Shrinking the mean of fewer views towards the unseen cost (by ``n / (n + 3)``, scaled to
    1 for all views) fixed a fifth of the strip and cost K = 5 -0.57 / -0.24 (panel_hair_books -36 dB)."""
    guard_jump: float = 2.0
    """Disparity (px per view step) by which the bias must have moved a pixel back, and by which the textured
    surface around must be farther (:func:`own_surfaces`)."""
    guard_radius: int = 16
    """Reach (px) of the ring around a moved region (:func:`own_surfaces`)."""
    guard_share: float = 0.15
    """Share of the unlike ring (colour) that must be farther (:func:`own_surfaces`)."""
    guard_carry: float = 0.1
    """At most this share of the unlike ring (against the farther part of it) may be as near as the region: a
    neighbour it may have taken its depth from (:func:`own_surfaces`). Measured: 1.0 lets a plain wall between a
    near subject and a farther photo card come forward with the subject's depth (doll_plaster K = 2, 38 % of
    the pixels too near against 12 %)."""
    guard_unlike: float = 12.0
    """Colour difference (8-bit sRGB, mean over channels) from the region's mean above which a ring pixel counts
    as another surface, not the region's own surface continuing (:func:`own_surfaces`)."""
    flat_texture: float | None = None
    """Local grey-level deviation (8-bit units, 9 x 9 window) below which a pixel counts as plain: the bias weight
    is also multiplied by ``exp(-deviation / flat_texture)``; None: the cost gap alone decides."""
    strip_memory: float = 6.0
    """GiB the stage's cost volumes may take at once. A plate whose volumes need more is solved in horizontal
    strips (:func:`strips`), each with ``strip_margin`` rows of context above and below that are solved and
    thrown away; rectified rigs only (a general camera is solved whole). 6 GiB solves 1920x1080 with up to
    129 planes whole and 4096x2160 with 65 planes in 2 strips, with 129 in 4;
    :func:`vfxstereo.solver.fit_to_memory` lowers it on a machine with less free memory. (2 GiB cut
    4096x2160 x 129 planes into 54 strips of 40 rows, each solved with 130 rows of margin: 4x the work.)"""
    strip_margin: int = 64
    """Rows of context on each side of a strip (plus the largest vertical shift of any view). Semi-global
    matching carries costs along whole columns, so strips can differ from the whole solve near their seams
    where nothing local decides the depth. Measured on the z-key scenes cut into 60-row strips: trolls_art
    (textured) no pixel off by more than half a plane with 48 rows, 0.2 % with 24; koala_slope (a plain slanted
    wall) 5 % with 48 and 9 % with 24, its comps 0.1-1.1 dB lower; in 135-row strips with 32 rows, 2.8 %
    and comps within 0.11 dB. HD plates are solved whole by default, 4K ones in 2-4 strips of 540-1080 rows."""

    edge_refine: bool = False
    """Step 8: re-decide the pixels near depth edges between their neighbourhood's front and back disparity by a
    pixelwise cost with colour-adaptive support weights (:func:`refine_edges`), against foreground fattening.
    Off: measured on the z-key tuning scenes (full solve, with ``edge_margin=0.05`` and ``consistency_method=
    "rematch"``) it helps at K = 5 (mean 26.88 / 19.09 -> 27.19 / 19.27 dB frame / band, no scene worse by
    more than 0.08 dB) but not at K = 2 (24.75 / 17.25 -> 24.77 / 17.26: trolls_art +1.3 / +1.0, the plain
    walls and tassels_room -0.2 to -0.7). Most of the remaining "fattening" on those scenes is hair below
    alpha 0.5 and half-occluded strips wider than the neighbourhood, which this step does not reach. Re-measured
    since (all later steps in place): session 44, -0.80 / -0.40 dB on the tuning rows; with
    ``edge_zbuffer="sided"``, see there. The rim is now taken by step 19 (colour, not matching; on by default,
    ``rim_ratio``), whose docstring has the numbers."""
    edge_radius: int = 4
    """Half-side of the neighbourhood whose disparity range marks a depth edge and gives the two candidates."""
    edge_jump: float = 1.5
    """Disparity range (px per view step) of the neighbourhood above which a pixel is at a depth edge."""
    edge_support: int = 4
    """Half-side of the support window of the pixelwise cost."""
    edge_gamma_c: float = 10.0
    """Colour difference (8-bit sRGB, mean over channels) that divides a support weight by e."""
    edge_gamma_s: float = 4.0
    """Distance (px) that divides a support weight by e."""
    edge_margin: float = 0.0
    """Cost a pixel's other candidate must win by before it moves (per view)."""
    edge_census_radius: tuple[int, int] = (1, 1)
    """Census window of the pixelwise cost (3 x 3: it barely straddles an edge)."""
    edge_lambda_census: float = 4.0
    """Scale of the Hamming distance of the pixelwise cost (bits)."""
    edge_zbuffer: str = "confident"
    """Visibility of the candidates: z-buffers of the map with the front side of the edge pixels left out
    ("confident": a fattened foreground does not hide its own background), of the whole map ("all"), or no
    z-buffer: the views on the side away from the neighbourhood's front pixels ("sided"; Kang, Szeliski & Chai's
    one-sided view subsets, chosen per pixel). With "confident", a true background pixel beside the front is
    also judged by the views its true front hides, and loses to the front candidate: measured on the final maps
    of four Middlebury sets (tsukuba, teddy, Art, Reindeer) and of the 72 z-key scene/rig pairs, default settings,
    it moved 18.0k / 384k pixels, put 4.1k / 75k of them right and 12.3k / 212k wrong. "sided" with
    ``edge_forward=False`` and ``edge_margin=0.05``: 5.5k / 41k moved, 3.3k / 27k put right, 0.3k / 5.8k wrong.
    In the pipeline (sessions 45-46, depth recomputed, the same settings) it is still not worth turning on: Middlebury
    9.21 -> 9.04 % bad from all views (28 of 31 sets better, too near at the jumps 20.6 -> 19.3 %) but 14.33 ->
    14.69 % from the pair (Bowling1 16.1 -> 28.6 %: a few pixels moved at a cloth edge and the later steps carried
    the change across its plain white middle); z-key, all 362 rows, +0.05 / -0.02 dB frame / band, rows losing to
    the SGBM key 11 / 7 -> 12 / 10 (shelf_grille K = 2 -1.9 / -3.5, doll_plaster K = 5 -1.9, boards_rocks K = 5
    -1.3; fence_dof +1.1 to +1.4, sheep_duck_wall K = 2 +2.4 frame). Steps 9-18 and the soft edges are tuned to
    maps without it."""
    edge_forward: bool = True
    """Step 8 re-decides the back side of an edge too (False: only the front side, which fattening widens)."""
    edge_passes: int = 1
    """Passes of step 8 (later passes see z-buffers of the refined map)."""
    reopen: bool = False
    """Step 9: reopen the gaps the window filled (:func:`reopen_gaps`). A pixel moves back to a farther surface
    around it where views see that surface with the plate's colour there and neither its own depth nor a
    nearer surface around explains it as well. (On a stereo pair, ``reopen_pair`` runs it in a checked form.)
    Off by default, on in the ``soft`` preset: on the z-key
    benchmark it gains on foliage over textured backgrounds at K = 5 and is neutral elsewhere, and at HD it
    costs about as much as the rest of the depth stage. Measured in session 19 (frame / band dB; each version
    checked on held-out scenes scored last, two new ones each time):

    1. One view enough, no visibility: tuning 56 rows 30.06 / 21.97 -> 30.57 / 22.47 (tree_cloth +1.6 / +1.5
       at K = 5 and 2, its K = 2 rows that lost to the SGBM key won); held-out 70 rows 25.98 / 19.65 -> 25.22 /
       19.01 (artichoke_books K = 2 -3.7 / -5.3, bear_pillar K = 2 -3.4 / -2.5: beside a thin wire or filament
       the one other view of a pair sees the wire where the pixel's own depth should be, and a chance match
       elsewhere passes the ratio).
    2. Two views (``reopen_views``), hidden views left out: tuning K = 5 (K = 2 is left alone) +0.29 / +0.32;
       held-out K = 5 47 rows 28.33 / 21.52 -> 27.20 / 20.36 (shelf_grille -7.1 / -7.0: grille bars the depth
       map had missed, at the subject's depth behind them, went to the wall, and the element showed over them).
    3. The nearer surfaces too (``reopen_nearer``): tuning K = 5 28 rows 30.77 / 22.63 -> 31.06 / 22.96
       (tree_cloth +1.0 / +1.0, trolls_art +0.4 / +0.5); held-out K = 5 57 rows 27.57 / 20.97 -> 27.51 / 20.98
       (fence_dof +0.3 / +0.2, two_soft_pots -0.55 / +0.05, the two scenes new to it -0.01 / 0.00); all 170
       rows 27.57 / 20.87 -> 27.60 / 20.92. Under the ``soft`` preset, on the 7 scenes where it moves pixels at
       K = 5: 29.77 / 22.65 -> 30.02 / 22.93 (tree_cloth +1.0 / +1.0, fence_dof +0.5 / +0.2, plush_wall -0.2 /
       -0.2). Middlebury's 31 sets, depth alone: 9.76 -> 9.76 % bad (no set worse by more than 0.01), at
       50-130 % of the depth stage's own time at their sizes; HD x 64 planes (K = 5, random dots), side by
       side: 31 s with 2 passes against the rest of the depth stage's 35 s, 15 s against 34 s since a pass
       that moves almost nothing ends them (``reopen_settle``).

    Session 55, on the head (all of steps 10-19 in place), K = 5, all 181 rows: -0.01 / -0.01 (tuning +0.00 /
    -0.00, held out -0.05 / -0.05): tree_cloth +0.51 / +0.48, fence_dof +0.56 / +0.36, tassels_room +0.38 / +0.42,
    but sheep_duck_wall -0.64 / -0.79, wicker_grille_dolls -0.32 / -0.33, beanie_grille -0.31 / -0.25. The gaps it
    was made for are mostly taken by the later steps; the ones left (leaves_wire_bowling: pale wallpaper through
    dark leaves 9 px per view step nearer, bad pixels 8.3 -> 8.2 %) are seen by one view of four or none, with an
    error there of about 0.03 against 0.04-0.14 at the leaves' depth, above the ratio. Still off."""
    reopen_radii: tuple[int, ...] = (8, 16, 32, 64)
    """Candidate back surfaces: the farthest disparity within each of these distances (px)."""
    reopen_jump: float = 1.0
    """A candidate counts only this much farther than the pixel or more (px per view step; the soft edges' jump)."""
    reopen_ratio: float = 0.5
    """A pixel moves where the candidate's error is below this share of its own depth's error."""
    reopen_floor: float = 0.002
    """... and only where its own depth's error exceeds this (colour^2, the views' noise and resampling) ..."""
    reopen_relative: float = 0.01
    """... and this share of the pixel's squared colour ``|I|^2``: bright, finely textured surfaces resample
    with errors of that size at their own depth (a plush toy's fur moved back to the wall 12 px behind it
    at 0)."""
    reopen_jitter: float = 0.5
    """Both depths are tried within +- this (px per view step; 5 samples): sub-pixel misregistration of a fine
    texture must not count against a depth."""
    reopen_passes: int = 2
    """Passes of step 9 (the 3x3 errors of a pixel's neighbours change as they move)."""
    reopen_settle: float = 1e-4
    """The passes stop when fewer than this share of the pixels moved (at HD x 64 planes a pass costs about
    half as much as the rest of the depth stage: 15 s against 34 s)."""
    reopen_nearer: bool = True
    """A pixel moves only where the farther surface also beats the nearer surfaces within ``reopen_radii`` (in
    their best view): a pixel whose own depth fails may belong to a nearer surface the map missed -- a thin
    grille's bar given the subject's depth behind it -- and sending it farther still shows the element over
    it (shelf_grille, K = 5: 207 of 223 moved pixels wrong without it, none of 15 with it)."""
    reopen_pair: float = 0.0
    """Step 9 on a stereo pair, with the pair's one view and this ``reopen_ratio`` (0: off), where step 6's
    rematch made the other view's own map: of the groups of moved pixels (8-connected) only those stay where, at
    one pixel or more, the other view's own map agrees with the new depth (within one of its pixels, within one
    pixel of where the pixel lands there): both views' maps then say the pixel is the farther surface
    (:func:`vfxstereo.depth_plate.reopen_pair_checked`). One view matches thin structures and edges by chance (see
    ``reopen_views``); there the other view's map is fattened as the reference's is, and still has the near
    surface.

    Off by default: on the z-key tuning scenes at K = 2 it gains where leaves or hair lie over a textured
    background and costs two near-exact rows. Measured in session 39 (frame / band dB):

    * on the final maps of 7 tuning scenes at K = 2, the moves of step 9 with one view and ratio 0.2, right /
      wrong by the truth (more than 1 px off before / after): unchecked 1753 / 445 (shelf_grille 13 / 270: the
      teddy's and the card's edges), checked per pixel 271 / 9, per group (kept here) 703 / 40;
    * z-key tuning scenes, K = 2, 151 rows, ratio 0.2: 29.42 / 23.95 -> 29.48 / 23.92; fence_dof +2.26 / +1.70,
      tree_cloth +0.79 / +0.67, trolls_art +0.37 / +0.41, shelf_grille +0.04 / +0.04 (unchecked, session 38:
      -6.6 / -7.5); but two_soft_pots' two small-card rows -5.61 on the band (35.55 dB, a tie with the SGBM key,
      to 29.94: two pixels of the bear's edge sent back, which the other view's map also puts back), sign_plant_aloe
      -0.08 / -0.23, sheep_duck_wall -0.07 / -0.17; rows losing to the SGBM key on the band 2 -> 4;
    * a quarter of a group's pixels confirmed instead of one: 29.43 / 23.89 (fence_dof +0.25, tree_cloth 0: its
      gains need the groups only a few pixels confirm; two_soft_pots as before);
    * held-out scenes, K = 2, 30 rows, scored once after: 25.84 / 20.77 -> 25.93 / 20.82 (railing_subject_rocks
      +0.39 / +0.27), no row losing that did not;
    * Middlebury's classic pairs, depth alone: 14.33 -> 14.32 % bad (12 sets better, tsukuba 5.30 -> 5.20, Art
      22.17 -> 22.07; Bowling2 and cones 0.01 worse).

    Session 55, on the head (all of steps 10-19 in place), the 151 K = 2 tuning rows: -0.04 / -0.03 (fence_dof
    -0.10 / +0.21: its gain is gone, the later steps now take most of those gaps; tree_cloth -0.50 / -0.55,
    ostrich_grille -0.33 / -0.09). Still off.
    """
    reopen_views: int = 2
    """Views that must see the candidate with the plate's colour (its error: the ``reopen_views``-th least of
    the views'); a rig with fewer other views skips the step. With 1, a stereo pair's one other view decides
    alone, and beside a thin wire or a filament the pixel's own depth fails there (half-occluded) while a
    chance match passes the ratio: session 19's first measurement (``reopen``) lost most at K = 2.

    Session 58, step 9 on with 1 at K = 5 (a narrow gap between two subjects, such as witch_monster's strip of
    the card between the witch and the monster's fur, is seen by one view of four pixel by pixel): z-key K = 5
    rows, the depth maps solved again, tuning (157) 35.17 / 27.84 -> 34.68 / 27.63 dB, held out (42) 32.61 /
    26.11 -> 32.57 / 26.10, rows losing to the SGBM key 9 -> 12 and 0 -> 1 (shelf_grille's card at d = 3 -10.6 /
    -20.1, artichoke_books' near-exact card at d = 4 -5.7 / -6.4, two_soft_pots -1.8 / -4.3; leaves_wire_bowling
    +1.6 to +2.8, doll_plant +2.6, tassels_bear_bowling +1.8 / +2.7; witch_monster itself -0.4 to +0.5). One view's
    chance matches win again."""
    colour_reopen: bool = True
    """Step 10 (:func:`reopen_by_colour`), on the whole plate: a pixel whose colour is far more common among the
    farther surfaces beside it than on its own surface takes the nearest farther one's depth, where that joins
    a farther surface already in the map. Against the foreground the window grows over the gaps beside it and
    over half-occluded strips, which no view can place. Measured (session 27, z-key benchmark, frame / band dB):
    the 230 rows of the 25 tuning scenes 28.50 / 22.19 -> 28.66 / 22.32 (tassels_room +1.1 / +0.5 and +1.5 /
    +1.0, trolls_art K = 2 +0.6 / +0.6; worst doll_plant K = 2 -0.2 / -0.2, witch_monster K = 2 -0.2 / -0.2,
    fence_dof -0.2 / -0.1), rows losing to the SGBM key 16 / 12 -> 16 / 11; the four held-out scenes, scored once
    after it, 30.70 / 27.75 -> 30.86 / 28.02 (duck_monster_baby K = 2 +0.7 / +0.7; fur_pillar_monopoly -0.1 /
    0.0), rows losing 4 / 3 -> 6 / 4 (two rows that tied or won by < 0.5 dB now lose by 0.01-0.05 dB, one band
    row that tied loses by 4.6 dB: a small card under the artichoke's hairs). Middlebury: see the module
    docstring. The versions that also opened islands inside a surface gained more on the first seven tuning
    scenes and lost on the others (module docstring).

    Tried in session 58 and not kept: the groups that reach the frame's edge kept as well (open there: a gap
    between petals or leaves that the frame cuts, whose farther surface may go on beyond it). On the stored final
    maps of the 58 tuning scene-rigs such groups (10 px or more) were 22, 828 px, 684 of them put right (37 right
    before). In the stage (z-key benchmark, all 398 rows, the depth maps solved again, frame / band dB): 33.09 /
    26.38 -> 33.10 / 26.40; tuning K = 5 +0.02 / +0.02, K = 2 +0.00 / +0.02 (fur_grey_wall K = 5 +2.4 / +1.8,
    doll_plant K = 2 +1.6 / +1.7), held-out K = 5 0 / 0, K = 2 -0.06 / -0.01 (flowers_cone_cloth's full card at
    d = 2.9 -0.25 / -0.56); no row changed sides against the SGBM key. Middlebury, depth only: 8.21 -> 8.24 % bad
    (Midd2 11.92 -> 12.84 %, 14 sets +0.01). The petal gaps cut by the frame's top edge that cost hair_shelves
    most (``depth_plate``'s module docstring) do not move: no farther pixel within reach has their colour."""
    colour_radius: int = 40
    """Reach of step 10's window (px; steps 16's too).

    Session 55, against 40 (z-key tuning rows, frame / band dB): at K = 2, 60 +0.12 / +0.15, 80 +0.34 / +0.26
    (trolls_art +1.3 / +1.7, wicker_wall +1.5 / +1.6, tassels_room +1.3 / +1.2: a stereo pair's half-occluded
    strips beside a head or a pencil are wide, and within 40 px the strip's own wrongly placed pixels count as
    much as the surface it belongs to; doll_plaster -2.6 / +0.1, tree_cloth -0.8 / -0.8), 120 +0.25 / +0.03,
    80 sampled every 8 px +0.13 / +0.03; at K = 5, 80 -0.59 / +0.04, rows losing to the SGBM key 3 / 4 -> 6 / 4
    (two_soft_pots' near-exact rows -10 to -13 dB over the frame, duck_monster_baby -21 on one). Then scored on the
    held-out rows at K = 2, 80: +0.01 / -0.06 (wicker_grille_dolls -0.8 / -0.9, plank_toy_wood +0.7 / +0.4): the
    tuning gain is the scenes', not the radius's. Not kept, for a pair or at all."""
    colour_stride: int = 4
    """Step 10's window samples every this many px."""
    colour_like: float = 0.04
    """Two colours are alike when every channel (sRGB-encoded, 0-1) is within this."""
    colour_ratio: float = 4.0
    """How many times more common among the farther surfaces than on its own a pixel's colour must be."""
    colour_jump: float = 1.5
    """Disparity difference (px per view step) that makes a pixel farther; within half of it, the same depth."""
    thin: bool = True
    """Step 11 (:func:`recover_thin`), on the whole plate: a thin near structure the window of steps 1-3 and the
    median erased (a grille's bars or a wire over a textured background, twigs) comes back where, pixel by
    pixel, every other view sees the plate's colour on a nearer plane and no view that the map says sees the
    pixel's own depth does. Needs ``thin_views`` other views, on both sides of the reference (a stereo pair's
    one other view matches some nearer plane by chance almost everywhere: measured, it put 2-4 % of the pixels
    of hair and toy scenes too near). Measured (session 29, z-key benchmark, frame / band dB): the 230 rows of
    the 25 tuning scenes 28.67 / 22.32 -> 28.77 / 22.47 (only the K = 5 rows change: shelf_grille +2.9 / +3.5,
    beanie_grille +0.7 / +1.0, ostrich_grille +0.3 / +0.4, sphere_plant +0.3 / +1.1; no scene worse on
    average, the worst row -0.44 / -0.49); 93 % of the 7894 pixels it moved went to their true depth (within
    1 px), a third of the pixels put too far there. Without the both-sides test and the uniqueness test, plain
    blobs in a fringe matched a nearer plane (tassels_room -3.6 / -4.0, koala_slope -2.2 / -2.3). The four
    held-out scenes, scored once after: 30.85 / 28.02 -> 30.89 / 28.02 (petals_grille_plastic K = 5 +0.7 / +0.4,
    leaves_wire_bowling K = 5 -0.4 / -0.3: one row -1.6 / -1.6); all 278 rows 29.04 / 23.31 -> 29.14 / 23.42,
    rows losing to the SGBM key on the band 15 -> 14. Middlebury's 31 sets, depth alone: 9.39 % bad before and
    after (tsukuba 3.65 -> 3.61, Art 10.98 -> 10.97, no other set changes). Cost (K = 5, ``benchmarks/speed.py``,
    the step against the rest of the depth stage in the same run): 8 % of the stage at 1920 x 1080 x 64 planes
    (2.5 of 32.1 s), 10 % at 4096 x 2160 x 64 (11.6 of 115.6 s; the solve's peak 6.7 GiB, within its estimate
    of 13.0)."""
    thin_views: int = 3
    """Other views step 11 needs (and it needs them on both sides of the reference): with fewer it is skipped.

    Tried in session 55 for a stereo pair (a 1 px grille is where the K = 2 rows lose most against the true-depth
    key: petals_grille_plastic K = 2 has 45 % of its grille pixels off the grille's depth, K = 5 17 %): step 11
    with the pair's one view (``thin_ratio`` 3), keeping only groups at least 20 px long, on the final maps of 7
    tuning scenes put more pixels wrong than right on every one (petals_grille_plastic 1254 right / 1802 wrong,
    shelf_grille 167 / 418, beanie_grille 246 / 480, trolls_art 0 / 128, two_soft_pots 0 / 370, hair_shelves 0 /
    230): one view matches a nearer plane by chance along edges and hair too, in long groups."""
    thin_jump: float = 1.5
    """A candidate plane is nearer than the pixel's disparity by more than this (px per view step)."""
    thin_ratio: float = 3.0
    """A pixel moves where its own depth's least error over the views that see it (colour^2) is above this many
    times the candidate's error in its worst view ..."""
    thin_floor: float = 0.002
    """... plus this (the views' noise and resampling)."""
    thin_unique: float = 2.0
    """A pixel's candidate is unique where every plane two or more planes from it errs more than this many times
    as much (plus ``thin_floor``): a plain patch matches a range of planes, a bar one."""
    thin_share: float = 0.5
    """A group of moved pixels (8-connected) is kept where at least this share of it is unique, ..."""
    thin_width: float = 2.0
    """... or where it is thin: no pixel of it farther than this from its border (px; a bar or a wire)."""
    thin_size: int = 10
    """Groups smaller than this (px) are dropped."""
    join: bool = True
    """Step 12 (:func:`join_plain`), on the whole plate: inside a plain region of one colour, the nearer side of a
    depth step takes the farther side's depth (there is no colour edge for a depth edge to sit on), flooding from
    farther pixels whose depth some texture nearby supports; each group of moved pixels is then checked against
    the views (``join_check``). It is aimed at a plain wall beside a textured subject or seen through a grille,
    which the window and SGM gave the subject's depth, so that a z-keyed element between them is hidden by
    a wall that is not there.

    On by default since session 31, with two tests on what a flood may change, both on the plate's plain
    surfaces (:func:`plain_surfaces`: plain pixels joined where neighbours differ by at most 1 px in depth and
    less than ``join_like`` in colour):

    * ``join_slopes``: a surface the map already carries smoothly to the flood's depth is a slope, not a step
      (Middlebury Bowling1's receding cloth, Baby3's shelf top and front, which a flood of one depth flattened);
    * ``join_grow``: the moves on a surface (of the joined map) stay only where they are at most half the pixels
      that already had its depth there. A grown strip is a small part of the wall it belongs to; the rabbit's
      board that followed its rim (4823 px moved, 246 had the depth), Middlebury Reindeer's sofa back that
      followed a wrong dark patch, and Plastic's yellow board that followed a noisy far patch are not.

    Measured (frame / band dB on the z-key benchmark; Middlebury depth only, bad pixels):

    * off (before session 31): tuning rows (230) 28.77 / 22.47, 16 / 10 rows losing to the SGBM key; held-out
      rows (48) 30.89 / 28.02; all 278 29.14 / 23.42, 22 / 14 losing; Middlebury 9.39 %;
    * on without either test (session 30): tuning 29.30 / 22.77, 18 / 11 losing; held-out 31.63 / 28.24; all
      29.70 / 23.71, 25 / 15 losing; Middlebury 10.11 %, Baby3 above SGBM;
    * ``join_grow`` 0.5 alone: tuning 29.11 / 22.67, 16 / 10 losing; Middlebury 9.39 %, Bowling1 12.4 -> 17.5;
    * ``join_slopes`` alone: Middlebury 9.90 %, Reindeer 9.1 -> 18.3;
    * both, ``join_grow`` 1.0: tuning 29.29 / 22.72, 16 / 11 losing; Middlebury 9.28 %, Plastic 34.5 -> 37.1;
    * **both, ``join_grow`` 0.5 (the default)**: tuning 29.20 / 22.67, 16 / 10 losing; held-out (scored once)
      31.84 / 28.39, 6 / 4 losing; all 278 29.66 / 23.66, 22 / 14 losing; Middlebury 9.18 % (0.47x SGBM, the
      worst set 0.81x against 0.88x before).

    With the default, no z-key row changes side against the SGBM key. Gains: doll_plaster K = 5 +10.2 / +6.7
    (the plaster wall between the doll's hair and a card), duck_monster_baby (held out) +4.3 / +1.6 and +2.9 /
    +1.3, koala_slope +2.1 / 0.0 and +3.9 / +0.5, fur_grey_wall K = 2 +1.7 / +0.8, sheep_duck_wall K = 5 +1.2 /
    +0.4; worst: plush_wall K = 5 -0.45 / -0.48 (one row). ``join_grow`` 1.0 keeps hair_shelves K = 5's wall
    (+4.4 / +2.5; it moved 2777 px where 3280 had the depth) but flips curls_wire_midd K = 5's band on one row and
    lets Plastic's board follow its noisy patch. Middlebury: Midd1 25.5 -> 23.7, Midd2 17.3 -> 15.3, Lampshade2
    6.6 -> 6.0, Bowling1 12.4 -> 12.0, Plastic 34.5 -> 33.7, Reindeer 9.1 -> 8.7; worst Books 15.5 -> 15.9.

    Session 30's step without the two tests (measured without a reach, frame / band dB):

    * the 230 rows of the 25 tuning scenes 28.77 / 22.47 -> 29.30 / 22.77: doll_plaster K = 5 +8.9 / +4.9,
      hair_shelves K = 5 +4.4 / +2.5, koala_slope +2.1 / 0.0 and +3.9 / +0.5, sheep_duck_wall K = 5 +2.9 / +0.9,
      fur_grey_wall K = 2 +1.7 / +0.8, fence_dof +0.6 / +0.3 and +0.5 / +0.5; worse: rabbit_cream_board K = 5
      -1.6 / 0.0 (one row -12.8 / -1.0: the rim of the plain board in front had the rabbit's depth, the
      rabbit's texture beside it supports that depth, and the whole board follows), witch_monster K = 5 -0.5 /
      -0.1 (one row -6.3), plush_wall K = 5 -0.5 / -0.5;
    * without the views check: +0.42 / +0.30 (sheep_duck_wall K = 2 -3.1 / +0.8, where the pale sheep's colour
      runs on into the wall; with the check +1.4 / +1.0);
    * Middlebury: Baby3 8.30 -> 11.15 % (above SGBM's 10.19), Reindeer 9.1 -> 18.3, Bowling1 12.4 -> 17.5,
      Plastic 34.5 -> 37.5, Books 15.5 -> 17.7. ``join_reach`` 24 px brought those back but halved the z-key
      gain (tuning rows +0.27 / +0.14, rows losing 17 / 12);
    * with the ``grille`` preset's rival gate it added only +0.01 / +0.12 on the tuning rows (the gate sends
      most of the same walls back);
    * tried and left out: sources only inside a plain patch at one depth (more than half of 5 x 5), and support
      only from texture of the source's own colour -- neither changes what moves; a colour-weighted median of
      the map (radius 7) near its depth edges instead: -0.17 / -0.18; in session 31, counting the surface's
      texture-supported pixels twice more in the ``join_grow`` test (37 % of hair_shelves' wall that had the
      depth is supported, 3 % of Plastic's noisy patch): tuning +0.12 / +0.08 over the default (hair_shelves
      K = 5 +4.4 / +2.6), but the same curls_wire_midd row as ``join_grow`` 1.0 turns to losing on the band and
      Middlebury Moebius goes 12.0 -> 13.4 % (mean 9.20)."""
    join_plain: float = 3.0
    """Step 12's plain pixels: local deviation of the grey (8-bit sRGB, 5 x 5) below this (steps 13-15 and 17's
    too). Session 55, 5 (so that a faintly grained surface counts, such as petals_grille_plastic's Plastic card
    beside the flower, which matches every depth from its own to the flower's alike and takes the flower's):
    z-key tuning rows -0.32 / -0.14 dB frame / band at K = 5, -0.09 / +0.02 at K = 2 (ostrich_grille -3.5 / -2.3
    and -4.1 / -2.2, hair_shelves K = 5 -3.2 / -1.5; hair_shelves K = 2 +2.0 / +2.1, fur_grey_wall K = 5 +1.0 /
    +1.0). Not kept."""
    join_like: float = 0.04
    """Step 12 floods over pixels whose colour is within this of the colour it started from (every sRGB channel,
    0-1)."""
    join_jump: float = 1.5
    """Step 12 moves only pixels nearer than the flood's depth by more than this (px per view step)."""
    join_anchor: int = 8
    """Step 12 starts only from pixels with a textured pixel at their depth (within 1 px) within this reach (px)."""
    join_reach: int = 0
    """Step 12 moves no pixel more than this many 4-connected steps from where its flood started (0: no limit)."""
    join_slopes: bool = True
    """Step 12 leaves a plain surface where the map already reaches the flood's depth along it, smoothly
    (neighbours within 1 px, :func:`plain_surfaces`): a slope, which a flood of one depth would flatten."""
    join_grow: float = 0.5
    """Step 12 keeps the moves on a plain surface only where they are at most this many times the pixels of that
    surface that already had its depth (:func:`plain_surfaces`; 0: no such test)."""
    join_check: bool = True
    """Step 12's moves are checked against the views (:func:`views_confirm`, ``join_ratio``, ``join_floor``,
    ``join_share``)."""
    join_ratio: float = 4.0
    """:func:`views_confirm`'s ``ratio``."""
    join_floor: float = 0.002
    """:func:`views_confirm`'s ``floor`` (colour^2)."""
    join_unseen: float | None = 0.02
    """:func:`views_confirm`'s ``unseen_floor`` (colour^2; None: ``join_floor``): for a moved pixel whose old
    depth no view sees (a strip along the frame edge that the other views' frames leave out at that depth),
    there is no old error to compare with, and the move counts against its group only where the views see the
    new depth with an error above this. With ``join_floor`` (0.002) there, a plain wall's own error at its right
    depth (0.002-0.01 on flowers_fence K = 2's left cells) put right cells back. Added in session 37 (numbers
    under ``join_share``)."""
    join_share: float = 0.5
    """:func:`views_confirm`'s ``share``: a group of moved pixels stands unless more than this share of the
    pixels some view sees at their new depth are seen there with a larger error (``join_ratio``, ``join_floor``,
    ``join_unseen``).

    0.1 until session 37. With 0.1 the check put back whole grille cells that steps 14-16 had sent to the
    wall's depth, every pixel of them right: on a stereo pair's fence over a plain wall (flowers_fence K = 2)
    the cells along the frame edge (see ``join_unseen``), and cells whose few bad pixels (11-36 %) sit where
    the view sees a bar the map still draws too wide. Measured in session 37, z-key tuning rows (278, frame /
    band dB; rows losing to the SGBM key), against 0.1: 0.25 +0.03 / +0.02; 0.35 +0.05 / +0.04, losing 14 / 8
    either way (flowers_fence K = 2 +1.45 / +0.98, ostrich_grille K = 2 +0.99 / +0.76, K = 5 +0.58 / +0.57;
    worst doll_plaster K = 2 -1.00 / -1.15: a patch of its wall at 1.7 px goes from 13 to 0, both wrong);
    0.5 +0.07 / +0.05; 0.7 the same as 0.5. With ``join_unseen`` 0.02: at 0.35 +0.07 / +0.05, at **0.5 +0.07 /
    +0.06** (30.77 / 24.80 -> 30.85 / 24.85), losing 14 / 8 -> 14 / 7 (flowers_fence K = 2's card at d = 4
    turns to winning on the band: -0.42 -> +0.10; flowers_fence K = 2 +2.2 / +1.5, ostrich_grille K = 2
    +1.4 / +1.0, K = 5 +0.7 / +0.8; worst doll_plaster K = 2, as above). flowers_fence K = 2's wall within
    1 px: 47.8 -> 74.6 % (99.8 % of the pixels that move go back, to the truth). Held-out rows (60, scored
    once after the choice): 27.49 / 21.65 -> 27.58 / 21.71, none losing (wicker_grille_dolls K = 2 +0.57 /
    +0.24, board_fence_toy K = 2 +0.22 / +0.24; worst railing_subject_rocks K = 5 -0.03 / -0.01).
    Middlebury, depth only, all 31 sets: from all views 9.20 % either way (no set moves by more than 0.01),
    from the classic pair 14.32 -> 14.33 % (Baby2 10.85 -> 11.09, Baby1 8.87 -> 9.02)."""
    own: bool = True
    """Step 13 (:func:`own_edges`), on the whole plate: a plain region takes the depth of a textured edge beside it
    that is nearer than the region and than the texture beyond the edge (the edge moves with the plain side, so it
    belongs to it), where the edge runs over at least ``own_rows`` rows, the region so moved is solid
    (``own_solid``) and the texture beyond the edge is not at the region's own depth (``own_margin``); each
    group of moved pixels is then checked against the views as step 12's are. It is aimed at a plain board in
    front, at a frame edge or over a textured background, that the flat-surface bias put at the back: nothing in
    its interior says where it is, and on a stereo pair no half-occluded strip does either, but its edge against
    the texture beside it is matched at the board's depth.

    Added in session 32, on by default. Measured on the z-key benchmark (frame / band dB, rows losing to the
    SGBM key over the frame / on the band), against the default before it:

    * tuning rows (230, before fur_pillar_monopoly joined them): 29.20 / 22.67 -> 29.63 / 22.80, losing 16 / 10
      -> 9 / 7. Only two scenes move:
      boards_rocks K = 2 +11.0 / +4.1 (its top-left board 0 -> 100 % right: 15427 px claimed by its right
      edge, which the map had at 13.0 against the board's true 12.8 while the board's interior was at 0.75 and
      the troll and rocks beside it at 7; 8 losing rows now win) and rabbit_cream_board K = 2 +5.2 / +0.9 (its
      plain board in front, 4805 px, 90 % right; the full-card row -2.1 / -0.7 -> +13.1 / +3.5 against the SGBM
      key); every other tuning row is unchanged;
    * held-out rows, scored once: the step's first version took the 48 rows of the four scenes then held out
      from 31.84 / 28.39 to 31.97 / 28.39, no row changing side against the SGBM key. It moved one of them,
      fur_pillar_monopoly: at K = 2 its pillar's top (162 px, 85 % right), at K = 5 1972 px of its plain
      Monopoly card, wrongly, to the teddy's depth (one row +5.4 / +0.2, another -0.4 / -0.05). Finding why
      retired the scene (:data:`vfxstereo.zkey_scenes.RETIRED`) and gave the rule that a claim counts only the
      seeds it still holds (one edge there had flooded over another's seeds and counted their rows). With it the
      card stays (that scene's K = 5 rows are as without the step; K = 2 keeps the pillar's top). The five
      scenes held out now, two of them built after the step was chosen (panel_hair_books, sign_plant_aloe) and
      scored with it on and off side by side: no row changes;
    * Middlebury (all 31 sets, depth only): from all views unchanged on every set (9.18 %, 0.47x SGBM); from the
      classic pair unchanged but for Lampshade2, 13.96 -> 14.04 % (mean 14.05 % either way).

    The guards, each measured on the stored maps of the 25 tuning scenes (both rigs) and the 31 Middlebury
    sets, are what keep the step to those boards. Session 31's probe had none of them, and the walls of
    doll_plaster, fur_grey_wall, rabbit_cream_board, sheep_duck_wall, koala_slope and wicker_wall (17000-35000
    px each) came forward behind the strands of hair and fur along their outline. One at a time, against the
    default:

    * without the outline test (``own_cover`` 0): plush_wall K = 2's wall, 63839 px, claimed by 13 rows of fur
      strands along a 226-row outline (the map's right share 0.56 -> 0.45);
    * without the test on the texture beyond (``own_margin`` 0): sphere_plant K = 5's backdrop (4777 px, past
      the plant's stems), 1114 px between ostrich_grille K = 5's bars, small patches of beanie_grille and
      shelf_grille;
    * ``own_rows`` 4 instead of 8: 80 and 102 px between beanie_grille's and ostrich_grille's bars;
    * ``own_solid``: with the outline test it changes nothing measured; without both, Middlebury Wood2's cork
      (speckled: its flat pixels fill 74 % of their outline) comes forward, 4.0 -> 5.9 % bad.

    What it does not reach: a board whose interior the bias put at the depth of the texture beyond its edge
    (a board over a wall of one depth: the step cannot tell it from a plain part of that wall seen past a
    thin near line, and leaves it)."""
    own_rows: int = 8
    """Step 13 moves a region only where the edges that claim it lie on at least this many rows."""
    own_cover: float = 0.15
    """... and on at least this share of the rows where the region meets texture beside it."""
    own_solid: float = 0.9
    """Step 13 moves a region only where it fills at least this share of its outline (holes filled): a plain
    board, not the flat specks inside a textured surface."""
    own_margin: float = 1.0
    """Step 13 moves a region only where the texture beyond its claiming edges lies farther than the region's
    own depth by more than this, or nearer (px per view step): a region at the depth of the texture beyond a
    near line is more simply a plain part of that surface, seen past a thin near structure (a stem or a wire)."""
    cells: bool = True
    """Step 14 (:func:`grille_cells`), on the whole plate: a plain region takes the depth of the rival-gated map
    (one more semi-global pass over the same cost, with the flat-surface bias also on pixels a far depth explains
    about as well, ``cells_rival``) where that map puts it farther by ``cells_jump`` and the plain pixels
    around it (2 to ``cells_ring`` px out) that lie across a bar (``cells_across``) mostly (``cells_share``)
    have its colour (within ``cells_like``): a plain wall seen through the cells of a grille or fence sees the
    same wall again beyond each bar, while a plain subject sees something else beyond its outline. Then checked
    against the views as step 12's moves are. The rival-gated map gets the flat guard too
    (:func:`own_surfaces`): without it, a plain board in front went back with it (boards_rocks K = 5, -11.9 dB
    frame).

    Added in session 33 (ring 8 px, any plain region around counting), off: it won on the tuning scenes and
    lost on the held-out ones (three full-card rows of panel_hair_books K = 2 turned to losing, -3.2 dB at
    worst) and on Middlebury (9.18 -> 9.27 %, Plastic 33.7 -> 35.2). Session 34 found why: the map had split
    panel_hair_books' plain panel into regions of several depths, and each region saw the panel's own colour
    around it. With ``cells_across`` only what lies across a bar counts, and with a ring of 12 px the bars of
    ostrich_grille (2-3 px, with the unplain pixels beside them) are crossed: its wall was 4 % right, now 12 %
    (ring 8) -> 27 %. **On by default since session 34.** Measured on the z-key benchmark (frame / band dB; rows
    losing to the SGBM key, frame / band), against the default without it, side by side:

    * tuning rows (242, panel_hair_books aside): 30.03 / 23.89 -> 30.45 / 24.13, losing 11 / 7 -> 8 / 6
      (ring 12 without ``cells_across``: 30.50 / 24.18; ring 8: 30.42 / 24.17; ring 16 as 12). flowers_fence
      +2.6 / +1.6 and +1.9 / +1.2 (K = 5 / 2; five of its losing row-metrics win), doll_plaster K = 2 +6.5 /
      +6.2, ostrich_grille +2.5 / +1.5 and +3.2 / +1.8, hair_shelves K = 5 +2.1 / +0.7, fur_grey_wall K = 5
      +1.6 / -0.1. Losers: a plain surface *between* the fence and the wall, seen through the fence, goes back
      to the wall too (nothing here tells it from the wall): bear_pillar's pillar (the full card at d = 3 -4.1 /
      -1.8 and -4.9 / -1.9 at K = 5 / 2, while its rows at d = 7 gain) and curls_wire_midd's low-texture Midd2
      card (the card at d = 3 -3.8 / -3.7 and -2.3 / -2.3; at K = 5 its band row turns to losing, its other
      rows gain); hair_shelves K = 2 band -0.6;
    * panel_hair_books (12 rows, a tuning scene since): its K = 2 full-card rows stay winning (+1.35 / +1.99 /
      +1.17 dB frame over the SGBM key, against +1.55 / +2.18 / +1.32 without the step and -1.63 / -0.88 / -1.10
      without ``cells_across``);
    * held-out rows (60, scored once at the end, with board_fence_toy built for it): 27.57 / 21.88 -> 27.78 /
      22.02, losing 7 / 5 -> 7 / 5; board_fence_toy +1.2 / +0.9 and +0.9 / +0.5, every other row within 0.05;
    * Middlebury, depth only, all 31 sets: 9.18 -> 9.20 % from all views (Midd1 23.7 -> 24.1, Midd2 15.3 ->
      15.6, Plastic 33.7 -> 33.7; at most 0.83x SGBM on every set), the classic pair 14.05 -> 14.20 % (Midd1
      39.0 -> 41.7, Baby1 5.4 -> 6.5; Monopoly 18.2 -> 16.9).

    Cost: one more SGM and one more :func:`rival_gap` in the last pass, into the flat guard's buffer (no
    volume more; without the guard, one: :func:`bytes_per_cell`), and the step itself (0.03-0.11 s at
    320 x 240 x 33 planes, against SGM's 0.1 s): Middlebury Art (7 views, 695 x 555, 81 planes), the whole depth
    stage 1.09x its time without the step (best of two, side by side).

    Tried in session 47 for curls_wire_midd's card (sent to d = 0, behind the wall at 1.5): steps 14 and 15 moving
    no pixel more than 0.5 px behind the farthest depth the map gives a textured pixel within 32 px keeps it (its
    too-far pixels 2015 -> 391 at K = 5), but the plain walls behind ostrich_grille and flowers_fence have no
    texture at their depth nearby: z-key tuning rows -0.60 / -0.35 and -0.54 / -0.36 dB (K = 5, 2; ostrich_grille
    -7.7 / -5.8); the frame's texture as the limit instead (all but its farthest 1 %): -0.43 / -0.29 and -0.45 /
    -0.30. Not kept."""
    cells_rival: float = 3.0
    """Step 14's rival depth (px per view step): :attr:`rival_jump` of its map."""
    cells_jump: float = 1.5
    """Step 14 moves a plain pixel only where its map is farther than this (px per view step)."""
    cells_share: float = 0.7
    """Step 14's share of the plain pixels around a region that must have its colour."""
    cells_like: float = 0.02
    """Step 14's colour tolerance (sRGB 0-1, every channel) against the region's median colour."""
    cells_ring: int = 12
    """Step 14's ring around a region (px): it must reach across a bar and the unplain pixels beside it."""
    cells_across: bool = True
    """Step 14 counts, around a region, only the plain pixels across a bar: those no plain path of the region's
    colour joins to it, and those of its own surface the map already has at the depth the region would take.
    False: every plain pixel of another region (a surface the map split into depths then sees its own colour
    around each part)."""
    cells_own: float = 0.6
    """Step 14 (``own_plain`` of :func:`~vfxstereo.depth_plate.grille_cells`): where some of a region's colour
    across its bars lies between it and the rival-gated map's depth (farther than the region, nearer than the
    rival by more than ``cells_jump``), on a surface of the map (any colour, steps of at most 1 px) at least this
    share plain, the region takes that depth (the 10 % quantile of those pixels) instead of the rival's (0: off).
    The rival-gated map sends a plain region to the farthest plane its colour allows; a plain card between a fence
    and the wall, placed in some cells by its texture or its edges, keeps that depth in the others. A wall's
    colour at a textured subject's depth beside it (the window's fattening) lies on a mostly textured surface and
    does not count.

    Added in session 48, on by default. On the step's own moves (before the views' check): curls_wire_midd's card
    cells (true 4.8) went to d = 0, behind the wall at 1.5, and now take 4.9 (K = 5) and 5.5 (K = 2);
    bear_pillar K = 2's pillar cells (true 5.2) 5.5 instead of 0 (its rows move by 0.02 dB at most: the later
    steps and the views' check undo it). The plain shares of the surfaces so chosen:
    0.64-0.83 where right, 0.15-0.52 where wrong (ostrich_grille K = 2's wall cells would take its ostrich's
    depth, 8.3, instead of the right 0: -6.2 / -4.0 dB frame / band on its full card at d = 2.5 without the
    test). Measured on the z-key benchmark, frame / band dB, K = 5 ; K = 2, against the default without it,
    side by side:

    * tuning rows (302): 0.6 +0.06 / +0.07 ; +0.06 / +0.06, rows losing to the SGBM key unchanged (2 / 5 ;
      6 / 1): curls_wire_midd's card at d = 3 +4.8 / +5.9 and +6.3 / +5.8 (still losing, by 2.9 and 0.9 dB
      frame at K = 5 / 2: its card's top, beside the wall above it, the map sends back in steps 1-8); worst
      curls_wire_midd K = 5's card at d = 7 -0.10 / -0.11. All 362 rows 31.64 / 25.29 -> 31.69 / 25.34.
      0.4: the same rows alike. 0.8: nothing moves (+0.00). With no test on the surface (the quantile alone): +0.05 /
      +0.06 ; -0.05 / -0.01 (ostrich_grille K = 2 -6.2 / -4.0, bear_pillar K = 2 -5.4 / -2.6, flowers_fence
      K = 2 -1.7 / -1.1);
    * held-out rows (60, scored once, after the choice): every row unchanged;
    * Middlebury, depth only, all 31 sets: every set's bad pixels unchanged (9.13 %, the pair 14.31 %)."""
    cells_spread: int = 8
    """Step 15 (:func:`spread_cells`), on the whole plate: rounds of carrying a wall's depth from grille cell to
    grille cell across the bars (0: off), with step 14's ``cells_ring``, ``cells_share``, ``cells_like`` and
    ``cells_jump``. Step 14 moves only the cells the rival-gated map puts farther; the others keep the bars'
    depth while the cells beside them, across a bar, already show the same wall farther back. Each round, a
    plain region whose plain pixels across its bars mostly have its colour, and at least ``cells_farther`` of
    those lie farther, takes their median depth; then the views check the moves as step 12's.

    Added in session 36, on by default (8 rounds, ``cells_farther`` 0.3). Measured on the z-key benchmark
    (frame / band dB; rows losing to the SGBM key, frame / band), side by side with the default before it:

    * tuning rows (278): 30.63 / 24.67 -> 30.70 / 24.73, losing 15 / 8 -> 14 / 8 (flowers_fence K = 2's card
      at d = 4 turns to winning). ostrich_grille +1.6 / +1.2 and +1.0 / +0.9 (K = 5 / 2; of its wall's
      pixels, 42 -> 61 % and 46 -> 51 % within 1 px: the cells left of the subject), flowers_fence +0.7 /
      +0.4 and +0.5 / +0.3; worst doll_plaster K = 2 -0.2 / -0.3, bear_pillar (a plain pillar between the
      fence and the wall) -0.3 at most on one row;
    * held-out rows (60, scored after the choice; and once more with step 16): 27.21 / 21.46 -> 27.45 /
      21.62, none losing before or after; wicker_grille_dolls K = 5 +1.3 / +0.7, board_fence_toy K = 5 +0.7 /
      +0.7;
    * Middlebury, depth only, all 31 sets: from all views 9.20 % either way (no set moves by more than 0.01),
      from the classic pair 14.20 -> 14.24 % (Baby1 6.5 -> 7.4, Baby2 9.6 -> 10.0, Lampshade1 14.4 -> 14.2).

    Step 16 (``colour_again``) then pulls the bars' rims back to the cells it sent back."""
    spread_share: float | None = 0.45
    """Step 15's ``share`` (None: ``cells_share``): the share of the plain pixels across a cell's bars that must
    have its colour. Step 14 keeps ``cells_share`` (0.7) for the first cells; the spread steps from cells
    already right, and the views check each move. Cells over two backgrounds (ostrich_grille's bottom right:
    the card and the wall meet under the grille) see half the one, half the other across their bars and stayed
    at the bars' depth with 0.7.

    Added in session 37 (0.7 before, as ``cells_share``). Measured with the session's views' check
    (``join_share`` 0.5, ``join_unseen`` 0.02), z-key tuning rows (278, frame / band dB): 30.85 / 24.85 ->
    30.91 / 24.90, rows losing to the SGBM key 14 / 7 either way (ostrich_grille K = 5 +1.34 / +1.00,
    flowers_fence K = 2 +0.51 / +0.33, doll_plaster K = 5 +0.43 / +0.52, beanie_grille K = 2 +0.37 / +0.18;
    worst doll_plaster K = 2 -0.26 / -0.30, and curls_wire_midd's card at d = 3, already losing, -1.2 / -1.5
    more). ostrich_grille K = 5's bad pixels 18.5 -> 15.3 %. Both steps at 0.45 (``cells_share``) lost rows
    instead: 19 / 7 (doll_plaster K = 2 -4.8 frame, panel_hair_books K = 2 -1.3), from step 14. Held-out
    rows (60, scored once after the choice): 27.58 / 21.71 -> 27.72 / 21.77, none losing (board_fence_toy
    K = 5 +0.92 / +0.33, K = 2 +0.54 / +0.22; worst railing_subject_rocks K = 5 -0.04 / -0.02). Middlebury,
    depth only: from all views 9.20 % either way (Bowling1 11.88 -> 11.92, Wood2 3.91 -> 3.87), from the
    classic pair 14.33 % either way (Reindeer 12.86 -> 12.39, Wood1 8.72 -> 9.10)."""
    spread_like: float | None = 0.04
    """Step 15's colour tolerance (sRGB 0-1, every channel; None: ``cells_like``), step 12's ``join_like``: a pixel
    across a cell's bars is of the cell's colour when within this of the cell's median colour. Step 14 keeps
    ``cells_like`` (0.02) for the first cells; the spread goes from cells already right, and the views check
    each move. A faintly grained card behind a grille (petals_grille_plastic's Plastic card, sRGB spread 0.03
    over a cell) failed 0.02 in every cell, and the cells beside the flower kept the flower's depth.

    Session 56, against ``cells_like`` (0.02): z-key tuning rows (302, frame / band dB) 0.03: +0.14 / +0.10;
    **0.04: +0.20 / +0.14** (K = 5 +0.15 / +0.10, K = 2 +0.25 / +0.18; curls_wire_midd K = 2 +3.1 / +2.2 and K = 5
    +2.3 / +1.0, beanie_grille K = 2 +1.5 / +1.5, leaves_wire_bowling K = 2 +1.7 / +1.0, ostrich_grille K = 5
    +0.9 / +0.6, petals_grille_plastic K = 5 +0.5 / +0.8; worst fence_dof K = 5 -0.85 / -0.64, a blurred wire of
    nearly the floor's colour joined to the cell beside it, ostrich_grille K = 2 -0.3 / -0.3), rows
    losing to the SGBM key 8 / 7 -> 6 / 7; 0.06: +0.21 / +0.14 (K = 5 losing 3 / 5 again). Held-out rows (84,
    the two scenes built this session among them), scored once after the choice: +0.31 / +0.18 (railing_subject_rocks
    K = 5 +1.8 / +0.9, wire_plant_laundry K = 2 +1.4 / +1.0; worst wire_plant_laundry K = 5 -0.03 / -0.04), rows
    losing 3 / 3 either way. Middlebury, depth only, all 31 sets: from all views 8.19 -> 8.21 % (0.421x SGBM either
    way, none losing; Lampshade1 5.31 -> 5.71, Wood2 3.63 -> 3.54), from the classic pair 13.82 -> 13.84 %; held-out
    views (tsukuba, teddy, Cloth1, Plastic, Wood2) 37.85 -> 37.86 dB (Wood2 43.34 -> 43.37, the others unchanged).
    Step 14 at 0.03 as well (``cells_like``), over this: tuning rows -0.12 / -0.08
    (curls_wire_midd K = 2 -2.6 / -2.1, ostrich_grille K = 5 -1.5 / -1.2; koala_slope K = 2 +2.8 / +0.3): not kept."""
    cells_farther: float = 0.3
    """Step 15's share of a region's same-coloured pixels across its bars that must lie farther for it to move
    (the first cells beside a wall already right see one or two such neighbours of four)."""
    colour_again: float = 1.5
    """Step 16: step 10 (:func:`reopen_by_colour`) once more after steps 11-15, with this ``colour_ratio``
    (0: off), on the pixels within ``colour_again_near`` px of those steps 14 and 15 sent back, checked against
    the views as step 12's moves. Once the cells of a grille are back at the wall's depth, the rim the window
    left around each bar (1-4 px of wall colour at the bar's depth) has the wall beside it again, but step 10's
    ratio of 4 keeps it: much of what lies at the bar's depth near it is rim, of the wall's colour too.

    Added in session 36, on by default. Measured on the z-key tuning rows (278, frame / band dB; rows losing to
    the SGBM key), with step 15 on: 30.70 / 24.73 -> 30.77 / 24.80, losing 14 / 8 either way (ostrich_grille
    K = 2 +1.0 / +1.1, doll_plaster K = 2 +0.6 / +0.5, flowers_fence K = 5 +0.4 / +0.4; worst fence_dof K = 5
    -0.25 / -0.19); held-out rows (60, scored after the choice) 27.45 / 21.62 -> 27.49 / 21.65, none losing
    (wicker_grille_dolls +0.1 / +0.1 at both K). Middlebury, depth only: from all views 9.20 % either way, from
    the classic pair 14.24 -> 14.32 % (Baby1 7.4 -> 8.9, Baby2 10.0 -> 10.9). Anywhere on the plate
    (``colour_again_near`` 0) it gained more and lost rows: ratio 1.5
    30.79 / 24.97, losing 18 / 10 (rabbit_cream_board K = 2 +1.5 / +2.0 and boards_rocks K = 2 +1.0 / +1.2,
    but sheep_duck_wall K = 2 -3.0 frame and the small cards at d = 4 behind the artichoke's hairs -4.0 / -9.8);
    ratio 2.5 30.76 / 24.86, losing 16 / 9."""
    colour_again_near: int = 4
    """Step 16's reach around the pixels steps 14 and 15 moved (px); 0: the whole plate."""
    colour_forward: float = 2.0
    """Step 16's second half, colour forward: step 10 the other way round (:func:`reopen_by_colour` of the negated
    map), on the whole plate, with this ratio (0: off), ``colour_radius``, ``colour_like`` and ``colour_jump``,
    checked against the views as step 12's moves. A pixel whose colour is more than this many times as common
    among the nearer surfaces within ``colour_radius`` px as at its own depth takes the depth of the nearest
    nearer pixel of its colour, where the pixels so moved join a nearer surface already in the map. The window
    of steps 1-3 gives a plain card or board the depth of a textured background beside it, across an edge a
    horizontal rig cannot place (its top or bottom: curls_wire_midd's card under the wall); nothing else brings
    it forward, and its colour says where it belongs.

    Added in session 48, on by default. It is the one step that moves pixels nearer by colour; it only joins them
    to a surface of their colour the map already has beside them, never makes a new one. On curls_wire_midd K = 5
    (the card's top under the wall) its too-far card pixels 651 -> 294 (too-near ones 3829 -> 4296). Measured on
    the z-key benchmark (frame / band dB; rows losing to the SGBM key, frame / band), against the default without
    it, side by side:

    * tuning rows (302): K = 5 +0.25 / +0.28, K = 2 +0.20 / +0.22; losing 8 / 6 -> 7 / 6 (curls_wire_midd K = 5's
      card at d = 3 turns to winning, -2.9 / -1.3 -> +0.8 / +0.5 against the key; petals_grille_plastic K = 2's
      band at d = 12.4 turns to losing, +0.9 -> -1.2). Best: shelf_grille K = 2's card at d = 12.5 +7.5 / +7.5,
      sign_plant_aloe K = 5 +7.6 frame, ostrich_grille K = 2's card at d = 11.5 +5.8 / +9.2, doll_plant's card at
      d = 6 +5.3 / +5.6 and +5.5 / +5.8. Worst: curls_wire_midd K = 5's card at d = 11.6 -5.1 / -2.8,
      sheep_duck_wall K = 2's three small cards -5.0 frame (a pale subject over a wall of its colour),
      duck_monster_baby K = 5's full card at d = 10.4 -2.8 frame, rabbit_cream_board K = 2 -2.6 / -3.1, and on
      the band artichoke_books K = 5's card at d = 4 -4.5 (already losing: -0.2 -> -4.7 against the key) and
      boards_rocks K = 2's card at d = 11.4 -3.4;
    * held-out rows (60, scored once, after the choice): K = 5 +0.20 / +0.35, K = 2 +0.75 / +0.46, none turning
      (board_fence_toy +2 to +3.7, plank_toy_wood K = 2 +2.7 to +6.0 frame; worst wire_plant_laundry K = 2 -0.9 /
      -0.7);
    * all 362 rows: 31.69 / 25.34 -> 31.95 / 25.62;
    * Middlebury, depth only, all 31 sets: from all views 9.13 -> 9.17 % (0.464x -> 0.466x SGBM;
      Moebius 11.97 -> 12.29, Art 10.67 -> 10.85, Monopoly, Aloe, Dolls +0.1; none losing), from the classic pair
      14.31 -> 14.27 % (tsukuba 5.45 -> 5.26).

    Radius 40 (``colour_radius``), every pixel. First tries at radius 16, plain pixels only, ratios 4 and 8, moved
    nothing on curls_wire_midd. Known weakness: in a random texture one chance match of a pixel's colour among the
    nearer pixels, and none at its own depth, passes the ratio. On the step-11 test's synthetic bars over a random
    texture, the share of step 11's moves that land on the bars' depth falls from over 0.9 to 0.70 with this step
    on in both maps (that test runs without it).

    Swept in session 49 against ratio 2, side by side (z-key tuning rows, mean change frame / band dB; rows losing
    to the SGBM key): ratio 3: K = 5 +0.01 / +0.02, K = 2 +0.12 / +0.06, losing 7 / 6 -> 8 / 6; held-out rows
    (60) K = 5 +0.02 / +0.00, K = 2 +0.01 / -0.01, none turning. It trades rows rather than fixing a kind of
    error: sheep_duck_wall K = 2's three small cards +5.0 frame and boards_rocks K = 2 +2.3 / +3.5 back, but
    sign_plant_aloe K = 2's card at d = 10.2 -5.6 frame and curls_wire_midd's card at d = 3 -1.6 / -0.6 lost.
    Ratio 4: K = 5 +0.01 / -0.02, K = 2 +0.12 / +0.09, losing 8 / 7. A minimum of 3 matches of the pixel's colour
    among the nearer pixels (against the chance match above), ratio 2: K = 5 -0.00 / -0.03, K = 2 -0.15 / -0.08
    (shelf_grille K = 2's card at d = 12.5 -5.8 / -5.8), losing 7 / 6 -> 7 / 5. Ratio 2 stays: the gains at 3-4
    are within what one row's swap moves, and nothing on the held-out rows."""
    boards: bool = True
    """Step 17 (:func:`whole_boards`), on the whole plate: a plain surface of one colour that the map splits
    between a near part and a farther rest takes its near part's plane throughout, where that near part is the
    nearest thing around it (``boards_far``); checked against the views as step 12's moves. A plain board in
    front on a stereo pair: its edges place part of it, the flat-surface bias sends the rest back, and where no
    edge on the same rows claims the rest (its top and bottom edges tell nothing along the rows) step 13 leaves it.

    Added in session 40, on by default. On the final maps of the 31 tuning scenes it moved pixels in five: at
    K = 2 sign_plant_aloe's sign 4757 px, panel_hair_books' panel 9077, fur_pillar_monopoly's pillar 2108,
    boards_rocks' board 144, rabbit_cream_board 9, every one of them to its true depth (none was there before); at
    K = 5 panel_hair_books 3998, sign_plant_aloe 132, boards_rocks 72 (all to the truth) and rabbit_cream_board 430
    (113 at the truth before, 323 after). Measured on the z-key benchmark (frame / band dB; rows losing to the
    SGBM key): tuning rows (302) 30.97 / 24.93 -> 31.46 / 25.01, losing 10 / 7 -> 11 / 7 (sign_plant_aloe K = 2
    +8.82 / +3.33, panel_hair_books +5.95 and +6.44 frame at K = 2 and 5, fur_pillar_monopoly K = 2 +1.34 frame;
    the row that turns was a tie, panel_hair_books K = 2's card at d = 3, +0.01 -> -0.06 against the SGBM key);
    held-out rows (60, scored after the choice) 27.24 / 22.10 -> 27.20 / 22.11, none turning (plank_toy_wood
    K = 2: 37 px moved, all to the truth, and the soft edges answer with -2.4 dB on one row's frame); Middlebury,
    depth only, from all views 9.20 -> 9.21 % (Wood1 4.88 -> 5.23, SGBM 7.91; no other set changes), from the
    classic pair 14.33 % either way. Tried: ``boards_far`` 0.6 also moved grille cells whose near part sits at
    the bars' depth (ostrich_grille, 86 and 123 px, all wrong), and counting only textured pixels around the near
    part moved fur_pillar_monopoly K = 5's strip between its plain pillar and the card (1037 px, all wrong)."""
    boards_share: float = 0.2
    """Step 17 moves a surface only where its near part is at least this share of it."""
    boards_far: float = 0.8
    """Step 17 moves a surface only where at least this share of the pixels 4 to 12 px around its near part lie
    farther by more than ``join_jump``."""

    rails: bool = True
    """Step 18 (:func:`level_rails`), on the whole plate: a thin level line (a grille's bar, a rail or wire along the
    rig's baseline, which matching along the rows cannot see move) whose crossings the map placed nearer than
    what lies around the line, at ``rails_pieces`` or more places, takes their depth along its length; checked
    against the views as step 12's moves. The lines are found at most 3 px tall (``level_rails``' ``height``):
    at HD a thicker bar is not found.

    Added in session 40, on by default. On the final maps of all 36 z-key scenes at both rigs (the held-out ones
    too) it moves pixels only in petals_grille_plastic, the scene built for it (half its grille's 1.2 px bars
    level): K = 2 1907 px (1711 at their true depth after, 196 before), K = 5 2101 (1908 after, 193 before).
    Z-key rows of that scene (frame / band dB): K = 2 +0.56 / +0.08, K = 5 +1.98 / +1.59; the two rows of the
    card at d = 12.4 at K = 2, just behind the grille, turn from losing to the SGBM key to beating it (-0.11 ->
    +2.17 frame, -0.01 -> +0.90 band); worst row, the full card at d = 8 at K = 5, -1.23 / -1.09 (the soft edges
    along the new bars). Middlebury, depth only: every set unchanged. Tried: ``rails_pieces`` 3 also moved
    texture lines in photos that a wire fence crosses three times (bear_pillar 202 and 64 px, shelf_grille 74,
    lattice_leaves 19, and the held-out wire_plant_laundry 33 and 104: all wrong; looking at that held-out
    scene's maps is what set 4); the crossings judged against the line's own median depth instead of what lies
    above and below it gave a bar the flower's depth where it runs in front of the flower (K = 5, the centred
    card at d = 12.4, -8.5 dB band against judging by what lies around)."""
    rails_contrast: float = 0.1
    """Step 18's lines stand out from the rows above and below by more than this (sRGB, 0-1, some channel)."""
    rails_pieces: int = 4
    """Step 18 moves a line only where the map has it nearer at this many places or more."""
    rim_ratio: float = 3.0
    """Step 19 (:func:`vfxstereo.depth_plate.rim_colours`; 0: off): a pixel on the near side of a depth jump
    goes to the back where its colour (the plate over its mean colour) is nearer the back side's mean than the
    front side's by more than this ratio of distances.

    On since session 46. Chosen on the z-key tuning rows, the depth maps of the head with the step added after them
    (the step is the stage's last, so this equals the full solve, which gave the same rows to the last digit), frame
    / band dB against no step (ratio: K = 5; K = 2; pixels moved over the 72 scene/rig maps, put right / put wrong
    by more than 1 px): 1.0: -0.05 / +0.03; -0.17 / -0.26 (wicker_wall -1.6 to -3.1, tassels_room K = 5 -2.4,
    shelf_grille K = 2 -3.4 / -4.7; 72k / 9k); 1.5: +0.01 / +0.11; +0.02 / -0.01 (60k / 3.9k); 2.0: +0.06 / +0.15;
    +0.28 / +0.08 (wicker_wall K = 2 -1.2 / -1.4, tassels_room K = 2 -1.7, hair_shelves K = 5 -1.1; 52k / 2.3k);
    **3.0**: +0.07 / +0.11; +0.08 / +0.12 (42k / 1.2k; worst scene two_soft_pots K = 5 -0.7 frame; best
    fur_pillar_monopoly K = 2 +0.4 / +1.0, witch_monster +0.6 / +0.7 at both K, flowers_fence K = 5 +0.7 / +0.5).
    All 362 rows: 31.50 / 25.19 -> 31.59 / 25.30, the band against the true-depth key -3.82 -> -3.70, rows losing to
    the SGBM key 11 / 7 -> 10 / 7 (panel_hair_books K = 2, the card at d = 3, turns: -0.25 -> +0.15 dB frame);
    held-out rows, scored after the choice: +0.09 / +0.11 (K = 5), +0.18 / +0.10 (K = 2), none turning; rows where
    the later stages end below their initial volume 31 -> 33. The hard key from our map gains more (+0.39 / +0.64
    and +0.39 / +0.56; with ratio 1.0, +0.55 / +0.83): the soft-edge passes
    (:attr:`vfxstereo.softedge.SoftEdgeParams.passes`) already send many of these pixels back from the matte, and
    with a looser ratio the pixels of hair and wicker whose colour is mostly the background's lose the front they
    need for their partial alpha. Middlebury, depth only, all 31 sets: 9.21 -> 9.13 % bad (0.468x -> 0.464x SGBM's,
    worst set 0.83x -> 0.82x), the pair 14.33 -> 14.31; near the depth jumps too near 20.6 -> 19.6 %, too far 5.5 ->
    5.9; from all views better on 24 sets, worse on 4 by at most 0.04, from the pair worse on 12 by at most 0.2
    (Baby1 9.08 -> 9.28). Held-out views: tsukuba 33.89 -> 33.75 dB, teddy 31.18 -> 31.22, Cloth1 41.29 -> 41.28
    (the SGBM warp 32.52, 29.65, 35.00). At 1920 x 1080, 0.07x the time of step 10.

    Session 47, the looser ratio with the later stages retuned around it (z-key tuning rows, 302, frame / band dB
    against the default, K = 5; K = 2): 1.0 -0.13 / -0.08; -0.25 / -0.38 (shelf_grille K = 2 -3.4 / -4.7,
    wicker_wall K = 2 -2.6 / -2.9, tassels_room K = 5 -2.4 / -2.5); with 3 soft-edge passes -0.55 / -0.46; -0.09 /
    -0.47; with ``relabel_explained`` 0.5 -0.16 / -0.08; -0.27 / -0.42; with ``laplacian_free`` 0 -0.19 / -0.13;
    -0.43 / -0.58. Where it loses, the map barely changes: on shelf_grille K = 2 the maps agree around the teddy
    whose card row falls (72 -> 43 dB), but the passes move 75 of its pixels there against 5 and turn 40 px of
    it see-through, and on tassels_room K = 5 a hole between tassels that the passes opened from the old rim
    stays filled from the new one. Checking step 19's moves against the views (as steps 12-18's, groups of
    moved pixels or each pixel alone; on a random-dot board the check puts back every wrong move of ratio 0.5)
    did not help: ratio 3 -0.02 / -0.03; -0.02 / -0.02, 1.5 +0.02 / -0.02; -0.27 / -0.17, 1.0 -0.04 / -0.10;
    -0.45 / -0.42. Not kept."""
    strips: bool = True
    """Step 20 (:func:`vfxstereo.depth_plate.level_strips`), on the whole plate, last: a strip up to 3 rows tall
    that the map puts nearer than the rows just above and below, of one side's colour, takes that side's depth:
    the level top or bottom edge of a card that semi-global matching gave the depth of a grille's bars.

    On since session 57. Side by side on all z-key rows, the depth maps solved with and without it (frame / band
    dB; held-out rows scored in the same run as the tuning rows, the step having been found and measured on the
    tuning scenes' stored maps before): tuning K = 5 (154 synthetic rows) 35.08 / 27.90 -> 35.13 / 27.91, K = 2
    +0.00 / +0.00; held out +0.00 / -0.00 (K = 5) and +0.01 / +0.00 (K = 2); the rendered scenes unchanged; rows
    losing to the SGBM key 9 / 10 either way. Largest: duck_monster_baby K = 5, full card at d = 10.4, +5.6 / +0.2
    (the Baby3 card's top edge, at the bars' depth, drawn over the element across the frame) and at d = 6 +1.1 /
    +0.0; hat_slats_lampshade K = 5 card at d = 13.1 +0.4 / +0.4. Worst: board_fence_toy K = 5, full card at
    d = 12.4, -0.10 / -0.08 (held out). curls_wire_midd's losing card row at d = 3, whose card edge it was found
    on, +0.04 / +0.03 (K = 2) and +0.24 / -0.01 (K = 5): the rest of that band's error lies elsewhere.
    Middlebury, depth only, all 31 sets: 8.21 % bad from all views and 13.84 % from the pair, as without it. At
    1920 x 1080 (a z-key map scaled up), side by side: 2.3x step 19's time, under 1 % of the depth stage's."""
    rim_passes: int = 2
    """Rounds of step 19 (a rim 2 px wide goes in two)."""
    rim_radius: int = 3
    """Half-side of step 19's window, px."""
    rim_jump: float = 1.5
    """Step 19's depth jumps: a 3 x 3 disparity range of at least this (px per view step)."""
    rim_tolerance: float = 0.5
    """Step 19's sides: the window's pixels within this of the front's and of the back's disparity (below half of
    ``rim_jump``)."""

    def passes(self, views: int) -> int:
        """Matching passes (step 5's visibility passes + 1) of a solve from ``views`` views."""
        if views >= 3 and self.visibility_passes_views is not None:
            return self.visibility_passes_views + 1
        return self.visibility_passes + 1

    def __post_init__(self):
        if (self.box < 1 or self.paths not in (4, 8) or self.median < 0 or self.visibility_passes < 0
                or (self.visibility_passes_views is not None and self.visibility_passes_views < 0)
                or self.flat_window < 1 or self.reopen_passes < 0 or any(r < 1 for r in self.reopen_radii)
                or not 0 < self.reopen_ratio <= 1 or self.reopen_floor < 0 or self.reopen_relative < 0
                or self.reopen_jitter < 0 or self.reopen_jump < 0 or self.reopen_views < 1
                or not 0 <= self.reopen_pair <= 1
                or self.reopen_settle < 0 or self.aggregation not in ("box", "guided")
                or self.guided_radius < 1 or self.guided_eps <= 0 or self.rival_jump < 0 or self.rival_scale <= 0
                or self.guard_jump < 0 or self.guard_radius < 1 or not 0 < self.guard_share <= 1
                or self.guard_unlike < 0 or self.guard_carry < 0 or not 0 <= self.boards_share <= 1
                or not 0 <= self.boards_far <= 1 or self.rails_contrast < 0 or self.rails_pieces < 1
                or not self.visibility_decided >= 0 or not self.visibility_rival > 0
                or not self.visibility_plain >= 0):
            raise VfxStereoError("depth settings: box >= 1, paths 4 or 8, median >= 0, visibility_passes >= 0, "
                                 "visibility_passes_views >= 0, flat_window >= 1, reopen_passes >= 0, "
                                 "reopen_radii >= 1, 0 < reopen_ratio <= 1, "
                                 "reopen_floor, reopen_relative, reopen_jitter, reopen_jump, reopen_settle >= 0, "
                                 "reopen_views >= 1, 0 <= reopen_pair <= 1, aggregation 'box' or 'guided', "
                                 "guided_radius >= 1, "
                                 "guided_eps > 0, rival_jump >= 0, rival_scale > 0, guard_jump >= 0, "
                                 "guard_radius >= 1, 0 < guard_share <= 1, guard_unlike, guard_carry >= 0, "
                                 "0 <= boards_share <= 1, 0 <= boards_far <= 1, rails_contrast >= 0, "
                                 "rails_pieces >= 1, visibility_decided >= 0, visibility_rival > 0, "
                                 "visibility_plain >= 0")
        if (self.rim_ratio < 0 or self.rim_passes < 0 or self.rim_radius < 1 or self.rim_tolerance <= 0
                or not self.rim_jump > 2 * self.rim_tolerance):
            raise VfxStereoError("depth settings: rim_ratio, rim_passes >= 0, rim_radius >= 1, rim_tolerance > 0, "
                                 "rim_jump > 2 * rim_tolerance")
        if self.edge_zbuffer not in EDGE_ZBUFFERS:
            raise VfxStereoError(f"depth settings: edge_zbuffer is one of {', '.join(EDGE_ZBUFFERS)}, "
                                 f"got {self.edge_zbuffer!r}")
        if self.consistency_contradict < 0 or self.consistency_region < 1:
            raise VfxStereoError("depth settings: consistency_contradict >= 0, consistency_region >= 1")
        if not (0 <= self.P1 <= self.P2):
            raise VfxStereoError(f"SGM needs 0 <= P1 <= P2, got P1={self.P1}, P2={self.P2}")
        if not (self.strip_memory > 0 and self.strip_margin >= 0):
            raise VfxStereoError("depth settings: strip_memory > 0 GiB, strip_margin >= 0 rows")
        if not (self.thin_views >= 1 and self.thin_jump >= 0 and self.thin_ratio > 0 and self.thin_floor >= 0
                and self.thin_unique >= 0 and 0 <= self.thin_share <= 1 and self.thin_width >= 0
                and self.thin_size >= 1):
            raise VfxStereoError("depth settings: thin_views >= 1, thin_jump, thin_floor, thin_unique, "
                                 "thin_width >= 0, thin_ratio > 0, 0 <= thin_share <= 1, thin_size >= 1")
        if not (self.colour_radius >= 1 and self.colour_stride >= 1 and self.colour_like > 0
                and self.colour_ratio > 0 and self.colour_jump >= 0):
            raise VfxStereoError("depth settings: colour_radius, colour_stride >= 1, colour_like, colour_ratio > 0, "
                                 "colour_jump >= 0")
        if (self.cells_rival <= 0 or self.cells_jump < 0 or not 0 <= self.cells_share <= 1 or self.cells_like <= 0
                or self.cells_ring < 2 or self.cells_spread < 0 or not 0 <= self.cells_farther <= 1
                or not 0 <= self.cells_own <= 1
                or self.colour_again < 0 or self.colour_again_near < 0 or self.colour_forward < 0
                or not (self.spread_share is None or 0 <= self.spread_share <= 1)
                or not (self.spread_like is None or self.spread_like > 0)):
            raise VfxStereoError("depth settings: cells_rival > 0, cells_jump >= 0, 0 <= cells_share <= 1, "
                                 "cells_like > 0, cells_ring >= 2, cells_spread >= 0, 0 <= cells_farther <= 1, "
                                 "0 <= cells_own <= 1, colour_again, colour_again_near, colour_forward >= 0, "
                                 "0 <= spread_share <= 1, spread_like > 0")
        if self.own_rows < 1 or not 0 <= self.own_cover <= 1 or not 0 <= self.own_solid <= 1 or self.own_margin < 0:
            raise VfxStereoError("depth settings: own_rows >= 1, 0 <= own_cover <= 1, 0 <= own_solid <= 1, "
                                 "own_margin >= 0")
        if not (self.join_plain > 0 and self.join_like > 0 and self.join_jump >= 0 and self.join_anchor >= 0
                and self.join_reach >= 0 and self.join_grow >= 0 and self.join_ratio > 0 and self.join_floor >= 0
                and 0 <= self.join_share <= 1 and (self.join_unseen is None or self.join_unseen >= 0)):
            raise VfxStereoError("depth settings: join_plain, join_like, join_ratio > 0, join_jump, join_anchor, "
                                 "join_reach, join_grow, join_floor, join_unseen >= 0, 0 <= join_share <= 1")


@dataclass
class DepthResult:
    """What :func:`robust_depth` found."""

    disparity: np.ndarray
    """(H, W) float32 sub-pixel disparity of the reference camera (px per view step), every pixel decided."""
    index: np.ndarray
    """(H, W) int32 index of the plane nearest ``disparity`` (:func:`vfxstereo.layers.plane_index`)."""
    reliable: np.ndarray
    """(H, W) bool: the winner passed the consistency check (all True without it)."""
    aggregated: np.ndarray | None = None
    """(H, W, D) float32 SGM costs of the last pass (kept with ``keep_volume``)."""
    visible: np.ndarray | None = None
    """(H, W, D) uint8: number of views that see each cell in the last pass (kept with ``keep_volume``)."""
    timings: dict = field(default_factory=dict)
    cells: np.ndarray | None = None
    """(H, W) float32 the rival-gated map of step 14 (``DepthConfig.cells``), else None."""
    pair: np.ndarray | None = None
    """(H, W) float32 the map of view ``pair_view`` as a reference of its own (step 6's rematch), for step 9 on a
    stereo pair (``DepthConfig.reopen_pair``); None without the rematch, and once steps 9-20 are done."""
    pair_view: int | None = None
    """The view ``pair`` was solved for (the consistency check's), or None without the rematch."""


def box_filter(cost: np.ndarray, size: int, *, out: np.ndarray | None = None) -> np.ndarray:
    """Mean over a ``size`` x ``size`` window per plane (edges replicated), into ``out`` when given.

    An odd ``size`` on an (H, W, D) float32 volume with up to 512 planes goes through OpenCV's ``blur``
    (running sums over all planes at once; 3x the numba kernel below at 960 x 540 x 64), an odd ``size`` on a
    larger one (or where OpenCV is missing: the Blender extension does not bundle it) through a parallel numba
    kernel (``scipy.ndimage.uniform_filter`` is the reference of both in the tests); anything else through
    scipy.
    """
    if size <= 1:
        return cost
    try:
        import cv2
    except ImportError:  # the Blender extension bundles no OpenCV: the numba kernel then
        cv2 = None
    if (cv2 is not None and size % 2 == 1 and cost.dtype == np.float32 and cost.ndim == 3
            and cost.shape[2] <= 512 and cost.flags.c_contiguous):
        out = np.empty_like(cost) if out is None else out
        res = cv2.blur(cost, (size, size), dst=out, borderType=cv2.BORDER_REPLICATE)
        if res is not out:  # OpenCV hands back a new array when it cannot write into ``out``
            out[...] = res.reshape(out.shape)
        return out
    if size % 2 == 1 and cost.dtype == np.float32 and cost.ndim == 3 and cost.flags.c_contiguous:
        from vfxstereo import _depth_kernels

        out = np.empty_like(cost) if out is None else out
        _depth_kernels.box_mean(cost, size // 2, out)
        return out
    from scipy import ndimage

    return ndimage.uniform_filter(cost, size=(size, size, 1), mode="nearest", output=out)


def _guide_inverse(I: np.ndarray, size: int, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """The guide's window means (H, W, 3) and the inverse of its regularised window covariance (H, W, 3, 3)."""
    h, w = I.shape[:2]
    mI = box_filter(I, size)
    pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    mII = box_filter(np.ascontiguousarray(np.stack([I[..., i] * I[..., j] for i, j in pairs], -1)), size)
    v = {(i, j): mII[..., n].astype(np.float64) - mI[..., i] * mI[..., j] + (eps if i == j else 0.0)
         for n, (i, j) in enumerate(pairs)}
    a, b, c, d, e, f = v[0, 0], v[0, 1], v[0, 2], v[1, 1], v[1, 2], v[2, 2]
    cof = {(0, 0): d * f - e * e, (0, 1): c * e - b * f, (0, 2): b * e - c * d,
           (1, 1): a * f - c * c, (1, 2): b * c - a * e, (2, 2): a * d - b * b}  # the symmetric adjugate
    det = a * cof[0, 0] + b * cof[0, 1] + c * cof[0, 2]
    inv = np.empty((h, w, 3, 3), np.float32)
    for (i, j), x in cof.items():
        inv[..., i, j] = inv[..., j, i] = x / det
    return mI, inv


def guided_filter(cost: np.ndarray, guide: np.ndarray, radius: int, eps: float, *,
                  out: np.ndarray | None = None, chunk: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each plane of ``cost`` (H, W, D) filtered by the colour guided filter of ``guide`` (H, W, 3), in [0, 1].

    Cost-volume filtering (Hosni, Rhemann, Bleyer, Rother & Gelautz, PAMI 2013) with He, Sun & Tang's guided
    filter (ECCV 2010): per window of side ``2 radius + 1`` the cost is a linear function of the guide's colour,
    ``q = a . I + b``, so the aggregated cost follows colour edges instead of spilling the nearer surface's
    texture across them as a box does (the fattening of steps 1-3). ``eps`` (colour^2) is the regulariser:
    colour differences well below ``sqrt(eps)`` are smoothed over like a box.

    Returns ``(filtered, gap)``: the filtered volume (into ``out`` when given; it must not be ``cost``) and
    each pixel's mean-minus-least over the planes of the *box*-filtered cost, which :func:`flat_bias` is
    calibrated on. Planes are filtered ``chunk`` at a time (numba kernels around :func:`box_filter`; default
    ``D // 16``, 1 to 4): the temporaries are ``8 chunk / D`` of a volume (at most half of one) and about 100
    bytes per pixel.
    """
    h, w, D = cost.shape
    size = 2 * radius + 1
    I = np.ascontiguousarray(guide, np.float32)
    mI, inv = _guide_inverse(I, size, eps)
    chunk = max(1, min(4, D // 16)) if chunk is None else int(chunk)
    from vfxstereo import _depth_kernels

    out = np.empty_like(cost) if out is None else out
    total = np.zeros((h, w), np.float64)
    least = np.full((h, w), np.inf, np.float32)
    cost = np.ascontiguousarray(cost, np.float32)
    stack = np.empty((h, w, 4 * min(chunk, D)), np.float32)
    means = np.empty_like(stack)
    for d0 in range(0, D, chunk):
        n = min(chunk, D - d0)
        if 4 * n < stack.shape[2]:  # the last, shorter chunk
            stack, means = np.empty((h, w, 4 * n), np.float32), np.empty((h, w, 4 * n), np.float32)
        _depth_kernels.guided_stack(I, cost, d0, n, stack)
        box_filter(stack, size, out=means)  # window means of p and I p
        _depth_kernels.guided_coefficients(mI, inv, means, n, stack, total, least)
        box_filter(stack, size, out=means)  # window means of a and b
        _depth_kernels.guided_apply(I, means, d0, n, out)
    gap = (total / D - least).astype(np.float32)
    return out, gap


def view_sides(camera, reference: int) -> list[int]:
    """-1 or +1 per view: which side of the reference it lies on along the rig's main direction.

    0 for the reference and for views level with it.
    """
    p = camera.positions - camera.positions[reference]
    axis = np.array([1.0, 0.0]) if np.ptp(p[:, 0]) >= np.ptp(p[:, 1]) else np.array([0.0, 1.0])
    return [int(np.sign(round(float(q @ axis), 9))) for q in p]


def partial_views(warper, others: list[int]) -> dict[int, np.ndarray]:
    """Per view of ``others``, the pixels it must skip (``DepthConfig.same_views``): (H, W) bool.

    Those it has inside its frame at some planes but not all, where another view has them at every plane.
    Rectified or not, a pixel's position in a view moves monotonically with the disparity, so a view that has it
    inside its frame at the nearest and the farthest plane has it at every plane between.
    """
    h, w = warper.shape
    d = warper.disparities
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    full = {}
    for k in others:
        inside = np.ones((h, w), bool)
        for dd in (float(d.min()), float(d.max())):
            u, v = warper.points_to_view(k, xx.ravel(), yy.ravel(), np.full(h * w, dd))
            u, v = u.reshape(h, w), v.reshape(h, w)
            with np.errstate(invalid="ignore"):
                inside &= (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)
        full[k] = inside
    some = np.logical_or.reduce([full[k] for k in others]) if others else np.zeros((h, w), bool)
    return {k: some & ~full[k] for k in others}


def combine_views(total: dict, count: dict, unseen: float, penalty: float | None, *,
                  out: np.ndarray | None = None) -> np.ndarray:
    """The cost volume from per-side sums and counts of view costs (see ``DepthConfig.subset_penalty``).

    A cell no view sees costs ``unseen`` (the most one view can add; 0, the mean, for centred costs).
    ``out``: a buffer for the result (used when there is one set of views and no penalty).
    """
    keys = list(total)
    if len(keys) == 1 and out is not None:  # the default: one mean over all views, no temporaries
        from vfxstereo import _depth_kernels

        _depth_kernels.mean_cost(total[keys[0]], count[keys[0]], np.float32(unseen), out)
        return out
    t_all = sum(total[k] for k in keys) if len(keys) > 1 else total[keys[0]]
    c_all = sum(count[k].astype(np.float32) for k in keys) if len(keys) > 1 else count[keys[0]].astype(np.float32)
    cost = np.where(c_all > 0, t_all / np.maximum(c_all, 1.0), np.float32(unseen)).astype(np.float32)
    if penalty is None or len(keys) < 2:
        return cost
    for k in keys:
        with np.errstate(invalid="ignore", divide="ignore"):
            sub = total[k] / count[k] + np.float32(penalty)
        np.minimum(cost, np.where(count[k] > 0, sub, np.inf), out=cost)
    return cost


def local_deviation(gray: np.ndarray, size: int = 9) -> np.ndarray:
    """Standard deviation of ``gray`` over a ``size`` x ``size`` window (edges replicated)."""
    from scipy import ndimage

    g = np.asarray(gray, np.float32)
    m = ndimage.uniform_filter(g, size, mode="nearest")
    m2 = ndimage.uniform_filter(g * g, size, mode="nearest")
    return np.sqrt(np.maximum(m2 - m * m, 0.0))


def flat_bias(cost: np.ndarray, disparities: np.ndarray, strength: float, gap_scale: float,
              texture: np.ndarray | None = None, texture_scale: float | None = None, *, window: int = 9,
              gap: np.ndarray | None = None, rival: int = 0, rival_scale: float = 1.0,
              seen: list[np.ndarray] | None = None) -> np.ndarray | None:
    """Add a cost growing towards the near planes where the cost curve is flat (in place).

    Returns the (H, W) weight it added (None: no bias).

    The cost added is ``strength * exp(-gap / gap_scale) * (d - d_min) / (d_max - d_min)`` (times
    ``exp(-texture / texture_scale)`` when both are given).

    ``gap`` is each pixel's mean cost over the planes minus its least cost: near zero where nothing in the
    views tells the planes apart (a plain wall, sky, a blown-out highlight), large where the texture decides.
    Stereo cannot tell the depth of such a surface; semi-global matching then carries in the depth of whatever
    textured surface its paths cross, most often a nearer object in front of it, and the wall ends up in
    front of a z-keyed element. The bias sends the undecided surface back instead: a figure is usually the
    textured, enclosed region and the ground the plain one around it.

    ``gap`` (H, W): the gap computed elsewhere (:func:`guided_filter` gives the box-filtered cost's, so that
    the bias means the same whichever aggregation ran).

    ``rival`` (planes, 0: none): the gap is also at most ``rival_scale`` times :func:`rival_gap` of ``cost``
    (``seen``: the views' counts per cell, :func:`rival_gap`). A pixel two far-apart depths explain alike is as
    undecided as a flat one (``DepthConfig.rival_jump``).
    """
    if strength <= 0 or cost.shape[2] < 2:
        return None
    gap = cost.mean(axis=2) - cost.min(axis=2) if gap is None else gap
    if rival > 0:
        gap = np.minimum(gap, rival_scale * rival_gap(cost, rival, seen))
    weight = bias_weight(gap, strength, gap_scale, texture, texture_scale, window=window)
    add_ramp(cost, disparities, weight)
    return weight


def bias_weight(gap: np.ndarray, strength: float, gap_scale: float, texture: np.ndarray | None = None,
                texture_scale: float | None = None, *, window: int = 9) -> np.ndarray:
    """(H, W) float32 weight of :func:`flat_bias` for a cost gap (before its window average)."""
    from scipy import ndimage

    gap = ndimage.uniform_filter(gap, window, mode="reflect")  # flat over a region (``DepthConfig.flat_window``)
    weight = strength * np.exp(-gap / gap_scale)
    if texture is not None and texture_scale:
        weight = weight * np.exp(-texture / texture_scale)
    return weight.astype(np.float32)


def add_ramp(cost: np.ndarray, disparities: np.ndarray, weight: np.ndarray) -> None:
    """Add ``weight`` times a ramp from 0 at the farthest plane to 1 at the nearest to ``cost`` (in place)."""
    d = np.asarray(disparities, np.float64)
    ramp = ((d - d[0]) / (d[-1] - d[0])).astype(np.float32)
    for y in range(0, cost.shape[0], 64):  # in bands of rows: no volume-sized temporary
        cost[y:y + 64] += weight[y:y + 64, :, None] * ramp[None, None, :]


def own_surfaces(biased: np.ndarray, unbiased: np.ndarray, colour: np.ndarray, *, jump: float, radius: int,
                 share: float, unlike: float, carry: float = 0.1, plain: float = 3.0,
                 seen: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool: the pixels the flat-surface bias sent back that belong to a nearer surface of their own.

    Where the bias moved a plain region back (``unbiased - biased > jump``, and the unbiased cell ``seen`` by
    some view), semi-global matching without it gave the region a nearer depth from somewhere. Either that
    depth was carried in from a textured neighbour at the same depth (the bars around a hole in a grille, the
    subject beside a plain wall: the bias is right), or it comes from the region's own edges, where it ends in
    front of a farther surface (a plain board or pillar in front of a textured wall: the bias is wrong). Its
    ring (the pixels within ``radius`` of it, outside it) tells which:

    * ring pixels unlike the region in colour (``unlike``: mean absolute difference from its mean, 8-bit
      sRGB) are other surfaces: those farther than the region's nearest unbiased depth around by more than
      ``jump`` show it ends in front of them, those as near may have lent it their depth;
    * plain ring pixels like the region (local deviation below ``plain``) are its own surface continuing:
      those at the nearer depth anchor it there, those farther say the surface goes back.

    A region is a surface of its own where at least ``share`` of the unlike ring is farther, at most ``carry``
    times as much of it is as near, and no more of its own surface goes back than stays near -- both for the
    region and for the region grown by its own surface at its nearer depth around it (the rim of a plain wall
    that a textured subject fattened stays near without the bias too; the subject lies beyond that rim, out of
    the region's own ring). Only its pixels like it in colour keep the nearer depth: a fattened strip of the
    textured surface beside it stays back.
    """
    from scipy import ndimage

    moved = (unbiased - biased) > jump
    if seen is not None:
        moved &= seen
    if not moved.any():
        return moved
    eight = np.ones((3, 3), bool)
    labels, n = ndimage.label(moved, structure=eight)
    n_px = np.bincount(labels.ravel(), minlength=n + 1).astype(np.float64)
    mean = np.stack([np.bincount(labels.ravel(), colour[..., c].ravel(), minlength=n + 1) for c in range(3)],
                    -1) / np.maximum(n_px, 1)[:, None]

    def ring_test(mask, lab, count, region_mean):
        """Per component of ``lab`` (``mask`` its pixels): the unlike ring's verdict, its like ring, near."""
        size = 2 * radius + 1
        near = ndimage.grey_dilation(np.where(mask, unbiased, -np.inf).astype(np.float32), size=(size, size))
        owner = ndimage.grey_dilation(lab, size=(size, size))
        ring = (owner > 0) & ~mask
        like = np.abs(colour - region_mean[owner]).mean(axis=-1) <= unlike
        farther = unbiased < near - jump
        total = np.bincount(owner[ring & ~like], minlength=count + 1)
        hits = np.bincount(owner[ring & ~like & farther], minlength=count + 1)
        return (hits >= share * np.maximum(total, 1)) & (total - hits <= carry * hits), ring & like, farther, owner

    own, like_ring, farther, owner = ring_test(moved, labels, n, mean)
    same = like_ring & (local_deviation(colour.mean(axis=-1), 5) < plain)  # its own plain surface continuing
    behind = np.bincount(owner[same & farther], minlength=n + 1)
    own &= behind <= np.bincount(owner[same & ~farther], minlength=n + 1)
    grown, gn = ndimage.label(moved | (like_ring & ~farther), structure=eight)
    comp = np.zeros(n + 1, np.int64)
    comp[labels[moved]] = grown[moved]
    grown_mean = np.zeros((gn + 1, 3))
    grown_mean[comp[1:]] = mean[1:]
    own &= ring_test(grown > 0, grown, gn, grown_mean)[0][comp]
    own[0] = False
    # only the pixels like the region: a fattened strip of the textured surface beside it stays where the bias put it
    return own[labels] & (np.abs(colour - mean[labels]).mean(axis=-1) <= unlike)


def rival_gap(cost: np.ndarray, planes: int, seen: list[np.ndarray] | None = None) -> np.ndarray:
    """(H, W) each pixel's least cost at least ``planes`` planes away from its winner, minus the winner's.

    Near zero where two well separated depths explain the pixel equally (a plain wall seen through a grille
    matches at the wall's depth and at the grille's), large where one depth stands out.
    """
    h, w, D = cost.shape
    out = np.empty((h, w), np.float32)
    idx = np.arange(D)
    for y in range(0, h, 64):
        c = cost[y:y + 64]
        win = c.argmin(axis=2)
        best = np.take_along_axis(c, win[..., None], axis=2)[..., 0]
        far = np.abs(idx[None, None, :] - win[..., None]) >= planes
        if seen is not None:  # a cell no other view sees says nothing: it is no rival
            far &= sum(n[y:y + 64] for n in seen) > 0
        out[y:y + 64] = np.where(far, c, np.inf).min(axis=2) - best
    return np.where(np.isfinite(out), out, np.float32(1e3))


def decided(cost: np.ndarray, grey: np.ndarray, planes: int, gap: float, plain: float,
            seen: list[np.ndarray] | None = None) -> np.ndarray:
    """(H, W) bool: the pixels whose depth ``cost`` decides (``DepthConfig.visibility_decided``).

    Those whose :func:`rival_gap` (``planes``, ``seen``) is at least ``gap``, and those whose ``grey`` (8-bit)
    deviates by less than ``plain`` over 5 x 5 (0: none): a plain surface is placed by its edges, not by its
    own cost.
    """
    sure = rival_gap(cost, planes, seen) >= gap
    if plain > 0:
        sure |= local_deviation(grey, 5) < plain
    return sure


def seen_at(count: dict, win: np.ndarray) -> np.ndarray:
    """(H, W) bool: some other view sees each pixel's cell on plane ``win``.

    ``count``: the views' counts per cell, by side (:func:`combine_views`'s input).
    """
    return sum(np.take_along_axis(c, win[..., None], axis=2)[..., 0].astype(np.int32) for c in count.values()) > 0


def winner_subpixel(S: np.ndarray, disparities: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane index of least ``S`` per pixel and the parabola vertex through it and its neighbours.

    Returns ``(index (H, W) int32, disparity (H, W) float32)``; the disparity is clamped to the midpoints to
    the neighbouring planes and is the plane's own at the first and last plane.
    """
    D = S.shape[2]
    win = np.argmin(S, axis=2).astype(np.int32)
    inner = (win > 0) & (win < D - 1)
    i0 = np.clip(win, 1, D - 2)
    s0 = np.take_along_axis(S, i0[..., None], axis=2)[..., 0]
    sm = np.take_along_axis(S, (i0 - 1)[..., None], axis=2)[..., 0]
    sp = np.take_along_axis(S, (i0 + 1)[..., None], axis=2)[..., 0]
    d = np.asarray(disparities, np.float64)
    dm, d0, dp = d[i0 - 1], d[i0], d[i0 + 1]
    x = parabola_vertex(dm, d0, dp, sm, s0, sp)
    x = np.clip(x, 0.5 * (dm + d0), 0.5 * (d0 + dp))
    out = np.where(inner, x, d[win])
    return win, out.astype(np.float32)


def zbuffer(warper, disparity: np.ndarray, k: int, *, uv: tuple[np.ndarray, np.ndarray] | None = None
            ) -> np.ndarray:
    """The largest disparity of the reference's depth map that lands on each pixel of view ``k`` (-inf: none).

    Each reference pixel is forward-projected at its own disparity (:meth:`Warper.project`, or ``uv`` when the
    caller has it already) and splatted onto the four view pixels around where it lands.
    """
    from vfxstereo import _depth_kernels

    u, v = warper.project(disparity, k) if uv is None else uv
    out = np.full(warper.shape, -np.inf, np.float32)
    _depth_kernels.zbuffer(u, v, np.asarray(disparity, np.float32), out)
    return out


def fill_unreliable(disparity: np.ndarray, reliable: np.ndarray, guide: np.ndarray) -> np.ndarray:
    """Unreliable pixels take a reliable neighbour's disparity, never a nearer one.

    Of the nearest reliable pixels in 8 directions, those not nearer than the second farthest of them, and of
    those the one most alike in ``guide``.
    """
    from vfxstereo import _depth_kernels

    out = np.empty_like(disparity, dtype=np.float32)
    _depth_kernels.fill_from_farther(np.ascontiguousarray(disparity, np.float32), np.ascontiguousarray(reliable),
                                     np.ascontiguousarray(guide, np.float32), out)
    return out


def _seen_by_any(warper, reference: int, xs: np.ndarray, ys: np.ndarray, d: np.ndarray) -> np.ndarray:
    """True where reference points ``(xs, ys)`` at disparities ``d`` land inside some other view's frame."""
    h, w = warper.shape
    seen = np.zeros(np.shape(xs), bool)
    for k in range(warper.camera.K):
        if k != reference:
            u, v = warper.points_to_view(k, xs, ys, d)
            seen |= np.isfinite(u) & (u >= -0.5) & (u <= w - 0.5) & (v >= -0.5) & (v <= h - 0.5)
    return seen


def extend_to_frame_edges(disparity: np.ndarray, warper, reference: int) -> np.ndarray:
    """``disparity`` with surfaces carried across the frame-edge strips that no other view sees.

    Scanning each row inwards-out (and each column, for a rig with vertical baselines), a pixel takes its
    inner neighbour's disparity when that is nearer than its own and a point there at that disparity falls
    outside every other view's frame: no view can confirm or refute the surface, and it is already there
    next to it. Pixels whose carried surface some view sees are never changed, so this acts only within
    ``max disparity x baseline`` px of the frame edges. Rectified rigs; a general camera is returned as is.
    """
    out = np.array(disparity, np.float32, copy=True)
    cam = warper.camera
    if cam.is_general or cam.K < 2:
        return out
    h, w = out.shape
    offsets = np.array([cam.view_offset(k) for k in range(cam.K) if k != reference])
    dmax = float(np.max(warper.disparities))
    reach_x = int(np.ceil(dmax * np.abs(offsets[:, 0]).max())) + 1  # widest strip any view leaves unseen
    reach_y = int(np.ceil(dmax * np.abs(offsets[:, 1]).max())) + 1 if np.any(offsets[:, 1] != 0) else 0
    xs_all, ys_all = np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)

    def carry(line, prev, at_x: bool, pos: int):
        cand = np.nonzero(prev > line)[0]
        if len(cand):
            xs = np.full(len(cand), float(pos)) if at_x else xs_all[cand]
            ys = ys_all[cand] if at_x else np.full(len(cand), float(pos))
            take = cand[~_seen_by_any(warper, reference, xs, ys, prev[cand].astype(np.float64))]
            line[take] = prev[take]

    for x in range(min(reach_x, w - 1) - 1, -1, -1):  # left edge, carried from the right
        carry(out[:, x], out[:, x + 1], True, x)
    for x in range(max(w - reach_x, 1), w):  # right edge, carried from the left
        carry(out[:, x], out[:, x - 1], True, x)
    if reach_y:
        for y in range(min(reach_y, h - 1) - 1, -1, -1):
            carry(out[y], out[y + 1], False, y)
        for y in range(max(h - reach_y, 1), h):
            carry(out[y], out[y - 1], False, y)
    return out


def _consistency(S: np.ndarray, win: np.ndarray, disparities: np.ndarray, offset: float) -> np.ndarray:
    """True where the reference's winner agrees with another view's, within one pixel of that view.

    The other view, at ``offset`` view steps along x, gets its winners by a diagonal search of ``S``
    (Hirschmueller 2008, Section 3.4).
    """
    h, w, D = S.shape
    shift = np.rint(np.asarray(disparities) * offset).astype(np.int64)  # view pixel u = x - shift
    best = np.full((h, w), np.inf, np.float32)
    other = np.zeros((h, w), np.int32)
    for i in range(D):
        s = int(shift[i])
        plane = np.full((h, w), np.inf, np.float32)
        if s >= 0:
            plane[:, :w - s] = S[:, s:, i] if s < w else np.inf
        else:
            plane[:, -s:] = S[:, :w + s, i] if -s < w else np.inf
        better = plane < best
        best[better] = plane[better]
        other[better] = i
    xs = np.arange(w)[None, :]
    u = xs - shift[win]
    inside = (u >= 0) & (u < w)
    back = other[np.arange(h)[:, None], np.clip(u, 0, w - 1)]
    agree = np.abs(np.asarray(disparities)[back] - np.asarray(disparities)[win]) * abs(offset) <= 1.0
    return agree | ~inside


def _rematch_consistency(views, warper, reference: int, disparity: np.ndarray, offset: float,
                         config: DepthConfig) -> tuple[np.ndarray, int, np.ndarray]:
    """``(agree, k, d_k)``: where the reference's disparity agrees with the other view's own; that view, its map.

    ``agree`` is True within one pixel of view ``k``; ``d_k`` is view ``k``'s own map.

    The view ``offset`` steps along x is solved as a reference of its own (the left-right check of
    Hirschmueller 2008, with a real second match instead of the diagonal search of :func:`_consistency`).
    """
    from dataclasses import replace

    from vfxstereo.geometry import Camera
    from vfxstereo.warp import Warper

    cam = warper.camera
    k = int(np.argmin(np.abs(cam.positions[:, 0] - cam.positions[reference, 0] - offset)))
    other = Warper(Camera.from_positions(cam.positions, k), warper.disparities, warper.shape)
    sub = replace(config, consistency=False, edge_refine=False)
    d_o = _robust_depth(views, other, k, sub, None, False).disparity
    return consistent(views, warper, reference, disparity, k, d_o, offset, contradict=config.consistency_contradict,
                      region=config.consistency_region), k, d_o


def consistent(views, warper, reference: int, disparity: np.ndarray, k: int, other: np.ndarray, offset: float, *,
               contradict: float = 0.0, region: int = 10, like: float = 0.04) -> np.ndarray:
    """The pair check: True where the reference's disparity agrees with view ``k``'s own map.

    ``other`` is view ``k``'s map, ``offset`` view steps along x; a pixel agrees within one pixel of view ``k``,
    or where it lands outside view ``k``.

    ``contradict`` > 0: where ``other`` is *farther*, two things can be wrong. Either the reference's pixel is a
    near surface fattened over a strip view ``k`` cannot see (in view ``k`` the farther depth lands behind the
    near surface: nothing there contradicts it), or ``other`` is wrong (a plain surface that view's map sent
    back, with nothing to tell it where its own edges are). In the second case view ``k`` sees the farther depth
    (its map has that depth there) with a colour error above ``contradict`` more than twice that of the pixel's
    own depth (sRGB, mean over channels, the least within a pixel, after the views' gains). Such pixels pass,
    and with them the pixels the check rejects for the same reason in their connected region of one plane,
    where it has at least ``region`` of them, and of those, the ones within ``like`` (every channel) of their
    colour: the evidence of a plain board lies along one of its edges, while a thin wire's halo has the colour
    of what lies behind it. Not where view ``k``'s pixel is within the largest disparity of its frame edge on
    the side the reference cannot see: a near surface beyond the reference's frame may show there.
    """
    h, w = disparity.shape
    rows = np.arange(h)[:, None]
    xs = np.arange(w)[None, :]
    u = np.rint(xs - disparity * offset).astype(np.int64)
    inside = (u >= 0) & (u < w)
    back = other[rows, np.clip(u, 0, w - 1)]
    agree = (np.abs(back - disparity) * abs(offset) <= 1.0) | ~inside
    farther = ~agree & (back < disparity)
    if contradict <= 0 or not farther.any():
        return agree
    from scipy import ndimage

    from vfxstereo.layers import view_gains
    from vfxstereo.sweep import matching_values

    u2 = np.rint(xs - back * offset).astype(np.int64)
    # where view k sees the farther depth, and no nearer surface beyond the reference's frame can show there
    reach = float(np.max(warper.disparities)) * offset
    inside2 = (u2 >= 0) & (u2 < w) & (u2 + reach >= 0) & (u2 + reach < w)
    u2 = np.clip(u2, 0, w - 1)
    seen = np.abs(other[rows, u2] - back) * abs(offset) <= 1.0  # view k's map has the farther depth there
    gain = view_gains(views, warper, reference, disparity)[k]  # the cameras' exposures differ
    ref = matching_values(views[reference], "srgb", 1.0)
    view = matching_values(np.asarray(views[k], np.float32) * gain, "srgb", 1.0)

    def error(at):  # the least colour error within a pixel of ``at`` in view k
        return np.min([np.abs(ref - view[rows, np.clip(at + j, 0, w - 1)]).mean(axis=-1) for j in (-1, 0, 1)],
                      axis=0)

    contradicted = farther & inside2 & seen & (error(u2) > contradict + 2.0 * error(np.clip(u, 0, w - 1)))
    if not contradicted.any():
        return agree
    step = float(np.min(np.diff(warper.disparities))) if warper.D > 1 else 1.0
    level = np.rint(disparity / step).astype(np.int64)
    labels = np.zeros((h, w), np.int64)
    n = 0
    for lv in np.unique(level[farther]):
        lab, m = ndimage.label(farther & (level == lv), structure=np.ones((3, 3), bool))
        labels[lab > 0] = lab[lab > 0] + n
        n += m
    hits = np.bincount(labels[contradicted], minlength=n + 1)
    keep = hits >= region
    keep[0] = False
    if not keep.any():
        return agree
    # of a kept region, the pixels of the contradicted pixels' colour: the board, not a halo a thin near
    # structure (a wire, whose own pixels the other view contradicts too) grew over another surface
    smooth = ndimage.uniform_filter(ref, (3, 3, 1), mode="nearest")  # the plate's noise aside
    colour = np.zeros((n + 1, 3), np.float32)
    for c in range(3):
        sums = np.bincount(labels[contradicted], weights=smooth[..., c][contradicted], minlength=n + 1)
        colour[:, c] = sums / np.maximum(hits, 1)
    alike = ((np.abs(smooth - colour[labels]).max(axis=-1) < like)
             | (np.abs(ref - colour[labels]).max(axis=-1) < like))  # (or itself: its own edge's pixels)
    return agree | (keep[labels] & (alike | contradicted))


DEPTH_BYTES_PER_CELL = 16
"""Peak bytes the stage holds per (x, y, plane) cell of the volume it solves at once: the view-cost sums and
counts, the combined and windowed costs and the SGM sums (4 + 1 + 4 + 4) and small temporaries. Measured:
about 14 at 4096x2160 (speed benchmark), 20.8 at 480x270 x 32 planes, where the per-pixel images weigh more
(tracemalloc)."""


def strips(h: int, rows: int, margin: int) -> list[tuple[int, int, int, int]]:
    """Horizontal strips ``(y0, y1, p0, p1)`` of an image ``h`` rows high.

    Rows ``[y0, y1)`` are kept from a solve of rows ``[p0, p1)``, which add up to ``margin`` rows of context on
    each side. The strips are of equal height (to a row), at most ``rows`` each, and cover the image once.
    """
    n = max(1, -(-int(h) // max(1, int(rows))))
    bounds = np.linspace(0, h, n + 1).round().astype(int)
    return [(int(a), int(b), max(0, int(a) - margin), min(int(h), int(b) + margin))
            for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def bytes_per_cell(config: DepthConfig) -> int:
    """Peak bytes per cell of the volume the stage solves at once with ``config``.

    :data:`DEPTH_BYTES_PER_CELL`, and the unbiased SGM sums of ``flat_guard`` (step 14's map, ``cells``, reuses
    them, or needs as many without the guard).
    """
    second = config.far_bias > 0 and (config.flat_guard or config.cells)
    return DEPTH_BYTES_PER_CELL + (4 if second else 0)


def strip_plan(warper, config: DepthConfig) -> list[tuple[int, int, int, int]]:
    """The strips :func:`robust_depth` solves ``warper``'s plate in (one, the whole plate, when it fits).

    A strip with its margins holds at most ``config.strip_memory`` GiB of cost volumes
    (:func:`bytes_per_cell`), and never fewer than 32 kept rows. The margin is ``config.strip_margin``
    plus the largest vertical shift of any view (a 2-D array's upper and lower views see rows outside the
    strip). General cameras (homographies) are solved whole.
    """
    h, w = warper.shape
    cam = warper.camera
    fits = int(config.strip_memory * 2**30 // (w * warper.D * bytes_per_cell(config)))
    if fits >= h or cam.is_general:
        return [(0, h, 0, h)]
    dy = float(np.abs(cam.positions[:, 1] - cam.reference[1]).max() * np.abs(warper.disparities).max())
    margin = int(config.strip_margin) + int(np.ceil(dy)) + 1
    return strips(h, max(32, fits - 2 * margin), margin)


def robust_depth(views: np.ndarray, warper, reference: int, *, config: DepthConfig | None = None,
                 progress: Progress | None = None, keep_volume: bool = False) -> DepthResult:
    """Disparity of every reference pixel from all views (the stage's steps are in the module docstring).

    A plate whose cost volumes do not fit in ``config.strip_memory`` is solved in horizontal strips with
    margins (:func:`strip_plan`); ``keep_volume`` solves it whole.

    Parameters
    ----------
    views : ndarray of shape (K, H, W, 3)
        Scene-linear views.
    warper : vfxstereo.warp.Warper
        Geometry and planes.
    reference : int
        The view the virtual camera is at.
    config : DepthConfig, optional
    progress : callable, optional
        ``progress(stage, done, total)`` with stages ``"match"`` (per view and pass) and ``"sgm"``.
    keep_volume : bool
        Keep the aggregated costs and view counts of the last pass in the result.
    """
    config = config or DepthConfig()
    views = np.asarray(views, dtype=np.float32)
    K, h, w = views.shape[:3]
    if not 0 <= reference < K:
        raise VfxStereoError(f"reference view {reference} is not one of the {K} views")
    from vfxstereo.depth_plate import _reopened  # steps 9-20 (that module imports this one)

    plan = [(0, h, 0, h)] if keep_volume else strip_plan(warper, config)
    if len(plan) == 1:
        return _reopened(_robust_depth(views, warper, reference, config, progress, keep_volume), views, warper,
                         reference, config, progress)
    from vfxstereo.layers import plane_index
    from vfxstereo.warp import Warper

    disparity = np.empty((h, w), np.float32)
    reliable = np.empty((h, w), bool)
    cells = None
    pair, pair_view = None, None
    timings: dict[str, float] = {}
    for n, (y0, y1, p0, p1) in enumerate(plan):
        part = _robust_depth(views[:, p0:p1], Warper(warper.camera, warper.disparities, (p1 - p0, w)),
                             reference, config, None, False)
        disparity[y0:y1] = part.disparity[y0 - p0:y1 - p0]
        reliable[y0:y1] = part.reliable[y0 - p0:y1 - p0]
        if part.cells is not None:
            if cells is None:
                cells = np.empty((h, w), np.float32)
            cells[y0:y1] = part.cells[y0 - p0:y1 - p0]
        if part.pair is not None:
            if pair is None:
                pair = np.empty((h, w), np.float32)
            pair[y0:y1], pair_view = part.pair[y0 - p0:y1 - p0], part.pair_view
        for name, seconds in part.timings.items():
            timings[name] = timings.get(name, 0.0) + seconds
        report(progress, "depth strips", n + 1, len(plan))
    return _reopened(DepthResult(disparity=disparity, index=plane_index(disparity, warper.disparities),
                                 reliable=reliable, timings=timings, cells=cells, pair=pair, pair_view=pair_view),
                     views, warper, reference, config, progress)


def _robust_depth(views, warper, reference, config, progress, keep_volume) -> DepthResult:
    """:func:`robust_depth` of one strip (or the whole plate)."""
    K, h, w = views.shape[:3]
    D = warper.D
    d = warper.disparities
    step = warper.step
    timings: dict[str, float] = {}

    def timed(name, t0):
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    prep = matching.prepare(views, config.matching)
    timed("match", t0)
    others = [k for k in range(K) if k != reference]
    side = view_sides(warper.camera, reference)
    sides = sorted({side[k] for k in others}) if config.subset_penalty is not None else [0]
    total = {sd: np.empty((h, w, D), np.float32) for sd in sides}
    count = {sd: np.empty((h, w, D), np.uint8) for sd in sides}
    S = np.empty((h, w, D), np.float32)
    windowed = np.empty((h, w, D), np.float32)
    guarded = config.flat_guard and config.far_bias > 0
    unbiased_S = np.empty((h, w, D), np.float32) if guarded else None
    from vfxstereo.sgm import sgm
    disparity = None
    sure = None  # the pixels whose depth the pass decided (``visibility_decided``)
    passes = config.passes(K)

    def aggregate(cost, out):  # semi-global matching of a cost volume into ``out``
        sgm(cost, prep.grey[reference], P1=config.P1, P2=config.P2, sigma=config.sigma, paths=config.paths, out=out)

    partial = partial_views(warper, others) if config.same_views else None
    for p in range(passes):
        t0 = time.perf_counter()
        for sd in sides:
            total[sd][...] = 0.0
            count[sd][...] = 0
        # (A pass that only revisits the pixels whose visibility changed was measured at HD x 64 planes: a
        # pixel's cells sweep D x baseline px of each view's row, so nearly every pixel has some cell a nearer
        # surface hides; it saved 0.3 of 6.3 s and was taken out.)
        # undecided pixels hide nothing (``sure`` is set, with ``disparity``, from the first pass on)
        occluding = disparity if sure is None else np.where(sure, disparity, np.float32(d.min()))
        for n, k in enumerate(others):
            zbuf = zbuffer(warper, occluding, k) if disparity is not None else None
            sd = side[k] if len(sides) > 1 else sides[0]
            matching.accumulate(prep, warper, k, reference, total[sd], count[sd], zbuf=zbuf,
                                tolerance=config.visibility_tolerance * step, centre=config.centre,
                                params=config.matching, skip=None if partial is None else partial[k])
            report(progress, "match", p * len(others) + n + 1, passes * len(others))
        guided = config.aggregation == "guided"
        cost = combine_views(total, count, 0.0 if config.centre else config.matching.max_cost,
                             config.subset_penalty, out=S if config.box > 1 or guided else windowed)
        gap = None
        if guided:
            cost, gap = guided_filter(cost, prep.values[reference] * np.float32(1 / 255), config.guided_radius,
                                      config.guided_eps, out=windowed)
        else:
            cost = box_filter(cost, config.box, out=windowed)  # S is free again: SGM writes it
        # the map without the bias first (step 3 on the unbiased cost, into the other buffer); in the last pass
        # only: run in every pass it put 0.15 % more of boards_rocks' pixels (K = 5) right, at twice the cost
        guard = guarded and p == passes - 1
        if guard:
            t1 = time.perf_counter()
            aggregate(cost, unbiased_S)
            win2, disparity2 = winner_subpixel(unbiased_S, d)
            timings["guard"] = timings.get("guard", 0.0) + time.perf_counter() - t1
            t0 += time.perf_counter() - t1  # not matching's time
        texture = local_deviation(prep.grey[reference]) if config.flat_texture else None
        cells = config.cells and config.far_bias > 0 and p == passes - 1 and D > 1
        if cells:  # step 14's rival gap, on the cost before the bias
            t1 = time.perf_counter()
            if gap is None:  # flat_bias's own gap, computed once for both
                gap = cost.mean(axis=2) - cost.min(axis=2)
            gap_c = np.minimum(gap, config.rival_scale * rival_gap(
                cost, max(1, int(round(config.cells_rival / step))), list(count.values())))
            timings["cells"] = timings.get("cells", 0.0) + time.perf_counter() - t1
            t0 += time.perf_counter() - t1
        weight = flat_bias(cost, d, config.far_bias, config.flat_gap, texture=texture,
                           texture_scale=config.flat_texture, window=config.flat_window, gap=gap,
                           rival=max(1, int(round(config.rival_jump / step))) if config.rival_jump > 0 else 0,
                           rival_scale=config.rival_scale, seen=list(count.values()))
        if config.visibility_decided > 0 and p < passes - 1:  # the pixels step 5's next pass lets hide others
            sure = decided(cost, prep.grey[reference], max(1, int(round(config.visibility_rival / step))),
                           config.visibility_decided, config.visibility_plain, list(count.values()))
        timed("match", t0)
        t0 = time.perf_counter()
        aggregate(cost, S)
        win, disparity = winner_subpixel(S, d)
        timed("sgm", t0)
        if guard:
            t1 = time.perf_counter()
            seen2 = seen_at(count, win2)

            def owned(biased, unbiased=disparity2, seen=seen2):  # regions the bias sent back that are a surface
                return own_surfaces(biased, unbiased, prep.values[reference], jump=config.guard_jump,
                                    radius=config.guard_radius, share=config.guard_share,
                                    unlike=config.guard_unlike, carry=config.guard_carry, seen=seen)

            own = owned(disparity)
            win = np.where(own, win2, win)
            disparity = np.where(own, disparity2, disparity)
            S[own] = unbiased_S[own]
            timings["guard"] = timings.get("guard", 0.0) + time.perf_counter() - t1
        if cells:  # step 14's map: the bias also where a far depth rivals the winner, one more SGM
            t1 = time.perf_counter()
            # the rival only lowers the gap, so this weight is at least the main one's (below 0 only where the
            # main bias had a rival gate of its own, ``rival_jump``: nothing more to add there)
            extra = bias_weight(gap_c, config.far_bias, config.flat_gap, texture, config.flat_texture,
                                window=config.flat_window) - weight
            add_ramp(cost, d, np.maximum(extra, 0.0))
            out2 = unbiased_S if unbiased_S is not None else np.empty_like(S)
            aggregate(cost, out2)
            cells_map = winner_subpixel(out2, d)[1]
            del out2
            if guard:  # as for the main map
                cells_map = np.where(owned(cells_map), disparity2, cells_map)
            timings["cells"] = timings.get("cells", 0.0) + time.perf_counter() - t1
    t0 = time.perf_counter()
    reliable = np.ones((h, w), bool)
    if config.fill_occluded and passes > 1:
        # no other view sees the winning cell: half-occluded in every view, so matching said nothing there
        reliable &= seen_at(count, win)
    pair_map, pair_view = None, None  # the other view's own map (the rematch), for step 9 on a pair
    if config.consistency or (config.consistency is None and K == 2):
        off = _consistency_offset(warper, reference, config.consistency_view)
        if off is not None and config.consistency_method == "rematch":
            if not keep_volume:  # the second match builds volumes of its own: free ours first
                total.clear()
                count.clear()
                del windowed, cost
                unbiased_S = None
                S = None
            agree, pair_view, pair_map = _rematch_consistency(views, warper, reference, disparity, off, config)
            reliable &= agree
        elif off is not None:
            reliable &= _consistency(S, win, d, off)
    if not reliable.all():
        disparity = fill_unreliable(disparity, reliable, prep.grey[reference])
    if config.frame_edges:
        disparity = extend_to_frame_edges(disparity, warper, reference)
    if config.median > 1:
        from scipy import ndimage

        disparity = ndimage.median_filter(np.asarray(disparity, np.float32), config.median, mode="nearest")
    if config.edge_refine:
        disparity = refine_edges(prep, warper, reference, disparity, config)[0]
    from vfxstereo.layers import plane_index

    index = plane_index(disparity, d)
    if cells and config.median > 1:
        from scipy import ndimage

        cells_map = ndimage.median_filter(np.asarray(cells_map, np.float32), config.median, mode="nearest")
    timed("finish", t0)
    return DepthResult(disparity=disparity.astype(np.float32), index=index, reliable=reliable,
                       aggregated=S if keep_volume else None,
                       visible=sum(c.astype(np.uint8) for c in count.values()) if keep_volume else None,
                       timings=timings, cells=cells_map.astype(np.float32) if cells else None,
                       pair=pair_map if config.reopen_pair > 0 else None, pair_view=pair_view)


def _edge_inputs(prepared, warper, reference: int, disparity: np.ndarray, config: DepthConfig, confident: bool):
    """What :func:`refine_edges` and its reference need: small census codes, view offsets, z-buffers, tables."""
    from scipy import ndimage

    others = [k for k in range(warper.K) if k != reference]
    codes = np.stack([matching.census_transform(g, config.edge_census_radius) for g in prepared.grey])
    offsets = np.array([warper.camera.view_offset(k) for k in others], np.float64).reshape(len(others), 2)
    params = matching.MatchingParams(census_radius=config.edge_census_radius,
                                     lambda_census=config.edge_lambda_census,
                                     lambda_ad=config.matching.lambda_ad, w_ad=config.matching.w_ad)
    if config.edge_zbuffer == "sided":  # views chosen by side: no z-buffer is read
        return others, codes, offsets, np.zeros((len(others), 1, 1), np.float32), params, 0.0
    occluders = np.asarray(disparity, np.float32)
    if confident:
        size = 2 * config.edge_radius + 1
        hi = ndimage.maximum_filter(occluders, size, mode="nearest")
        lo = ndimage.minimum_filter(occluders, size, mode="nearest")
        uncertain = (hi - lo >= config.edge_jump) & (occluders >= 0.5 * (hi + lo))
        occluders = np.where(uncertain, np.float32(np.nan), occluders)
    zbufs = np.stack([zbuffer(warper, occluders, k) for k in others])
    step = warper.step
    return others, codes, offsets, zbufs, params, config.visibility_tolerance * step


def refine_edges(prepared, warper, reference: int, disparity: np.ndarray,
                 config: DepthConfig) -> tuple[np.ndarray, np.ndarray]:
    """Step 8: remove foreground fattening at depth edges. Returns ``(disparity, state)``, both (H, W).

    Window costs (the census window, the box, SGM's smoothness) carry a textured near surface's disparity 2-4 px
    out over the background next to it. A pixel whose ``(2 edge_radius + 1)``-square neighbourhood spans more
    than ``edge_jump`` of disparity is re-decided between the neighbourhood's front and back disparity (means of
    the values above and below the middle of the range, so never a surface nearer than its neighbours): each
    candidate is scored by a pixelwise AD-census cost (a 3 x 3 census, which barely straddles the edge)
    aggregated with adaptive support weights from the reference's colours (Yoon & Kweon, PAMI 2006: pixels of
    the same colour likely lie on the same surface), averaged over the views that see the back candidate
    (z-buffers of the map without the edges' front side, :func:`zbuffer`; a view that does not see the back
    surface says nothing about it). A pixel keeps its side unless the other candidate costs less by
    ``edge_margin`` per view, and is kept where no view sees its back candidate (half-occluded: step 6 decides
    those). ``state``: see :func:`vfxstereo._depth_kernels.edge_refine`. Rectified rigs only (general cameras:
    unchanged).
    """
    from vfxstereo import _depth_kernels

    disparity = np.ascontiguousarray(disparity, np.float32)
    state = np.zeros(disparity.shape, np.int8)
    if warper.camera.is_general or warper.K < 2:
        return disparity, state
    sided = config.edge_zbuffer == "sided"
    for p in range(max(1, config.edge_passes)):
        others, codes, offsets, zbufs, params, tol = _edge_inputs(
            prepared, warper, reference, disparity, config, confident=config.edge_zbuffer == "confident" and p == 0)
        out = np.empty_like(disparity)
        _depth_kernels.edge_refine(disparity, int(config.edge_radius), np.float32(config.edge_jump),
                                   codes[reference], prepared.values[reference], np.ascontiguousarray(codes[others]),
                                   np.ascontiguousarray(prepared.values[others]), offsets, zbufs, np.float32(tol),
                                   *params.tables(), int(config.edge_support), float(config.edge_gamma_c),
                                   float(config.edge_gamma_s), float(config.edge_margin), sided,
                                   bool(config.edge_forward), out, state)
        disparity = out
    return disparity, state


def refine_edges_reference(prepared, warper, reference: int, disparity: np.ndarray,
                           config: DepthConfig) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy :func:`refine_edges` (one pass), the reference its kernel is tested against."""
    others, codes, offsets, zbufs, params, tol = _edge_inputs(prepared, warper, reference, disparity, config,
                                                              config.edge_zbuffer == "confident")
    small = matching.Prepared(values=prepared.values, grey=prepared.grey, census=codes)
    d = np.asarray(disparity, np.float64)
    h, w = d.shape
    r, R = config.edge_radius, config.edge_support
    out = d.copy()
    state = np.zeros((h, w), np.int8)
    ref = prepared.values[reference].astype(np.float64)
    for y in range(h):
        for x in range(w):
            nb = d[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
            if not nb.max() - nb.min() >= config.edge_jump:
                continue
            mid = 0.5 * (nb.max() + nb.min())
            if not config.edge_forward and d[y, x] < mid:
                continue
            state[y, x] = 1
            front, back = nb[nb >= mid].mean(), nb[nb < mid].mean()
            fy, fx = np.nonzero(nb >= mid)  # towards the front: its pixels' centroid ("sided")
            towards = (fx.mean() + max(x - r, 0) - x, fy.mean() + max(y - r, 0) - y)
            cost = {front: 0.0, back: 0.0}
            n = 0
            for m, k in enumerate(others):
                ub, vb = x - back * offsets[m, 0], y - back * offsets[m, 1]
                if not (0 <= ub <= w - 1 and 0 <= vb <= h - 1):
                    continue
                if config.edge_zbuffer == "sided":
                    if offsets[m, 0] * towards[0] + offsets[m, 1] * towards[1] > 0:
                        continue
                elif zbufs[m][min(int(vb + 0.5), h - 1), min(int(ub + 0.5), w - 1)] > back + tol:
                    continue
                each = {}
                for cand in (front, back):
                    s = wsum = 0.0
                    for b in range(max(y - R, 0), min(y + R + 1, h)):
                        for a in range(max(x - R, 0), min(x + R + 1, w)):
                            wt = np.exp(-np.abs(ref[b, a] - ref[y, x]).mean() / config.edge_gamma_c
                                        - np.hypot(a - x, b - y) / config.edge_gamma_s)
                            c = matching.cell_cost_reference(small, k, reference, b, a, a - cand * offsets[m, 0],
                                                             b - cand * offsets[m, 1], params)
                            if np.isfinite(c):
                                s += wt * c
                                wsum += wt
                    each[cand] = s / wsum if wsum > 0 else None
                if each[front] is None or each[back] is None:
                    continue
                cost[front] += each[front]
                cost[back] += each[back]
                n += 1
            if n == 0:
                state[y, x] = 4
                continue
            if d[y, x] >= mid and cost[back] + n * config.edge_margin < cost[front]:
                out[y, x], state[y, x] = back, 2
            elif d[y, x] < mid and cost[front] + n * config.edge_margin < cost[back]:
                out[y, x], state[y, x] = front, 3
    return out.astype(np.float32), state


def _consistency_offset(warper, reference: int, steps: int | None) -> float | None:
    """Baseline offset (view steps along x) of the view the consistency check uses.

    None where the rig is not rectified and horizontal.
    """
    cam = warper.camera
    if cam.is_general or np.any(cam.positions[:, 1] != cam.positions[0, 1]):
        return None
    offs = cam.positions[:, 0] - cam.positions[reference, 0]
    if steps is not None:
        return float(steps)
    right, left = offs[offs > 0], offs[offs < 0]
    if len(right) >= len(left) and len(right):
        return float(right.max())
    return float(left.min()) if len(left) else None
