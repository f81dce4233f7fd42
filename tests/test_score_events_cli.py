"""``turn-eval score-events`` (issue 12): stdout, files, exit codes, one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import run_turn_eval as run

REF = """session,subject,start_s,end_s,angle_deg,cohort,scenario,location
s1,P1,0,2,90,PD,scripted,kitchen
s1,P1,10,12,180,PD,scripted,kitchen
s1,P1,20,22,90,PD,free-living,kitchen
s2,P2,0,3,135,HC,scripted,hall
s2,P2,5,6,360,HC,scripted,hall
"""
DET = """session,subject,start_s,end_s,angle_deg,score
s1,P1,0,2,80,0.9
s1,P1,10.5,12,200,0.8
s1,P1,30,31,90,0.7
s2,P2,0.5,3,135,0.3
"""


@pytest.fixture()
def files(tmp_path: Path) -> tuple[Path, Path]:
    (tmp_path / "ref.csv").write_text(REF)
    (tmp_path / "det.csv").write_text(DET)
    return tmp_path / "det.csv", tmp_path / "ref.csv"


def test_json_has_the_keys_the_issue_names(capsys, files):
    det, ref = files
    code, out, _ = run(
        ["score-events", str(det), "-r", str(ref), "--format", "json", "--bootstrap", "50"], capsys
    )
    assert code == 0
    doc = json.loads(out)
    o = doc["overall"]
    assert {"tp", "fp", "fn", "precision", "recall", "f1"} <= set(o)
    assert {"n", "accuracy", "mae_deg", "wprec", "mae_speed_deg_s", "direction_agreement"} <= set(
        o["matched"]
    )
    assert "ap" in o and "ci95" in o
    assert {"tp", "fp", "fn", "precision", "recall", "f1"} <= set(
        doc["by"]["cohort"]["groups"]["PD"]
    )
    assert {"iou", "seed", "resamples", "version"} <= set(doc["settings"])
    assert (o["tp"], o["fp"], o["fn"]) == (3, 1, 2)


def test_markdown_by_default_and_by_takes_a_comma_list(capsys, files):
    det, ref = files
    code, out, err = run(
        ["score-events", str(det), "-r", str(ref), "--by", "cohort,scenario"], capsys
    )
    assert code == 0
    assert "## By cohort" in out and "## By scenario" in out and "## By subject" not in out
    assert "F1 (%) | 66.7" in out
    assert "'unknown' holds false detections" in out
    assert "temporal IoU >= 0.5" in out
    assert err.count("\n") <= 2  # progress only


def test_out_dir_is_written_whole_and_identically(capsys, files, tmp_path):
    det, ref = files
    sessions = tmp_path / "sessions.csv"
    sessions.write_text("session,subject,duration_s\ns1,P1,1800\ns2,P2,3600\n")
    args = ["score-events", str(det), "-r", str(ref), "--sessions", str(sessions)]
    code, _, err = run([*args, "--out-dir", str(tmp_path / "a")], capsys)
    assert code == 0 and "wrote event scores" in err
    code, _, _ = run([*args, "--out-dir", str(tmp_path / "b")], capsys)
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert names == sorted(
        [
            "event_scores.json",
            "event_scores.md",
            "event_scores.csv",
            "event_scores.manifest.json",
            "events.csv",
            "turn_rates.csv",
        ]
    )
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.parametrize(
    ("det_text", "message"),
    [
        (DET.replace("10.5,12", "10.5,10"), "det.csv:3: end_s 10 is not after start_s 10.5"),
        (DET.replace("30,31", "1,3"), "det.csv:4: detections on lines 2 and 4 overlap"),
        (DET.replace("s2,P2,0.5", "s3,P2,0.5"), "det.csv:5: session 's3', subject 'P2' is not"),
        (DET.replace("30,31,90", "30,31,nan"), "det.csv:4: angle_deg is NaN"),
        (DET.replace(",angle_deg", ",angle"), "det.csv:1: the detections file lacks column"),
    ],
)
def test_bad_input_is_one_line_naming_file_and_line(capsys, tmp_path, files, det_text, message):
    _, ref = files
    bad = tmp_path / "det.csv"
    bad.write_text(det_text)
    code, out, err = run(["score-events", str(bad), "-r", str(ref)], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1
    assert message in err


def test_ignore_unknown_warns_and_scores(capsys, tmp_path, files):
    _, ref = files
    bad = tmp_path / "det.csv"
    bad.write_text(DET.replace("s2,P2,0.5", "s3,P2,0.5"))
    code, out, err = run(
        ["score-events", str(bad), "-r", str(ref), "--ignore-unknown", "--format", "json"], capsys
    )
    assert code == 0
    assert json.loads(out)["counts"]["dropped_unknown"] == 1
    assert "warning:" in err and "dropped 1 detection" in err


def test_iou_out_of_range_is_a_usage_error(capsys, files):
    det, ref = files
    code, _, err = run(["score-events", str(det), "-r", str(ref), "--iou", "0"], capsys)
    assert code == 2 and "--iou" in err


def test_plots_are_written_identically_and_removed_by_a_run_without(capsys, files, tmp_path):
    det, ref = files
    args = ["score-events", str(det), "-r", str(ref), "--bootstrap", "20"]
    for name in ("a", "b"):
        code, _, err = run([*args, "--out-dir", str(tmp_path / name), "--plots"], capsys)
        assert code == 0, err
    a, b = tmp_path / "a", tmp_path / "b"
    figures = sorted(str(p.relative_to(a)) for p in a.rglob("*.png"))
    # One timeline per (session, subject), F1 per group, the PR curve (the detections score).
    assert figures == [
        "f1_by_group.png",
        "pr_curve.png",
        "timelines/0000_s1_P1.png",
        "timelines/0001_s2_P2.png",
    ]
    for name in figures:
        assert (a / name).read_bytes() == (b / name).read_bytes()
        assert (a / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, _, err = run([*args, "--out-dir", str(a)], capsys)
    assert code == 0
    assert not list(a.rglob("*.png"))
    assert "removed 4 file(s) of the previous run" in err


def test_plots_need_an_out_dir(capsys, files):
    det, ref = files
    code, _, err = run(["score-events", str(det), "-r", str(ref), "--plots"], capsys)
    assert code == 2 and "--plots needs --out-dir" in err


def test_an_out_dir_that_would_overwrite_an_input_names_out_dir(capsys, tmp_path):
    # the detections file sits where the run would write its events table
    out = tmp_path / "scores"
    out.mkdir()
    (out / "events.csv").write_text(DET)
    (tmp_path / "ref.csv").write_text(REF)
    code, stdout, err = run(
        [
            "score-events",
            str(out / "events.csv"),
            "-r",
            str(tmp_path / "ref.csv"),
            "--out-dir",
            str(out),
        ],
        capsys,
    )
    assert code == 2 and stdout == ""
    assert "choose another --out-dir" in err and len(err.strip().splitlines()) == 1
    assert (out / "events.csv").read_text() == DET
