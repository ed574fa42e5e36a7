"""The z-key benchmark's summary: rows ours beats, ties with and loses to the SGBM key are counted apart."""

import re
import sys
from pathlib import Path

import pytest

from vfxstereo.errors import VfxStereoError

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
zkey = pytest.importorskip("zkey_scenes")


def _row(ours, sgbm, K=5):
    row = {m: (30.0, 20.0) for m in zkey.METHODS}
    row.update({"scene": "s", "K": K, "element": "card", "seconds": 1.0, "ours": ours, "SGBM key": sgbm})
    return row


def test_the_summary_counts_wins_ties_and_losses_against_the_sgbm_key():
    rows = [_row((31.0, 21.0), (30.0, 20.0)),   # beats on both
            _row((30.0, 20.0), (30.0, 20.0)),   # the same comp: a tie, not a win
            _row((29.0, 20.002), (30.0, 20.0)),  # loses the frame, ties the band within TIE
            _row((30.5, 19.0), (30.0, 20.0), K=2),  # beats the frame, loses the band
            _row((31.0, 150.0), (30.0, 160.0))]  # both exact on the band (above CAP): a tie
    text = zkey.tables(rows, "test")
    m = re.search(r"beats the SGBM key on (\d+)/5 rows over the frame \(ties (\d+), (\d+) of them with both above "
                  r"60 dB; loses (\d+)\) and (\d+)/5 on the band \(ties (\d+), (\d+) of them both above 60 dB; "
                  r"loses (\d+)\)", text)
    assert m, text
    assert tuple(map(int, m.groups())) == (3, 1, 0, 1, 1, 3, 1, 1)


def test_settings_on_top_of_a_preset_change_only_the_names_given():
    config = zkey.configured("robust", {"soft_edge": {"laplacian": 0.3}, "soft_edges": False})
    base = zkey.SolveConfig.preset("robust")
    assert config.soft_edge.laplacian == 0.3 and not config.soft_edges
    assert config.soft_edge.relabel_radius == base.soft_edge.relabel_radius
    assert config.depth_config == base.depth_config
    with pytest.raises(VfxStereoError, match="unknown solver setting"):
        zkey.configured("robust", {"no_such_setting": 1})


def test_the_comparison_with_an_earlier_run_is_ours_change_per_scene():
    before = [_row((30.0, 20.0), (0, 0)), _row((40.0, 30.0), (0, 0), K=2)]
    after = [_row((31.0, 19.0), (0, 0)), _row((40.0, 150.0), (0, 0), K=2)]  # the band above CAP counts as CAP
    text = zkey.compare(after, before)
    assert "| s     |   5 |    1 | +1.00 / -1.00" in text, text
    assert f"+0.00 / {zkey.CAP - 30.0:+.2f}" in text, text
    assert "| all" in text and f"+0.50 / {(zkey.CAP - 30.0 - 1.0) / 2:+.2f}" in text, text


@pytest.mark.data
def test_a_cached_depth_map_gives_the_rows_of_a_full_solve(shared_data, tmp_path):
    """run_scene with a depth cache: the first run solves in full and stores the depth stage's map, the second
    builds the layers from it (solve(disparity=...)) and gives the same rows."""
    first = zkey.run_scene("trolls_art", 2, "robust", figures=False, depth_cache=tmp_path)
    assert len(list(tmp_path.glob("trolls_art_K2_*.npy"))) == 1
    again = zkey.run_scene("trolls_art", 2, "robust", figures=False, depth_cache=tmp_path)
    assert len(first) == len(again) > 0
    for a, b in zip(first, again, strict=True):
        for m in zkey.METHODS:
            assert a[m] == b[m], m


def test_the_depth_cache_key_follows_the_depth_settings_and_the_depth_code(tmp_path, monkeypatch):
    """A cached map is stale when the depth settings or the depth stage's code change, not when soft edges do."""
    base = zkey.configured("robust")
    key = zkey._depth_path(tmp_path, "s", 5, base)
    assert key == zkey._depth_path(tmp_path, "s", 5, zkey.configured("robust", {"soft_edge": {"laplacian": 0.3}}))
    assert key != zkey._depth_path(tmp_path, "s", 5, zkey.configured("robust", {"depth_config": {"median": 5}}))
    assert key != zkey._depth_path(tmp_path, "s", 2, base)
    monkeypatch.setattr(zkey, "DEPTH_SOURCES", zkey.DEPTH_SOURCES[:-1])  # other code: another key
    assert key != zkey._depth_path(tmp_path, "s", 5, base)


