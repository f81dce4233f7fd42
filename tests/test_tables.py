"""The scores document, its group averages and its Markdown and CSV tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_eval.clips.metrics import METRICS
from turn_eval.clips.submission import read_predictions, read_reference
from turn_eval.clips.tables import SCORES_CSV_COLUMNS, build_scores, scores_frame, scores_markdown


def table4a_files(tmp_path: Path) -> tuple[Path, Path]:
    """Three scenarios whose accuracies are exactly the paper's Table 4a: 37.6, 26.5, 44.0 %.

    376 of 1000, 53 of 200 and 44 of 100 clips right; every reference angle is 90 and a wrong
    prediction is 180 (error 90°), so a group's MAE is 90 x (1 - accuracy).
    """
    rows, preds = [], []
    for scenario, n, right in [
        ("clinical", 1000, 376),
        ("free-living", 200, 53),
        ("scripted", 100, 44),
    ]:
        for i in range(n):
            clip = f"{scenario}_{i:04d}"
            rows.append(f"{clip},{scenario},90,3.0")
            preds.append(f"{clip},{90 if i < right else 180}")
    ref = tmp_path / "labels.csv"
    ref.write_text("clip_id,scenario,angle_deg,duration_s\n" + "\n".join(rows) + "\n")
    pred = tmp_path / "pred.csv"
    pred.write_text("clip_id,angle_deg\n" + "\n".join(preds) + "\n")
    return ref, pred


@pytest.fixture()
def table4a(tmp_path):
    ref, pred = table4a_files(tmp_path)
    return read_predictions(pred, read_reference(ref))


def test_avg_is_the_papers_unweighted_mean(table4a):
    scores = build_scores(table4a, by=["scenario"], n_resamples=0)
    block = scores["by"]["scenario"]
    assert list(block["groups"]) == ["clinical", "free-living", "scripted"]
    assert [g["accuracy"] for g in block["groups"].values()] == pytest.approx([0.376, 0.265, 0.44])
    # Table 4a: (37.6 + 26.5 + 44.0) / 3 = 36.03 -> "36.0"; pooled it would be 473/1300 = 36.4.
    assert block["avg"]["accuracy"] == pytest.approx((0.376 + 0.265 + 0.44) / 3)
    assert scores["overall"]["accuracy"] == pytest.approx(473 / 1300)
    assert block["avg"]["n"] == pytest.approx(1300 / 3)
    assert block["avg"]["mae_deg"] == pytest.approx(90 * (1 - (0.376 + 0.265 + 0.44) / 3))
    md = scores_markdown(scores)
    assert "| scenario | clinical | free-living | scripted | Avg. |" in md
    assert "| Acc. (%) | 37.6 | 26.5 | 44.0 | 36.0 |" in md
    assert "| # Turns | 1000 | 200 | 100 | 433.3 |" in md
    # MAE 90 x (1 - 0.376) = 56.16 -> 56.2, 66.15 -> 66.2 (half up), 50.4; avg 57.57 -> 57.6.
    assert "| MAE (°) | 56.2 | 66.2 | 50.4 | 57.6 |" in md


def test_markdown_rows_in_the_papers_order(table4a):
    md = scores_markdown(build_scores(table4a, by=["scenario"], n_resamples=0))
    section = md.split("## By scenario")[1].split("\n\n")[1].splitlines()
    assert [line.split(" | ")[0] for line in section] == [
        "| scenario",
        "| ---",
        "| Acc. (%)",
        "| MAE (°)",
        "| WPrec (%)",
        "| MAE speed (°/s)",
        "| # Turns",
    ]
    assert section[1] == "| --- | ---: | ---: | ---: | ---: |"


def test_json_document_shape(table4a):
    scores = build_scores(table4a, n_resamples=50, seed=3)
    assert list(scores) == ["overall", "by", "n_missing", "settings"]
    overall = scores["overall"]
    for key in ("n", *METRICS, "ci95", "per_bin", "kappa"):
        assert key in overall
    assert set(overall["ci95"]) == set(METRICS)
    low, high = overall["ci95"]["accuracy"]
    assert low <= overall["accuracy"] <= high
    # Default groupings: the reference has scenario; bin_deg every reference has.
    assert list(scores["by"]) == ["scenario", "bin_deg"]
    assert list(scores["by"]["bin_deg"]["groups"]) == ["90"]
    group = scores["by"]["scenario"]["groups"]["clinical"]
    assert group["n"] == 1000 and set(group["ci95"]) == set(METRICS)
    assert scores["settings"] == {
        "bin_width_deg": 45,
        "bootstrap": 50,
        "seed": 3,
        "confidence": 0.95,
        "ci_method": "percentile",
        "kappa_weights": "quadratic",
        "version": __version__,
    }
    assert scores["n_missing"] == 0


def test_avg_interval_matches_scipy_on_the_mean_of_group_accuracies(table4a):
    n_resamples, seed = 200, 1
    scores = build_scores(table4a, by=["scenario"], n_resamples=n_resamples, seed=seed)
    t = table4a.table
    correct = (t["pred_angle_deg"] == t["ref_angle_deg"]).to_numpy().astype(float)
    group = t["scenario"].map({"clinical": 0, "free-living": 1, "scripted": 2}).to_numpy()

    def mean_of_group_accuracies(c, g, axis=-1):
        return np.mean(
            [np.sum(c * (g == k), axis=axis) / np.sum(g == k, axis=axis) for k in range(3)],
            axis=0,
        )

    res = stats.bootstrap(
        (correct, group),
        mean_of_group_accuracies,
        paired=True,
        vectorized=True,
        n_resamples=n_resamples,
        method="percentile",
        rng=seed,
    )
    assert scores["by"]["scenario"]["avg"]["ci95"]["accuracy"] == pytest.approx(
        list(res.confidence_interval), rel=1e-12
    )


def test_csv_one_row_per_group_then_avg(table4a):
    frame = scores_frame(build_scores(table4a, by=["scenario"], n_resamples=20))
    assert list(frame.columns) == list(SCORES_CSV_COLUMNS)
    assert frame[["grouping", "group"]].values.tolist() == [
        ["overall", "all"],
        ["scenario", "clinical"],
        ["scenario", "free-living"],
        ["scenario", "scripted"],
        ["scenario", "avg"],
    ]
    assert frame["accuracy"].tolist()[1:4] == pytest.approx([0.376, 0.265, 0.44])
    assert frame["n"].tolist()[:4] == [1300, 1000, 200, 100]
    assert frame["accuracy_ci_low"].notna().all()


def test_groups_in_natural_order_blank_group_and_by_checks(tmp_path):
    ref = tmp_path / "ref.csv"
    ref.write_text(
        "clip_id,subject,split,angle_deg\n"
        "a,S11,test,230\nb,S9,,100\nc,S1,train,50\nd,S5,,181\ne,S1,train,140\n"
    )
    pred = tmp_path / "pred.csv"
    pred.write_text("clip_id,angle_deg\na,230\nb,100\nc,50\nd,181\ne,140\n")
    joined = read_predictions(pred, read_reference(ref))
    scores = build_scores(joined, n_resamples=0)
    assert list(scores["by"]["subject"]["groups"]) == ["S1", "S5", "S9", "S11"]
    assert list(scores["by"]["bin_deg"]["groups"]) == ["45", "90", "135", "180", "225"]
    assert list(scores["by"]["split"]["groups"]) == ["(blank)", "test", "train"]
    only = build_scores(joined, by=[" Subject "], n_resamples=0)
    assert list(only["by"]) == ["subject"]
    with pytest.raises(TurnbenchError, match="no such group column"):
        build_scores(joined, by=["cohort"], n_resamples=0)


def test_all_empty_column_is_not_a_default_grouping(tmp_path):
    ref = tmp_path / "ref.csv"
    ref.write_text("clip_id,split,angle_deg\na,,90\nb,,180\n")
    pred = tmp_path / "pred.csv"
    pred.write_text("clip_id,angle_deg\na,90\nb,170\n")
    scores = build_scores(read_predictions(pred, read_reference(ref)), n_resamples=0)
    assert list(scores["by"]) == ["bin_deg"]


def test_markdown_of_a_hand_made_document_rounds_half_up():
    scores = {
        "overall": {
            "n": 16,
            "accuracy": 1 / 16,
            "mae_deg": 6.25,
            "wprec": 0.5,
            "mae_speed_deg_s": None,
            "kappa": None,
            "per_bin": {},
        },
        "by": {
            "cohort": {
                "groups": {
                    "HC": {
                        "n": 8,
                        "accuracy": 0.125,
                        "mae_deg": 2.05,
                        "wprec": 0.0,
                        "mae_speed_deg_s": None,
                    },
                    "PD": {
                        "n": 8,
                        "accuracy": 0.0,
                        "mae_deg": 10.45,
                        "wprec": 1.0,
                        "mae_speed_deg_s": None,
                    },
                },
                "avg": {
                    "n": 8.0,
                    "accuracy": 0.0625,
                    "mae_deg": 6.25,
                    "wprec": 0.5,
                    "mae_speed_deg_s": None,
                },
            }
        },
        "n_missing": 2,
        "settings": {"bin_width_deg": 45, "bootstrap": 0, "seed": 0, "version": "x"},
    }
    md = scores_markdown(scores)
    # 100/16 = 6.25 -> 6.3 and 2.05 -> 2.1, 10.45 -> 10.5: halves up, as printed tables do.
    assert "| Acc. (%) | 6.3 |" in md
    assert "| Acc. (%) | 12.5 | 0.0 | 6.3 |" in md
    assert "| MAE (°) | 2.1 | 10.5 | 6.3 |" in md
    assert "MAE speed" not in md  # no durations: no row
    assert "| # Turns | 8 | 8 | 8 |" in md
    assert "2 reference clips were missing" in md
    assert "95% CI" not in md


def test_markdown_rounds_any_finite_value():
    # A submission in the wrong unit can make an MAE of 1e300 degrees: printed, not a crash.
    from turn_datasets.render.numbers import format_metric as _format

    assert _format("mae_deg", 1e300) == "1" + "0" * 300 + ".0"
    assert _format("mae_deg", 0.05) == "0.1" and _format("accuracy", 0.3333) == "33.3"


def test_scores_frame_is_typed(table4a):
    frame = scores_frame(build_scores(table4a, by=["scenario"], n_resamples=0))
    assert frame.dtypes.astype(str).tolist()[2:] == ["float64"] * (len(SCORES_CSV_COLUMNS) - 2)
    assert frame["accuracy_ci_low"].isna().all()  # no bootstrap: empty intervals
    assert isinstance(frame, pd.DataFrame)


def test_every_group_entry_equals_sklearn_on_its_clips(tmp_path):
    from turn_eval.clips.metrics import compute_metrics

    rng = np.random.default_rng(2)
    n = 240
    ref_angle = rng.uniform(30, 250, n).round(1)
    subject = rng.choice(["P1", "P2", "P3", "P4"], n)
    pd.DataFrame(
        {
            "clip_id": [f"c{i}" for i in range(n)],
            "subject": subject,
            "angle_deg": ref_angle,
            "duration_s": rng.uniform(1, 3, n).round(2),
        }
    ).to_csv(tmp_path / "ref.csv", index=False)
    pred_angle = np.abs(ref_angle + rng.normal(0, 40, n)).round(1)
    pd.DataFrame({"clip_id": [f"c{i}" for i in range(n)], "angle_deg": pred_angle}).to_csv(
        tmp_path / "pred.csv", index=False
    )
    joined = read_predictions(tmp_path / "pred.csv", read_reference(tmp_path / "ref.csv"))
    scores = build_scores(joined, by=["subject"], n_resamples=0)
    t = joined.table
    for label, entry in scores["by"]["subject"]["groups"].items():
        keep = (t["subject"] == label).to_numpy()
        expected = compute_metrics(
            t["pred_angle_deg"][keep],
            t["ref_angle_deg"][keep],
            ref_duration_s=t["ref_duration_s"][keep],
        )
        assert entry["n"] == expected["n"]
        for m in METRICS:
            assert entry[m] == pytest.approx(expected[m], abs=1e-12), (label, m)
    whole = compute_metrics(
        t["pred_angle_deg"], t["ref_angle_deg"], ref_duration_s=t["ref_duration_s"]
    )
    assert {m: scores["overall"][m] for m in METRICS} == pytest.approx(
        {m: whole[m] for m in METRICS}, abs=1e-12
    )
