"""Statistics of a Turn-REMAP label set: the paper's Table 1 and Table 2, and turns per room.

:func:`table1` (subjects, turns, ages, years since diagnosis, per cohort), :func:`table2`
(turns per scenario and angle) and :func:`turns_per_location` summarise a labels table
(:func:`read_labels`), as Markdown, CSV or a JSON document.
"""

from __future__ import annotations

import math
from os import PathLike
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.limits import MAX_ANGLE_DEG
from turn_datasets.remap.participants import COHORTS
from turn_datasets.remap.schema import load_schema
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import MISSING, fixed
from turn_datasets.usertable import read_table

__all__ = [
    "read_labels",
    "TABLE1_COLUMNS",
    "table1",
    "table2",
    "turns_per_location",
    "stats_markdown",
    "stats_csv",
    "stats_dict",
]


_STATS_NEEDS = ("clip_id", "subject", "cohort", "angle_deg", "scenario", "location")


def read_labels(path: str | PathLike[str]) -> pd.DataFrame:
    """Read a labels CSV for :func:`table1`/:func:`table2` (errors name file and line).

    Only the columns the tables need are required; the others are kept as text.
    """
    file = str(path)
    # The one reader of user tables (turn_datasets.usertable): UTF-8 with or without a BOM,
    # header names ignoring case and spaces, each row's own line number.
    table = read_table(path, what="labels", numeric_columns=(), allow_no_rows=True)
    df = pd.DataFrame({c: table.columns[c] for c in table.header if c}, dtype=object)
    lines = table.lines
    missing = [c for c in _STATS_NEEDS if c not in df.columns]
    if missing:
        raise TurnbenchError(f"labels lack column(s) {', '.join(missing)}", file=file, row=1)
    angle = pd.to_numeric(df["angle_deg"], errors="coerce")
    bad = angle.isna() | ~np.isfinite(angle)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise TurnbenchError(
            f"angle_deg {df['angle_deg'].iloc[i]!r} is not a number", file=file, row=int(lines[i])
        )
    absurd = angle.abs() > MAX_ANGLE_DEG
    if absurd.any():
        i = int(np.flatnonzero(absurd.to_numpy())[0])
        raise TurnbenchError(
            f"angle_deg {angle.iloc[i]:g} is beyond the plausible {MAX_ANGLE_DEG:g} "
            "(see the README)",
            file=file,
            row=int(lines[i]),
        )
    df["angle_deg"] = angle.astype("float64")
    cohort = df["cohort"].str.strip().str.upper()
    bad = ~cohort.isin(COHORTS)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise TurnbenchError(
            f"cohort {df['cohort'].iloc[i]!r} is not PD or HC", file=file, row=int(lines[i])
        )
    df["cohort"] = cohort
    df.attrs["source"] = file
    return df


def _subject_table(labels: pd.DataFrame, participants: pd.DataFrame | None) -> pd.DataFrame:
    subjects = labels.groupby("subject", sort=True)["cohort"].first().rename("cohort").to_frame()
    if participants is None:
        subjects["age"] = math.nan
        subjects["years_since_diagnosis"] = math.nan
        return subjects
    info = participants.set_index("subject")
    missing = [s for s in subjects.index if s not in info.index]
    if missing:
        raise TurnbenchError(
            f"subject {missing[0]!r} of the labels is not in the participants table",
            file=participants.attrs.get("source"),
        )
    subjects["age"] = info.loc[subjects.index, "age"].to_numpy()
    subjects["years_since_diagnosis"] = info.loc[subjects.index, "years_since_diagnosis"].to_numpy()
    return subjects


TABLE1_COLUMNS = {
    "cohort": "str",
    "subjects": "int64",
    "turns": "int64",
    "age_mean": "float64",
    "age_sd": "float64",
    "years_since_diagnosis_mean": "float64",
    "years_since_diagnosis_sd": "float64",
}


