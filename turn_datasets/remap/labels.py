"""Turn-REMAP labels: one row per turn after adjudication.

In the paper (Cheng et al., Section 3.2) two clinicians labelled the turns of 24 people
(12 with Parkinson's disease, 12 healthy controls) in ELAN; about half of the turns were
labelled by both, and disagreements were resolved before the labels were used. Here:

- :func:`turn_datasets.remap.participants.read_participants` reads and checks the
  participants table (``subject, cohort, pair, sex, age, years_since_diagnosis``; cohort
  ``PD`` or ``HC``).
- :func:`adjudicate` makes one turn of the matched annotations of two raters (matched as in
  the agreement audit, :func:`turn_datasets.remap.matching.match_annotations`), lets the
  consensus rater decide where they disagree, and lists what no one decided.
- :func:`make_labels` adds the cohort and gives the labels table of DESIGN.md.
- :mod:`turn_datasets.remap.stats` summarises a label set as the paper's Table 1 (subjects,
  turns, ages, years since diagnosis) and Table 2 (turns per scenario and angle).

``clip_id`` is ``{session}_{subject}_{start_ms}-{end_ms}`` (times in whole milliseconds as in
ELAN, spaces replaced by ``-``), mirroring the Turn-H3.6M clip id; it is unique because two
turns of one subject with the same times would have been matched into one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.remap.matching import match_annotations
from turn_datasets.remap.schema import load_schema, normalise_value

__all__ = [
    "MIN_LABELLED_TURN_DEG",
    "LABEL_COLUMNS",
    "RESOLVE_CHOICES",
    "UNRESOLVED_COLUMNS",
    "Adjudication",
    "adjudicate",
    "clip_id_for",
    "make_labels",
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

RESOLVE_CHOICES = ("consensus", "first-rater")
#: The smallest turn Turn-REMAP labels: its smallest label is the 90° bin, and a turn under
#: 67.5° (half a 45° bin below it) rounds to 45°. A detector run on REMAP-like sessions
#: takes it as its ``min_turn_deg``.
MIN_LABELLED_TURN_DEG = 67.5


def clip_id_for(*, session: str, subject: str, start_s: float, end_s: float) -> str:
    """``{session}_{subject}_{start_ms}-{end_ms}`` with spaces replaced by ``-``."""
    start_ms = int(round(start_s * 1000))
    end_ms = int(round(end_s * 1000))
    return "_".join(str(x).strip().replace(" ", "-") for x in (session, subject)) + (
        f"_{start_ms}-{end_ms}"
    )


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


def _overlapping(rows: list[dict[str, Any]], start: float, end: float) -> bool:
    return any(r["start_s"] < end and start < r["end_s"] for r in rows)


def _without_overlaps(
    chosen: list[tuple[dict[str, Any], int, Any]],
    records: dict[Any, dict[str, Any]],
    *,
    resolve: str,
    unresolved: list[dict[str, Any]],
) -> list[dict[str, Any]]:
    """One participant's labels with no two overlapping in time.

    Two raters' turns that overlap too little to be matched (overlap ratio below
    ``min_overlap``) would otherwise both become labels: two turns of one person at once.
    The consensus rater's labels stand, and a rater's label overlapping one of them goes
    (the consensus decided that stretch). The other labels are swept in start order into
    clusters of overlapping ones; in a cluster of several, ``resolve="first-rater"`` keeps the
    labels of the first rater present, and ``"consensus"`` lists the cluster as unresolved,
    like an angle disagreement.
    """
    consensus = [row for row, rank, _ in chosen if rank < 0]
    others = sorted(
        (
            c
            for c in chosen
            if c[1] >= 0 and not _overlapping(consensus, c[0]["start_s"], c[0]["end_s"])
        ),
        key=lambda c: (c[0]["start_s"], c[0]["end_s"]),
    )
    clusters: list[list[tuple[dict[str, Any], int, Any]]] = []
    reach = float("-inf")
    for c in others:
        if clusters and c[0]["start_s"] < reach:
            clusters[-1].append(c)
            reach = max(reach, c[0]["end_s"])
        else:
            clusters.append([c])
            reach = c[0]["end_s"]
    kept = list(consensus)
    for cluster in clusters:
        if len(cluster) == 1 or resolve == "first-rater":
            best = min(rank for _, rank, _ in cluster)
            kept += [row for row, rank, _ in cluster if rank == best]
            continue
        first = records[cluster[0][2]]
        unresolved.append(
            {
                "session": first["session"],
                "participant": first["participant"],
                "start_s": min(row["start_s"] for row, _, _ in cluster),
                "end_s": max(row["end_s"] for row, _, _ in cluster),
                "values": "overlapping turns: "
                + ", ".join(
                    f"{row['annotator']} {row['angle_deg']:g} "
                    f"({row['start_s']:.3f}-{row['end_s']:.3f} s)"
                    for row, _, _ in cluster
                ),
                "file": first["file"],
                "tier": first["tier"],
            }
        )
    return kept


def _group_turns(
    group: pd.DataFrame, raters: list, consensus: pd.DataFrame, *, min_overlap: float
) -> list[_Turn]:
    """One participant's annotations in one session as turns (see :func:`adjudicate`'s
    notes): the first rater's are turns, each further rater's are matched to them (or are
    new turns), the consensus annotations last."""
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
        turns += [_Turn(rep=i, members={}, consensus=i) for i in consensus.index if i not in linked]
    return turns


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
    Times, scenario and location come from the annotation the label is taken from. Labels of
    one participant never overlap: turns of two raters that overlap too little to be matched
    are a disagreement too (see :func:`_without_overlaps`).
    ``double_annotated`` is true when at least two raters (consensus aside) labelled it.
    """
    if resolve not in RESOLVE_CHOICES:
        raise TurnbenchError(
            f"resolve must be one of {RESOLVE_CHOICES}, not {resolve!r}", item="resolve"
        )
    if not annotations.index.is_unique:
        raise ValueError("annotations have duplicate index labels")
    consensus_key = normalise_value(consensus_annotator)
    rows: list[dict[str, Any]] = []
    unresolved: list[dict[str, Any]] = []
    records = annotations.to_dict("index")
    for (session, participant), group in annotations.groupby(["session", "participant"], sort=True):
        is_consensus = group["annotator"].map(normalise_value) == consensus_key
        raters = list(dict.fromkeys(group.loc[~is_consensus, "annotator"]))
        turns = _group_turns(group, raters, group[is_consensus], min_overlap=min_overlap)
        rank = {rater: k for k, rater in enumerate(raters)}
        chosen: list[tuple[dict[str, Any], int, Any]] = []  # label row, rater rank, source
        for t in turns:
            double = len(t.members) >= 2
            if t.consensus is not None:
                row = _label_row(records, t.consensus, annotator=consensus_annotator, double=double)
                chosen.append((row, -1, t.consensus))
                continue
            first_rater, first_idx = next(iter(t.members.items()))
            angles = {float(records[i]["angle_deg"]) for i in t.members.values()}
            if len(angles) == 1 or resolve == "first-rater":
                row = _label_row(records, first_idx, annotator=first_rater, double=double)
                chosen.append((row, rank[first_rater], first_idx))
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
        rows += _without_overlaps(chosen, records, resolve=resolve, unresolved=unresolved)

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
        Table of :func:`turn_datasets.remap.participants.read_participants`.
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
