"""The detector's targets on the synthetic untrimmed sessions, scored by score-events.

One seed of ``benchmarks/eval_detect.py`` (which runs three): 16 participant-sessions of 10
minutes at 30 fps, labels of 90-225°, ``min_turn_deg`` 67.5, IoU 0.5. The targets are the
issue's: F1 >= 0.93 overall and >= 0.90 per cohort, matched accuracy >= 95%, matched MAE
<= 11°, median boundary error <= 0.3 s, on the sessions they were set on (turns at corners
and on the spot); with the movements of real life (quick successions, curved walks,
circling, turns to sit, white depth error), the same targets. Beside them, the miner's
rule run raw on the same streams falls well short of the detector.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from turn_datasets.synthetic.untrimmed import PLAIN_MOVEMENT, ArtefactParams
from turn_eval.detect.rule import split_overlaps

REPO = Path(__file__).resolve().parents[1]
#: Labelled turns of seed 1: plain sessions and with the movements of real life (planted.csv).
N_PLAIN = 427
N_REAL = 503


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
    # the sessions these targets were set on: turns at corners and on the spot, no white
    # depth error (the movements of real life are scored below)
    eval_detect = _eval_detect()
    out = eval_detect.evaluate(
        1,
        tmp_path_factory.mktemp("eval"),
        movement=PLAIN_MOVEMENT,
        artefacts=ArtefactParams(white_depth_sd_mm=0.0),
    )
    return {(r["detector"], r["group"]): r for r in out}


@pytest.fixture(scope="module")
def real_rows(tmp_path_factory) -> dict:
    out = _eval_detect().evaluate(1, tmp_path_factory.mktemp("eval_real"))
    return {(r["detector"], r["group"]): r for r in out}


def test_targets_on_synthetic_untrimmed_sessions(rows) -> None:
    overall = rows[("detect", "overall")]
    assert overall["tp"] + overall["fn"] == N_PLAIN  # every labelled turn of seed 1
    assert overall["F1"] >= 0.93
    for cohort in ("PD", "HC"):
        assert rows[("detect", cohort)]["F1"] >= 0.90
    assert overall["acc"] >= 0.95
    assert overall["MAE"] <= 11.0
    assert max(overall["|dstart| s"], overall["|dend| s"]) <= 0.3


def test_targets_with_the_movements_of_real_life(real_rows) -> None:
    # quick successions, curved walks, circling, turns to sit, white depth error along the
    # ray: every target holds, matched accuracy included (benchmarks/eval_detect.py: 96.5,
    # 98.3 and 95.1% on seeds 1-3)
    overall = real_rows[("detect", "overall")]
    assert overall["tp"] + overall["fn"] == N_REAL
    assert overall["F1"] >= 0.93
    for cohort in ("PD", "HC"):
        assert real_rows[("detect", cohort)]["F1"] >= 0.90
    assert overall["acc"] >= 0.95
    assert overall["MAE"] <= 11.0
    assert max(overall["|dstart| s"], overall["|dend| s"]) <= 0.3


def test_the_raw_rule_without_preprocessing_falls_short_of_detect(rows) -> None:
    # The miner's rule alone (hips, no identity split, no shoulders) reads bystanders,
    # sitting down and depth noise as turns. Since the rule unwraps the hip line and bounds
    # a turn's speed, it no longer reads swaps as turns (its F1 here rose from 0.56 to
    # 0.82), so it is compared with detect on the same streams, not with the hidden
    # sessions' raw figures (precision 0.41, F1 0.57) that the old rule gave.
    raw, full = rows[("raw miner", "overall")], rows[("detect", "overall")]
    assert raw["P"] < 0.85
    assert raw["F1"] < full["F1"] - 0.1
    assert raw["MAE"] > full["MAE"] + 3.0


def test_split_overlaps_by_hand() -> None:
    # [10, 20) and [18, 30) share frames 18 and 19: each keeps one; a clean pair stays
    start, end = split_overlaps(np.array([10, 18, 40]), np.array([20, 30, 50]))
    assert start.tolist() == [10, 19, 40] and end.tolist() == [19, 30, 50]
