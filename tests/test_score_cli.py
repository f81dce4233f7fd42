"""``turn-eval score``: formats, files, exit codes, atomic output, reproducible bytes."""

from __future__ import annotations

import json
import subprocess
import sys
from io import StringIO
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets
from conftest import run_turn_eval as run

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_eval.cli import score as _cli_score
from turn_eval.clips import plots

REPO = Path(__file__).resolve().parents[1]
TURN_EVAL = Path(sys.executable).with_name("turn-eval")

# The four hand-worked clips of test_metrics: accuracy 3/4, MAE 13.125, WPrec 0.625,
# MAE speed 10.208; subjects S1 (2 clips, both right), S9 (right), S11 (wrong).
REFERENCE = (
    "clip_id,subject,action,split,angle_deg,duration_s\n"
    "a,S1,Walking,train,90,1.0\n"
    "b,S1,Walking,train,180,2.0\n"
    "c,S9,Walking,test,45,0.5\n"
    "d,S11,Walking,test,135,1.5\n"
)
PREDICTIONS = "clip_id,angle_deg\na,92.5\nb,170\nc,40\nd,100\n"


@pytest.fixture()
def files(tmp_path: Path) -> tuple[Path, Path]:
    ref = tmp_path / "ref.csv"
    ref.write_text(REFERENCE)
    pred = tmp_path / "pred.csv"
    pred.write_text(PREDICTIONS)
    return pred, ref


def test_json_on_stdout_has_the_hand_worked_numbers(files, capsys):
    pred, ref = files
    code, out, err = run(
        ["score", pred, "--reference", ref, "--format", "json", "--bootstrap", "100"], capsys
    )
    assert code == 0, err
    scores = json.loads(out)
    overall = scores["overall"]
    assert overall["n"] == 4 and overall["accuracy"] == pytest.approx(0.75)
    assert overall["mae_deg"] == pytest.approx(13.125) and overall["wprec"] == pytest.approx(0.625)
    assert overall["mae_speed_deg_s"] == pytest.approx((2.5 + 5 + 10 + 70 / 3) / 4)
    assert list(scores["by"]) == ["subject", "bin_deg", "action", "split"]
    # S1: 2 of 2 right, S9: 1 of 1, S11: 0 of 1 -> avg (1 + 1 + 0) / 3.
    assert scores["by"]["subject"]["avg"]["accuracy"] == pytest.approx(2 / 3)
    assert scores["settings"]["bootstrap"] == 100
    assert "wrote" not in err  # nothing written without --out-dir


def test_markdown_is_the_default_and_csv_parses(files, capsys):
    pred, ref = files
    code, out, _ = run(["score", pred, "-r", ref, "--by", "subject", "--bootstrap", "0"], capsys)
    assert code == 0
    assert "| subject | S1 | S9 | S11 | Avg. |" in out
    assert "| Acc. (%) | 100.0 | 100.0 | 0.0 | 66.7 |" in out
    code, out, _ = run(
        ["score", pred, "-r", ref, "--by", "subject", "--format", "csv", "--bootstrap", "0"], capsys
    )
    frame = pd.read_csv(StringIO(out))
    assert frame["group"].tolist() == ["all", "S1", "S9", "S11", "avg"]


def test_out_dir_writes_everything_and_reruns_are_byte_identical(files, tmp_path, capsys):
    pred, ref = files
    out_dir = tmp_path / "scores"
    args = ["score", pred, "-r", ref, "--out-dir", out_dir, "--plots", "--bootstrap", "200"]
    code, out, err = run(args, capsys)
    assert code == 0, err
    names = sorted(p.name for p in out_dir.iterdir())
    assert names == sorted(
        [
            *_cli_score.SCORE_FILES,
            _cli_score.SCORE_RECORD,
            "confusion_matrix.png",
            "predicted_by_bin.png",
            "abs_error.png",
            "bland_altman.png",
        ]
    )
    for png in out_dir.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((out_dir / "scores.json").read_text())["overall"]["n"] == 4
    assert (out_dir / "scores.md").read_text() == out  # md on stdout too, same text
    assert err.strip().splitlines()[-1].startswith(f"wrote scores {out_dir / 'scores.json'}")
    first = {p.name: p.read_bytes() for p in out_dir.iterdir()}
    assert run(args, capsys)[0] == 0
    assert {p.name: p.read_bytes() for p in out_dir.iterdir()} == first


def test_bad_submission_exits_2_with_one_line_and_writes_nothing(files, tmp_path, capsys):
    pred, ref = files
    pred.write_text("clip_id,angle_deg\na,92.5\nb,NaN\nc,40\nd,100\n")
    out_dir = tmp_path / "scores"
    code, out, err = run(["score", pred, "-r", ref, "--out-dir", out_dir], capsys)
    assert code == EXIT_BAD_INPUT
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"turn-eval: error: {pred}:3: angle_deg is NaN")
    assert not out_dir.exists()


