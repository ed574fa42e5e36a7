"""The Middlebury benchmark's depth-only mode scores the same map as the full solve, with the settings given."""

import sys
from pathlib import Path

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
