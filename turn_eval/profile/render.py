"""The contrasts as a Markdown table (``turn-eval profile``'s stdout and report.html)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from turn_datasets.render.markdown import metric_table
from turn_datasets.render.numbers import MISSING, fixed, is_missing

__all__ = ["contrasts_markdown"]


def _num(value: Any, digits: int) -> str:
    return MISSING if is_missing(value) else fixed(float(value), digits)


def _interval(row: Mapping[str, Any], name: str, digits: int) -> str:
    low, high = row[f"{name}_lo"], row[f"{name}_hi"]
    if is_missing(low) or is_missing(high):
        return MISSING
    return f"[{fixed(float(low), digits)}, {fixed(float(high), digits)}]"


def contrasts_markdown(doc: Mapping[str, Any]) -> str:
    """One row per measure: the groups' sizes and means, the difference, Hedges' g and the
    AUC, each with its 95% interval; a line on suppression and the signature below."""
    groups = doc["groups"]
    header = [
        "measure",
        f"n {groups['pd']}",
        f"n {groups['hc']}",
        f"{groups['pd']} mean",
        f"{groups['hc']} mean",
        "difference",
        "95% CI",
        "Hedges' g",
        "95% CI",
        "AUC",
        "95% CI",
    ]
    rows = [
        [
            row["measure"],
            row["n_pd"],
            row["n_hc"],
            _num(row["pd_mean"], 3),
            _num(row["hc_mean"], 3),
            _num(row["difference"], 3),
            _interval(row, "difference", 3),
            _num(row["hedges_g"], 2),
            _interval(row, "hedges_g", 2),
            _num(row["auc"], 2),
            _interval(row, "auc", 2),
        ]
        for row in doc["contrasts"]
    ]
    settings = doc["settings"]
    lines = [
        f"# Turning profile: {groups['pd']} vs {groups['hc']} (by {doc['by']})",
        "",
        *metric_table(header, rows),
        "",
        f"{doc['participants']} participants; {doc['suppressed']} with fewer than "
        f"{settings['min_turns']} turns suppressed (blank measures, not in the contrasts). "
        f"Intervals: {settings['ci_method']}, {settings['resamples']} resamples, seed "
        f"{settings['seed']}. AUC > 0.5: higher in {groups['pd']}.",
        "",
        f"signature: {doc['signature']['options']} version={doc['signature']['version']}",
    ]
    return "\n".join(lines) + "\n"
