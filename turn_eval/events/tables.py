"""The Markdown and CSV tables of ``score-events`` (as ``score``'s: fractions in JSON and CSV,
percentages with one decimal in Markdown, rounded by :func:`turn_datasets.render.numbers.one_decimal`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_datasets.render.labels import METRIC_LABELS
from turn_datasets.render.markdown import metric_table
from turn_datasets.render.numbers import MISSING, fixed, is_missing, one_decimal
from turn_eval.events.bootstrap import CI_METRICS
from turn_eval.events.scoring import MATCHED_METRICS, NO_DETECTIONS, UNKNOWN_GROUP

__all__ = ["EVENT_LABELS", "EVENTS_CSV_COLUMNS", "events_markdown", "events_frame"]

#: Row label and kind of every number of the tables (percent: a fraction printed x 100). The
#: harness's angle metrics keep their one label (:data:`METRIC_LABELS`); the rest are the
#: detection counts and rates, and the matched pairs' extras.
EVENT_LABELS: Mapping[str, tuple[str, str]] = MappingProxyType(
    {
        "tp": ("# TP", "count"),
        "fp": ("# FP", "count"),
        "fn": ("# FN", "count"),
        "precision": ("Precision (%)", "percent"),
        "recall": ("Recall (%)", "percent"),
        "f1": ("F1 (%)", "percent"),
        "n": ("# Matched", "count"),
        **{key: (label.short, label.kind) for key, label in METRIC_LABELS.items()},
        "direction_agreement": ("Direction agreement (%)", "percent"),
        "median_abs_dstart_s": ("Median |Δstart| (s)", "seconds"),
        "median_abs_dend_s": ("Median |Δend| (s)", "seconds"),
    }
)
_DETECTION = ("precision", "recall", "f1")
# the matched-pair metrics in the order scoring reports them (declared once, in scoring)
_MATCHED = MATCHED_METRICS
#: ``score_events.csv``: one row per group of every grouping, the overall row and ``avg`` rows.
EVENTS_CSV_COLUMNS: Mapping[str, str] = {
    "grouping": "str",
    "group": "str",
    "tp": "float64",
    "fp": "float64",
    "fn": "float64",
    "precision": "float64",
    "recall": "float64",
    "f1": "float64",
    "matched_n": "float64",
    **{m: "float64" for m in _MATCHED},
    **{f"{m}_ci_{b}": "float64" for m in CI_METRICS for b in ("low", "high")},
}


def _format(metric: str, value: Any) -> str:
    if is_missing(value):
        return MISSING
    kind = EVENT_LABELS[metric][1]
    if kind == "count":
        return f"{int(value)}" if float(value).is_integer() else one_decimal(value)
    if kind == "percent":
        return one_decimal(100 * value)
    if kind == "seconds":
        return fixed(value, 2)
    return one_decimal(value)


def _get(entry: Mapping[str, Any], metric: str) -> Any:
    return entry["matched"].get(metric) if metric in (*_MATCHED, "n") else entry.get(metric)


def _interval(entry: Mapping[str, Any], metric: str) -> str:
    ci = entry.get("ci95")
    if ci is None or metric not in ci:
        return ""
    bounds = ci[metric]
    return (
        MISSING
        if bounds is None
        else f"{_format(metric, bounds[0])} – {_format(metric, bounds[1])}"
    )


def _present(entries: Sequence[Mapping[str, Any]], metrics: Sequence[str]) -> list[str]:
    return [m for m in metrics if any(_get(e, m) is not None for e in entries)]


def events_markdown(doc: Mapping[str, Any]) -> str:
    """Markdown tables of a ``score_events`` document: overall detection and matched-turn
    metrics with 95% intervals, AP, turns per hour, then per grouping (groups as columns and
    ``Avg.``, as the paper's Tables 4-5), then the rule and settings."""
    overall = doc["overall"]
    settings = doc["settings"]
    with_ci = "ci95" in overall
    header = ["Metric", "All"] + (["95% CI"] if with_ci else [])
    rows = []
    for m in ("tp", "fp", "fn", *_DETECTION, "n", *_present([overall], _MATCHED)):
        row = [EVENT_LABELS[m][0], _format(m, _get(overall, m))]
        rows.append(row + ([_interval(overall, m)] if with_ci else []))
    out = ["## Overall", ""] + metric_table(header, rows)

    ap = overall.get("ap")
    if ap is not None:
        ious = list(ap["by_iou"])
        out += ["", "## Average precision (ActivityNet interpolation)", ""]
        out += metric_table(
            ["tIoU", *ious, "Mean"],
            [
                ["AP (%)"]
                + [_format("precision", ap["by_iou"][k]) for k in ious]
                + [_format("precision", ap["mean"])]
            ],
        )
    rates = overall.get("turns_per_hour")
    if rates is not None:
        out += ["", "## Turns per hour (per session and participant)", ""]
        out += metric_table(
            ["Reference (mean)", "Detected (mean)", "Mean abs. difference", "# Units"],
            [
                [
                    one_decimal(rates["reference_per_hour_mean"]),
                    one_decimal(rates["detected_per_hour_mean"]),
                    one_decimal(rates["mean_abs_difference_per_hour"]),
                    str(rates["n_units"]),
                ]
            ],
        )

    notes: list[str] = []
    for col, block in doc.get("by", {}).items():
        groups, avg = block["groups"], block["avg"]
        names = list(groups)
        entries = list(groups.values())
        out += ["", f"## By {col}", ""]
        rows = []
        for m in (*_DETECTION, *_present(entries, _MATCHED[:4]), "tp", "fp", "fn", "n"):
            rows.append(
                [EVENT_LABELS[m][0]]
                + [_format(m, _get(groups[g], m)) for g in names]
                + [_format(m, _get(avg, m))]
            )
        if "ci95" in avg:
            rows.append(
                ["F1 95% CI"] + [_interval(groups[g], "f1") for g in names] + [_interval(avg, "f1")]
            )
        out += metric_table([col, *names, "Avg."], rows)
        if UNKNOWN_GROUP in groups:
            notes.append(
                f"By {col}: {UNKNOWN_GROUP!r} holds false detections whose {col} is not known"
                + (
                    " (no --context given)"
                    if col in ("scenario", "location") and not settings.get("context")
                    else " (no context interval at their midpoint)"
                )
                + "; they lower that group's precision only."
            )
    counts = doc.get("counts", {})
    if counts.get("detections", 1) == 0:
        notes.append(NO_DETECTIONS)
    summary = (
        f"Matching: {settings['matching']}. "
        f"{counts.get('units', 0)} (session, subject) units, {counts.get('reference_turns', 0)} "
        f"reference turns, {counts.get('detections', 0)} detections"
        + (
            f" ({counts['dropped_unknown']} of unannotated units dropped)"
            if counts.get("dropped_unknown")
            else ""
        )
        + f". Bins of {settings['bin_width_deg']}°"
        + (
            f"; {int(100 * settings['confidence'])}% percentile intervals from "
            f"{settings['resamples']} cluster-bootstrap resamples of the (session, subject) "
            f"units, seed {settings['seed']}"
            if settings.get("resamples")
            else "; no bootstrap"
        )
        + f"; Avg. is the unweighted mean over groups; turnbench {settings['version']}."
    )
    out += ["", summary, *notes]
    return "\n".join(out) + "\n"


def _csv_row(grouping: str, group: str, entry: Mapping[str, Any]) -> dict[str, Any]:
    def num(value):
        return np.nan if value is None else value

    row: dict[str, Any] = {"grouping": grouping, "group": group}
    for m in ("tp", "fp", "fn", *_DETECTION):
        row[m] = num(entry.get(m))
    row["matched_n"] = num(entry["matched"].get("n"))
    for m in _MATCHED:
        row[m] = num(entry["matched"].get(m))
    ci = entry.get("ci95") or {}
    for m in CI_METRICS:
        bounds = ci.get(m)
        row[f"{m}_ci_low"] = np.nan if bounds is None else bounds[0]
        row[f"{m}_ci_high"] = np.nan if bounds is None else bounds[1]
    return row


def events_frame(doc: Mapping[str, Any]) -> pd.DataFrame:
    """``score_events.csv``: the overall row, then every group of every grouping and its
    ``avg`` (:data:`EVENTS_CSV_COLUMNS`; fractions as in the JSON; empty where undefined)."""
    rows = [_csv_row("overall", "all", doc["overall"])]
    for col, block in doc.get("by", {}).items():
        for label, entry in block["groups"].items():
            rows.append(_csv_row(col, label, entry))
        rows.append(_csv_row(col, "avg", block["avg"]))
    return typed_frame(pd.DataFrame(rows), EVENTS_CSV_COLUMNS)
