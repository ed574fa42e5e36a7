"""Solver settings: every parameter of the paper in one dataclass, with the paper's values as defaults.

Named presets reproduce the paper's configurations (Section 7):

=========  =====================================================================================
preset     what
=========  =====================================================================================
paper      the full method, the defaults of :class:`SolveConfig`: aggregation, thresholded
           selection, visibility re-estimation with hidden layers, completion of the initial
           volume, refinement with lambda = (50, 1, 10), sub-pixel disparity
literal    the paper as written, for comparison: none of the extensions marked "beyond the paper"
           below, lambda = (50, 1, 50) (Fig. 6(d)); the refinement's own additions (Huber rho2,
           C1 warm-up, backtracking, see :mod:`vfxstereo.refine`) stay
wta        Fig. 6(f): plain winner-take-all -- very large theta_min, no clarity test, no
           occlusion reasoning, no refinement ("the same as Fig. 6(a) with a very large theta_min
           and no occluded pixel removal": same matching and aggregation as ``paper``)
fig6a      Fig. 6(a): aggregation + thresholded selection + visibility (with hidden layers), no
           completion, no refinement: the stack is the selected 0/1 volume
fig6b      Fig. 6(b): refinement with lambda = (1, 0, 0)
fig6c      Fig. 6(c): lambda = (1, 1, 0)
fig6d      Fig. 6(d): lambda = (50, 1, 50)
fig6e      Fig. 6(e): lambda = (50, 1, 100)
robust     the default (:data:`DEFAULT_PRESET`), beyond the paper: the robust multi-view depth stage
           (:mod:`vfxstereo.depth`), the initial volume from it with hidden layers (:mod:`vfxstereo.layers`),
           soft edges by triangulation against the backgrounds the views see (:mod:`vfxstereo.softedge`), in up
           to 8 passes that send edge pixels the matte calls background back where the views agree
           (``SoftEdgeParams.relabel_explained``), and that open holes the depth map filled over a plain
           wall (``SoftEdgeParams.relabel_radius``); over a plain background, a rim the depth map grew over
           the wall goes back (foreground samples of the wall's colour are walked past:
           ``SoftEdgeParams.separation_where``); no refinement (it is Eqs. 9-13 that the paper's selection
           needs to fill in, not this volume)
zkey       the same as ``robust`` (the z-keying default, by its old name; it used to be ``paper`` with edge
           matting, which measured worse than either on production-like plates)
soft       ``robust`` with the passes unguarded (``SoftEdgeParams.relabel_explained`` = 0): every
           near-side edge pixel whose alpha comes out below 0.5 moves back, for hair, fur and foliage over
           plain backgrounds, where the views cannot tell. On hard, opaque edges in real photographs it eats
           into the edge (Middlebury's held-out views of tsukuba and teddy 33.25 and 30.75 dB against the
           default's 33.48 and 31.24; z-key tuning scenes +0.57 / +0.98 dB frame / band). Its foreground
           samples walk past the background's colour over any background, not only a plain one
           (``SoftEdgeParams.separation_where`` = "everywhere")
=========  =====================================================================================

fig6b-e differ from ``paper`` in their lambdas only.

Beyond the paper (each a setting; ``literal`` turns them all off)
----------------------------------------------------------------
* ``tolerant_matching`` -- resampling-tolerant variance (:mod:`vfxstereo.sweep`).
* ``reference_votes`` -- when the front surface is selected again after visibility (Section 5), the
  reference view votes at every depth: it sees exactly one surface per pixel, the one the selection is
  deciding, so the previous winner must not veto the others. With the paper's rule (the reference's
  visibility from the previous pass applies too), a background cell behind a foreground edge gets
  votes only from the views that see the background there, agrees perfectly, and wins the pixel from the
  foreground: on the Fig. 6 stimulus (seeds 0-2) 88-103 wrong winners after re-estimation, 101 of them
  at pixels every view sees (none before it). With the reference voting: none at pixels every view sees,
  and the first pass's "too near" chance matches at occluded pixels are mostly corrected too (27-37
  before; 0-2 after, seeds 0-7).
* ``hidden_layers`` -- cells behind the front surface are selected as well
  (:func:`vfxstereo.select.select_behind`).
* ``fill_undecided``, ``extend_background``, ``soft_alpha`` -- completion of the selected volume
  before refinement (:func:`vfxstereo.select.complete`).
* ``lambdas = (50, 1, 10)`` -- with colours in [0, 1], C3 with lambda3 = lambda1 = 50 is not the "weak"
  0/1 prior the paper describes: a mixed pixel whose true opacity is 0.6 gains about 1 in lambda1 C1 by
  becoming transparent and pays about 12 in lambda3 C3 (at 8-bit colour units C1 would be 65025 times
  larger). Measured with the rest of ``paper`` (seeds 0-4): with lambda3 = 50 (preset ``fig6d``) the
  refinement leaves the Fig. 7 edge matte worse than the completed volume it starts from (mean alpha
  error 0.18 against 0.16) and the worst view at 38.0 dB (RDS 41.9 dB); with lambda3 = 10 it ends at
  0.09 with 42.4 dB (RDS 45.9 dB). lambda3 = 5 re-synthesises a little better still (~45 dB) with
  slightly softer edges.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from vfxstereo import aggregate as _aggregate
from vfxstereo import depth as _depth
from vfxstereo import refine as _refine
from vfxstereo import select as _select
from vfxstereo import softedge as _softedge
from vfxstereo.errors import VfxStereoError

LAMBDAS = (50.0, 1.0, 10.0)
"""Default lambda_1, lambda_2, lambda_3 of Eq. (13) (see the module notes for lambda_3 = 10)."""


@dataclass(frozen=True)
class SolveConfig:
    """All settings of :func:`vfxstereo.solve`; symbols as in Szeliski & Golland (1999).

    Variances and thresholds are in 8-bit units squared (matching values scaled to 0..255), as in the
    paper. The defaults are the stage modules' own constants, so there is one source for each number,
    except ``lambdas`` (:data:`LAMBDAS`, see the module notes); they make the ``paper`` preset.
    """

    # Depth: the paper's variance sweep and thresholded selection, or the robust multi-view stage
    depth: str = "variance"
    """How the front surface is found: ``"variance"`` (the paper: Eq. 1 sweep, Eq. 2, thresholded selection
    and visibility passes) or ``"robust"`` (beyond the paper: AD-census over all views, semi-global matching,
    visibility from the depth map; :mod:`vfxstereo.depth`, then :mod:`vfxstereo.layers`)."""
    depth_config: _depth.DepthConfig = field(default_factory=_depth.DepthConfig)
    """Settings of the robust depth stage (``depth="robust"``)."""
    # Sweep (Eq. 1)
    matching: str = "srgb"
    """Values the variance is computed on: "srgb" (display-encoded, like the paper's 8-bit data) or "linear"."""
    min_votes: float = 2.0
    """Cells seen by fewer views (total visibility weight) get no variance and cannot win."""
    tolerant_matching: bool = True
    """Resampling-tolerant variance: also match on views low-passed along the baseline, keep the smaller
    variance (beyond the paper; :mod:`vfxstereo.sweep`)."""
    # Aggregation, Eq. (2)
    aggregation: str = "szeliski1999"
    """Aggregation method (:data:`vfxstereo.aggregate.AGGREGATION_METHODS`)."""
    a: float = _aggregate.A
    """Weight of the current variance (a in Eq. 2)."""
    b: float = _aggregate.B
    """Weight of each of the four neighbours' limited variances (b in Eq. 2)."""
    c: float = _aggregate.C
    """Weight of the original variance sigma^0 (c in Eq. 2)."""
    sigma_max: float = _aggregate.SIGMA_MAX
    """Limit of the robustified variance (sigma_max in Eq. 2), 8-bit units squared."""
    aggregation_iterations: int = _aggregate.ITERATIONS
    """Iterations of Eq. (2); the paper does not say how many."""
    limit_centre: bool = False
    """Also limit the centre term of Eq. (2) by sigma_max (the extracted text lost which terms carry the tilde)."""
    # Selection (Section 4, footnote 6)
    theta_min: float = _select.THETA_MIN
    """Variance threshold floor theta_min, 8-bit units squared."""
    theta_s: float = _select.THETA_S
    """Slope of the threshold on the local 3x3 image variance (theta_s)."""
    clear_ratio: float = _select.CLEAR_RATIO
    """A winner is clear when its variance is below clear_ratio times the best non-adjacent competitor's."""
    require_clear: bool = True
    """Apply the clear-winner test (off for plain winner-take-all)."""
    # Visibility (Section 5)
    visibility_iterations: int = 1
    """Re-estimation passes: re-project, compute V_k, recompute weighted statistics, select again."""
    binary_visibility: bool = False
    """Use the paper's simple visibility (d >= d_top) instead of the soft front-to-back product of Eq. (7)."""
    reference_votes: bool = True
    """After visibility, the reference view still votes at every depth of its own pixel when the front
    surface is selected again (beyond the paper; see the module notes). Needs a virtual camera that is
    one of the views."""
    hidden_layers: bool = True
    """After visibility, also select the cells behind the front surface (beyond the paper;
    :func:`vfxstereo.select.select_behind`)."""
    # Completion of the initial volume (beyond the paper; vfxstereo.select.complete)
    fill_undecided: bool = True
    """Give undecided pixels the farthest neighbouring surface before refinement."""
    extend_background: int = 3
    """Continue the background this many pixels behind the edges of nearer surfaces (0: off)."""
    soft_alpha: float = 0.5
    """Opacity given to the boundary cells of nearer surfaces before refinement (1: off)."""
    # Refinement (Section 6, Appendix)
    lambdas: tuple[float, float, float] = LAMBDAS
    """lambda_1, lambda_2, lambda_3 of Eq. (13) (:data:`LAMBDAS`; the paper's Fig. 6(d) is (50, 1, 50))."""
    rho1: str = _refine.RefineConfig.rho1
    """Penalty of the re-synthesis error C1: "quadratic" or "huber"."""
    rho2: str = _refine.RefineConfig.rho2
    """Penalty of the smoothness term C2: "quadratic" or "huber" (Huber by default: see refine.py)."""
    huber_scale: float = _refine.RefineConfig.huber_scale
    """Huber threshold, in colour units (0..1)."""
    premultiplied_smoothness: bool = _refine.RefineConfig.premultiplied_smoothness
    """Use C2' (Eq. 12), the smoothness term for premultiplied colours."""
    epsilon1: float = _refine.RefineConfig.epsilon1
    """Step size epsilon_1 of Eq. (A2)."""
    epsilon2: float = _refine.RefineConfig.epsilon2
    """Stabiliser epsilon_2 of Eq. (A2)."""
    refine_iterations: int = _refine.RefineConfig.iterations
    """Preconditioned gradient descent steps; 0 skips refinement."""
    backtrack: bool = _refine.RefineConfig.backtrack
    """Retry a step that raised C at half the size (not in the paper; keeps C from rising)."""
    warmup: float = _refine.RefineConfig.warmup
    """Fraction of the refinement spent on C1 alone first (not in the paper; see refine.py)."""
    border_weights: bool = False
    """Give no weight in C1 to view pixels whose content lies outside the reference frame on some plane
    (:func:`vfxstereo.solver.border_weights`). Off by default, measured: on the synthetic scenes (whose
    back layer covers every view) it only removes data -- with the paper preset (seeds 0-2) the worst
    Fig. 7 view drops from 42.3 to 22.2 dB (the unweighted edge columns are left unexplained) and the
    worst RDS view from 45.9 to 43.2 dB; on Middlebury tsukuba (paper preset, full size) bad pixels are unchanged
    (19.74 % against 19.72 %) and every view re-synthesises worse (34.3-40.4 dB against 36.0-41.4 dB,
    also 8 px inside the frame: 36.1-40.2 dB against 38.8-41.7 dB)."""
    # Sub-pixel disparity (Section 8.1)
    subpixel: bool = True
    """Report a sub-pixel disparity map by a parabola through the aggregated variance."""
    # Edge matting (beyond the paper; vfxstereo.matting)
    edge_matting: bool = False
    """After refinement, re-solve colour and alpha of the soft-edge band per pixel against the background seen
    by the unoccluded views (:func:`vfxstereo.matting.matte_edges`). On the hair/fur z-key benchmark it lifts
    the edge band from 17.3 to 24.8 dB (hard matte from true depth: 23.3 dB); the ``zkey`` preset turns it on."""
    soft_edges: bool = False
    """Robust depth only: alpha along the depth edges by triangulation against the backgrounds the views see
    (:mod:`vfxstereo.softedge`, beyond the paper)."""
    soft_edge: _softedge.SoftEdgeParams = field(default_factory=_softedge.SoftEdgeParams)
    """Settings of the soft edges."""
    soft_rounds: int = 2
    """Robust depth with soft edges, three views or more: rounds of the layers and soft edges. Each round after
    the first builds the initial volume again from the front surface the previous round's passes left (the
    front-most layer with alpha > 0.5, where it moved off the map's plane) and runs the soft-edge passes on it:
    a pixel the passes moved back becomes background for the next round's volume, z-buffers and bands, so the
    hidden layers and the backgrounds the views see behind it follow. The result's ``disparity`` stays the
    depth stage's map. A stereo pair always gets one round: two at K = 2 (session 60, on the head, the 157 K = 2
    tuning rows, frame / band dB) -0.14 / -0.17, rows losing to the SGBM key 8 -> 15 (fur_pillar_monopoly's card at
    d = 3.4 -8.6 on the band, curls_wire_midd's at d = 11.6 -3.8, koala_slope -2.5; beanie_grille's card at d = 12
    +5.8): with one other view, a front the first round's passes moved back has no view left to bring it forward.

    Two rounds by default since session 55: measured again on the head (since session 49 the depth stage's second
    visibility pass, the plain pixels' visibility and the soft edges' covered-pixel rules came in), 2 rounds
    against 1, z-key benchmark, frame / band dB: K = 5 tuning rows (151) 35.12 / 27.79 -> 35.40 / 28.02 (+0.28 /
    +0.23), held-out rows (30, scored after the tuning rows) 31.19 / 25.64 -> 31.65 / 25.94 (+0.46 / +0.31); all 362
    rows 33.02 / 26.42 -> 33.17 / 26.54; best fur_grey_wall +3.3 / +3.2, wire_plant_laundry (held out) +1.8 / +0.9,
    fence_dof +1.3 / +1.1, doll_plaster +1.0 / +1.5; worst witch_monster -0.2 / -0.6, sphere_plant -0.4 / -0.4,
    trolls_art -0.4 / -0.3; K = 5 rows worse than their initial volume 11 -> 10; rows losing to the SGBM key 3 / 4
    -> 3 / 5 at K = 5 (curls_wire_midd's card at d = 3, already losing over the frame, now also on the band by
    0.04 dB: 24.34 against 24.38). Three rounds: +0.38 / +0.27 tuning, +0.53 / +0.29 held out, 3 / 4 losing --
    over two rounds +0.10 / +0.04 and +0.07 / -0.02 for a third run of the soft edges; not taken. Middlebury's
    held-out views (K = 4 solves, side by side): tsukuba 34.25 -> 34.00 dB, teddy 31.17 -> 30.75, Cloth1 41.30 ->
    41.23, Plastic 39.53 -> 39.94, Wood2 43.70 -> 43.34, mean 37.99 -> 37.85 (the SGBM warp's 36.08): the second
    round moves more of the hard edges of photographs, which re-synthesis punishes and a z-key mostly does not.
    Cost: the stages after the depth 1.5x on six z-key scenes, 2.0x at HD x 64 on a random-dot plate (README).

    Added in session 49, not on by default then (the evidence was mixed). Measured side by side, 2 rounds against 1
    (z-key benchmark, frame / band dB, K = 5 rows; K = 2 rows unchanged): tuning rows (151) +0.12 / +0.17, but
    rows losing to the SGBM key 1 / 4 -> 3 / 4 (fur_pillar_monopoly's card at d = 3.4 +0.27 -> -0.81 frame,
    artichoke_books' hidden card at d = 4 0.0 -> -2.9 frame) and rows worse than their initial volume 35 -> 38
    of 302 (best sheep_duck_wall's full card at d = 10.5 +8.8 / +7.7, fur_grey_wall +3.4 / +3.3 on three rows;
    worst boards_rocks' full card at d = 11.4 -8.0 frame, duck_monster_baby -5.1 frame, sign_plant_aloe -4.5 /
    -2.5 and -3.2 / -5.4); held-out rows (30, scored after) +0.20 / +0.20, none turning (wire_plant_laundry
    +0.9 to +1.8, worst railing_subject_rocks -0.3). On the synthetic hair of tests/test_layers.py (GT04 over
    a random texture or a painted wall, K = 5) the holdout's mean error on the rim gets worse in four of six
    cases (textured background from the true depth 0.079 -> 0.091, from the depth grown by 3 px 0.078 ->
    0.091, from the robust depth 0.106 -> 0.102; painted wall 0.048 -> 0.052, 0.049 -> 0.044, 0.040 -> 0.044).
    Middlebury's held-out views (K = 4 solves) fall on four of five sets: tsukuba 33.82 -> 33.48 dB, teddy
    31.22 -> 30.80, Cloth1 41.28 -> 41.16, Wood2 44.18 -> 44.10 (Plastic 39.10 -> 39.26; mean 37.92 -> 37.76).
    On a stereo pair (the gate lifted, K = 2 tuning rows): -0.11 / +0.02, losing 6 / 2 -> 7 / 1; session 45's
    first form (re-solving from the front map) measured -0.11 / -0.02 there -- hence one round on a pair. Again
    in session 58, on that head's maps (K = 2 tuning rows, 157): 32.00 / 25.75 -> 31.86 / 25.65, losing 8 -> 10
    (curls_wire_midd's card at d = 11.6 -3.8 / -3.8, koala_slope -2.5 / -2.5, witch_monster -1.8 / -2.1;
    beanie_grille +5.8 / +5.8, petals_grille_plastic +2.3 / +3.4). Each round costs the stages after the depth
    again."""
    keep_empty_planes: bool = True
    """Robust depth only: the stack has a layer for every plane asked for. False: only the planes the depth
    map uses (the front surface's planes; hidden cells and soft edges lie on them too), so a 4096x2160 plate
    swept over 128 planes does not hold a 4096x2160x128 RGBA volume that is mostly empty. Without refinement
    and edge matting (which may fill any plane) the layers kept are exactly those of the full stack."""
    extra: dict = field(default_factory=dict, compare=False)
    """Free-form settings for alternative methods (registry entries); recorded in metadata."""

    def replace(self, **changes) -> SolveConfig:
        """A copy with ``changes`` applied; unknown names raise VfxStereoError."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise VfxStereoError(f"unknown solver setting(s): {', '.join(unknown)}")
        return dataclasses.replace(self, **changes)

    def refine_config(self, *, white: float = 1.0) -> _refine.RefineConfig:
        """The refinement stage's settings."""
        return _refine.RefineConfig(
            lambdas=self.lambdas, rho1=self.rho1, rho2=self.rho2, huber_scale=self.huber_scale,
            premultiplied_smoothness=self.premultiplied_smoothness, epsilon1=self.epsilon1,
            epsilon2=self.epsilon2, iterations=self.refine_iterations, backtrack=self.backtrack,
            warmup=self.warmup, white=white)

    def to_dict(self) -> dict:
        """Plain-JSON form, recorded in the stack's metadata."""
        d = dataclasses.asdict(self)
        d["lambdas"] = list(self.lambdas)
        d["depth_config"]["matching"]["census_radius"] = list(self.depth_config.matching.census_radius)
        d["depth_config"]["edge_census_radius"] = list(self.depth_config.edge_census_radius)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> SolveConfig:
        """Inverse of :meth:`to_dict` (JSON lists back to tuples, nested settings back to their classes)."""
        d = dict(d)
        d["lambdas"] = tuple(d["lambdas"])
        dc = dict(d["depth_config"])
        dc["matching"] = _depth.matching.MatchingParams(**{**dc["matching"],
                                                           "census_radius": tuple(dc["matching"]["census_radius"])})
        if "edge_census_radius" in dc:
            dc["edge_census_radius"] = tuple(dc["edge_census_radius"])
        if "reopen_radii" in dc:
            dc["reopen_radii"] = tuple(dc["reopen_radii"])
        d["depth_config"] = _depth.DepthConfig(**dc)
        d["soft_edge"] = _softedge.SoftEdgeParams(**d["soft_edge"])
        return cls(**d)

    @classmethod
    def preset(cls, name: str) -> SolveConfig:
        """The named configuration (see the module docstring)."""
        try:
            changes = PRESETS[name]
        except KeyError:
            raise VfxStereoError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}") from None
        return cls().replace(**changes)