def test_rows_count_as_worse_than_the_initial_volume_only_below_the_cap():
    rows = [_row((31.0, 21.0), (0, 0)), _row((61.0, 40.0), (0, 0)), _row((29.0, 20.0), (0, 0))]
    rows[0]["ours, initial"] = (32.0, 21.0)   # worse by 1 dB: counts
    rows[1]["ours, initial"] = (170.0, 40.0)  # both above CAP (an exact initial comp): does not count
    rows[2]["ours, initial"] = (29.02, 20.0)  # within 0.05 dB: does not count
    text = zkey.tables(rows, "test")
    assert "worse than the initial volume (frame, > 0.05 dB) on 1/3 rows" in text, text


def test_band_pixels_are_classed_by_the_true_front_alpha_and_ours():
    import numpy as np

    true_a = np.array([0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 0.01, 0.99])
    ours_a = np.array([0.95, 0.5, 0.05, 0.2, 0.5, 0.05, 0.95, 0.1, 0.9])
    classes = zkey.alpha_classes(true_a, ours_a)
    names = [zkey.ALPHA_CLASSES[k] for k in classes]
    assert names == ["clear, under an opaque front", "clear, under a partial front", "right", "soft",
                     "solid, made see-through", "solid, lost", "right", "clear, under a partial front",
                     "solid, made see-through"]


def test_the_front_alpha_is_what_lies_in_front_of_the_element():
    import numpy as np

    from vfxstereo.composite import holdout
    from vfxstereo.stack import LayerStack

    rgba = np.zeros((3, 2, 2, 4), np.float32)
    rgba[0, ..., 3] = 1.0  # the back wall, at d = 1: behind the element
    rgba[1, 0, 0, 3] = 0.5
    rgba[2, 0, 0, 3] = 0.5
    rgba[2, 1, 1, 3] = 0.25
    stack = LayerStack(rgba, np.array([1.0, 5.0, 9.0]))
    assert np.allclose(holdout(stack, 3.0), [[0.75, 0.0], [0.0, 0.25]])
    assert np.allclose(holdout(stack, 7.0), [[0.5, 0.0], [0.0, 0.25]])

    class Rendered:  # no layers: the true depth map decides (one surface per pixel)
        pass

    d = np.array([[2.0, 8.0], [np.nan, 5.0]])
    assert np.array_equal(zkey.true_front_alpha(Rendered(), 4.0, d), [[0, 1], [0, 1]])


def test_the_band_gain_of_fixing_one_class_alone():
    import numpy as np

    row = _row((30.0, 20.0), (0, 0))
    n = 1000  # band pixels; ours' band PSNR 20 dB: squared error 10 summed, 8 of it clear pixels under an opaque front
    row["band error by alpha"] = {"ours": [8.0, 0.5, 1.0, 0.25, 0.25, 0.0], "true-depth key": [0.0, 0, 1.0, 0, 0, 0],
                                  "pixels": [100, 50, 200, 20, 10, 620]}
    assert np.isclose(zkey._band_without(row, 0), 10 * np.log10(n / 2.0))  # 10 - 8 + 0
    assert np.isclose(zkey._band_without(row, 2), 20.0)  # the key is as wrong as ours on the soft pixels
    text = zkey.tables([row], "test")
    assert f"clear, under an opaque front {10 * np.log10(n / 2.0) - 20:+.2f}" in text, text


def test_too_near_pixels_are_binned_by_their_distance_from_our_depth_jumps():
    import numpy as np

    d = np.zeros((5, 40), np.float32)
    d[:, :10] = 5.0  # one step at x = 9 | 10: those two columns are at the jump
    classes = zkey.jump_distance_class(d)
    assert list(classes[2, [9, 10, 11, 12, 13, 17, 18, 25, 26, 39]]) == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]
    assert (zkey.jump_distance_class(np.zeros((4, 4), np.float32)) == 4).all()  # no jump at all: far from any
    row = _row((30.0, 20.0), (0, 0))
    row["band too-near error by jump distance"] = {"ours": [3.0, 1.0, 0.0, 0.0, 4.0], "pixels": [3, 2, 0, 0, 9]}
    text = zkey.tables([row], "test")
    assert "0-1 38%; 1-3 12%; 3-8 0%; 8-16 0%; 16+ 50%" in text, text
