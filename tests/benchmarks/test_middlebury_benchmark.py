"""The Middlebury benchmark's depth-only mode scores the same map as the full solve, with the settings given."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
mb = pytest.importorskip("middlebury")


@pytest.mark.data
def test_depth_only_scores_the_full_solves_map_and_takes_settings(shared_data):
    full = mb._job("ours", "tsukuba", True)
    alone = mb._job("ours", "tsukuba", True, depth_only=True)
    assert alone["bad"] == full["bad"] and alone["disc"] == full["disc"]
    other = mb._job("ours", "tsukuba", True, overrides={"depth_config": {"median": 0, "far_bias": 0.0}},
                    depth_only=True)
    assert other["bad"] != alone["bad"]
    text = mb.tables(["tsukuba"], ["ours", "pair", "sgbm"], {("ours", "tsukuba"): alone,
                                                              ("sgbm", "tsukuba"): mb._job("sgbm", "tsukuba", True)},
                     True)
    assert "Mean bad %: ours" in text and f"{alone['bad']:.2f}" in text


def test_the_bad_pixels_near_depth_jumps_split_into_fattened_and_eroded():
    """A step edge whose nearer side the map spreads 2 px over the farther one (fattening) on the upper rows and
    pulls back 3 px on the lower rows: the discontinuity's bad pixels split into exactly those two strips."""
    h, w = 40, 60
    gt = np.full((h, w), 2.0)
    gt[:, 30:] = 10.0  # the nearer surface on the right
    d = gt.copy()
    d[:20, 28:30] = 10.0  # fattened: the near surface 2 px over the far one
    d[20:, 30:33] = 2.0  # eroded: the far surface 3 px into the near one
    d[5, 5] = np.nan  # undecided, away from the jump: bad, neither side
    s = mb.score(d, gt, eval_steps=1, border=0)
    disc = mb.discontinuities(gt, 1)
    assert s["disc_near"] == pytest.approx(100.0 * 40 / disc.sum())
    assert s["disc_far"] == pytest.approx(100.0 * 60 / disc.sum())
    assert s["disc"] == pytest.approx(s["disc_near"] + s["disc_far"])
    assert s["bad"] == pytest.approx(100.0 * 101 / (h * w))
