"""``score-events`` takes what ``detect`` writes, and its inputs are read within bounds.

- optional detection columns may be empty, and a detections file may hold no rows (a
  detector that found no turn): zero detections score (recall 0, precision undefined, said so).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_detect import stream

from turn_datasets.cli.common import EXIT_BAD_INPUT, run_group
from turn_datasets.synthetic import mocap as sm
from turn_eval.cli import cli
from turn_eval.events.contract import DETECTION_DTYPES

REF = """session,subject,start_s,end_s,angle_deg,cohort
s1,P1,0,2,90,PD
s1,P1,10,12,180,PD
s2,P2,0,3,135,HC
"""


def _run(args: list, capsys) -> tuple[int, str, str]:
    code = run_group(cli, "turn-eval", [str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.fixture()
def ref(tmp_path: Path) -> Path:
    (tmp_path / "ref.csv").write_text(REF)
    return tmp_path / "ref.csv"


def _score(det: Path, ref: Path, capsys, *more) -> tuple[int, dict, str]:
    code, out, err = _run(
        ["score-events", det, "-r", ref, "--bootstrap", "0", "--format", "json", *more], capsys
    )
    return code, (json.loads(out) if code == 0 else {}), err


def test_empty_optional_detection_columns_are_not_given(tmp_path, ref, capsys):
    det = tmp_path / "det.csv"
    det.write_text(
        "session,subject,start_s,end_s,angle_deg,direction,speed_deg_s,score\n"
        "s1,P1,0,2,80,,,\n"
        "s1,P1,10.5,12,200,,,\n"
    )
    code, doc, err = _score(det, ref, capsys)
    assert code == 0, err
    o = doc["overall"]
    # Matched by hand: [0, 2] with [0, 2] (IoU 1), [10.5, 12] with [10, 12] (IoU 0.75).
    assert (o["tp"], o["fp"], o["fn"]) == (2, 0, 1)
    assert o["matched"]["mae_deg"] == pytest.approx((10 + 20) / 2)
    assert "ap" not in o  # an empty score column is no score: nothing to rank
    assert o["matched"]["direction_agreement"] is None


def test_a_score_given_on_some_detections_only_is_refused_naming_the_row(tmp_path, ref, capsys):
    det = tmp_path / "det.csv"
    det.write_text(
        "session,subject,start_s,end_s,angle_deg,score\ns1,P1,0,2,80,0.9\ns1,P1,10.5,12,200,\n"
    )
    code, _, err = _score(det, ref, capsys)
    assert code == EXIT_BAD_INPUT
    assert f"{det}:3: score is empty here but given on other rows" in err


def test_a_header_only_detections_file_scores_recall_zero_precision_undefined(
    tmp_path, ref, capsys
):
    det = tmp_path / "det.csv"
    det.write_text(",".join(DETECTION_DTYPES) + "\n")
    code, doc, err = _score(det, ref, capsys)
    assert code == 0, err
    o = doc["overall"]
    assert (o["tp"], o["fp"], o["fn"]) == (0, 0, 3)
    assert o["recall"] == 0.0 and o["f1"] == 0.0
    assert o["precision"] is None
    assert doc["counts"]["detections"] == 0
    assert "precision is undefined" in err
    code, out, _ = _run(["score-events", det, "-r", ref, "--bootstrap", "0"], capsys)
    assert code == 0
    assert "| Precision (%) | – |" in out and "No detections: recall is 0" in out


def test_what_detect_writes_for_a_still_person_is_scored(tmp_path, ref, capsys):
    # A person standing for 20 s: detect finds no turn and writes a header-only CSV.
    still = stream([sm.Segment.stand(20)])
    np.savez(tmp_path / "s1.npz", P1=still)
    det = tmp_path / "det.csv"
    args = ["detect", tmp_path / "s1.npz", "--layout", "h36m17", "--up-axis", "z"]
    code, _, err = _run([*args, "--fps", "30", "--out", det], capsys)
    assert code == 0, err
    assert pd.read_csv(det).shape[0] == 0
    code, doc, err = _score(det, ref, capsys)
    assert code == 0, err
    assert (doc["overall"]["tp"], doc["overall"]["fn"]) == (0, 3)


def test_what_detect_writes_for_a_detector_without_optional_columns_is_scored(
    tmp_path, ref, capsys
):
    np.savez(tmp_path / "s1.npz", P1=stream([sm.Segment.stand(22)]))
    det = tmp_path / "det.csv"
    args = ["detect", tmp_path / "s1.npz", "--layout", "h36m17", "--up-axis", "z", "--fps", "30"]
    code, _, err = _run(
        [*args, "--detector", "test_detect_cli:HalfwayDetector", "--out", det], capsys
    )
    assert code == 0, err
    written = pd.read_csv(det, keep_default_na=False)
    assert written["score"].tolist() == [""]  # the documented required columns only
    code, doc, err = _score(det, ref, capsys)
    assert code == 0, err
    # The detector's one turn is 10.5-11.5 s: IoU 1/2 with the turn at 10-12 s.
    assert (doc["overall"]["tp"], doc["overall"]["fp"], doc["overall"]["fn"]) == (1, 0, 2)
