"""Issue 13's targets on the synthetic untrimmed sessions, scored by score-events.

One seed of ``benchmarks/eval_detect.py`` (which runs three): 16 participant-sessions of 10
minutes at 30 fps, labels of 90-225°, ``min_turn_deg`` 67.5, IoU 0.5. The targets are the
issue's: F1 >= 0.93 overall and >= 0.90 per cohort, matched accuracy >= 95%, matched MAE
<= 11°, median boundary error <= 0.3 s. Beside them, the miner's rule run raw on the same
streams stays where the issue measured it on its hidden sessions (F1 0.57): the sessions
are as hard as those.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from turn_eval.detect.rule import split_overlaps

REPO = Path(__file__).resolve().parents[1]


def _eval_detect():
    spec = importlib.util.spec_from_file_location(
        "eval_detect", REPO / "benchmarks" / "eval_detect.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def rows(tmp_path_factory) -> dict:
    out = _eval_detect().evaluate(1, tmp_path_factory.mktemp("eval"))
    return {(r["detector"], r["group"]): r for r in out}


def test_targets_on_synthetic_untrimmed_sessions(rows) -> None:
    overall = rows[("detect", "overall")]
    assert overall["tp"] + overall["fn"] == 440  # every labelled turn of seed 1
    assert overall["F1"] >= 0.93
    for cohort in ("PD", "HC"):
        assert rows[("detect", cohort)]["F1"] >= 0.90
    assert overall["acc"] >= 0.95
    assert overall["MAE"] <= 11.0
    assert max(overall["|dstart| s"], overall["|dend| s"]) <= 0.3


def test_the_raw_miner_is_fooled_as_on_the_hidden_sessions(rows) -> None:
    raw = rows[("raw miner", "overall")]
    assert raw["P"] < 0.5 and raw["F1"] < 0.65 and raw["MAE"] > 15.0


def test_split_overlaps_by_hand() -> None:
    # [10, 20) and [18, 30) share frames 18 and 19: each keeps one; a clean pair stays
    start, end = split_overlaps(np.array([10, 18, 40]), np.array([20, 30, 50]))
    assert start.tolist() == [10, 19, 40] and end.tolist() == [19, 30, 50]