_NO_COMPLETION = {"fill_undecided": False, "extend_background": 0, "soft_alpha": 1.0}

PRESETS: dict[str, dict] = {
    "paper": {},
    "literal": {
        "tolerant_matching": False,
        "reference_votes": False,
        "hidden_layers": False,
        **_NO_COMPLETION,
        "lambdas": (50.0, 1.0, 50.0),
    },
    "wta": {
        "theta_min": float("inf"),
        "require_clear": False,
        "visibility_iterations": 0,
        "hidden_layers": False,
        **_NO_COMPLETION,
        "refine_iterations": 0,
    },
    "fig6a": {"refine_iterations": 0, **_NO_COMPLETION},
    "fig6b": {"lambdas": (1.0, 0.0, 0.0)},
    "fig6c": {"lambdas": (1.0, 1.0, 0.0)},
    "fig6d": {"lambdas": (50.0, 1.0, 50.0)},
    "fig6e": {"lambdas": (50.0, 1.0, 100.0)},
    "robust": {"depth": "robust", "refine_iterations": 0, "soft_edges": True},
}
PRESETS["soft"] = {**PRESETS["robust"], "soft_edge": _softedge.SoftEdgeParams(relabel_explained=0.0,
                                                                            min_separation=0.18,
                                                                            separation_where="everywhere"),
                   # foliage over textured backgrounds: the depth stage's gap reopening (DepthConfig.reopen); its
                   # window stays the box it was measured with (the guided window under soft is not measured)
                   "depth_config": _depth.DepthConfig(reopen=True, aggregation="box")}
# plain walls seen through grilles, fences, wicker or foliage: the depth stage's rival gate (DepthConfig.rival_jump)
PRESETS["grille"] = {**PRESETS["robust"], "depth_config": _depth.DepthConfig(rival_jump=3.0)}
PRESETS["zkey"] = PRESETS["robust"]  # the z-keying default, by its old name

DEFAULT_PRESET = "robust"
"""The configuration of :func:`vfxstereo.solve` without a config, and of ``vfxstereo solve`` without --preset:
the best measured for z-keying real plates (benchmarks/zkey_scenes.py, benchmarks/middlebury.py)."""