def test_missing_clips_exit_2_unless_allowed(files, capsys):
    pred, ref = files
    pred.write_text("clip_id,angle_deg\na,92.5\nc,40\n")
    code, _, err = run(["score", pred, "-r", ref], capsys)
    assert code == EXIT_BAD_INPUT and "2 of the reference's 4 clips are missing" in err
    code, out, err = run(
        ["score", pred, "-r", ref, "--allow-missing", "--format", "json", "--bootstrap", "0"],
        capsys,
    )
    assert code == 0
    scores = json.loads(out)
    assert scores["n_missing"] == 2 and scores["overall"]["n"] == 2
    assert "warning:" in err and "'b', 'd'" in err


def test_negative_angles_hint_and_abs(files, capsys):
    pred, ref = files
    pred.write_text(PREDICTIONS.replace("170", "-170"))
    code, _, err = run(["score", pred, "-r", ref], capsys)
    assert code == EXIT_BAD_INPUT and "--abs" in err and f"{pred}:3" in err
    code, out, _ = run(
        ["score", pred, "-r", ref, "--abs", "--format", "json", "--bootstrap", "0"], capsys
    )
    assert code == 0 and json.loads(out)["overall"]["accuracy"] == pytest.approx(0.75)


def test_radians_warning_still_scores(files, capsys):
    pred, ref = files
    pred.write_text("clip_id,angle_deg\na,1.5708\nb,3.1416\nc,0.7854\nd,2.3562\n")
    code, out, err = run(["score", pred, "-r", ref, "--format", "json", "--bootstrap", "0"], capsys)
    assert code == 0 and "radians" in err
    assert json.loads(out)["overall"]["accuracy"] == 0.0


def test_usage_errors_exit_2(files, tmp_path, capsys):
    pred, ref = files
    code, _, err = run(["score", pred, "-r", ref, "--plots"], capsys)
    assert code == EXIT_BAD_INPUT and "--plots needs --out-dir" in err
    code, _, err = run(["score", pred, "-r", ref, "--by", "cohort"], capsys)
    assert code == EXIT_BAD_INPUT and "no such group column" in err
    code, _, _ = run(["score", pred, "-r", ref, "--bootstrap", "-1"], capsys)
    assert code == EXIT_BAD_INPUT


def test_never_writes_over_an_input(files, tmp_path, capsys):
    pred, _ = files
    out_dir = tmp_path / "here"
    out_dir.mkdir()
    ref = out_dir / "scores.csv"  # the reference sits where scores.csv would go
    ref.write_text(REFERENCE)
    code, _, err = run(["score", pred, "-r", ref, "--out-dir", out_dir], capsys)
    assert code == EXIT_BAD_INPUT and "overwrite" in err
    assert ref.read_text() == REFERENCE
    assert sorted(p.name for p in out_dir.iterdir()) == ["scores.csv"]