def table1(labels: pd.DataFrame, participants: pd.DataFrame | None = None) -> pd.DataFrame:
    """The paper's Table 1: subjects, turns, age and years since diagnosis per cohort.

    Parameters
    ----------
    labels
        The labels table (``subject``, ``cohort`` and one row per turn).
    participants
        :func:`read_participants`; without it ages and durations are NaN.

    Returns
    -------
    pandas.DataFrame
        Rows ``PD``, ``HC``, ``all``; columns :data:`TABLE1_COLUMNS`. Subjects are those with
        at least one turn; means and sample standard deviations (``ddof=1``) are over
        subjects, skipping unknown values; years since diagnosis is over PD subjects only.
    """
    subjects = _subject_table(labels, participants)
    rows = []
    for name, mask_s, mask_t in [
        *((c, subjects["cohort"] == c, labels["cohort"] == c) for c in COHORTS),
        ("all", subjects["cohort"].notna(), labels["cohort"].notna()),
    ]:
        s = subjects[mask_s]
        pd_only = s[s["cohort"] == "PD"]["years_since_diagnosis"]
        rows.append(
            {
                "cohort": name,
                "subjects": len(s),
                "turns": int(mask_t.sum()),
                "age_mean": s["age"].mean(),
                "age_sd": s["age"].std(ddof=1),
                "years_since_diagnosis_mean": pd_only.mean() if name != "HC" else math.nan,
                "years_since_diagnosis_sd": pd_only.std(ddof=1) if name != "HC" else math.nan,
            }
        )
    return typed_frame(pd.DataFrame(rows), TABLE1_COLUMNS)


def _ordered(present: list[Any], preferred: list[Any]) -> list[Any]:
    """Every preferred item (shown even when empty), then the others present, sorted."""
    return list(preferred) + sorted(p for p in present if p not in preferred)


def table2(
    labels: pd.DataFrame,
    *,
    angles_deg: tuple[float, ...] | None = None,
    scenarios: tuple[str, ...] | None = None,
) -> pd.DataFrame:
    """The paper's Table 2: turns per scenario (rows) and angle (columns), with totals.

    Parameters
    ----------
    labels
        The labels table.
    angles_deg, scenarios
        The columns and rows always shown, in order (default: the default schema's
        vocabularies, so an angle with no turn shows 0); others present are appended.

    Returns
    -------
    pandas.DataFrame
        Index: scenario (``(none)`` for turns without one) and ``total``; columns: the angles
        as ``int`` degrees when whole, and ``total``. Counts are ``int64``.
    """
    schema = load_schema()
    angles_deg = schema.angles_deg if angles_deg is None else angles_deg
    scenarios = schema.scenario.values if scenarios is None else scenarios
    scen = labels["scenario"].replace("", "(none)")
    angles = labels["angle_deg"].astype("float64")
    col_order = _ordered(sorted(set(angles)), list(angles_deg))
    row_order = _ordered(sorted(set(scen)), list(scenarios))
    counts = pd.crosstab(scen, angles).reindex(index=row_order, columns=col_order, fill_value=0)
    counts = counts.astype("int64")
    counts.columns = [int(c) if float(c).is_integer() else float(c) for c in counts.columns]
    counts["total"] = counts.sum(axis=1)
    counts.loc["total"] = counts.sum(axis=0)
    counts.index.name = "scenario"
    counts.columns.name = None
    return counts.astype("int64")


def turns_per_location(labels: pd.DataFrame) -> pd.DataFrame:
    """Turns per location (rows, most turns first) and cohort (columns), with totals."""
    loc = labels["location"].replace("", "(none)")
    counts = pd.crosstab(loc, labels["cohort"]).reindex(columns=list(COHORTS), fill_value=0)
    counts["total"] = counts.sum(axis=1)
    counts = (
        counts.assign(_name=counts.index)
        .sort_values(["total", "_name"], ascending=[False, True], kind="mergesort")
        .drop(columns="_name")
    )
    counts.loc["total"] = counts.sum(axis=0)
    counts.index.name = "location"
    counts.columns.name = None
    return counts.astype("int64")


