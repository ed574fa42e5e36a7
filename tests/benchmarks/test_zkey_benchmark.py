"""The z-key benchmark's summary: rows ours beats, ties with and loses to the SGBM key are counted apart."""

import re
import sys
from pathlib import Path

import pytest

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
