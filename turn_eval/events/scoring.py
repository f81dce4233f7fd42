"""``score_events``: detected turns in untrimmed sessions scored against time-stamped labels.

What is reported, on top of the matching of :mod:`turn_eval.events.matching`:

Detection
    TP, FP, FN, precision TP/(TP+FP), recall TP/(TP+FN) and F1 2TP/(2TP+FP+FN), overall and
    per group. A TP and an FN take the group of their reference turn; an FP, which has none,
    takes the group of its (session, subject) for columns constant within it (subject,
    cohort, a clip index's action), and for ``scenario`` and ``location`` the context in force
    at its midpoint (``context.csv``: the participant's own context intervals first, then the
    session's shared ones). Without a context file, or where no context interval covers the
    midpoint, an FP is in the group :data:`UNKNOWN_GROUP`.
Matched turns
    On the TP pairs, the harness's own angle metrics, with the same code as ``turn-eval
    score`` (:func:`turn_eval.clips.metrics.clip_outcomes`, :func:`turn_eval.clips.metrics.metrics_of`,
    :func:`turn_eval.clips.metrics.grouped_metrics`): accuracy of the 45° bin, MAE, WPrec, and
    the MAE of angular speed when the detections give ``speed_deg_s`` (against the reference
    angle over the reference duration, equation 4; pairs whose detection has no speed are
    left out of it). Direction agreement when both sides have ``direction``; the medians of
    ``|Δstart|`` and ``|Δend|`` in seconds.
Turns per hour
    With ``sessions``: per (session, subject), reference and detected turns over the
    annotated duration, and the mean absolute difference over the units.
Average precision
    When the detections carry ``score``: :mod:`turn_eval.events.ap`.
Intervals
    Cluster bootstrap over (session, subject) units (:mod:`turn_eval.events.bootstrap`) for
    precision, recall, F1, matched accuracy and MAE, overall, per group and for the groups'
    unweighted average (the paper's "Avg.").
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, TypeAlias

import numpy as np
import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import BIN_WIDTH_DEG
from turn_datasets.render.order import natural_key
from turn_eval.clips.metrics import Partition, clip_outcomes, grouped_metrics
from turn_eval.events.ap import AP_IOUS, average_precision
from turn_eval.events.bootstrap import (
    CI_METRICS,
    COMPONENTS,
    cluster_bootstrap,
    event_metrics,
)
from turn_eval.events.contract import CONTEXT_GROUPS
from turn_eval.events.matching import IOU, MatchParams, categorize_events, overlapping_pairs
from turn_eval.events.reading import (
    Units,
    check_context,
    check_detections_pairs,
    check_event_reference_pairs,
    check_sessions,
    check_within_durations,
    drop_unknown,
    pair_codes,
    read_context,
    read_detections_pairs,
    read_event_reference_pairs,
    read_sessions,
    units_of_pairs,
)
from turn_eval.events.time_unit import check_time_unit
from turn_eval.scoring.bootstrap import CONFIDENCE, unit_sums
from turn_eval.scoring.groups import BLANK_GROUP, average, check_groupings, split_by
from turn_eval.scoring.signature import Signature

__all__ = ["DEFAULT_BY", "UNKNOWN_GROUP", "MATCHING_RULE", "EventScores", "score_events"]

#: Groupings reported when ``by`` is not given, those the reference has (the clinical
#: groupings, and a clip index's action).
DEFAULT_BY = ("cohort", "scenario", "location", "subject", "action")
#: The group of a false detection whose group is not known (no context at its midpoint).
UNKNOWN_GROUP = "unknown"
#: The matching rule, printed beside every table (as sed_eval and ActivityNet state theirs).
MATCHING_RULE = (
    "per (session, subject), one-to-one; eligible pairs at temporal IoU >= {iou:g}; the "
    "matching with the most pairs, then the largest total IoU"
)
#: The matched-pair metrics, in the order of the tables.
MATCHED_METRICS = (
    "accuracy",
    "mae_deg",
    "wprec",
    "mae_speed_deg_s",
    "direction_agreement",
    "median_abs_dstart_s",
    "median_abs_dend_s",
)

Progress = Callable[[Iterable[np.ndarray], int], Iterable[np.ndarray]]
Frame: TypeAlias = pd.DataFrame | str | os.PathLike[str]


#: What a run without detections says (in the Markdown and on stderr): "–" is not a zero.
NO_DETECTIONS = (
    "No detections: recall is 0 and precision is undefined (no detection to count as right "
    "or wrong), shown as – and null."
)


@dataclass(frozen=True)
class EventScores:
    """The result of :func:`score_events`.

    Attributes
    ----------
    doc
        The JSON-able scores document (``overall``, ``by``, ``counts``, ``settings``).
    rates
        Turns per hour per (session, subject), or None without ``sessions``.
    pr_curves
        Per AP threshold, ``precision`` and ``recall`` after each ranked detection, or None.
    detections, reference
        The validated inputs (detections of unannotated units dropped), rows as numbered in
        :attr:`events`.
    """

    doc: dict[str, Any]
    rates: pd.DataFrame | None = field(repr=False, default=None)
    pr_curves: dict[str, dict[str, np.ndarray]] | None = field(repr=False, default=None)
    detections: pd.DataFrame | None = field(repr=False, default=None)
    reference: pd.DataFrame | None = field(repr=False, default=None)
    _parts: tuple = field(repr=False, default=())

    def to_dict(self) -> dict[str, Any]:
        """The scores document (the ``--format json`` output)."""
        return self.doc

    @cached_property
    def events(self) -> pd.DataFrame:
        """One row per TP pair, FP and FN (:data:`turn_eval.events.matching.EVENT_COLUMNS`
        plus ``session, subject``, both sides' times and angles, and each grouping's group as
        ``group_<column>``); built when first asked for."""
        return _events_table(*self._parts)


def _load(value: Frame | None, reader, checker):
    if value is None:
        return None
    if isinstance(value, pd.DataFrame):
        return checker(value)
    return reader(value)


#: Factorisations of the reference's text columns (codes, distinct values), by column: each
#: column is factorised once for choosing the groupings and for grouping the events.
_Factorized = dict[str, tuple[np.ndarray, np.ndarray]]


def _factorize(
    reference: pd.DataFrame, col: str, cache: _Factorized
) -> tuple[np.ndarray, np.ndarray]:
    """``pandas.factorize`` of a reference text column, computed once per ``cache``."""
    if col not in cache:
        cache[col] = pd.factorize(reference[col].to_numpy(dtype=object))
    return cache[col]


def _has_text(reference: pd.DataFrame, col: str, cache: _Factorized) -> bool:
    """Whether a text column has a non-empty cell (through its distinct values: an
    element-wise comparison of object cells costs far more)."""
    return any(v != "" for v in _factorize(reference, col, cache)[1])


def _groupings(
    reference: pd.DataFrame, by: Sequence[str] | None, cache: _Factorized | None = None
) -> list[str]:
    text_cols = [
        c
        for c in reference.columns
        if c not in ("session", "start_s", "end_s", "angle_deg", "direction")
    ]
    if not split_by(by):
        cache = {} if cache is None else cache
        return [c for c in DEFAULT_BY if c in text_cols and _has_text(reference, c, cache)]
    return check_groupings(by, text_cols, default=(), file=reference.attrs.get("path"))


def _context_at(
    context: pd.DataFrame, units: Units, unit: np.ndarray, time_s: np.ndarray
) -> dict[str, np.ndarray]:
    """Each column of :data:`CONTEXT_GROUPS` at the given times of the given units ("" where
    none covers it): the participant's own intervals first, then the session's shared ones."""
    out = {c: np.full(time_s.shape[0], "", dtype=object) for c in CONTEXT_GROUPS}
    if context.shape[0] == 0 or time_s.shape[0] == 0:
        return out
    # One numbering of the (session, subject) pairs of the context's rows and of the units,
    # each unit with its own subject and with the session's shared "" (a few thousand names,
    # not one per time).
    n_ctx, n_units = context.shape[0], len(units)
    ctx_key, own, shared = (
        codes.astype(np.float64)
        for codes in pair_codes(
            np.concatenate(
                [context["session"].to_numpy(dtype=object), units.sessions, units.sessions]
            ),
            np.concatenate(
                [
                    context["subject"].to_numpy(dtype=object),
                    units.subjects,
                    np.full(n_units, "", dtype=object),
                ]
            ),
            split=[n_ctx, n_ctx + n_units],
        )
    )
    start = context["start_s"].to_numpy(dtype=np.float64)
    end = context["end_s"].to_numpy(dtype=np.float64)
    order = np.lexsort((start, ctx_key))
    sorted_keys = ctx_key[order] + 1j * start[order]
    for unit_key in (own, shared):
        # A pair the context lacks has a number no context row has: never a hit.
        key = unit_key[unit]
        todo = (out[CONTEXT_GROUPS[0]] == "") & (out[CONTEXT_GROUPS[1]] == "")
        pos = np.searchsorted(sorted_keys, key + 1j * time_s, side="right") - 1
        row = order[np.maximum(pos, 0)]
        hit = todo & (pos >= 0) & (ctx_key[row] == key) & (end[row] > time_s)
        for c in CONTEXT_GROUPS:
            out[c][hit] = context[c].to_numpy(dtype=object)[row[hit]]
    return out


def _constant_per(key: np.ndarray, codes: np.ndarray, n_keys: int) -> np.ndarray:
    """Per key, the one code of ``codes`` its rows share, -1 where they differ or are none."""
    low = np.full(n_keys, np.iinfo(np.int64).max)
    high = np.full(n_keys, -1)
    np.minimum.at(low, key, codes)
    np.maximum.at(high, key, codes)
    return np.where(low == high, high, -1)


def _unit_codes(
    codes: np.ndarray, ref_unit: np.ndarray, subject: np.ndarray, unit_subject: np.ndarray
) -> np.ndarray:
    """Each unit's code of a reference column where the column is constant over the unit's
    turns, else over its subject's turns (a unit without turns, in sessions.csv only), else
    -1 (not known).

    ``codes`` and ``subject`` are the reference rows' codes of the column and of the
    subject; ``unit_subject`` each unit's subject code (-1 for a subject without turns).
    """
    per_unit = _constant_per(np.asarray(ref_unit, dtype=np.int64), codes, unit_subject.shape[0])
    per_subject = _constant_per(subject, codes, int(subject.max(initial=-1)) + 1)
    from_subject = np.where(unit_subject >= 0, per_subject[np.maximum(unit_subject, 0)], -1)
    return np.where(per_unit >= 0, per_unit, from_subject)


def _named(
    values: np.ndarray, empty: str, factorized: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, list[str]]:
    """Codes and names of text values (a factorisation, or ``factorized`` when already
    made), ``empty`` naming the empty text."""
    codes, uniq = (
        pd.factorize(np.asarray(values, dtype=object)) if factorized is None else factorized
    )
    return codes, [empty if u == "" else str(u) for u in uniq]


def _partition(name: str, parts: Sequence[tuple[np.ndarray, list[str]]]) -> Partition:
    """One grouping from codes and names of several sets of events (the names merged, in
    natural order: S2 before S11)."""
    index: dict[str, int] = {}
    codes = []
    for part_codes, names in parts:
        mapping = np.array([index.setdefault(n, len(index)) for n in names], dtype=np.int64)
        codes.append(mapping[part_codes] if mapping.size else part_codes.astype(np.int64))
    # Only the names some event has: a group with no event is no group. (np.unique's
    # numbering, by counting: the codes are small.)
    merged = np.concatenate(codes)
    used = np.flatnonzero(np.bincount(merged, minlength=len(index)))
    renumber = np.zeros(len(index), dtype=np.int64)
    renumber[used] = np.arange(used.shape[0])
    merged = renumber[merged]
    names = [list(index)[i] for i in used]
    order = sorted(range(len(names)), key=lambda i: natural_key(names[i]))
    rank = np.empty(len(names), dtype=np.int64)
    rank[order] = np.arange(len(names))
    return Partition(name, tuple(names[i] for i in order), rank[merged])


def _event_groups(
    events: pd.DataFrame,
    reference: pd.DataFrame,
    ref_unit: np.ndarray,
    detections: pd.DataFrame,
    units: Units,
    context: pd.DataFrame | None,
    groupings: Sequence[str],
    cache: _Factorized | None = None,
) -> list[Partition]:
    """Each event's group per grouping, as partitions of the events (module docstring).

    Works on codes, not labels: the reference column is factorised once (``cache`` holds
    the factorisations already made) and the false detections' few values on their own.
    """
    cache = {} if cache is None else cache
    ref_row = events["ref_row"].to_numpy()
    det_row = events["det_row"].to_numpy()
    is_fp = ref_row < 0
    # The events are split into those with a reference row and the FPs, then put back.
    order = np.concatenate([np.flatnonzero(~is_fp), np.flatnonzero(is_fp)])
    back = np.empty_like(order)
    back[order] = np.arange(order.shape[0])
    fp_det = det_row[is_fp]
    ds = detections["start_s"].to_numpy(dtype=np.float64)[fp_det]
    de = detections["end_s"].to_numpy(dtype=np.float64)[fp_det]
    fp_unit = events["unit"].to_numpy()[is_fp]
    ctx = None
    if context is not None:
        ctx = _context_at(context, units, fp_unit, (ds + de) / 2)
    subject, subjects = _factorize(reference, "subject", cache)
    unit_subject = pd.Index(subjects).get_indexer(units.subjects)
    out: list[Partition] = []
    for col in groupings:
        ref_codes, ref_names = _named(
            reference[col].to_numpy(dtype=object), BLANK_GROUP, _factorize(reference, col, cache)
        )
        if col in CONTEXT_GROUPS:
            fp_values = ctx[col] if ctx is not None else np.full(fp_det.shape[0], "", dtype=object)
            fp_codes, fp_names = _named(fp_values, UNKNOWN_GROUP)
        else:
            unit_codes = _unit_codes(ref_codes, ref_unit, subject, unit_subject)
            # An unknown unit value is its own name, whatever an empty one is called.
            fp_codes = np.where(unit_codes >= 0, unit_codes, len(ref_names))[fp_unit]
            fp_names = [*ref_names, UNKNOWN_GROUP]
        p = _partition(col, [(ref_codes[ref_row[~is_fp]], ref_names), (fp_codes, fp_names)])
        out.append(Partition(col, p.labels, p.codes[back]))
    return out


def _float(value) -> float | None:
    return float(value) if value is not None and np.isfinite(value) else None


def _kinds(events: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which events are TP, FP and FN, read off their rows as :func:`categorize_events` sets
    the kinds (a TP has a detection and a reference turn, an FP no reference turn, an FN no
    detection): integer comparisons, not one of text per event."""
    det_row = events["det_row"].to_numpy()
    ref_row = events["ref_row"].to_numpy()
    fp, fn = ref_row < 0, det_row < 0
    return ~(fp | fn), fp, fn


