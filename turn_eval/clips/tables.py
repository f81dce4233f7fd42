"""The scores document of ``turn-eval score`` and its Markdown and CSV tables.

One document holds everything (DESIGN.md, "Scores"):

``overall``
    Every scored clip pooled: ``n``, the metrics of :mod:`turn_eval.clips.metrics`, their bootstrap
    ``ci95``, the quadratic-weighted ``kappa`` between predicted and reference bins and
    ``per_bin`` precision and recall.
``by``
    One entry per grouping (``scenario``, ``subject``, ``bin_deg``, ...): ``groups``, each with
    ``n``, the metrics and their ``ci95``, and ``avg``, the unweighted mean over the groups of
    each metric and of ``n`` (the "Avg." column of the paper's Tables 4 and 5) with its own
    ``ci95``. Every interval comes from the same bootstrap resamples of all the clips
    (:func:`turn_eval.clips.metrics.grouped_bootstrap`): a group's metric on a resample is computed
    on the group's clips it drew, and the average's on the same resample is the mean of those,
    so the groups' sampling noise enters the average's interval jointly. A resample that drew
    no clip of some group is left out of that group's interval and the average's.
``n_missing``
    Reference clips the submission left out (``--allow-missing``).
``settings``
    Bin width, resamples, seed, confidence and the turnbench version: what a reader needs to
    reproduce a number.

Fractions stay fractions in JSON and CSV; Markdown prints them as percentages with one
decimal, as the paper does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.render.labels import METRIC_LABELS
from turn_datasets.render.markdown import markdown_cell, metric_table
from turn_datasets.render.numbers import MISSING, fixed, format_metric
from turn_datasets.render.order import natural_key
from turn_eval.clips.metrics import (
    KAPPA_WEIGHTS,
    METRICS,
    ClipOutcomes,
    Partition,
    bin_report,
    clip_outcomes,
    grouped_bootstrap,
    grouped_metrics,
)
from turn_eval.clips.submission import BIN_COLUMN, Joined
from turn_eval.scoring.bootstrap import (
    CONFIDENCE,
    chunk_rows,
    percentile_interval,
    resample_indices,
)
from turn_eval.scoring.groups import BLANK_GROUP, average, check_groupings, group_label
from turn_eval.scoring.signature import Signature, signature_line
from turn_eval.scoring.writers import csv_row, grouped_frame

__all__ = [
    "SCORES_CSV_COLUMNS",
    "scores_csv",
    "outcomes_of",
    "partitions_of",
    "build_scores",
    "scores_markdown",
    "scores_frame",
]

#: Columns and dtypes of ``scores.csv``: one row per group, the overall row and ``avg`` rows.
SCORES_CSV_COLUMNS: Mapping[str, str] = {
    "grouping": "str",
    "group": "str",
    "n": "float64",
    **{m: "float64" for m in METRICS},
    **{f"{m}_ci{b}": "float64" for m in METRICS for b in ("_low", "_high")},
}

#: Wraps the iterator of resample chunks (and their number) to show progress.
Progress = Callable[[Iterable[np.ndarray], int], Iterable[np.ndarray]]


def outcomes_of(joined: Joined) -> ClipOutcomes:
    """The per-clip outcomes of a joined submission (:func:`turn_eval.clips.metrics.clip_outcomes`)."""
    t = joined.table
    return clip_outcomes(
        t["pred_angle_deg"].to_numpy(),
        t["ref_angle_deg"].to_numpy(),
        ref_duration_s=t["ref_duration_s"].to_numpy() if joined.has_durations else None,
        pred_speed_deg_s=t["pred_speed_deg_s"].to_numpy(),
        bin_width_deg=joined.bin_width_deg,
    )


def _partition(joined: Joined, column: str) -> Partition:
    """The groups of one grouping column, in natural order; empty cells form one group."""
    values = joined.table[column]
    if column == BIN_COLUMN:
        bins, codes = np.unique(values.to_numpy(dtype=np.float64), return_inverse=True)
        return Partition(column, tuple(group_label(b) for b in bins), codes.reshape(-1))
    inverse, unique = pd.factorize(values.to_numpy(dtype=object))
    labels = [BLANK_GROUP if u == "" else str(u) for u in unique]
    order = sorted(range(len(labels)), key=lambda i: natural_key(labels[i]))
    rank = np.empty(len(labels), dtype=np.int64)
    rank[order] = np.arange(len(labels))
    return Partition(column, tuple(labels[i] for i in order), rank[inverse.reshape(-1)])


def partitions_of(joined: Joined, groupings: Sequence[str]) -> list[Partition]:
    """The pooled clips, then one partition per grouping column: what :func:`build_scores`
    scores and resamples."""
    return [Partition.whole(len(joined.table)), *(_partition(joined, col) for col in groupings)]


def _intervals(
    distribution: Mapping[str, np.ndarray], column: int | None
) -> dict[str, list[float] | None]:
    """``ci95`` of one group (a column of the distribution) or of the groups' average."""
    out: dict[str, list[float] | None] = {}
    for m in METRICS:
        values = distribution.get(m)
        if values is None:
            out[m] = None
            continue
        # The average over groups on a resample is undefined when one group is.
        v = values[:, column] if column is not None else values.mean(axis=1)
        bounds = percentile_interval(v)
        out[m] = None if bounds is None else [bounds[0], bounds[1]]
    return out


