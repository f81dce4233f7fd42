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
from conftest import run_turn_eval as _run
from test_detect import WALK_TURN_WALK, stream

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.synthetic import mocap as sm
from turn_eval.events.contract import DETECTION_DTYPES

REF = """session,subject,start_s,end_s,angle_deg,cohort
s1,P1,0,2,90,PD
s1,P1,10,12,180,PD
s2,P2,0,3,135,HC
"""


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


def _chain(n: int) -> tuple[pd.DataFrame, pd.DataFrame, np.ndarray]:
    """``n`` reference turns [2k, 2k + 2] and ``n`` detections [2k + 1, 2k + 3] of one unit:
    each detection overlaps two turns by 1 s (IoU 1/3), so at --iou 0.3 every pair is
    eligible and all 2n intervals are one connected component."""
    k = np.arange(n, dtype=np.float64)
    ref = pd.DataFrame({"start_s": 2 * k, "end_s": 2 * k + 2})
    det = pd.DataFrame({"start_s": 2 * k + 1, "end_s": 2 * k + 3})
    return det, ref, np.zeros(n, dtype=np.int64)


def test_matching_memory_grows_with_the_pairs_not_rows_times_columns():
    import tracemalloc

    from turn_eval.events.matching import categorize_events

    n = 4000  # a dense n x n weight matrix and its pair index: 256 MB
    det, ref, unit = _chain(n)
    tracemalloc.start()
    try:
        events = categorize_events(det, unit, ref, unit, iou=0.3)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # Every detection matched (d_k with r_k, or with r_k+1 for all k: n pairs either way).
    assert (events["kind"] == "TP").sum() == n
    assert events.loc[events["kind"] == "TP", "iou"].sum() == pytest.approx(n / 3)
    assert peak < 32e6, f"{peak / 1e6:.0f} MB"


def test_sparse_matching_equals_a_dense_assignment_on_a_long_component():
    # scipy's dense Hungarian solver on the same weights, as the rule states them: the same
    # number of pairs and the same total IoU (ties may pick other pairs).
    from scipy.optimize import linear_sum_assignment

    from turn_eval.events.matching import categorize_events, eligible_pairs, overlapping_pairs

    rng = np.random.default_rng(5)
    n = 300
    ref_start = np.cumsum(rng.uniform(0.1, 2.0, n) + 1.0)
    ref = pd.DataFrame({"start_s": ref_start, "end_s": ref_start + rng.uniform(0.5, 1.0, n)})
    det_start = np.sort(ref_start + rng.uniform(-1.0, 1.0, n))
    det_end = np.minimum(det_start + rng.uniform(0.3, 1.5, n), np.append(det_start[1:], np.inf))
    det = pd.DataFrame({"start_s": det_start, "end_s": det_end})
    unit = np.zeros(n, dtype=np.int64)
    for iou in (0.1, 0.3, 0.5):
        pairs = eligible_pairs(overlapping_pairs(det, unit, ref, unit), iou=iou)
        weight = np.zeros((n, n))
        weight[pairs["det_row"], pairs["ref_row"]] = n + 1.0 + pairs["iou"].to_numpy()
        a, b = linear_sum_assignment(weight, maximize=True)
        chosen = weight[a, b] > 0
        events = categorize_events(det, unit, ref, unit, iou=iou)
        tp = events[events["kind"] == "TP"]
        assert tp.shape[0] == chosen.sum()
        assert tp["iou"].sum() == pytest.approx((weight[a, b][chosen] - n - 1.0).sum(), abs=1e-9)


@pytest.mark.parametrize("duration", ["1", "1e-9"])
def test_turns_longer_than_their_sessions_duration_are_refused_before_any_work(
    tmp_path, ref, capsys, duration
):
    # Turns of 2 s in a session said to last 1 s (or 1e-9 s) gave thousands (or 1e14) of
    # turns per hour, after the bootstrap.
    det = tmp_path / "det.csv"
    det.write_text("session,subject,start_s,end_s,angle_deg\ns1,P1,0,2,80\n")
    sessions = tmp_path / "sessions.csv"
    sessions.write_text(f"session,subject,duration_s\ns1,P1,{duration}\ns2,P2,3600\n")
    args = ["score-events", det, "-r", ref, "--sessions", sessions, "--bootstrap", "200"]
    code, out, err = _run(args, capsys)
    assert code == EXIT_BAD_INPUT and out == ""
    assert (
        f"{ref}:2: the turns of session 's1', subject 'P1' up to this one last 2 s, longer "
        f"than its annotated duration_s in {sessions}, {float(duration):g} s (1 more row like it)"
    ) in err
    assert "bootstrap" not in err  # refused before the resampling started