def _matched_block(
    events: pd.DataFrame,
    detections: pd.DataFrame,
    reference: pd.DataFrame,
    bin_width_deg: float,
):
    """The TP pairs' outcomes (harness code) and the extra per-pair quantities."""
    tp = _kinds(events)[0]
    d = events["det_row"].to_numpy()[tp]
    r = events["ref_row"].to_numpy()[tp]
    ref_start = reference["start_s"].to_numpy(dtype=np.float64)[r]
    ref_end = reference["end_s"].to_numpy(dtype=np.float64)[r]
    speed = None
    duration = None
    if "speed_deg_s" in detections:
        speed = detections["speed_deg_s"].to_numpy(dtype=np.float64)[d]
        # Only pairs whose detection gives a speed: NaN duration leaves the pair out.
        duration = np.where(np.isfinite(speed), ref_end - ref_start, np.nan)
    outcomes = clip_outcomes(
        detections["angle_deg"].to_numpy(dtype=np.float64)[d],
        reference["angle_deg"].to_numpy(dtype=np.float64)[r],
        ref_duration_s=duration,
        pred_speed_deg_s=speed,
        bin_width_deg=bin_width_deg,
    )
    agree = None
    if "direction" in detections and "direction" in reference:
        dd = detections["direction"].to_numpy(dtype=object)[d]
        rd = reference["direction"].to_numpy(dtype=object)[r]
        both = (dd != "") & (rd != "")
        agree = np.where(both, (dd == rd).astype(np.float64), np.nan)
    dstart = np.abs(detections["start_s"].to_numpy(dtype=np.float64)[d] - ref_start)
    dend = np.abs(detections["end_s"].to_numpy(dtype=np.float64)[d] - ref_end)
    return tp, outcomes, agree, dstart, dend