def build_scores(
    joined: Joined,
    *,
    by: Sequence[str] | None = None,
    n_resamples: int = 1000,
    seed: int = 0,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Score a joined submission overall and per group (the scores JSON of DESIGN.md).

    Parameters
    ----------
    joined
        From :func:`turn_eval.clips.submission.read_predictions`.
    by
        Group columns of the reference; None or empty for every default grouping the
        reference has (:attr:`Joined.default_groupings`).
    n_resamples
        Bootstrap resamples per interval; 0 for no intervals.
    seed
        Seed of every resampling (see the module docstring).
    progress
        Wraps the iterator of chunks of resamples, given it and the number of chunks, to
        show progress; None for none.

    Returns
    -------
    dict
        ``overall``, ``by``, ``n_missing``, ``settings``, ``signature``
        (:mod:`turn_eval.scoring.signature`), ready for JSON.
    """
    if n_resamples < 0:
        raise TurnbenchError(f"--bootstrap must be 0 or more, got {n_resamples}")
    if seed < 0:
        raise TurnbenchError(f"--seed must be 0 or more, got {seed}")
    groupings = check_groupings(
        by,
        joined.group_columns,
        default=joined.default_groupings,
        file=joined.reference_path,
    )
    outcomes = outcomes_of(joined)
    partitions = partitions_of(joined, groupings)

    distributions: list[dict[str, np.ndarray]] = [{} for _ in partitions]
    if n_resamples > 0:
        chunks: Iterable[np.ndarray] = resample_indices(
            outcomes.n, n_resamples=n_resamples, seed=seed
        )
        if progress is not None:
            rows = chunk_rows(outcomes.n)
            chunks = progress(chunks, -(-n_resamples // rows))
        distributions = grouped_bootstrap(outcomes, partitions, indices=chunks)

    observed = grouped_metrics(outcomes, partitions)

    def entry(part: int, column: int) -> dict[str, Any]:
        values: dict[str, Any] = {"n": int(observed[part]["n"][column])}
        for m in METRICS:
            value = observed[part].get(m)
            values[m] = (
                None if value is None or not np.isfinite(value[column]) else float(value[column])
            )
        if n_resamples > 0:
            values["ci95"] = _intervals(distributions[part], column)
        return values

    overall = entry(0, 0)
    overall.update(bin_report(outcomes, bin_width_deg=joined.bin_width_deg))
    by_doc: dict[str, Any] = {}
    for part, p in enumerate(partitions[1:], start=1):
        groups = {label: entry(part, g) for g, label in enumerate(p.labels)}
        avg = average(groups.values(), ("n", *METRICS))
        if n_resamples > 0:
            avg["ci95"] = _intervals(distributions[part], None)
        by_doc[p.name] = {"groups": groups, "avg": avg}
    width = joined.bin_width_deg
    return {
        "overall": overall,
        "by": by_doc,
        "n_missing": joined.n_missing,
        "settings": {
            "bin_width_deg": int(width) if float(width).is_integer() else width,
            "bootstrap": n_resamples,
            "seed": seed,
            "confidence": CONFIDENCE,
            "ci_method": "percentile",
            "kappa_weights": KAPPA_WEIGHTS,
            "version": __version__,
        },
        "signature": _signature(joined, groupings, n_resamples=n_resamples, seed=seed).as_dict(),
    }


def _signature(joined: Joined, groupings: Sequence[str], *, n_resamples: int, seed: int):
    """What reproduces the scores: the options that change a number and both files' sha256."""
    return Signature.of(
        "score",
        [
            ("by", groupings),
            ("bin", joined.bin_width_deg),
            ("bootstrap", f"percentile-{n_resamples}"),
            ("seed", seed),
            ("abs", joined.abs_angles),
            ("allow-missing", joined.allow_missing),
        ],
        {"reference": joined.reference_path, "predictions": joined.predictions_path},
        {"reference": joined.reference_sha256, "predictions": joined.predictions_sha256},
    )


def _present(entries: Iterable[Mapping[str, Any]]) -> list[str]:
    entries = list(entries)
    return [m for m in METRICS if any(e.get(m) is not None for e in entries)]


def scores_markdown(scores: Mapping[str, Any]) -> str:
    """Markdown tables of a scores document, laid out as the paper's Tables 4 and 5.

    First the overall metrics with their 95% intervals and the kappa; then, per grouping,
    the metrics as rows and the groups as columns, then ``Avg.``, with ``# Turns`` as the
    last row; then each bin's precision and recall. Percentages with one decimal.
    """
    overall = scores["overall"]
    settings = scores["settings"]
    out: list[str] = ["## Overall", ""]
    ci = overall.get("ci95")
    header = ["Metric", "All"] + (["95% CI"] if ci is not None else [])
    rows = []
    for m in _present([overall]):
        row = [METRIC_LABELS[m].short, format_metric(m, overall[m])]
        if ci is not None:
            bounds = ci.get(m)
            row.append(
                MISSING
                if bounds is None
                else f"{format_metric(m, bounds[0])} – {format_metric(m, bounds[1])}"
            )
        rows.append(row)
    kappa = overall.get("kappa")
    rows.append(
        [
            f"Kappa ({settings.get('kappa_weights', KAPPA_WEIGHTS)})",
            MISSING if kappa is None else fixed(kappa, 3),
        ]
        + ([""] if ci is not None else [])
    )
    rows.append(["# Turns", format_metric("n", overall["n"])] + ([""] if ci is not None else []))
    out += metric_table(header, rows)

    for col, block in scores.get("by", {}).items():
        groups = block["groups"]
        avg = block["avg"]
        names = list(groups)
        out += ["", f"## By {markdown_cell(col)}", ""]
        rows = []
        for m in _present(groups.values()):
            rows.append(
                [METRIC_LABELS[m].short]
                + [format_metric(m, groups[g].get(m)) for g in names]
                + [format_metric(m, avg.get(m))]
            )
        rows.append(
            ["# Turns"]
            + [format_metric("n", groups[g]["n"]) for g in names]
            + [format_metric("n", avg["n"])]
        )
        header = [col, *names, "Avg."]
        out += metric_table(header, rows)

    per_bin = overall.get("per_bin")
    if per_bin:
        out += ["", "## Per bin (reference bin, degrees)", ""]
        labels = list(per_bin)
        out += metric_table(
            ["Bin", *labels],
            [
                ["Precision (%)"]
                + [format_metric("wprec", per_bin[b]["precision"]) for b in labels],
                ["Recall (%)"] + [format_metric("accuracy", per_bin[b]["recall"]) for b in labels],
                ["# Turns"] + [str(per_bin[b]["n"]) for b in labels],
                ["# Predicted"] + [str(per_bin[b]["n_predicted"]) for b in labels],
            ],
        )

    notes = [
        f"Bins of {settings['bin_width_deg']}°"
        + (
            f"; {int(100 * settings.get('confidence', CONFIDENCE))}% percentile bootstrap "
            f"intervals from {settings['bootstrap']} resamples of the clips, seed "
            f"{settings['seed']}"
            if settings.get("bootstrap")
            else "; no bootstrap"
        )
        + f"; Avg. is the unweighted mean over groups; turnbench {settings['version']}."
    ]
    if scores.get("n_missing"):
        notes.append(
            f"{scores['n_missing']} reference clips were missing from the predictions and "
            "are not scored."
        )
    out += [""] + notes
    if "signature" in scores:
        out += ["", f"signature: {signature_line(scores['signature'])}"]
    return "\n".join(out) + "\n"


def _csv_row(grouping: str, group: str, entry: Mapping[str, Any]) -> dict[str, Any]:
    values = {"n": entry["n"], **{m: entry.get(m) for m in METRICS}}
    return csv_row(grouping, group, values, entry.get("ci95"), METRICS)


def scores_csv(frame: pd.DataFrame) -> str:
    """``scores.csv``'s text: :func:`scores_frame` with each count printed as one (``235``,
    not ``235.0``; only a grouping's ``avg`` row has a fractional ``n``)."""
    out = frame.astype({"n": "object"})
    out["n"] = [int(n) if float(n).is_integer() else n for n in frame["n"]]
    return out.to_csv(index=False, lineterminator="\n")


def scores_frame(scores: Mapping[str, Any]) -> pd.DataFrame:
    """``scores.csv``: the overall row, then every group of every grouping and its ``avg``.

    Columns :data:`SCORES_CSV_COLUMNS`; fractions as in the JSON; empty where undefined.
    """
    return grouped_frame(scores, _csv_row, SCORES_CSV_COLUMNS)