def test_a_failure_while_writing_leaves_no_partial_output(files, tmp_path, capsys, monkeypatch):
    pred, ref = files
    out_dir = tmp_path / "scores"

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(plots, "write_plots", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        run(["score", pred, "-r", ref, "--out-dir", out_dir, "--plots", "--bootstrap", "0"], capsys)
    # scores.json was written to the staging folder first; none of it reached out_dir.
    assert not out_dir.exists() or list(out_dir.iterdir()) == []
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_plot_names_agree():
    assert _cli_score.PLOT_FILES == plots.PLOT_FILES


def test_help_has_an_example(capsys):
    code, out, _ = run(["score", "--help"], capsys)
    assert code == 0 and "Example:" in out and "turn-eval score predictions.csv" in out


def test_console_script_exit_codes(files):
    pred, ref = files
    ok = subprocess.run(
        [TURN_EVAL, "score", pred, "-r", ref, "--bootstrap", "0"],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert ok.returncode == 0 and ok.stdout.startswith("## Overall")
    bad = subprocess.run(
        [TURN_EVAL, "score", pred, "-r", ref.with_name("nope.csv")],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert bad.returncode == 2
    assert (
        bad.stderr.strip() == f"turn-eval: error: {ref.with_name('nope.csv')}: "
        "reference file not found"
    )


def test_a_real_clip_index_scores_as_it_is(cmu_dir, tmp_path, capsys):
    # Turn-H3.6M's clip index format, mined from the real CMU captures in ../shared/data.
    index = tmp_path / "cmu.csv"
    bvh = sorted(str(p) for p in cmu_dir.glob("*.bvh"))
    code, _, err = run_turn_datasets(
        ["h36m", "mine", *bvh, "--skip-first-frame", "--out", index], capsys
    )
    assert code == 0, err
    clips = pd.read_csv(index)
    assert len(clips) >= 1
    # A submission off by known amounts: +10, +30, -50, +10, ... degrees.
    offsets = [(10.0, 30.0, -50.0)[i % 3] for i in range(len(clips))]
    predicted = clips["angle_deg"] + offsets
    pred = tmp_path / "pred.csv"
    pd.DataFrame({"clip_id": clips["clip_id"], "angle_deg": predicted}).to_csv(pred, index=False)
    code, out, err = run(
        ["score", pred, "-r", index, "--format", "json", "--bootstrap", "50"], capsys
    )
    assert code == 0, err
    overall = json.loads(out)["overall"]

    def bin_of(a):  # DESIGN.md: nearest multiple of 45, halves up
        return 45 * np.floor(np.asarray(a) / 45 + 0.5)

    assert overall["n"] == len(clips)
    assert overall["mae_deg"] == pytest.approx(np.mean(np.abs(offsets)))
    assert overall["accuracy"] == pytest.approx(
        np.mean(bin_of(predicted) == bin_of(clips["angle_deg"]))
    )
    # Equation 4 with the reference duration: |offset| / duration per clip.
    assert overall["mae_speed_deg_s"] == pytest.approx(
        np.mean(np.abs(offsets) / clips["duration_s"])
    )


def test_plots_of_one_clip_are_drawn_and_reproducible(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    written = plots.write_plots([90.0], [92.0], first)
    plots.write_plots([90.0], [92.0], second)
    assert [p.name for p in written] == list(plots.PLOT_FILES)
    for name in plots.PLOT_FILES:
        data = (first / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and b"Software" not in data
        assert data == (second / name).read_bytes()


def test_bin_width_option(files, capsys):
    pred, ref = files
    code, out, _ = run(
        ["score", pred, "-r", ref, "--bin-width-deg", "90", "--format", "json", "--bootstrap", "0"],
        capsys,
    )
    assert code == 0
    scores = json.loads(out)
    # 90-degree bins: ref 90, 180, 45, 135 -> 90, 180, 90, 180; pred 92.5, 170, 40, 100 ->
    # 90, 180, 0, 90: two of four right.
    assert scores["overall"]["accuracy"] == pytest.approx(0.5)
    assert scores["settings"]["bin_width_deg"] == 90
    assert list(scores["by"]["bin_deg"]["groups"]) == ["90", "180"]


def test_plots_of_a_submission_in_the_wrong_unit_stay_bounded(tmp_path):
    # Centidegrees: 300 clips spread over ~200 bins. The confusion matrix merges runs of
    # bins into at most 40 rows and columns, and no figure grows past 14 inches (plus the
    # colour bar's 1.2) at 110 dpi: 15.2 * 110 = 1672 pixels.
    rng = np.random.default_rng(0)
    ref = rng.uniform(45, 360, 300)
    written = plots.write_plots(ref * 100, ref, tmp_path)
    for path in written:
        data = path.read_bytes()
        width = int.from_bytes(data[16:20], "big")  # PNG IHDR: width, then height
        height = int.from_bytes(data[20:24], "big")
        assert width <= 1672 and height <= 1672, (path.name, width, height)


def test_out_dir_that_is_a_file_or_under_one_is_one_line_exit_2(files, capsys):
    pred, ref = files
    for out_dir, expected in (
        (ref, "--out-dir is a file, not a folder"),
        (ref / "sub", f"cannot write the scores: {ref}: File exists"),
    ):
        code, out, err = run(
            ["score", pred, "-r", ref, "--bootstrap", "0", "--out-dir", out_dir], capsys
        )
        assert code == EXIT_BAD_INPUT and out == "", out_dir
        assert err == f"turn-eval: error: {out_dir}: {expected}\n"
    assert ref.read_text() == REFERENCE
    assert sorted(p.name for p in ref.parent.iterdir()) == ["pred.csv", "ref.csv"]


def test_json_without_durations_has_null_speed_everywhere(files, capsys):
    # DESIGN.md: mae_speed_deg_s is null where the reference has no durations, in the
    # overall entry, every group, every avg and every interval; fractions stay fractions.
    pred, ref = files
    ref.write_text("clip_id,subject,angle_deg\na,S1,90\nb,S1,180\nc,S9,45\nd,S11,135\n")
    code, out, err = run(
        ["score", pred, "-r", ref, "--format", "json", "--bootstrap", "20"], capsys
    )
    assert code == 0, err
    scores = json.loads(out)
    assert list(scores) == ["overall", "by", "n_missing", "settings", "signature"]
    entries = [scores["overall"]]
    for block in scores["by"].values():
        assert list(block) == ["groups", "avg"]
        entries += [*block["groups"].values(), block["avg"]]
    for entry in entries:
        assert entry["mae_speed_deg_s"] is None and entry["ci95"]["mae_speed_deg_s"] is None
        assert 0.0 <= entry["accuracy"] <= 1.0 and 0.0 <= entry["wprec"] <= 1.0
    assert "MAE speed" not in run(["score", pred, "-r", ref, "--bootstrap", "0"], capsys)[1]
