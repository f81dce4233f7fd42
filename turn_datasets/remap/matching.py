"""Matching two raters' turn annotations, and pairing them into compared items.

Matching follows ELAN's own inter-annotator reliability ("modified kappa", Holle & Rein
2015): two annotations of the same participant in the same session are linked when their
overlap divided by the duration of the *longer* one is at least ``min_overlap``; links are
made greedily, highest ratio first, each annotation used at most once. The adjudication of
labels (:mod:`turn_datasets.remap.labels`) and the agreement audit
(:mod:`turn_datasets.remap.agreement`) both match so.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame

__all__ = [
    "MATCH_COLUMNS",
    "match_annotations",
    "PAIR_COLUMNS",
    "DISAGREEMENT_COLUMNS",
    "UNMATCHED",
    "default_raters",
    "pair_items",
    "disagreements",
]


#: Column contract of :func:`match_annotations`.
MATCH_COLUMNS = {"index_a": "int64", "index_b": "int64", "overlap_ratio": "float64"}


#: Overlap ratios are computed in floating point; a ratio meant to equal ``min_overlap``
#: exactly (0.6 s of a 1.0 s turn) can come out a hair below it, so the test allows this.
_RATIO_TOLERANCE = 1e-9


_KEYS = ("session", "participant")


def _check_columns(df: pd.DataFrame, name: str) -> None:
    missing = [c for c in (*_KEYS, "start_s", "end_s") if c not in df.columns]
    if missing:
        raise ValueError(f"annotations {name} lack columns {missing}")


def _overlapping_pairs(a: pd.DataFrame, b: pd.DataFrame) -> dict[str, np.ndarray]:
    """Every pair of an annotation of ``a`` and one of ``b`` of the same session and
    participant whose intervals overlap, found by sweeping start-sorted intervals.

    Pairing every annotation with every other of its participant took memory quadratic in
    the annotations (11 GB for 10,000 per rater). Here, per participant, ``b`` is sorted by
    start and the running maximum of its ends is kept: the annotations of ``b`` that can
    overlap one of ``a`` lie between the first whose running end passes ``a``'s start and the
    last that starts before ``a``'s end, both found by binary search. For a rater's tier,
    whose turns do not overlap, that range holds only the overlapping annotations, so time
    and memory grow with the number of annotations plus the overlapping pairs.

    Returns positions (row numbers in ``a`` and ``b``) and times, one entry per pair;
    annotations without a positive duration are left out (they are never linked).
    """

    def side(df: pd.DataFrame) -> tuple[pd.DataFrame, np.ndarray]:
        start = df["start_s"].to_numpy(dtype="float64")
        end = df["end_s"].to_numpy(dtype="float64")
        pos = np.flatnonzero(end > start)
        keys = pd.DataFrame({k: df[k].to_numpy(dtype=object)[pos] for k in _KEYS}, index=pos)
        return keys, np.column_stack([start[pos], end[pos]]) if pos.size else np.empty((0, 2))

    keys_a, times_a = side(a)
    keys_b, times_b = side(b)
    parts: list[tuple[np.ndarray, np.ndarray]] = []
    groups_b = keys_b.groupby(list(_KEYS), sort=False, dropna=False).indices if len(keys_b) else {}
    if len(keys_a):
        for key, rows_a in keys_a.groupby(list(_KEYS), sort=False, dropna=False).indices.items():
            rows_b = groups_b.get(key)
            if rows_b is None:
                continue
            order = rows_b[np.argsort(times_b[rows_b, 0], kind="stable")]
            sb = times_b[order, 0]
            reach = np.maximum.accumulate(times_b[order, 1])
            sa, ea = times_a[rows_a, 0], times_a[rows_a, 1]
            lo = np.searchsorted(reach, sa, side="right")
            hi = np.searchsorted(sb, ea, side="left")
            count = np.maximum(hi - lo, 0)
            if not count.any():
                continue
            which_a = np.repeat(np.arange(rows_a.size), count)
            offset = np.arange(which_a.size) - np.repeat(np.cumsum(count) - count, count)
            which_b = order[np.repeat(lo, count) + offset]
            overlaps = times_b[which_b, 1] > sa[which_a]
            parts.append((rows_a[which_a[overlaps]], which_b[overlaps]))
    ia = np.concatenate([p[0] for p in parts]) if parts else np.empty(0, dtype=np.intp)
    ib = np.concatenate([p[1] for p in parts]) if parts else np.empty(0, dtype=np.intp)
    return {
        "pos_a": keys_a.index.to_numpy()[ia].astype(np.int64),
        "pos_b": keys_b.index.to_numpy()[ib].astype(np.int64),
        "start_a": times_a[ia, 0],
        "end_a": times_a[ia, 1],
        "start_b": times_b[ib, 0],
        "end_b": times_b[ib, 1],
    }


def match_annotations(
    a: pd.DataFrame, b: pd.DataFrame, *, min_overlap: float = 0.6
) -> pd.DataFrame:
    """Link annotations of rater A to those of rater B, as ELAN's reliability check does.

    Parameters
    ----------
    a, b
        One rater's annotations each, with columns ``session``, ``participant``, ``start_s``
        and ``end_s`` (seconds). Their index labels identify the annotations and must be
        unique; any other column is ignored.
    min_overlap
        Smallest ``overlap / max(duration_a, duration_b)`` for a link, in ``(0, 1]``
        (ELAN's default and the issue's: 0.6).

    Returns
    -------
    pandas.DataFrame
        ``index_a, index_b, overlap_ratio`` (:data:`MATCH_COLUMNS`), one row per link, each
        index label at most once, in the row order of ``a``.

    Notes
    -----
    Only annotations with the same ``session`` and ``participant`` can be linked. Candidate
    pairs are taken in order of decreasing ratio; ties are broken by the smaller absolute
    start difference, then by the position of the annotations in ``a`` and in ``b``, so the
    result never depends on hash order. An annotation with zero or negative duration is
    never linked (its ratio is undefined).
    """
    if not 0.0 < float(min_overlap) <= 1.0:
        raise TurnbenchError(
            f"min_overlap must be in (0, 1], got {min_overlap}", item="min_overlap"
        )
    _check_columns(a, "a")
    _check_columns(b, "b")
    for df, name in ((a, "a"), (b, "b")):
        if not df.index.is_unique:
            raise ValueError(f"annotations {name} have duplicate index labels")

    pairs = _overlapping_pairs(a, b)
    overlap = np.minimum(pairs["end_a"], pairs["end_b"]) - np.maximum(
        pairs["start_a"], pairs["start_b"]
    )
    longer = np.maximum(pairs["end_a"] - pairs["start_a"], pairs["end_b"] - pairs["start_b"])
    ratio = overlap / longer if overlap.size else np.empty(0)
    keep = (overlap > 0) & (ratio >= float(min_overlap) - _RATIO_TOLERANCE)
    pairs = pd.DataFrame(
        {
            "pos_a": pairs["pos_a"][keep],
            "pos_b": pairs["pos_b"][keep],
            "ratio": ratio[keep],
            "start_gap": np.abs(pairs["start_a"] - pairs["start_b"])[keep],
        }
    )
    pairs = pairs.sort_values(
        ["ratio", "start_gap", "pos_a", "pos_b"],
        ascending=[False, True, True, True],
        kind="mergesort",
    )

    used_a: set[int] = set()
    used_b: set[int] = set()
    rows: list[tuple[int, int, float]] = []
    for pos_a, pos_b, ratio in zip(
        pairs["pos_a"].to_numpy(),
        pairs["pos_b"].to_numpy(),
        pairs["ratio"].to_numpy(),
        strict=True,
    ):
        if pos_a in used_a or pos_b in used_b:
            continue
        used_a.add(int(pos_a))
        used_b.add(int(pos_b))
        rows.append((int(pos_a), int(pos_b), float(min(ratio, 1.0))))
    rows.sort()

    out = pd.DataFrame(
        {
            "index_a": [a.index[r[0]] for r in rows],
            "index_b": [b.index[r[1]] for r in rows],
            "overlap_ratio": [r[2] for r in rows],
        }
    )
    # Index labels are usually the integer row numbers of the annotations table; keep other
    # labels (strings) as they are rather than failing the int64 contract.
    dtypes = dict(MATCH_COLUMNS)
    for col, df in (("index_a", a), ("index_b", b)):
        if not pd.api.types.is_integer_dtype(df.index.dtype):
            dtypes[col] = "object"
    return out.astype(dtypes).reset_index(drop=True)


#: One row per compared item of two raters (``pairs.csv``): a matched pair, or an annotation
#: of one rater that the other has no partner for (``status`` ``unmatched_a``/``unmatched_b``).
PAIR_COLUMNS = {
    "session": "object",
    "participant": "object",
    "status": "object",
    "start_a_s": "float64",
    "end_a_s": "float64",
    "angle_a_deg": "float64",
    "start_b_s": "float64",
    "end_b_s": "float64",
    "angle_b_deg": "float64",
    "overlap_ratio": "float64",
    "agree": "bool",
    "file": "object",
}


#: One row per disagreement for review (``disagreements.csv``): ``kind`` is ``angle`` (a
#: matched pair with different angles) or ``unmatched`` (one rater only; the other's columns
#: empty).
DISAGREEMENT_COLUMNS = {
    "session": "object",
    "participant": "object",
    "kind": "object",
    "rater_a": "object",
    "start_a_s": "float64",
    "end_a_s": "float64",
    "angle_a_deg": "float64",
    "rater_b": "object",
    "start_b_s": "float64",
    "end_b_s": "float64",
    "angle_b_deg": "float64",
    "overlap_ratio": "float64",
    "file": "object",
}


_STATUS_ORDER = {"matched": 0, "unmatched_a": 1, "unmatched_b": 2}


UNMATCHED = "unmatched"


def check_annotations(annotations: pd.DataFrame) -> None:
    need = ("session", "file", "annotator", "participant", "start_s", "end_s", "angle_deg")
    missing = [c for c in need if c not in annotations.columns]
    if missing:
        raise ValueError(f"annotations lack columns {missing}")


def default_raters(
    annotations: pd.DataFrame, *, consensus_annotator: str = "consensus"
) -> tuple[str, str]:
    """The two raters to compare when none are named: the non-consensus raters present.

    Raises
    ------
    TurnbenchError
        There are not exactly two (the message lists those found and suggests ``--raters``).
    """
    names = sorted(
        {
            str(r)
            for r in annotations["annotator"].dropna().unique()
            if str(r).casefold().strip() != consensus_annotator.casefold().strip()
        },
        key=lambda r: (r.casefold(), r),
    )
    if len(names) != 2:
        found = ", ".join(repr(n) for n in names) or "none"
        raise TurnbenchError(
            f"the agreement audit compares two raters; found {len(names)} besides "
            f"{consensus_annotator!r}: {found}",
            hint="name the two with --raters A B" if len(names) > 2 else None,
        )
    return names[0], names[1]


def pair_items(
    annotations: pd.DataFrame, *, rater_a: str, rater_b: str, min_overlap: float = 0.6
) -> tuple[pd.DataFrame, dict[str, int]]:
    """Match two raters' annotations and list every compared item.

    Parameters
    ----------
    annotations
        Every rater's rows (``eaf.read_annotations``).
    rater_a, rater_b
        The two raters (values of ``annotator``).
    min_overlap
        See :func:`match_annotations`.

    Returns
    -------
    items : pandas.DataFrame
        :data:`PAIR_COLUMNS`, sorted by session, participant and time: the matched pairs and
        the unmatched annotations of the (session, participant) units both raters labelled.
    single_annotated : dict
        Rater -> number of annotations in units the other rater did not label (left out).
    """
    check_annotations(annotations)
    a = annotations[annotations["annotator"] == rater_a]
    b = annotations[annotations["annotator"] == rater_b]
    units_a = set(zip(a["session"], a["participant"], strict=True))
    units_b = set(zip(b["session"], b["participant"], strict=True))
    both = units_a & units_b
    in_a = [u in both for u in zip(a["session"], a["participant"], strict=True)]
    in_b = [u in both for u in zip(b["session"], b["participant"], strict=True)]
    single = {rater_a: int(len(a) - sum(in_a)), rater_b: int(len(b) - sum(in_b))}
    a = a[in_a].reset_index(drop=True)
    b = b[in_b].reset_index(drop=True)

    links = match_annotations(a, b, min_overlap=min_overlap)
    ia = links["index_a"].to_numpy(dtype=int)
    ib = links["index_b"].to_numpy(dtype=int)
    matched = pd.DataFrame(
        {
            "session": a["session"].to_numpy()[ia],
            "participant": a["participant"].to_numpy()[ia],
            "status": "matched",
            "start_a_s": a["start_s"].to_numpy()[ia],
            "end_a_s": a["end_s"].to_numpy()[ia],
            "angle_a_deg": a["angle_deg"].to_numpy()[ia],
            "start_b_s": b["start_s"].to_numpy()[ib],
            "end_b_s": b["end_s"].to_numpy()[ib],
            "angle_b_deg": b["angle_deg"].to_numpy()[ib],
            "overlap_ratio": links["overlap_ratio"].to_numpy(),
            "file": a["file"].to_numpy()[ia],
        }
    )
    rest_a = a.drop(index=ia)
    rest_b = b.drop(index=ib)
    unmatched_a = pd.DataFrame(
        {
            "session": rest_a["session"].to_numpy(),
            "participant": rest_a["participant"].to_numpy(),
            "status": "unmatched_a",
            "start_a_s": rest_a["start_s"].to_numpy(),
            "end_a_s": rest_a["end_s"].to_numpy(),
            "angle_a_deg": rest_a["angle_deg"].to_numpy(),
            "file": rest_a["file"].to_numpy(),
        }
    )
    unmatched_b = pd.DataFrame(
        {
            "session": rest_b["session"].to_numpy(),
            "participant": rest_b["participant"].to_numpy(),
            "status": "unmatched_b",
            "start_b_s": rest_b["start_s"].to_numpy(),
            "end_b_s": rest_b["end_s"].to_numpy(),
            "angle_b_deg": rest_b["angle_deg"].to_numpy(),
            "file": rest_b["file"].to_numpy(),
        }
    )
    parts = [df for df in (matched, unmatched_a, unmatched_b) if len(df)]
    items = (
        pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=list(PAIR_COLUMNS))
    )
    for col in PAIR_COLUMNS:
        if col not in items.columns:
            items[col] = np.nan
    items["agree"] = (items["status"] == "matched") & (items["angle_a_deg"] == items["angle_b_deg"])
    # Sort by where the item happens, so the table reads like the timeline.
    items["_t"] = items[["start_a_s", "start_b_s"]].min(axis=1)
    items["_s"] = items["status"].map(_STATUS_ORDER)
    items = items.sort_values(["session", "participant", "_t", "_s"], kind="mergesort").drop(
        columns=["_t", "_s"]
    )
    return typed_frame(items, PAIR_COLUMNS), single


def disagreements(items: pd.DataFrame, *, rater_a: str, rater_b: str) -> pd.DataFrame:
    """The items to review: matched pairs with different angles, and unmatched annotations."""
    rows = items[~items["agree"]].copy()
    rows["kind"] = np.where(rows["status"] == "matched", "angle", UNMATCHED)
    rows["rater_a"] = rater_a
    rows["rater_b"] = rater_b
    return typed_frame(rows, DISAGREEMENT_COLUMNS)