def test_detections_longer_than_their_sessions_duration_are_refused(tmp_path, ref, capsys):
    det = tmp_path / "det.csv"
    det.write_text("session,subject,start_s,end_s,angle_deg\ns1,P1,0,2,80\ns2,P2,4,14.5,80\n")
    sessions = tmp_path / "sessions.csv"
    # duration_s is how long was annotated, not where the time line ends: the reference's
    # turns (4 s and 3 s in all) fit, wherever they lie; a detection may end a little past
    # the duration (far past it is a unit mistake, refused as such: test_new_user).
    sessions.write_text("session,subject,duration_s\ns1,P1,12\ns2,P2,10\n")
    code, _, err = _run(["score-events", det, "-r", ref, "--sessions", sessions], capsys)
    assert code == EXIT_BAD_INPUT
    assert f"{det}:3: the turns of session 's2', subject 'P2' up to this one last 10.5 s" in err
    # Within a millisecond (ELAN's resolution) of the duration is not longer than it.
    det.write_text("session,subject,start_s,end_s,angle_deg\ns2,P2,4,14.001,80\n")
    code, out, err = _run(
        ["score-events", det, "-r", ref, "--sessions", sessions, "--format", "json"], capsys
    )
    assert code == 0, err
    rates = json.loads(out)["overall"]["turns_per_hour"]
    # Reference: 2 turns in 12 s (600/h) and 1 in 10 s (360/h); detected: 0 and 1.
    assert rates["reference_per_hour_mean"] == pytest.approx((600 + 360) / 2)
    assert rates["detected_per_hour_mean"] == pytest.approx((0 + 360) / 2)


def _stray_quote(path: Path, header: str, row: str, n: int, *, at: int = 3) -> int:
    """A CSV of ``n`` rows (``row`` formatted with the row number) over 128 KiB, with a
    quote opened and never closed in row ``at``; returns that row's line number."""
    rows = [row.format(i=i, t=2 * i) for i in range(n)]
    rows[at] = rows[at].replace(",", ',"', 1)
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    assert path.stat().st_size > 131072
    return at + 2


def _field_limit_line(code: int, out: str, err: str, path: Path, line: int) -> None:
    assert code == EXIT_BAD_INPUT and out == "", err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{path}:{line}: a field runs on past 131,072 characters from this line" in err


def test_a_stray_quote_in_a_large_predictions_file_is_one_line(tmp_path, capsys):
    ref = tmp_path / "ref.csv"
    ref.write_text("clip_id,angle_deg\n" + "".join(f"c{i:06d},90\n" for i in range(12000)))
    pred = tmp_path / "pred.csv"
    line = _stray_quote(pred, "clip_id,angle_deg", "c{i:06d},92", 12000)
    _field_limit_line(*_run(["score", pred, "-r", ref], capsys), pred, line)
    _field_limit_line(*_run(["compare", ref, pred, "--reference", ref], capsys), pred, line)
    _field_limit_line(*_run(["score", ref, "-r", pred], capsys), pred, line)


@pytest.mark.parametrize("which", ["detections", "reference", "context", "sessions"])
def test_a_stray_quote_in_any_score_events_file_is_one_line(tmp_path, capsys, which):
    n = 9000
    files = {
        "detections": ("session,subject,start_s,end_s,angle_deg", "s1,P1,{t},{t}.5,90"),
        "reference": ("session,subject,start_s,end_s,angle_deg", "s1,P1,{t},{t}.5,90"),
        "context": ("session,subject,start_s,end_s,scenario,location", "s1,P1,{t},{t}.5,x,y"),
        "sessions": ("session,subject,duration_s", "s{i},P1,100000"),
    }
    paths = {}
    line = 0
    for name, (header, row) in files.items():
        paths[name] = tmp_path / f"{name}.csv"
        if name == which:
            line = _stray_quote(paths[name], header, row, n)
        else:
            paths[name].write_text(header + "\n" + row.format(i=1, t=2) + "\n")
    args = ["score-events", paths["detections"], "-r", paths["reference"]]
    args += ["--context", paths["context"], "--sessions", paths["sessions"]]
    _field_limit_line(*_run(args, capsys), paths[which], line)