def _matched_entry(values: Mapping[str, np.ndarray], g: int, extra: Mapping[str, Any]) -> dict:
    n = int(values["n"][g]) if "n" in values else 0
    entry: dict[str, Any] = {"n": n}
    for m in ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s"):
        v = values.get(m)
        entry[m] = None if v is None or n == 0 else _float(v[g])
    entry.update(extra)
    return entry


def _group_medians(
    codes: np.ndarray, count: np.ndarray, values: np.ndarray, ascending: np.ndarray
) -> np.ndarray:
    """``numpy.median`` of ``values`` per group (NaN for an empty one), ``ascending`` being
    ``numpy.argsort(values)``; the values are finite (|Δstart|, |Δend| of validated times).

    The values' one sort serves every grouping: a stable sort of their codes in that order
    leaves each group's values contiguous and ascending, and its median is read off the
    middle, ``(a + b) / 2`` of the middle two (one twice for an odd count), the mean that
    ``numpy.median`` takes, so the same bits."""
    if values.shape[0] == 0:
        return np.full(count.shape[0], np.nan)
    # Small integer codes sort by radix (numpy's stable sort of 16-bit keys): linear time.
    small = codes.astype(np.int16) if count.shape[0] < 2**15 else codes
    grouped = values[ascending[np.argsort(small[ascending], kind="stable")]]
    start = np.cumsum(count) - count
    last = grouped.shape[0] - 1
    low = np.minimum(start + (count - 1) // 2, last)
    high = np.minimum(start + count // 2, last)
    return np.where(count > 0, (grouped[low] + grouped[high]) / 2, np.nan)


def _pair_stats(
    codes: np.ndarray, n_groups: int, agree, dstart, dend, ascending
) -> list[dict[str, Any]]:
    """Per group of matched pairs: direction agreement and the medians of |Δstart|, |Δend|
    (``ascending``: ``numpy.argsort`` of each of those two, computed once for every
    grouping)."""
    count = np.bincount(codes, minlength=n_groups)
    median_start = _group_medians(codes, count, dstart, ascending[0])
    median_end = _group_medians(codes, count, dend, ascending[1])
    direction = np.full(n_groups, np.nan)
    if agree is not None:
        # The mean of each group's 0/1 agreements (NaN left out): sums of 0s and 1s are exact
        # in any order, so a count is the mean numpy.mean takes.
        known = np.isfinite(agree)
        n_known = np.bincount(codes[known], minlength=n_groups)
        agreed = np.bincount(codes[known], weights=agree[known], minlength=n_groups)
        with np.errstate(divide="ignore", invalid="ignore"):
            direction = np.where(n_known > 0, agreed / n_known, np.nan)
    return [
        {
            "direction_agreement": _float(direction[g]) if agree is not None else None,
            "median_abs_dstart_s": float(median_start[g]) if count[g] else None,
            "median_abs_dend_s": float(median_end[g]) if count[g] else None,
        }
        for g in range(n_groups)
    ]


def _matched_by_group(
    partitions: Sequence[Partition], tp: np.ndarray, outcomes, agree, dstart, dend
) -> tuple[list[dict[str, np.ndarray]], list[list[dict[str, Any]]]]:
    """Per grouping, the harness's own metrics of each group's matched pairs (as `score`
    computes them) and the pairs' direction agreement and boundary medians."""
    matched: list[dict[str, np.ndarray]] = [{} for _ in partitions]
    if outcomes.n > 0:
        matched = grouped_metrics(
            outcomes, [Partition(p.name, p.labels, p.codes[tp]) for p in partitions]
        )
    # |Δstart| and |Δend| sorted once for every grouping's medians.
    ascending = (np.argsort(dstart), np.argsort(dend))
    pair_stats = [
        _pair_stats(p.codes[tp], len(p.labels), agree, dstart, dend, ascending) for p in partitions
    ]
    return matched, pair_stats


def _unit_durations(units: Units, sessions: pd.DataFrame) -> np.ndarray:
    """Each unit's annotated duration (seconds) from ``sessions``; a unit the reference
    annotates without one is an error naming the sessions file."""
    duration = np.full(len(units), np.nan)
    codes = units.codes(sessions)
    known = codes >= 0
    duration[codes[known]] = sessions["duration_s"].to_numpy(dtype=np.float64)[known]
    lacking = np.flatnonzero(np.isnan(duration))
    if lacking.size:
        u = int(lacking[0])
        raise TurnbenchError(
            f"no annotated duration for session {units.sessions[u]!r}, subject "
            f"{units.subjects[u]!r}, which the reference annotates"
            + (f" ({lacking.size - 1} more like it)" if lacking.size > 1 else ""),
            file=sessions.attrs.get("path", "sessions"),
        )
    return duration


def _checked_durations(
    units: Units,
    sessions: pd.DataFrame | None,
    ref: pd.DataFrame,
    ref_unit: np.ndarray,
    det: pd.DataFrame,
    det_unit: np.ndarray,
    warn: Callable[[str], None] | None = None,
) -> np.ndarray | None:
    """Each unit's duration (:func:`_unit_durations`; None without sessions, when only the
    detections' time unit is checked), checked before any work: turns that do
    not fit in their session's annotated time mean the durations (or the times) are wrong,
    and every rate would be too (:func:`check_within_durations`)."""
    if sessions is None:
        check_time_unit(det, det_unit, ref, units, None, warn=warn)
        return None
    duration = _unit_durations(units, sessions)
    where = str(sessions.attrs.get("path", "sessions"))
    check_within_durations(ref, ref_unit, duration, what="reference", sessions=where)
    # detections far past their session's end are a unit mistake (milliseconds): said as
    # such before the plainer "longer than the session" below
    check_time_unit(det, det_unit, ref, units, sessions, warn=warn)
    check_within_durations(det, det_unit, duration, what="detections", sessions=where)
    return duration


def _rates(
    units: Units,
    ref_unit: np.ndarray,
    det_unit: np.ndarray,
    duration: np.ndarray,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Turns per hour per (session, subject), reference and detected, and their summary
    (``duration``: each unit's, :func:`_unit_durations`)."""
    n_ref = np.bincount(ref_unit, minlength=len(units))
    n_det = np.bincount(det_unit, minlength=len(units))
    hours = duration / 3600.0
    table = pd.DataFrame(
        {
            "session": units.sessions,
            "subject": units.subjects,
            "duration_s": duration,
            "reference_turns": n_ref,
            "detected_turns": n_det,
            "reference_per_hour": n_ref / hours,
            "detected_per_hour": n_det / hours,
        }
    )
    diff = np.abs(table["detected_per_hour"] - table["reference_per_hour"])
    summary = {
        "n_units": len(units),
        "reference_per_hour_mean": float(table["reference_per_hour"].mean()),
        "detected_per_hour_mean": float(table["detected_per_hour"].mean()),
        "mean_abs_difference_per_hour": float(diff.mean()),
    }
    return table, summary


def _percentiles(values: np.ndarray, qs: Sequence[float]) -> np.ndarray:
    """``numpy.percentile(column[finite], q)`` (linear) of every column at once, per ``q``.

    NaN sorts last, so each column's finite values are its first ``k``; the rank is
    ``q / 100 * (k - 1)`` and the value the linear interpolation between its neighbours
    (numpy's own formulas, so the same bits as ``numpy.nanpercentile(values, qs, axis=0)``,
    tested). NaN for a column without a finite value. One sort serves every ``q``: on 1000
    resamples of 300 groups this takes 9 ms where ``nanpercentile``, a loop over the columns
    with a NaN, takes 82 ms.
    """
    ordered = np.sort(values, axis=0)
    k = np.isfinite(ordered).sum(axis=0)
    cols = np.arange(values.shape[1])
    out = []
    for q in qs:
        # numpy's virtual index of the linear method, as numpy computes it (same rounding).
        rank = np.maximum(k - 1, 0) * (q / 100)
        lo = np.floor(rank).astype(np.int64)
        hi = np.minimum(lo + 1, np.maximum(k - 1, 0))
        a, b = ordered[lo, cols], ordered[hi, cols]
        t = rank - lo
        diff = b - a
        value = np.where(t >= 0.5, b - diff * (1 - t), a + diff * t)
        out.append(np.where(k > 0, value, np.nan))
    return np.stack(out)


def _intervals(distribution: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], ...]:
    """Per metric, the percentile bounds of every group and of the groups' average.

    :func:`turn_eval.scoring.bootstrap.percentile_interval` for all groups at once (tested equal):
    undefined resamples are left out; the average on a resample is undefined when one
    group is."""
    alpha = (1 - CONFIDENCE) / 2  # the bounds as percentile_interval computes them
    groups: dict[str, np.ndarray] = {}
    average: dict[str, np.ndarray] = {}
    for m in CI_METRICS:
        values = distribution[m]
        both = np.concatenate([values, values.mean(axis=1, keepdims=True)], axis=1)
        bounds = _percentiles(both, (100 * alpha, 100 * (1 - alpha)))
        groups[m] = bounds[:, :-1]
        average[m] = bounds[:, -1]
    return groups, average


def _ci(bounds: Mapping[str, np.ndarray], column: int | None) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for m in CI_METRICS:
        low, high = bounds[m][:, column] if column is not None else bounds[m]
        out[m] = [float(low), float(high)] if np.isfinite(low) else None
    return out


def _detection_entry(sums: np.ndarray) -> dict[str, Any]:
    metrics = event_metrics(sums)
    entry: dict[str, Any] = {c: int(round(sums[k])) for k, c in enumerate(COMPONENTS[:3])}
    entry.update({m: _float(metrics[m]) for m in ("precision", "recall", "f1")})
    return entry


def _average(groups: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The paper's "Avg.": unweighted means over the groups (of the defined values), of the
    detection counts and rates and of the matched pairs' metrics."""
    out = average(groups.values(), ("tp", "fp", "fn", "precision", "recall", "f1"))
    out["matched"] = average((g["matched"] for g in groups.values()), ("n", *MATCHED_METRICS))
    return out


def _event_components(events: pd.DataFrame, tp: np.ndarray, outcomes) -> np.ndarray:
    """Each event's additive components (:data:`COMPONENTS`): TP, FP, FN, matched-right,
    matched absolute angle error (column by column in memory, as :func:`turn_eval.scoring.bootstrap.unit_sums` reads
    them)."""
    _, fp, fn = _kinds(events)
    out = np.zeros((events.shape[0], len(COMPONENTS)), order="F")
    out[:, 0], out[:, 1], out[:, 2] = tp, fp, fn
    out[tp, 3] = outcomes.correct
    out[tp, 4] = outcomes.abs_error_deg
    return out


class _Entries:
    """The document's entries of each group of each partition (the first is ``overall``)."""

    def __init__(self, partitions, sums, matched, pair_stats, distributions) -> None:
        self.partitions = partitions
        self.totals = [sums[p.name].sum(axis=0) for p in partitions]
        self.matched = matched
        self.pair_stats = pair_stats
        self.distributions = distributions

    def __call__(self, part: int, g: int) -> dict[str, Any]:
        values = _detection_entry(self.totals[part][g])
        values["matched"] = _matched_entry(self.matched[part], g, self.pair_stats[part][g])
        if self.distributions is not None:
            values["ci95"] = _ci(self.distributions[self.partitions[part].name][0], g)
        return values

    def grouping(self, part: int, *, fp_groups: str) -> dict[str, Any]:
        """``by.<column>``: its groups, their unweighted average, and how FPs were grouped."""
        p = self.partitions[part]
        groups = {label: self(part, g) for g, label in enumerate(p.labels)}
        avg = _average(groups)
        if self.distributions is not None:
            avg["ci95"] = _ci(self.distributions[p.name][1], None)
        return {"groups": groups, "avg": avg, "fp_groups": fp_groups}


def _fp_rule(column: str, has_context: bool) -> str:
    """How false detections got their group of ``column`` (said in the JSON)."""
    if column in CONTEXT_GROUPS:
        return "context at the midpoint" if has_context else UNKNOWN_GROUP
    return "the (session, subject)'s"


def _settings(
    iou: float, bin_width_deg: float, n_resamples: int, seed: int, *, ap: bool, context: bool
) -> dict[str, Any]:
    """What a reader needs to reproduce a number (as sacrebleu's signature)."""
    return {
        "iou": iou,
        "matching": MATCHING_RULE.format(iou=iou),
        "bin_width_deg": int(bin_width_deg) if float(bin_width_deg).is_integer() else bin_width_deg,
        "resamples": n_resamples,
        "seed": seed,
        "confidence": CONFIDENCE,
        "ci_method": "percentile, cluster bootstrap over (session, subject)",
        "ap_ious": list(AP_IOUS) if ap else None,
        "context": context,
        "version": __version__,
    }


def score_events(
    detections: Frame,
    reference: Frame,
    *,
    iou: float = IOU,
    context: Frame | None = None,
    sessions: Frame | None = None,
    by: Sequence[str] | None = None,
    n_resamples: int = 1000,
    seed: int = 0,
    ignore_unknown: bool = False,
    bin_width_deg: float = BIN_WIDTH_DEG,
    warn: Callable[[str], None] | None = None,
    progress: Progress | None = None,
) -> EventScores:
    """Score detected turns against reference turns (module docstring).

    Parameters
    ----------
    detections
        The detections contract (:mod:`turn_eval.events.contract`), a frame or a CSV path.
    reference
        ``remap labels`` output or a Turn-H3.6M clip index, a frame or a CSV path.
    iou
        IoU threshold of an eligible pair, in (0, 1].
    context, sessions
        ``context.csv`` and ``sessions.csv`` (frames or paths), or None.
    by
        Reference columns to group by; None for :data:`DEFAULT_BY` where present.
    n_resamples, seed
        Cluster bootstrap resamples (0: no intervals) and seed.
    ignore_unknown
        Drop (and count) detections of units the reference does not annotate instead of
        refusing them.
    bin_width_deg
        Bin width of the matched accuracy (the paper's 45°).
    warn, progress
        Callbacks for a one-line warning and for the bootstrap's progress.

    Returns
    -------
    EventScores
        ``doc`` is the JSON document: ``overall.{tp,fp,fn,precision,recall,f1,ci95}``,
        ``overall.matched.{n,accuracy,mae_deg,wprec,mae_speed_deg_s,direction_agreement,
        median_abs_dstart_s,median_abs_dend_s}``, ``overall.ap`` (with scores),
        ``overall.turns_per_hour`` (with sessions), ``by.<column>.groups.<group>`` and
        ``by.<column>.avg``, ``settings``, ``signature`` (options, inputs' sha256).
    """
    MatchParams(iou=iou)  # checks the range
    if n_resamples < 0 or seed < 0:
        raise TurnbenchError("--bootstrap and --seed must be 0 or more")
    # The (session, subject) pairs of every row are factorised once, by the validation.
    det, det_pairs = _load(detections, read_detections_pairs, check_detections_pairs)
    ref, ref_pairs = _load(reference, read_event_reference_pairs, check_event_reference_pairs)
    ctx = _load(context, read_context, check_context)
    ses = _load(sessions, read_sessions, check_sessions)
    read = (ref, det, ctx, ses)  # as read: their files and sha256 in attrs, for the signature
    factorized: _Factorized = {}
    groupings = _groupings(ref, by, factorized)
    units, ref_unit = units_of_pairs(ref_pairs, ses)
    det, det_unit, n_dropped = drop_unknown(
        det, units, ignore_unknown=ignore_unknown, warn=warn, pairs=det_pairs
    )
    if det.shape[0] == 0 and warn is not None:
        warn(NO_DETECTIONS[0].lower() + NO_DETECTIONS[1:])
    duration = _checked_durations(units, ses, ref, ref_unit, det, det_unit, warn)

    overlaps = overlapping_pairs(det, det_unit, ref, ref_unit)
    events = categorize_events(det, det_unit, ref, ref_unit, iou=iou, overlaps=overlaps)
    grouped = _event_groups(events, ref, ref_unit, det, units, ctx, groupings, factorized)
    tp, outcomes, agree, dstart, dend = _matched_block(events, det, ref, bin_width_deg)
    components = _event_components(events, tp, outcomes)
    unit = events["unit"].to_numpy(dtype=np.int64)
    partitions = [Partition.whole(events.shape[0]), *grouped]
    sums = {
        p.name: unit_sums(unit, p.codes, components, len(units), len(p.labels)) for p in partitions
    }
    distributions = None
    if n_resamples > 0 and len(units) > 0:
        resampled = cluster_bootstrap(sums, n_resamples=n_resamples, seed=seed, progress=progress)
        distributions = {name: _intervals(d) for name, d in resampled.items()}
    matched, pair_stats = _matched_by_group(partitions, tp, outcomes, agree, dstart, dend)
    entry = _Entries(partitions, sums, matched, pair_stats, distributions)
    overall = entry(0, 0)
    rates = None
    if duration is not None:
        rates, overall["turns_per_hour"] = _rates(units, ref_unit, det_unit, duration)
    curves: dict[str, dict[str, np.ndarray]] | None = None
    if "score" in det:
        ap = average_precision(det, det_unit, ref, ref_unit, ious=AP_IOUS, overlaps=overlaps)
        overall["ap"] = {"by_iou": ap["by_iou"], "mean": ap["mean"]}
        curves = ap["curves"]
    by_doc = {
        p.name: entry.grouping(part, fp_groups=_fp_rule(p.name, ctx is not None))
        for part, p in enumerate(partitions[1:], start=1)
    }
    doc = {
        "overall": overall,
        "by": by_doc,
        "counts": {
            "units": len(units),
            "reference_turns": int(ref.shape[0]),
            "detections": int(det.shape[0]),
            "dropped_unknown": n_dropped,
        },
        "settings": _settings(
            iou, bin_width_deg, n_resamples, seed, ap=curves is not None, context=ctx is not None
        ),
        "signature": _signature(
            (iou, groupings, bin_width_deg, n_resamples, seed, ignore_unknown), read
        ),
    }
    return EventScores(
        doc=doc,
        rates=rates,
        pr_curves=curves,
        detections=det,
        reference=ref,
        _parts=(events, det, ref, units, grouped),
    )


def _signature(options: tuple, inputs: tuple) -> dict[str, Any]:
    """The signature object of :func:`score_events`' run.

    ``options`` are its ``(iou, groupings, bin_width_deg, n_resamples, seed, ignore_unknown)``
    and ``inputs`` its ``(reference, detections, context, sessions)`` as checked, each a frame
    whose ``attrs["path"]`` is its file and ``attrs["sha256"]`` the sha256 of the bytes read
    (else its file is hashed), or None; an input not given, or built in memory, is left out.
    """
    iou, groupings, bin_width_deg, n_resamples, seed, ignore_unknown = options
    named = [
        ("iou", iou),
        ("by", groupings),
        ("bin", bin_width_deg),
        ("bootstrap", f"cluster-percentile-{n_resamples}"),
        ("seed", seed),
        ("ignore-unknown", ignore_unknown),
    ]

    roles = ("reference", "detections", "context", "sessions")
    files: dict[str, str | None] = {}
    digests: dict[str, str | None] = {}
    for role, source in zip(roles, inputs, strict=True):
        attrs = {} if source is None else source.attrs
        files[role] = None if attrs.get("path") is None else str(attrs["path"])
        digests[role] = attrs.get("sha256")
    return Signature.of("score-events", named, files, digests).as_dict()


def _events_table(
    events: pd.DataFrame,
    det: pd.DataFrame,
    ref: pd.DataFrame,
    units: Units,
    groups: Sequence[Partition],
) -> pd.DataFrame:
    """The categorised events with names, both sides' times and angles, and their groups."""
    out = events.copy()
    u = out["unit"].to_numpy()
    out.insert(1, "session", units.sessions[u])
    out.insert(2, "subject", units.subjects[u])
    d = out["det_row"].to_numpy()
    r = out["ref_row"].to_numpy()
    for side, rows, frame in (("det", d, det), ("ref", r, ref)):
        for col in ("start_s", "end_s", "angle_deg"):
            values = frame[col].to_numpy(dtype=np.float64)
            column = np.full(rows.shape[0], np.nan)
            column[rows >= 0] = values[rows[rows >= 0]]
            out[f"{side}_{col}"] = column
    for p in groups:
        out[f"group_{p.name}"] = np.asarray(p.labels, dtype=object)[p.codes]
    return out
