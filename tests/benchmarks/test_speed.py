"""The speed benchmark's harness: refused cases are rows, the byte model, the report (no HD solve here)."""

import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
speed = pytest.importorskip("speed")


def test_a_case_the_solver_refuses_is_a_row_not_a_crash(monkeypatch):
    from vfxstereo import solver

    monkeypatch.setattr(solver, "available_memory", lambda: 2**20)  # 1 MiB: every case is too big
    result = speed.run_case(64, 48, 8)
    assert result["refused"].startswith("8 disparity planes at 64x48 with 5 views need about")
    done = {"width": 32, "height": 16, "planes": 8, "views": 5, "seconds": 2.0, "peak": 2**30, "estimate": 2**29,
            "good": 0.5, "settings": {}, "timings": {"sweep": 1.0, "newstage": 1.0}}
    report = speed.tables([result, done], bytes_per_second=1e9)
    rows = re.findall(r"^\|\s*64x48\s*\|\s*8\s*\|\s*refused: 8 disparity planes at 64x48", report, re.M)
    assert len(rows) == 2  # in the time table and in the ratio table
    assert "newstage" in report  # a stage without a byte model still shows its time


def test_the_byte_model_counts_passes_and_iterations_from_the_settings():
    n, d, k = 100, 10, 5
    one_pass = {"visibility_iterations": 0, "hidden_layers": False, "refine_iterations": 0}
    two_passes = {"visibility_iterations": 1, "hidden_layers": True, "reference_votes": True}
    assert speed.stage_bytes("sweep", n=n, d=d, k=k, settings=one_pass) == 12 * k * n + 20 * d * n
    # three sweeps (front and hidden in the second pass), two of them reading the visibilities
    assert speed.stage_bytes("sweep", n=n, d=d, k=k, settings=two_passes) == (
        3 * (12 * k * n + 20 * d * n) + 2 * 4 * d * k * n)
    assert speed.stage_bytes("visibility", n=n, d=d, k=k, settings=one_pass) == 0
    assert speed.stage_bytes("refine", n=n, d=d, k=k, settings={"refine_iterations": 3}) == 3 * (
        32 * d * n + 12 * k * n)
    assert speed.stage_bytes("newstage", n=n, d=d, k=k, settings={}) is None


def test_a_case_that_does_not_finish_is_a_failed_row():
    result = speed._spawn(64, 48, 8, preset=None, timeout=0.05)
    assert result["failed"] == "no result within --timeout 0.05 s"
    assert "failed: no result" in speed.tables([result], bytes_per_second=1e9)


def test_the_robust_byte_model_sums_the_depth_stages_and_counts_the_layers_held():
    n, d, k = 100, 10, 5
    robust = {"depth": "robust", "depth_config": {"visibility_passes_views": 1}}
    parts = [speed.stage_bytes(s, n=n, d=d, k=k, settings=robust) for s in ("depth.match", "depth.sgm",
                                                                             "depth.finish")]
    assert parts[0] == 2 * ((k - 1) * 10 * d * n + 28 * d * n)  # two passes
    assert speed.stage_bytes("depth", n=n, d=d, k=k, settings=robust) == sum(parts)
    full = speed.stage_bytes("layers", n=n, d=d, k=k, settings=robust)
    lean = speed.stage_bytes("layers", n=n, d=d, k=k, settings=robust, layers=2)
    assert full - lean == 16 * (d - 2) * n
    # the default's passes: three with three or more views, two for a pair
    default = {"depth": "robust"}
    assert speed.stage_bytes("depth.match", n=n, d=d, k=k, settings=default) == 3 * ((k - 1) * 10 * d * n + 28 * d * n)
    assert speed.stage_bytes("depth.match", n=n, d=d, k=2, settings=default) == 2 * (10 * d * n + 28 * d * n)


def test_a_case_with_fewer_views_solves_the_central_ones():
    result = speed.run_case(64, 48, 8, views=3)
    assert result["views"] == 3 and result["good"] > 0.8  # still solves
    assert speed._label(result) == "64x48, K = 3"
