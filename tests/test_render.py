"""The presentation rules declared once (turn_datasets.render), and every output following them."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import pandas as pd
import pytest

from turn_datasets.fileio import to_json_text
from turn_datasets.render.labels import METRIC_LABELS
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import fixed, format_metric, one_decimal
from turn_datasets.render.order import natural_key
from turn_eval.clips.submission import read_predictions, read_reference
from turn_eval.clips.tables import build_scores, scores_frame, scores_markdown
from turn_eval.report import Report


@pytest.mark.parametrize(
    ("value", "digits", "text"),
    [
        (6.25, 1, "6.3"),  # exact in binary: Python's ".1f" rounds half to even, "6.2"
        (0.15, 1, "0.2"),  # a hair below 0.15 in binary: ".1f" gives "0.1"
        (2.675, 2, "2.68"),  # "2.67" with ".2f"
        (-0.05, 1, "-0.1"),  # half up means away from zero, as a reader rounds
        (86.25, 1, "86.3"),
        (0.0005, 3, "0.001"),
        (2.0, 2, "2.00"),
        (123.0, 0, "123"),
        (1e300, 1, "1" + "0" * 300 + ".0"),
    ],
)
def test_fixed_rounds_the_printed_decimal_half_up(value, digits, text) -> None:
    assert fixed(value, digits) == text


def test_format_metric_by_kind() -> None:
    assert format_metric("accuracy", 0.0625) == "6.3"  # 6.25 %
    assert format_metric("mae_deg", 6.25) == "6.3"
    assert format_metric("n", 16) == "16" and format_metric("n", 88.25) == "88.3"
    assert format_metric("mae_speed_deg_s", None) == "–"
    assert one_decimal(6.25) == "6.3"
    assert [label.short for label in METRIC_LABELS.values()] == [
        "Acc. (%)",
        "MAE (°)",
        "WPrec (%)",
        "MAE speed (°/s)",
    ]


def test_natural_key_orders_numbers_as_numbers() -> None:
    assert sorted(["S11", "S2", "S1", "S9"], key=natural_key) == ["S1", "S2", "S9", "S11"]
    assert sorted(["135", "22.5", "45", "90"], key=natural_key) == ["22.5", "45", "90", "135"]
    # text by code point, as the clip index and its manifest have always listed subjects,
    # actions and files (upper case first: "WalkTogether" before "Walking"); names equal as
    # numbers are ordered by their exact text
    assert sorted(["Walking", "WalkTogether", "b", "a", "A"], key=natural_key) == [
        "A",
        "WalkTogether",
        "Walking",
        "a",
        "b",
    ]
    assert sorted(["01", "1"], key=natural_key) == ["01", "1"]


def test_markdown_table_escapes_and_aligns() -> None:
    lines = markdown_table(["name", "n"], [["a|b", 3], ["two\nlines", 4]], align="lr")
    assert lines == ["| name | n |", "|---|---:|", "| a\\|b | 3 |", "| two lines | 4 |"]
    assert markdown_table(["x", "y"], [], align="lr", padded_rule=True)[1] == "| --- | ---: |"


def _sixteen_clips(tmp_path: Path):
    """16 clips of 2 s, reference 90°, subjects S1 and S2 alternating. Predicted: 90 (right
    bin), 112.5 (bin 135, error 22.5), then 14 x 135 (error 45).

    By hand: accuracy 1/16 = 6.25 %; MAE (0 + 22.5 + 14 x 45) / 16 = 652.5 / 16 = 40.78125;
    speed MAE (reference and predicted angles over the same 2 s) = 40.78125 / 2 = 20.390625;
    WPrec: all 16 reference clips are in bin 90, whose one prediction is right: 100 %.
    """
    ref = tmp_path / "ref.csv"
    pred = tmp_path / "pred.csv"
    angles = [90.0, 112.5] + [135.0] * 14
    ref.write_text(
        "clip_id,subject,angle_deg,duration_s\n"
        + "".join(f"c{i:02d},S{1 + i % 2},90,2.0\n" for i in range(16)),
        encoding="utf-8",
    )
    pred.write_text(
        "clip_id,angle_deg\n" + "".join(f"c{i:02d},{a}\n" for i, a in enumerate(angles)),
        encoding="utf-8",
    )
    return read_predictions(pred, read_reference(ref))


def test_the_same_scores_print_the_same_digits_everywhere(tmp_path: Path) -> None:
    scores = build_scores(_sixteen_clips(tmp_path), by=["subject"], n_resamples=0)
    overall = scores["overall"]
    # by hand (see _sixteen_clips): 6.25 % right, MAE 40.78125°, speed MAE 20.390625°/s
    assert overall["accuracy"] == pytest.approx(1 / 16)
    assert overall["mae_deg"] == pytest.approx(652.5 / 16)
    # S1 holds the clips 0, 2, ..., 14: errors 0 and 7 x 45 = 315 / 8 = 39.375 -> 39.4;
    # S2 the clips 1, 3, ..., 15: 22.5 + 7 x 45 = 337.5 / 8 = 42.1875 -> 42.2;
    # accuracies 1/8 = 12.5 % and 0 %; Avg. accuracy 6.25 % -> 6.3, Avg. MAE 40.78125 -> 40.8
    groups = scores["by"]["subject"]["groups"]
    assert groups["S1"]["mae_deg"] == pytest.approx(39.375)
    assert groups["S2"]["mae_deg"] == pytest.approx(42.1875)

    # JSON and CSV carry the values themselves; the one rounding rule gives their digits
    doc = json.loads(to_json_text(scores))
    assert doc["overall"]["accuracy"] == 0.0625
    csv = pd.read_csv(io.StringIO(scores_frame(scores).to_csv(index=False)))
    overall_row = csv[csv["grouping"] == "overall"].iloc[0]
    assert overall_row["accuracy"] == 0.0625 and overall_row["mae_deg"] == 40.78125

    md = scores_markdown(scores)
    assert "| Acc. (%) | 6.3 |" in md  # Python's "%.1f" would print 6.2
    assert "| MAE (°) | 40.8 |" in md
    assert "| Acc. (%) | 12.5 | 0.0 | 6.3 |" in md
    assert "| MAE (°) | 39.4 | 42.2 | 40.8 |" in md

    page = tmp_path / "report.html"
    report = Report("r")
    report.section("scores").summary({"run": scores}).scores(scores)
    report.write(page)
    html = page.read_text(encoding="utf-8")
    cells = re.findall(r"<t[dh][^>]*>([^<]*)</t[dh]>", html)
    # the summary row: run, n, accuracy, MAE, WPrec, speed MAE
    i = cells.index("run")
    assert cells[i : i + 6] == ["run", "16", "6.3", "40.8", "100.0", "20.4"]
    # the per-subject table: Acc. row and MAE row as in scores.md
    j = cells.index("Acc. (%)", i + 6)
    assert cells[j : j + 4] == ["Acc. (%)", "12.5", "0.0", "6.3"]
    assert cells[j + 4 : j + 8] == ["MAE (°)", "39.4", "42.2", "40.8"]
    # and every number in the Markdown is the one rule applied to the JSON's value
    assert format_metric("accuracy", doc["overall"]["accuracy"]) == "6.3"
    assert format_metric("mae_deg", overall_row["mae_deg"]) == "40.8"
