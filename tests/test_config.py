"""SolveConfig: the paper's parameters as defaults, presets that set what they claim, strict replace()."""

import dataclasses
import json

import numpy as np
import pytest

from vfxstereo import SolveConfig, VfxStereoError
from vfxstereo import aggregate as A
from vfxstereo import refine as R
from vfxstereo import select as S
from vfxstereo.config import LAMBDAS, PRESETS

PAPER_LAMBDAS = {  # Section 7, Fig. 6 (b)-(e)
    "fig6b": (1.0, 0.0, 0.0),
    "fig6c": (1.0, 1.0, 0.0),
    "fig6d": (50.0, 1.0, 50.0),
    "fig6e": (50.0, 1.0, 100.0),
}
EXTENSIONS = {  # the settings marked "beyond the paper", with the value that turns each off
    "tolerant_matching": False,
    "reference_votes": False,
    "hidden_layers": False,
    "fill_undecided": False,
    "extend_background": 0,
    "soft_alpha": 1.0,
}


def _differences(a: SolveConfig, b: SolveConfig) -> dict:
    return {f.name: getattr(b, f.name) for f in dataclasses.fields(a) if getattr(a, f.name) != getattr(b, f.name)}


def test_every_named_preset_exists():
    assert set(PRESETS) == {"paper", "literal", "wta", "fig6a", "fig6b", "fig6c", "fig6d", "fig6e", "zkey",
                            "robust", "soft", "grille"}
    for name in PRESETS:
        assert isinstance(SolveConfig.preset(name), SolveConfig)


def test_the_default_preset_is_the_robust_one_and_zkey_its_alias():
    from vfxstereo.config import DEFAULT_PRESET

    assert DEFAULT_PRESET == "robust"
    robust = SolveConfig.preset("robust")
    assert robust == SolveConfig.preset("zkey")
    assert _differences(SolveConfig(), robust) == {"depth": "robust", "refine_iterations": 0, "soft_edges": True}


def test_defaults_are_the_papers_numbers_from_the_stage_modules():
    c = SolveConfig()
    assert (c.a, c.b, c.c, c.sigma_max) == (0.1, 0.15, 0.3, 16.0) == (A.A, A.B, A.C, A.SIGMA_MAX)  # Eq. (2)
    assert (c.theta_min, c.theta_s) == (10.0, 0.02) == (S.THETA_MIN, S.THETA_S)  # footnote 6
    assert (c.epsilon1, c.epsilon2) == (0.5, 0.5)  # Eq. (A2)
    assert c.lambdas == LAMBDAS == (50.0, 1.0, 10.0)  # lambda3 below the paper's 50: see vfxstereo.config
    assert c.visibility_iterations == 1  # "after one iteration of this algorithm" (Section 5)


def test_paper_preset_is_the_default_configuration():
    assert SolveConfig.preset("paper") == SolveConfig()


def test_fig6_presets_set_the_papers_lambdas_and_nothing_else():
    paper = SolveConfig.preset("paper")
    for name, lam in PAPER_LAMBDAS.items():
        c = SolveConfig.preset(name)
        assert c.lambdas == lam
        assert _differences(paper, c) == {"lambdas": lam}
        assert c.refine_config().lambdas == lam


def test_fig6a_is_selection_with_visibility_and_nothing_after_it():
    c = SolveConfig.preset("fig6a")
    assert c.refine_iterations == 0
    assert c.visibility_iterations >= 1 and c.theta_min == 10.0 and c.require_clear
    assert not c.fill_undecided and c.extend_background == 0 and c.soft_alpha == 1.0


def test_wta_is_plain_winner_take_all():
    """Fig. 6(f): 'the same as Fig. 6(a) with a very large theta_min and no occluded pixel removal'."""
    c = SolveConfig.preset("wta")
    assert np.isinf(c.theta_min) and not c.require_clear
    assert c.visibility_iterations == 0 and not c.hidden_layers
    assert c.refine_iterations == 0
    assert not c.fill_undecided and c.extend_background == 0 and c.soft_alpha == 1.0
    paper = SolveConfig.preset("paper")
    for name in ("matching", "tolerant_matching", "aggregation", "a", "b", "c", "sigma_max",
                 "aggregation_iterations"):
        assert getattr(c, name) == getattr(paper, name)  # same matching and aggregation as Fig. 6(a)


def test_literal_turns_every_extension_off():
    c = SolveConfig.preset("literal")
    for name, off in EXTENSIONS.items():
        assert getattr(c, name) == off, name
    assert c.lambdas == PAPER_LAMBDAS["fig6d"]
    for name, off in EXTENSIONS.items():  # and the paper preset has every one of them on
        assert getattr(SolveConfig.preset("paper"), name) != off, name


def test_replace_applies_known_names_and_rejects_unknown_ones():
    c = SolveConfig().replace(theta_min=20.0, lambdas=(1.0, 2.0, 3.0))
    assert c.theta_min == 20.0 and c.lambdas == (1.0, 2.0, 3.0)
    assert SolveConfig().theta_min == 10.0  # the original is untouched (frozen)
    with pytest.raises(VfxStereoError, match="theta_mni"):
        SolveConfig().replace(theta_mni=20.0)
    with pytest.raises(VfxStereoError, match="unknown solver setting"):
        SolveConfig().replace(theta_min=1.0, nonsense=2)
    with pytest.raises(dataclasses.FrozenInstanceError):
        SolveConfig().theta_min = 3.0


def test_unknown_preset_raises():
    with pytest.raises(VfxStereoError, match="unknown preset 'fig6z'"):
        SolveConfig.preset("fig6z")


def test_refine_config_carries_the_refinement_settings():
    c = SolveConfig().replace(rho1="huber", huber_scale=0.1, epsilon1=0.25, refine_iterations=7, warmup=0.0)
    rc = c.refine_config(white=2.0)
    assert isinstance(rc, R.RefineConfig)
    assert (rc.rho1, rc.huber_scale, rc.epsilon1, rc.iterations, rc.warmup, rc.white) == (
        "huber", 0.1, 0.25, 7, 0.0, 2.0)
    with pytest.raises(VfxStereoError):  # the refinement validates what it is given
        SolveConfig().replace(lambdas=(1.0, -1.0, 0.0)).refine_config()


def test_to_dict_is_plain_json_and_round_trips():
    for name in PRESETS:
        c = SolveConfig.preset(name)
        d = json.loads(json.dumps(c.to_dict()))
        assert SolveConfig.from_dict(d) == c


def test_the_soft_preset_is_robust_with_soft_edges_that_follow_the_matte():
    soft, robust = SolveConfig.preset("soft"), SolveConfig.preset("robust")
    assert soft.soft_edge.passes == robust.soft_edge.passes == 8
    assert soft.soft_edge.relabel_explained == 0.0 < robust.soft_edge.relabel_explained  # unguarded
    assert soft.depth_config.reopen and not robust.depth_config.reopen  # and reopens gaps between leaves
    assert soft.depth_config.aggregation == "box" and robust.depth_config.aggregation == "guided"  # as measured
    assert soft.replace(soft_edge=robust.soft_edge, depth_config=robust.depth_config) == robust
    assert SolveConfig.from_dict(soft.to_dict()) == soft  # it round-trips through a stack's metadata


def test_the_grille_preset_is_robust_with_the_rival_gate():
    grille, robust = SolveConfig.preset("grille"), SolveConfig.preset("robust")
    assert grille.depth_config.rival_jump > 0 == robust.depth_config.rival_jump
    assert grille.replace(depth_config=robust.depth_config) == robust
    assert SolveConfig.from_dict(grille.to_dict()) == grille
