"""Turn-REMAP labels: one row per turn after adjudication, the participants table, Tables 1-2.

In the paper (Cheng et al., Section 3.2) two clinicians labelled the turns of 24 people
(12 with Parkinson's disease, 12 healthy controls) in ELAN; about half of the turns were
labelled by both, and disagreements were resolved before the labels were used. Here:

- :func:`read_participants` reads and checks the participants table
  (``subject, cohort, pair, sex, age, years_since_diagnosis``; cohort ``PD`` or ``HC``).
- :func:`adjudicate` makes one turn of the matched annotations of two raters (matched as in
  the agreement audit, :func:`turn_datasets.remap.agreement.match_annotations`), lets the
  consensus rater decide where they disagree, and lists what no one decided.
- :func:`make_labels` adds the cohort and gives the labels table of DESIGN.md.
- :func:`table1`, :func:`table2`, :func:`turns_per_location` summarise a label set as the
  paper's Table 1 (subjects, turns, ages, years since diagnosis) and Table 2 (turns per
  scenario and angle).

``clip_id`` is ``{session}_{subject}_{start_ms}-{end_ms}`` (times in whole milliseconds as in
ELAN, spaces replaced by ``-``), mirroring the Turn-H3.6M clip id; it is unique because two
turns of one subject with the same times would have been matched into one.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.limits import MAX_ANGLE_DEG
from turn_datasets.remap.agreement import match_annotations
from turn_datasets.remap.schema import load_schema, normalise_value

__all__ = [
    "COHORTS",
    "LABEL_COLUMNS",
    "PARTICIPANT_COLUMNS",
    "RESOLVE_CHOICES",
    "UNRESOLVED_COLUMNS",
    "Adjudication",
    "adjudicate",
    "clip_id_for",
    "make_labels",
    "read_labels",
    "read_participants",
    "stats_csv",
    "stats_dict",
    "stats_markdown",
    "table1",
    "table2",
    "turns_per_location",
    "unresolved_error",
]

#: Column contract of the labels file (DESIGN.md, "Labels (Turn-REMAP)").
LABEL_COLUMNS = {
    "clip_id": "str",
    "session": "str",
    "subject": "str",
    "cohort": "str",
    "annotator": "str",
    "start_s": "float64",
    "end_s": "float64",
    "duration_s": "float64",
    "angle_deg": "float64",
    "scenario": "str",
    "location": "str",
    "double_annotated": "bool",
    "source": "str",
}

#: Column contract of the participants table after :func:`read_participants`.
PARTICIPANT_COLUMNS = {
    "subject": "str",
    "cohort": "str",
    "pair": "str",
    "sex": "str",
    "age": "float64",
    "years_since_diagnosis": "float64",
}

#: Turns two raters labelled differently that no consensus annotation decided.
UNRESOLVED_COLUMNS = {
    "session": "str",
    "participant": "str",
    "start_s": "float64",
    "end_s": "float64",
    "values": "str",
    "file": "str",
    "tier": "str",
}

COHORTS = ("PD", "HC")
RESOLVE_CHOICES = ("consensus", "first-rater")


def clip_id_for(*, session: str, subject: str, start_s: float, end_s: float) -> str:
    """``{session}_{subject}_{start_ms}-{end_ms}`` with spaces replaced by ``-``."""
    start_ms = int(round(start_s * 1000))
    end_ms = int(round(end_s * 1000))
    return "_".join(str(x).strip().replace(" ", "-") for x in (session, subject)) + (
        f"_{start_ms}-{end_ms}"
    )


# ---------------------------------------------------------------------------------------
# Participants


def _number(text: str, *, column: str, file: str, row: int, lo: float, hi: float) -> float:
    text = text.strip()
    if not text:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise TurnbenchError(f"{column} {text!r} is not a number", file=file, row=row) from None
    if not math.isfinite(value) or not lo <= value <= hi:
        raise TurnbenchError(f"{column} {text!r} is outside {lo:g} to {hi:g}", file=file, row=row)
    return value


def read_participants(path: str | PathLike[str]) -> pd.DataFrame:
    """Read and check the participants table.

    Parameters
    ----------
    path
        CSV with header ``subject, cohort, pair, sex, age, years_since_diagnosis`` (in any
        order; extra columns are ignored). ``cohort`` is ``PD`` or ``HC`` (any case); ``pair``
        (the matched PD/HC pair), ``sex``, ``age`` (years) and ``years_since_diagnosis`` may be
        empty; a healthy control has no years since diagnosis.

    Returns
    -------
    pandas.DataFrame
        :data:`PARTICIPANT_COLUMNS`, one row per subject in file order; ``attrs["source"]``
        is the file name.

    Raises
    ------
    TurnbenchError
        Naming the file and line: a missing column, an empty or repeated subject, a cohort
        other than PD or HC, an age or duration that is not a number in range, a control with
        years since diagnosis, a diagnosis longer ago than the subject's age.
    """
    file = str(path)
    try:
        fh = open(path, encoding="utf-8-sig", newline="")
    except FileNotFoundError:
        raise TurnbenchError("participants table not found", file=file) from None
    except OSError as exc:
        raise TurnbenchError(f"cannot read the participants table: {exc}", file=file) from None
    rows: list[dict[str, Any]] = []
    with fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip().lower() for h in next(reader)]
        except StopIteration:
            raise TurnbenchError("participants table is empty", file=file, row=1) from None
        except (csv.Error, UnicodeDecodeError) as exc:
            raise TurnbenchError(f"not a readable CSV: {exc}", file=file, row=1) from None
        missing = [c for c in PARTICIPANT_COLUMNS if c not in header]
        if missing:
            raise TurnbenchError(
                f"participants table lacks column(s) {', '.join(missing)}",
                file=file,
                row=1,
                hint=f"header: {', '.join(PARTICIPANT_COLUMNS)}",
            )
        col = {c: header.index(c) for c in PARTICIPANT_COLUMNS}
        seen: dict[str, int] = {}
        try:
            for cells in reader:
                line = reader.line_num
                if not any(c.strip() for c in cells):
                    continue
                if len(cells) < len(header):
                    cells = cells + [""] * (len(header) - len(cells))

                def cell(name: str, cells: list[str] = cells) -> str:
                    return cells[col[name]].strip()

                subject = cell("subject")
                if not subject:
                    raise TurnbenchError("empty subject", file=file, row=line)
                if subject in seen:
                    raise TurnbenchError(
                        f"subject {subject!r} is listed twice (first on line {seen[subject]})",
                        file=file,
                        row=line,
                    )
                seen[subject] = line
                cohort = cell("cohort").upper()
                if cohort not in COHORTS:
                    raise TurnbenchError(
                        f"cohort {cell('cohort')!r} of {subject!r} is not PD or HC",
                        file=file,
                        row=line,
                    )
                age = _number(cell("age"), column="age", file=file, row=line, lo=0, hi=130)
                years = _number(
                    cell("years_since_diagnosis"),
                    column="years_since_diagnosis",
                    file=file,
                    row=line,
                    lo=0,
                    hi=130,
                )
                if cohort == "HC" and years > 0:
                    raise TurnbenchError(
                        f"healthy control {subject!r} has years_since_diagnosis {years:g}; "
                        "leave it empty",
                        file=file,
                        row=line,
                    )
                if years > age:  # False when either is NaN
                    raise TurnbenchError(
                        f"{subject!r} was diagnosed {years:g} years ago but is {age:g}",
                        file=file,
                        row=line,
                    )
                rows.append(
                    {
                        "subject": subject,
                        "cohort": cohort,
                        "pair": cell("pair"),
                        "sex": cell("sex"),
                        "age": age,
                        "years_since_diagnosis": years,
                    }
                )
        except (csv.Error, UnicodeDecodeError) as exc:
            raise TurnbenchError(
                f"not a readable CSV: {exc}", file=file, row=reader.line_num
            ) from None
    if not rows:
        raise TurnbenchError("participants table lists no subject", file=file)
    out = typed_frame(pd.DataFrame(rows, columns=list(PARTICIPANT_COLUMNS)), PARTICIPANT_COLUMNS)
    out.attrs["source"] = file
    return out


# ---------------------------------------------------------------------------------------
# Adjudication


@dataclass(frozen=True)
class Adjudication:
    """The result of :func:`adjudicate`.

    Attributes
    ----------
    labels
        :data:`LABEL_COLUMNS`, one row per decided turn, ``cohort`` still empty.
    unresolved
        :data:`UNRESOLVED_COLUMNS`, the turns two raters labelled differently with no
        consensus annotation (empty with ``resolve="first-rater"``).
    """

    labels: pd.DataFrame
    unresolved: pd.DataFrame


@dataclass
class _Turn:
    rep: Any  # index label of the annotation that stands for the turn when matching
    members: dict[str, Any]  # rater -> index label, in rater order
    consensus: Any = None


def _label_row(
    records: dict[Any, dict[str, Any]], idx: Any, *, annotator: str, double: bool
) -> dict[str, Any]:
    r = records[idx]
    start, end = float(r["start_s"]), float(r["end_s"])
    return {
        "clip_id": clip_id_for(
            session=r["session"], subject=r["participant"], start_s=start, end_s=end
        ),
        "session": r["session"],
        "subject": r["participant"],
        "cohort": "",
        "annotator": annotator,
        "start_s": start,
        "end_s": end,
        # ELAN times are whole milliseconds; rounding keeps 4.926 - 3.738 at 1.188.
        "duration_s": round(end - start, 3),
        "angle_deg": float(r["angle_deg"]),
        "scenario": r["scenario"],
        "location": r["location"],
        "double_annotated": double,
        "source": r["file"],
    }


def adjudicate(
    annotations: pd.DataFrame,
    *,
    consensus_annotator: str = "consensus",
    min_overlap: float = 0.6,
    resolve: str = "consensus",
) -> Adjudication:
    """Make one turn of the raters' matched annotations and decide its angle.

    Parameters
    ----------
    annotations
        Rows of :func:`turn_datasets.remap.eaf.read_annotations` (index labels unique).
    consensus_annotator
        The rater whose annotations hold adjudicated labels (case-insensitive).
    min_overlap
        Two raters' annotations of one participant are one turn when their overlap over the
        longer duration is at least this (ELAN's reliability matching, greedy, highest ratio
        first; :func:`turn_datasets.remap.agreement.match_annotations`).
    resolve
        ``"consensus"``: a disagreement without a consensus annotation is listed in
        ``unresolved`` and left out of ``labels``. ``"first-rater"``: the first rater's label
        is taken (the rater whose turn tier comes first in the file).

    Returns
    -------
    Adjudication

    Notes
    -----
    Per session and participant the raters are taken in the order of their tiers in the file.
    The first rater's annotations are turns; each further rater's are matched to the turns
    so far (unmatched ones become new turns); consensus annotations are matched to the turns
    last (an unmatched one is a turn only the consensus labelled). A turn then takes, in
    order: its consensus annotation; the single annotation of a turn one rater labelled; the
    first rater's annotation when all raters agree on the angle; else it is a disagreement.
    Times, scenario and location come from the annotation the label is taken from.
    ``double_annotated`` is true when at least two raters (consensus aside) labelled it.
    """
    if resolve not in RESOLVE_CHOICES:
        raise ValueError(f"resolve must be one of {RESOLVE_CHOICES}, not {resolve!r}")
    if not annotations.index.is_unique:
        raise ValueError("annotations have duplicate index labels")
    consensus_key = normalise_value(consensus_annotator)
    rows: list[dict[str, Any]] = []
    unresolved: list[dict[str, Any]] = []
    records = annotations.to_dict("index")
    for (session, participant), group in annotations.groupby(["session", "participant"], sort=True):
        is_consensus = group["annotator"].map(normalise_value) == consensus_key
        raters = list(dict.fromkeys(group.loc[~is_consensus, "annotator"]))
        turns: list[_Turn] = []
        for rater in raters:
            mine = group[group["annotator"] == rater]
            if not turns:
                turns = [_Turn(rep=i, members={rater: i}) for i in mine.index]
                continue
            by_rep = {t.rep: t for t in turns}
            links = match_annotations(group.loc[list(by_rep)], mine, min_overlap=min_overlap)
            for a, b in zip(links["index_a"], links["index_b"], strict=True):
                by_rep[a].members[rater] = b
            linked = set(links["index_b"])
            turns += [_Turn(rep=i, members={rater: i}) for i in mine.index if i not in linked]
        consensus = group[is_consensus]
        if len(consensus):
            by_rep = {t.rep: t for t in turns}
            links = (
                match_annotations(group.loc[list(by_rep)], consensus, min_overlap=min_overlap)
                if by_rep
                else pd.DataFrame({"index_a": [], "index_b": []})
            )
            for a, b in zip(links["index_a"], links["index_b"], strict=True):
                by_rep[a].consensus = b
            linked = set(links["index_b"])
            turns += [
                _Turn(rep=i, members={}, consensus=i) for i in consensus.index if i not in linked
            ]

        for t in turns:
            double = len(t.members) >= 2
            if t.consensus is not None:
                rows.append(
                    _label_row(records, t.consensus, annotator=consensus_annotator, double=double)
                )
                continue
            first_rater, first_idx = next(iter(t.members.items()))
            angles = {float(records[i]["angle_deg"]) for i in t.members.values()}
            if len(angles) == 1 or resolve == "first-rater":
                rows.append(_label_row(records, first_idx, annotator=first_rater, double=double))
                continue
            first = records[first_idx]
            unresolved.append(
                {
                    "session": session,
                    "participant": participant,
                    "start_s": float(first["start_s"]),
                    "end_s": float(first["end_s"]),
                    "values": ", ".join(
                        f"{rater} {records[i]['angle_deg']:g}" for rater, i in t.members.items()
                    ),
                    "file": first["file"],
                    "tier": first["tier"],
                }
            )

    labels = pd.DataFrame(rows, columns=list(LABEL_COLUMNS))
    labels = labels.sort_values(
        ["session", "subject", "start_s", "end_s", "annotator"], kind="mergesort"
    )
    labels = typed_frame(labels, LABEL_COLUMNS)
    dupes = labels["clip_id"][labels["clip_id"].duplicated()]
    if len(dupes):
        raise TurnbenchError(
            f"clip id {dupes.iloc[0]!r} would name two turns",
            hint="session or subject ids that differ only by '_' or spaces",
        )
    unresolved_df = pd.DataFrame(unresolved, columns=list(UNRESOLVED_COLUMNS))
    unresolved_df = typed_frame(
        unresolved_df.sort_values(["session", "participant", "start_s"], kind="mergesort"),
        UNRESOLVED_COLUMNS,
    )
    return Adjudication(labels=labels, unresolved=unresolved_df)


def unresolved_error(unresolved: pd.DataFrame) -> TurnbenchError:
    """The error for disagreements nobody resolved, located at the first of them."""
    first = unresolved.iloc[0]
    n = len(unresolved)
    return TurnbenchError(
        f"{n} turn(s) labelled differently by two raters have no consensus annotation; "
        f"the first: participant {first['participant']!r}, {first['values']}",
        file=first["file"],
        tier=first["tier"],
        time_s=float(first["start_s"]),
        hint="add the agreed value on a turn tier of rater 'consensus', or pass "
        "--resolve first-rater",
    )


def make_labels(
    annotations: pd.DataFrame,
    participants: pd.DataFrame,
    *,
    consensus_annotator: str | None = None,
    min_overlap: float = 0.6,
    resolve: str = "consensus",
    on_unresolved: Callable[[pd.DataFrame], None] | None = None,
) -> pd.DataFrame:
    """The Turn-REMAP labels table: adjudicated turns with their cohort.

    Parameters
    ----------
    annotations
        Rows of :func:`turn_datasets.remap.eaf.read_annotations`.
    participants
        Table of :func:`read_participants`.
    consensus_annotator
        The adjudicating rater (default: the default schema's, ``consensus``).
    min_overlap, resolve
        See :func:`adjudicate`.
    on_unresolved
        Called with every unresolved disagreement (:data:`UNRESOLVED_COLUMNS`) before the
        error is raised, so a caller can list them all (the command line prints them).

    Returns
    -------
    pandas.DataFrame
        :data:`LABEL_COLUMNS`, sorted by session, subject and time.

    Raises
    ------
    TurnbenchError
        A participant of the annotations is not in the table (naming the ``.eaf`` file, the
        tier and the time of its first turn); disagreements without consensus when
        ``resolve="consensus"`` (:func:`unresolved_error`).
    """
    if consensus_annotator is None:
        consensus_annotator = load_schema().consensus_annotator
    known = set(participants["subject"])
    unknown = annotations[~annotations["participant"].isin(known)]
    if len(unknown):
        first = unknown.iloc[0]
        table = participants.attrs.get("source", "the participants table")
        raise TurnbenchError(
            f"participant {first['participant']!r} is not in {table}",
            file=first["file"],
            tier=first["tier"],
            time_s=float(first["start_s"]),
        )
    adj = adjudicate(
        annotations,
        consensus_annotator=consensus_annotator,
        min_overlap=min_overlap,
        resolve=resolve,
    )
    if len(adj.unresolved) and resolve == "consensus":
        if on_unresolved is not None:
            on_unresolved(adj.unresolved)
        raise unresolved_error(adj.unresolved)
    cohort = dict(zip(participants["subject"], participants["cohort"], strict=True))
    labels = adj.labels.copy()
    labels["cohort"] = labels["subject"].map(cohort).fillna("")
    return typed_frame(labels, LABEL_COLUMNS)


# ---------------------------------------------------------------------------------------
# Reading a labels file back, and the paper's tables

_STATS_NEEDS = ("clip_id", "subject", "cohort", "angle_deg", "scenario", "location")


def read_labels(path: str | PathLike[str]) -> pd.DataFrame:
    """Read a labels CSV for :func:`table1`/:func:`table2` (errors name file and line).

    Only the columns the tables need are required; the others are kept as text.
    """
    file = str(path)
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False, encoding="utf-8-sig")
    except FileNotFoundError:
        raise TurnbenchError("labels file not found", file=file) from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"not a readable CSV: {exc}", file=file) from None
    missing = [c for c in _STATS_NEEDS if c not in df.columns]
    if missing:
        raise TurnbenchError(f"labels lack column(s) {', '.join(missing)}", file=file, row=1)
    angle = pd.to_numeric(df["angle_deg"], errors="coerce")
    bad = angle.isna() | ~np.isfinite(angle)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise TurnbenchError(
            f"angle_deg {df['angle_deg'].iloc[i]!r} is not a number", file=file, row=i + 2
        )
    absurd = angle.abs() > MAX_ANGLE_DEG
    if absurd.any():
        i = int(np.flatnonzero(absurd.to_numpy())[0])
        raise TurnbenchError(
            f"angle_deg {angle.iloc[i]:g} is beyond the plausible {MAX_ANGLE_DEG:g} "
            "(see the README)",
            file=file,
            row=i + 2,
        )
    df["angle_deg"] = angle.astype("float64")
    cohort = df["cohort"].str.strip().str.upper()
    bad = ~cohort.isin(COHORTS)
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise TurnbenchError(
            f"cohort {df['cohort'].iloc[i]!r} is not PD or HC", file=file, row=i + 2
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


# ---------------------------------------------------------------------------------------
# Rendering the tables


def _num(value: float, digits: int = 1) -> str:
    return "–" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def _mean_sd(mean: float, sd: float) -> str:
    if not np.isfinite(mean):
        return "–"
    return f"{mean:.1f}" if not np.isfinite(sd) else f"{mean:.1f} ± {sd:.1f}"


def _md(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + [
        "| " + " | ".join(r) + " |" for r in rows
    ]


def _angle_name(col: Any) -> str:
    return "total" if col == "total" else f"{col}°"


def stats_markdown(t1: pd.DataFrame, t2: pd.DataFrame, locations: pd.DataFrame) -> str:
    """Markdown of :func:`table1`, :func:`table2` and :func:`turns_per_location`."""
    lines = ["## Table 1: subjects and turns per cohort", ""]
    lines += _md(
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
    lines += _md(
        ["scenario", *(_angle_name(c) for c in t2.columns)],
        [
            [str(idx), *(str(int(v)) for v in row)]
            for idx, row in zip(t2.index, t2.to_numpy(), strict=True)
        ],
    )
    lines += ["", "## Turns per location and cohort", ""]
    lines += _md(
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