def test_a_symlinked_alias_keeps_the_real_files_session_and_a_dangling_link_is_named(
    tmp_path, capsys
):
    folder = tmp_path / "streams"
    folder.mkdir()
    np.savez(folder / "pair01_day1.npz", P1=stream(WALK_TURN_WALK))
    (folder / "alias.npz").symlink_to("pair01_day1.npz")  # sorts before the real file
    (folder / "x.npz").symlink_to("gone.npz")
    out = tmp_path / "det.csv"
    args = ["detect", folder, "--layout", "h36m17", "--up-axis", "z", "--fps", "30"]
    code, _, err = _run([*args, "--out", out], capsys)
    assert code == 0, err
    detections = pd.read_csv(out)
    assert detections.shape[0] == 1  # the walk-turn-walk's one turn, read once
    assert detections["session"].tolist() == ["pair01_day1"]
    assert f"skipped {folder / 'alias.npz'}: the same file as {folder / 'pair01_day1.npz'}" in err
    assert f"skipped {folder / 'x.npz'}: a symbolic link to gone.npz, which does not exist" in err


def _plots(tmp_path: Path, rows: list[tuple[str, str]], capsys):
    import warnings

    ref = tmp_path / "ref.csv"
    ref.write_text(
        "session,subject,start_s,end_s,angle_deg\n" + "".join(f"{s},{p},0,2,90\n" for s, p in rows)
    )
    out = tmp_path / "ev"
    args = ["score-events", ref, "-r", ref, "--bootstrap", "0", "--out-dir", out, "--plots"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, _, err = _run(args, capsys)
    assert code == 0, err
    return out, err, [str(w.message) for w in caught]


def test_timelines_of_long_session_names_get_short_unique_file_names(tmp_path, capsys):
    long_a, long_b = "S" * 299 + "a", "S" * 299 + "b"
    out, _, _ = _plots(tmp_path, [(long_a, "P1"), (long_b, "P1")], capsys)
    names = sorted(p.name for p in (out / "timelines").iterdir())
    assert len(names) == 2 and all(len(n) <= 124 for n in names)
    assert names[0].startswith("0000_SSSS") and names[1].startswith("0001_SSSS")
    assert names[0][-17:-4] != names[1][-17:-4]  # the hashes of the full names differ


def test_names_the_font_cannot_draw_are_one_line_of_ours_not_matplotlibs(tmp_path, capsys):
    out, err, caught = _plots(tmp_path, [("会话一", "受试者")], capsys)
    assert [m for m in caught if "Glyph" in m] == []
    assert len(list((out / "timelines").iterdir())) == 1
    font_lines = [line for line in err.splitlines() if "cannot draw" in line]
    assert len(font_lines) <= 1  # one line of ours (none where the font has the glyphs)
    if font_lines:
        assert font_lines[0].startswith("warning: the figures' font")
        assert "会话一受试者" in font_lines[0]


def test_a_name_a_spreadsheet_takes_for_a_formula_is_written_verbatim_and_scores(tmp_path, capsys):
    # The decision on formula injection: names are data, written as they are (an apostrophe
    # would make the session differ from the reference's, and score-events refuse it).
    np.savez(tmp_path / "=1+1.npz", **{"@P1": stream(WALK_TURN_WALK)})
    det = tmp_path / "det.csv"
    args = ["detect", tmp_path / "=1+1.npz", "--layout", "h36m17", "--up-axis", "z"]
    code, _, err = _run([*args, "--fps", "30", "--out", det], capsys)
    assert code == 0, err
    line = det.read_text().splitlines()[1]
    assert line.startswith("=1+1,@P1,")
    ref = tmp_path / "ref.csv"
    start, end = line.split(",")[2:4]
    ref.write_text(f"session,subject,start_s,end_s,angle_deg\n=1+1,@P1,{start},{end},90\n")
    code, doc, err = _score(det, ref, capsys)
    assert code == 0, err
    assert doc["overall"]["tp"] == 1
