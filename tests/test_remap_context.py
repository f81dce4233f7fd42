"""``remap labels`` writes context.csv and sessions.csv (issue 12), and score-events reads them:
values worked out by hand from the ELAN files built here."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
from _eaf_builder import Tier, write_eaf
from conftest import run_turn_datasets, run_turn_eval

from turn_datasets.cli.common import EXIT_OK
from turn_datasets.remap.context import (
    CONTEXT_COLUMNS,
    SESSIONS_COLUMNS,
    context_table,
    sessions_table,
)
from turn_datasets.remap.eaf import FileContext, _Context

HEADER = "subject,cohort,pair,sex,age,years_since_diagnosis\n"


def _eaf_dir(tmp_path: Path) -> Path:
    d = tmp_path / "eaf"
    d.mkdir()
    write_eaf(
        d / "S01.eaf",
        [
            Tier(
                "Turn alice",
                annotator="alice",
                participant="PD01",
                annotations=[(1000, 2000, "90"), (5000, 6000, "180"), (12000, 13000, "90")],
            ),
            Tier(
                "Turn alice HC",
                annotator="alice",
                participant="HC01",
                annotations=[(3000, 4500, "270")],
            ),
            # Shared: scripted 0-8 s then free living 8-20 s; the kitchen 0-20 s.
            Tier("Scenario", annotations=[(0, 8000, "scripted"), (8000, 20000, "free living")]),
            Tier("Location", annotations=[(0, 20000, "Kitchen")]),
            # PD01's own location tier: the lounge from 10 to 15 s.
            Tier("Location PD01", participant="PD01", annotations=[(10000, 15000, "Lounge")]),
        ],
    )
    # A session without context tiers: its duration is the last time slot.
    write_eaf(
        d / "S02.eaf",
        [Tier("Turn bob", annotator="bob", participant="PD02", annotations=[(500, 1500, "90")])],
    )
    return d


def _labels(capsys, tmp_path: Path) -> Path:
    participants = tmp_path / "participants.csv"
    participants.write_text(HEADER + "PD01,PD,a,F,60,4\nHC01,HC,a,M,64,\nPD02,PD,b,M,70,10\n")
    out = tmp_path / "labels" / "labels.csv"
    code, _, err = run_turn_datasets(
        ["remap", "labels", _eaf_dir(tmp_path), "--participants", participants, "--out", out],
        capsys,
    )
    assert code == EXIT_OK, err
    assert "context.csv" in err and "sessions.csv" in err
    return out


def test_labels_writes_context_and_sessions_beside_the_labels(capsys, tmp_path: Path):
    out = _labels(capsys, tmp_path)
    context = pd.read_csv(out.parent / "context.csv", keep_default_na=False)
    assert context.columns.tolist() == list(CONTEXT_COLUMNS)
    rows = [tuple(r) for r in context.itertuples(index=False)]
    # HC01 sees the shared tiers only; PD01 its own lounge from 10 to 15 s.
    assert rows == [
        ("S01", "HC01", 0.0, 8.0, "scripted", "kitchen"),
        ("S01", "HC01", 8.0, 20.0, "free-living", "kitchen"),
        ("S01", "PD01", 0.0, 8.0, "scripted", "kitchen"),
        ("S01", "PD01", 8.0, 10.0, "free-living", "kitchen"),
        ("S01", "PD01", 10.0, 15.0, "free-living", "living room"),
        ("S01", "PD01", 15.0, 20.0, "free-living", "kitchen"),
    ]
    sessions = pd.read_csv(out.parent / "sessions.csv")
    assert sessions.columns.tolist() == list(SESSIONS_COLUMNS)
    assert [tuple(r) for r in sessions.itertuples(index=False)] == [
        ("S01", "HC01", 20.0),
        ("S01", "PD01", 20.0),
        ("S02", "PD02", 1.5),
    ]


def test_context_pieces_take_own_tiers_first_and_merge_equal_neighbours():
    shared = _Context("", 0, 4000, "scripted")
    file = FileContext(
        session="s",
        participants=("P",),
        contexts={
            "scenario": [
                shared,
                _Context("", 4000, 6000, "scripted"),
                _Context("P", 5000, 7000, "clinical"),
            ],
            "location": [_Context("", 8000, 9000, "hall")],
        },
        last_time_ms=10000,
    )
    rows = [tuple(r) for r in context_table([file]).itertuples(index=False)]
    # 0-4 and 4-5 s are both scripted (merged); 5-7 s the participant's own clinical; 7-8 s
    # has no context (left out); 8-9 s only a location.
    assert rows == [
        ("s", "P", 0.0, 5.0, "scripted", ""),
        ("s", "P", 5.0, 7.0, "clinical", ""),
        ("s", "P", 8.0, 9.0, "", "hall"),
    ]
    # The annotated extent: 0 to 9 s.
    assert sessions_table([file])["duration_s"].tolist() == [9.0]


def test_score_events_on_perturbed_labels(capsys, tmp_path: Path):
    """The labels as a detector would report them: boundaries moved, one turn missed, one
    false turn in PD01's lounge, angles off; every number below worked out by hand."""
    out = _labels(capsys, tmp_path)
    labels = pd.read_csv(out, keep_default_na=False)
    det = labels.loc[:, ["session", "subject", "start_s", "end_s", "angle_deg"]].copy()
    # Turns in label order: S01 HC01 3-4.5 (270); S01 PD01 1-2 (90), 5-6 (180), 12-13 (90);
    # S02 PD02 0.5-1.5 (90).
    det["start_s"] = det["start_s"] + [0.25, 0.0, 0.5, 0.0, 0.0]
    det["angle_deg"] = [260.0, 100.0, 180.0, 90.0, 135.0]
    det = det.drop(index=3)  # PD01's 12-13 s turn is missed
    false = {"session": "S01", "subject": "PD01", "start_s": 13.5, "end_s": 14.5, "angle_deg": 45.0}
    det = pd.concat([det, pd.DataFrame([false])], ignore_index=True)
    path = tmp_path / "detections.csv"
    det.to_csv(path, index=False)
    args = ["score-events", str(path), "-r", str(out), "--format", "json"]
    args += ["--context", str(out.parent / "context.csv")]
    args += ["--sessions", str(out.parent / "sessions.csv"), "--bootstrap", "0"]
    code, stdout, err = run_turn_eval(args, capsys)
    assert code == 0, err
    doc = json.loads(stdout)
    o = doc["overall"]
    # IoUs: HC01 [3.25, 4.5] vs [3, 4.5] 1.25/1.5; PD01 [1, 2] exact; [5.5, 6] vs [5, 6] 0.5
    # (at the threshold: a match); PD02 exact. 4 TP, the false turn an FP, 12-13 s an FN.
    assert (o["tp"], o["fp"], o["fn"]) == (4, 1, 1)
    assert o["precision"] == 0.8 and o["recall"] == 0.8
    m = o["matched"]
    # Errors 10, 10, 0, 45: MAE 16.25; bins 270/270, 90/90, 180/180, 90/135: accuracy 3/4.
    assert m["mae_deg"] == 16.25 and m["accuracy"] == 0.75
    # |dstart| 0.25, 0, 0.5, 0 -> median 0.125.
    assert m["median_abs_dstart_s"] == 0.125
    # The false turn's midpoint, 14 s, is in PD01's lounge, free-living.
    assert doc["by"]["location"]["groups"]["living room"]["fp"] == 1
    assert doc["by"]["scenario"]["groups"]["free-living"]["fp"] == 1
    assert "unknown" not in doc["by"]["location"]["groups"]
    # Turns per hour: S01 HC01 1 and 1 in 20 s (180/h each); PD01 3 and 3 (540); S02 PD02
    # 1 and 1 in 1.5 s (2400): every difference 0.
    rates = o["turns_per_hour"]
    assert rates["mean_abs_difference_per_hour"] == 0.0
    assert rates["reference_per_hour_mean"] == (180 + 540 + 2400) / 3