def _num(value: float, digits: int = 1) -> str:
    return MISSING if value is None or not np.isfinite(value) else fixed(value, digits)


def _mean_sd(mean: float, sd: float) -> str:
    if not np.isfinite(mean):
        return MISSING
    return fixed(mean, 1) if not np.isfinite(sd) else f"{fixed(mean, 1)} ± {fixed(sd, 1)}"


def _angle_name(col: Any) -> str:
    return "total" if col == "total" else f"{col}°"


def stats_markdown(t1: pd.DataFrame, t2: pd.DataFrame, locations: pd.DataFrame) -> str:
    """Markdown of :func:`table1`, :func:`table2` and :func:`turns_per_location`."""
    lines = ["## Table 1: subjects and turns per cohort", ""]
    lines += markdown_table(
        ["cohort", "subjects", "turns", "age (years)", "years since diagnosis"],
        [
            [
                r.cohort,
                str(r.subjects),
                str(r.turns),
                _mean_sd(r.age_mean, r.age_sd),
                _mean_sd(r.years_since_diagnosis_mean, r.years_since_diagnosis_sd),
            ]
            for r in t1.itertuples(index=False)
        ],
    )
    lines += [
        "",
        "Ages and years since diagnosis: mean ± sample standard deviation over "
        "subjects with turns.",
        "",
        "## Table 2: turns per scenario and angle",
        "",
    ]
    lines += markdown_table(
        ["scenario", *(_angle_name(c) for c in t2.columns)],
        [
            [str(idx), *(str(int(v)) for v in row)]
            for idx, row in zip(t2.index, t2.to_numpy(), strict=True)
        ],
    )
    lines += ["", "## Turns per location and cohort", ""]
    lines += markdown_table(
        ["location", *locations.columns],
        [
            [str(idx), *(str(int(v)) for v in row)]
            for idx, row in zip(locations.index, locations.to_numpy(), strict=True)
        ],
    )
    return "\n".join(lines) + "\n"


def _value_text(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return "" if not np.isfinite(value) else f"{float(value):.4g}"
    return str(value)


def stats_csv(t1: pd.DataFrame, t2: pd.DataFrame, locations: pd.DataFrame) -> str:
    """The three tables as one long CSV: ``table, row, column, value``.

    ``table`` is ``table1``, ``table2`` or ``locations``; Table 1 values are counts, means and
    standard deviations (empty when unknown), the others counts.
    """
    records: list[tuple[str, str, str, str]] = []
    for r in t1.to_dict("records"):
        for col in list(t1.columns)[1:]:
            records.append(("table1", r["cohort"], col, _value_text(r[col])))
    for name, table in (("table2", t2), ("locations", locations)):
        for idx, row in zip(table.index, table.to_numpy(), strict=True):
            for col, v in zip(table.columns, row, strict=True):
                records.append((name, str(idx), str(col), _value_text(v)))
    frame = pd.DataFrame(records, columns=["table", "row", "column", "value"])
    return frame.to_csv(index=False, lineterminator="\n")


def stats_dict(t1: pd.DataFrame, t2: pd.DataFrame, locations: pd.DataFrame) -> dict[str, Any]:
    """The three tables as JSON-ready dictionaries (NaN becomes null when written)."""
    return {
        "table1": {
            r["cohort"]: {k: v for k, v in r.items() if k != "cohort"}
            for r in t1.to_dict("records")
        },
        "table2": {
            str(idx): {str(c): int(v) for c, v in zip(t2.columns, row, strict=True)}
            for idx, row in zip(t2.index, t2.to_numpy(), strict=True)
        },
        "locations": {
            str(idx): {str(c): int(v) for c, v in zip(locations.columns, row, strict=True)}
            for idx, row in zip(locations.index, locations.to_numpy(), strict=True)
        },
    }
