"""Inter-rater agreement on Turn-REMAP turn labels: matching, kappa, the audit.

In the paper (Cheng et al., Section 3.2, Turn-REMAP) two clinicians labelled each turn in
ELAN with its angle from a controlled vocabulary (90° to 360° in 45° steps); about half of
the turns were labelled by both, and Cohen's kappa (0.96) backed the labels before the
disagreements were resolved. This module reproduces that check on any set of annotations.

Matching follows ELAN's own inter-annotator reliability ("modified kappa", Holle & Rein
2015): two annotations of the same participant in the same session are linked when their
overlap divided by the duration of the *longer* one is at least ``min_overlap``; links are
made greedily, highest ratio first, each annotation used at most once.

The audit (:func:`audit_agreement`) compares two raters over the (session, participant) units
that both labelled, and reports, overall, per session and for every pair of raters present:

- annotations per rater, matched pairs, unmatched annotations per rater;
- percent agreement and Cohen's kappa, unweighted and linearly weighted (scikit-learn's
  ``cohen_kappa_score``, the angle bins in order, so two bins apart costs twice one bin
  apart), over matched pairs, each with a seeded percentile bootstrap 95% CI over the pairs;
- kappa with "unmatched" as an extra category (each unmatched annotation is an item one
  rater labelled and the other did not), as ELAN and Holle & Rein report it;
- the confusion matrix and the median start and end differences of matched pairs;
- the disagreements (different angles, or unmatched) for review.

A unit labelled by one rater only (a session the other did not annotate) is not a
disagreement: its annotations are counted as ``single_annotated`` and left out.
"""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import Any

import defusedxml.ElementTree as safe_et
import numpy as np
import pandas as pd
from sklearn.metrics import cohen_kappa_score, confusion_matrix

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, typed_frame

__all__ = [
    "MATCH_COLUMNS",
    "PAIR_COLUMNS",
    "DISAGREEMENT_COLUMNS",
    "AgreementAudit",
    "PairStats",
    "audit_agreement",
    "bootstrap_kappa_ci",
    "default_raters",
    "disagreements",
    "match_annotations",
    "pair_items",
    "pair_stats",
    "write_confusion_png",
    "write_review_eaf",
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
        raise ValueError(f"min_overlap must be in (0, 1], got {min_overlap}")
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


# ---------------------------------------------------------------------------------------
# Pairing two raters' annotations

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


def _check_annotations(annotations: pd.DataFrame) -> None:
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
    _check_annotations(annotations)
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


# ---------------------------------------------------------------------------------------
# Kappa and its bootstrap


def _fmt_deg(angle: float) -> str:
    return f"{angle:g}"


def _kappa_from_counts(counts: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Cohen's kappa of confusion matrices ``counts[..., k, k]`` (NaN where undefined).

    The same formula as scikit-learn's ``cohen_kappa_score`` (1 - sum(w O) / sum(w E), with
    E the outer product of the marginals over n), vectorised over the bootstrap resamples;
    a test checks it against scikit-learn.
    """
    counts = counts.astype(float)
    n = counts.sum(axis=(-2, -1))
    rows = counts.sum(axis=-1)
    cols = counts.sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = rows[..., :, None] * cols[..., None, :] / n[..., None, None]
        observed_cost = (weights * counts).sum(axis=(-2, -1))
        expected_cost = (weights * expected).sum(axis=(-2, -1))
        kappa = 1.0 - observed_cost / expected_cost
    return np.where(expected_cost > 0, kappa, np.nan)


def _weights(n_labels: int, kind: str | None) -> np.ndarray:
    idx = np.arange(n_labels)
    if kind is None:
        return 1.0 - np.eye(n_labels)
    return np.abs(idx[:, None] - idx[None, :]).astype(float)


def bootstrap_kappa_ci(
    codes_a: np.ndarray,
    codes_b: np.ndarray,
    *,
    n_labels: int,
    weights: str | None = None,
    n_bootstrap: int = 1000,
    seed: int = 0,
    confidence: float = 0.95,
) -> tuple[tuple[float, float] | None, int]:
    """Percentile bootstrap CI of Cohen's kappa over paired items.

    Parameters
    ----------
    codes_a, codes_b
        Each item's category for the two raters, as positions ``0 .. n_labels - 1`` in the
        ordered label list (the order is what linear weights count).
    n_labels
        Number of categories.
    weights
        ``None`` (unweighted) or ``"linear"``.
    n_bootstrap
        Resamples of the items, with replacement, each the size of the data.
    seed
        Seed of ``numpy.random.default_rng``: the same seed gives the same interval.
    confidence
        Coverage of the interval (0.95: the 2.5th and 97.5th percentiles).

    Returns
    -------
    ci : (float, float) or None
        The interval; ``None`` without items, without resamples, or when kappa is undefined
        in every resample.
    n_undefined : int
        Resamples in which kappa is undefined (a single category); they are left out, so the
        interval describes the resamples where kappa exists.
    """
    codes_a = np.asarray(codes_a, dtype=np.int64)
    codes_b = np.asarray(codes_b, dtype=np.int64)
    n = len(codes_a)
    if n == 0 or n_bootstrap <= 0:
        return None, 0
    rng = np.random.default_rng(seed)
    k = n_labels
    w = _weights(k, weights)
    values: list[np.ndarray] = []
    # Chunks keep the (resamples x items) index array small for large audits.
    chunk = max(1, min(n_bootstrap, 2_000_000 // max(n, 1)))
    done = 0
    while done < n_bootstrap:
        m = min(chunk, n_bootstrap - done)
        idx = rng.integers(0, n, size=(m, n))
        cell = codes_a[idx] * k + codes_b[idx] + (np.arange(m)[:, None] * k * k)
        counts = np.bincount(cell.ravel(), minlength=m * k * k).reshape(m, k, k)
        values.append(_kappa_from_counts(counts, w))
        done += m
    kappas = np.concatenate(values)
    ok = kappas[np.isfinite(kappas)]
    n_undefined = int(len(kappas) - len(ok))
    if len(ok) == 0:
        return None, n_undefined
    alpha = (1.0 - confidence) / 2.0
    lo, hi = np.percentile(ok, [100 * alpha, 100 * (1 - alpha)])
    return (float(lo), float(hi)), n_undefined


def _sk_kappa(y1: Sequence[Any], y2: Sequence[Any], labels: Sequence[Any], weights: str | None):
    if len(y1) == 0:
        return None
    with warnings.catch_warnings():
        # scikit-learn warns and returns NaN when kappa is undefined; we report a reason.
        warnings.simplefilter("ignore")
        value = cohen_kappa_score(y1, y2, labels=list(labels), weights=weights)
    return None if not np.isfinite(value) else float(value)


def _undefined_reason(y1: Sequence[Any], y2: Sequence[Any], what: str) -> str:
    if len(y1) == 0:
        return f"no {what}"
    used = sorted({str(v) for v in (*y1, *y2)})
    return (
        f"every one of the {len(y1)} {what} has the same label ({used[0]}), so agreement "
        "expected by chance is 1 and kappa is undefined"
    )


def _median(values: np.ndarray) -> float | None:
    values = values[np.isfinite(values)]
    # ELAN stores milliseconds; rounding to microseconds drops float noise of ms / 1000.
    return None if len(values) == 0 else round(float(np.median(values)), 6)


@dataclass(frozen=True)
class PairStats:
    """Agreement of two raters over a set of items (all, one session, ...).

    Fractions are 0 to 1; ``None`` where undefined (with a reason for the kappas); times in
    seconds; start and end differences are rater B minus rater A over matched pairs.
    """

    raters: tuple[str, str]
    annotations: dict[str, int]
    single_annotated: dict[str, int]
    matched: int
    unmatched: dict[str, int]
    percent_agreement: float | None
    kappa: float | None
    kappa_linear: float | None
    kappa_ci95: tuple[float, float] | None
    kappa_linear_ci95: tuple[float, float] | None
    bootstrap_undefined: int
    kappa_undefined_reason: str | None
    kappa_with_unmatched: float | None
    kappa_with_unmatched_undefined_reason: str | None
    median_start_diff_s: float | None
    median_end_diff_s: float | None
    median_abs_start_diff_s: float | None
    median_abs_end_diff_s: float | None
    labels_deg: tuple[float, ...]
    confusion: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the keys of ``turn-datasets remap agreement --format json``."""
        a, b = self.raters
        return {
            "raters": [a, b],
            "annotations": dict(self.annotations),
            "single_annotated": dict(self.single_annotated),
            "matched": self.matched,
            "unmatched": dict(self.unmatched),
            "percent_agreement": self.percent_agreement,
            "kappa": self.kappa,
            "kappa_linear": self.kappa_linear,
            "kappa_ci95": None if self.kappa_ci95 is None else list(self.kappa_ci95),
            "kappa_linear_ci95": (
                None if self.kappa_linear_ci95 is None else list(self.kappa_linear_ci95)
            ),
            "bootstrap_undefined": self.bootstrap_undefined,
            "kappa_undefined_reason": self.kappa_undefined_reason,
            "kappa_with_unmatched": self.kappa_with_unmatched,
            "kappa_with_unmatched_undefined_reason": self.kappa_with_unmatched_undefined_reason,
            "median_start_diff_s": self.median_start_diff_s,
            "median_end_diff_s": self.median_end_diff_s,
            "median_abs_start_diff_s": self.median_abs_start_diff_s,
            "median_abs_end_diff_s": self.median_abs_end_diff_s,
            "labels_deg": list(self.labels_deg),
            "confusion": self.confusion.astype(int).tolist(),
        }


def pair_stats(
    items: pd.DataFrame,
    *,
    raters: tuple[str, str],
    labels_deg: Sequence[float],
    single_annotated: Mapping[str, int] | None = None,
    n_bootstrap: int = 1000,
    seed: int = 0,
) -> PairStats:
    """Agreement statistics of the items of :func:`pair_items` (or a subset of them).

    Parameters
    ----------
    items
        :data:`PAIR_COLUMNS` rows.
    raters
        Rater A and rater B, in the order of the ``_a``/``_b`` columns.
    labels_deg
        The ordered angle categories (the vocabulary); angles found outside it are added in
        order. Linear weights count steps in this list, so with the paper's 45° vocabulary
        two bins apart weighs twice one bin apart.
    single_annotated
        Carried into the result (see :func:`pair_items`).
    n_bootstrap, seed
        Percentile bootstrap over matched pairs (:func:`bootstrap_kappa_ci`); 0 for none.
    """
    a, b = raters
    matched = items[items["status"] == "matched"]
    n_ua = int((items["status"] == "unmatched_a").sum())
    n_ub = int((items["status"] == "unmatched_b").sum())
    observed = pd.concat([items["angle_a_deg"], items["angle_b_deg"]]).dropna().unique()
    labels = sorted({float(x) for x in labels_deg} | {float(x) for x in observed})
    position = {x: i for i, x in enumerate(labels)}

    ya = [float(x) for x in matched["angle_a_deg"]]
    yb = [float(x) for x in matched["angle_b_deg"]]
    kappa = _sk_kappa(ya, yb, labels, None)
    kappa_linear = _sk_kappa(ya, yb, labels, "linear")
    reason = (
        None
        if kappa is not None
        else _undefined_reason(
            [_fmt_deg(x) for x in ya], [_fmt_deg(x) for x in yb], "matched pairs"
        )
    )
    codes_a = np.array([position[x] for x in ya], dtype=np.int64)
    codes_b = np.array([position[x] for x in yb], dtype=np.int64)
    ci = ci_linear = None
    n_undefined = 0
    if kappa is not None:
        ci, n_undefined = bootstrap_kappa_ci(
            codes_a, codes_b, n_labels=len(labels), n_bootstrap=n_bootstrap, seed=seed
        )
        ci_linear, _ = bootstrap_kappa_ci(
            codes_a,
            codes_b,
            n_labels=len(labels),
            weights="linear",
            n_bootstrap=n_bootstrap,
            seed=seed,
        )

    # Holle & Rein / ELAN: an unmatched annotation is an item the other rater put in the
    # extra category "unmatched".
    text_labels = [_fmt_deg(x) for x in labels] + [UNMATCHED]

    def _cat(v: float) -> str:
        return UNMATCHED if not np.isfinite(v) else _fmt_deg(v)

    y1u = [_cat(v) for v in items["angle_a_deg"]]
    y2u = [_cat(v) for v in items["angle_b_deg"]]
    kappa_u = _sk_kappa(y1u, y2u, text_labels, None)
    reason_u = None if kappa_u is not None else _undefined_reason(y1u, y2u, "items")

    conf = (
        confusion_matrix(ya, yb, labels=labels)
        if len(ya)
        else np.zeros((len(labels), len(labels)), dtype=int)
    )
    d_start = (matched["start_b_s"] - matched["start_a_s"]).to_numpy(dtype=float)
    d_end = (matched["end_b_s"] - matched["end_a_s"]).to_numpy(dtype=float)
    n_matched = int(len(matched))
    return PairStats(
        raters=(a, b),
        annotations={a: n_matched + n_ua, b: n_matched + n_ub},
        single_annotated=dict(single_annotated or {a: 0, b: 0}),
        matched=n_matched,
        unmatched={a: n_ua, b: n_ub},
        percent_agreement=(float(np.mean(np.asarray(ya) == np.asarray(yb))) if n_matched else None),
        kappa=kappa,
        kappa_linear=kappa_linear,
        kappa_ci95=ci,
        kappa_linear_ci95=ci_linear,
        bootstrap_undefined=n_undefined,
        kappa_undefined_reason=reason,
        kappa_with_unmatched=kappa_u,
        kappa_with_unmatched_undefined_reason=reason_u,
        median_start_diff_s=_median(d_start),
        median_end_diff_s=_median(d_end),
        median_abs_start_diff_s=_median(np.abs(d_start)),
        median_abs_end_diff_s=_median(np.abs(d_end)),
        labels_deg=tuple(labels),
        confusion=np.asarray(conf, dtype=int),
    )


# ---------------------------------------------------------------------------------------
# The audit


@dataclass(frozen=True)
class AgreementAudit:
    """Result of :func:`audit_agreement`.

    Attributes
    ----------
    overall
        The two audited raters over every unit both labelled.
    by_session
        Session -> the same, for the sessions with items.
    by_rater_pair
        Every pair of non-consensus raters present (the audited pair included).
    items
        :data:`PAIR_COLUMNS` rows of the audited pair (``pairs.csv``).
    disagreements
        :data:`DISAGREEMENT_COLUMNS` rows of the audited pair (``disagreements.csv``).
    settings
        ``min_overlap, bootstrap, seed, ci, consensus_annotator`` as used.
    """

    overall: PairStats
    by_session: dict[str, PairStats]
    by_rater_pair: list[PairStats]
    items: pd.DataFrame
    disagreements: pd.DataFrame
    settings: dict[str, Any]

    @property
    def raters(self) -> tuple[str, str]:
        return self.overall.raters

    def to_dict(self) -> dict[str, Any]:
        """The JSON document of ``--format json`` (fractions, not percentages)."""
        out = self.overall.to_dict()
        out["by_session"] = {s: st.to_dict() for s, st in self.by_session.items()}
        out["by_rater_pair"] = [st.to_dict() for st in self.by_rater_pair]
        out["settings"] = dict(self.settings)
        return out

    def summary_table(self, by: str) -> pd.DataFrame:
        """One row per session (``by="session"``) or per rater pair (``"rater_pair"``)."""
        if by == "session":
            keyed = [({"session": s}, st) for s, st in self.by_session.items()]
        elif by == "rater_pair":
            keyed = [
                ({"rater_a": st.raters[0], "rater_b": st.raters[1]}, st)
                for st in self.by_rater_pair
            ]
        else:
            raise ValueError(f"by must be 'session' or 'rater_pair', not {by!r}")
        rows = []
        for key, st in keyed:
            a, b = st.raters
            ci = st.kappa_ci95 or (np.nan, np.nan)
            rows.append(
                {
                    **key,
                    "annotations_a": st.annotations[a],
                    "annotations_b": st.annotations[b],
                    "matched": st.matched,
                    "unmatched_a": st.unmatched[a],
                    "unmatched_b": st.unmatched[b],
                    "percent_agreement": _nan(st.percent_agreement),
                    "kappa": _nan(st.kappa),
                    "kappa_ci95_lo": ci[0],
                    "kappa_ci95_hi": ci[1],
                    "kappa_linear": _nan(st.kappa_linear),
                    "kappa_with_unmatched": _nan(st.kappa_with_unmatched),
                    "median_start_diff_s": _nan(st.median_start_diff_s),
                    "median_end_diff_s": _nan(st.median_end_diff_s),
                }
            )
        key_cols = (
            {"session": "object"} if by == "session" else {"rater_a": "object", "rater_b": "object"}
        )
        dtypes = {
            **key_cols,
            "annotations_a": "int64",
            "annotations_b": "int64",
            "matched": "int64",
            "unmatched_a": "int64",
            "unmatched_b": "int64",
            "percent_agreement": "float64",
            "kappa": "float64",
            "kappa_ci95_lo": "float64",
            "kappa_ci95_hi": "float64",
            "kappa_linear": "float64",
            "kappa_with_unmatched": "float64",
            "median_start_diff_s": "float64",
            "median_end_diff_s": "float64",
        }
        return typed_frame(pd.DataFrame(rows, columns=list(dtypes)), dtypes)

    def confusion_table(self) -> pd.DataFrame:
        """The confusion matrix as a table: rows rater A's angle, columns rater B's."""
        a, b = self.raters
        labels = [_fmt_deg(x) for x in self.overall.labels_deg]
        table = pd.DataFrame(self.overall.confusion, columns=labels).astype("int64")
        table.insert(0, f"{a} (rows) / {b} (columns)", labels)
        return table

    def to_markdown(self) -> str:
        """The report as Markdown (percentages with one decimal, as the paper prints them)."""
        return _markdown(self)


def _nan(value: float | None) -> float:
    return np.nan if value is None else float(value)


def audit_agreement(
    annotations: pd.DataFrame,
    *,
    raters: Sequence[str] | None = None,
    labels_deg: Sequence[float] = (90, 135, 180, 225, 270, 315, 360),
    consensus_annotator: str = "consensus",
    min_overlap: float = 0.6,
    n_bootstrap: int = 1000,
    seed: int = 0,
) -> AgreementAudit:
    """Inter-rater agreement of turn labels, as the paper's kappa check (Section 3.2).

    Parameters
    ----------
    annotations
        Every rater's annotations (``eaf.read_annotations``: ``session, file, annotator,
        participant, start_s, end_s, angle_deg``).
    raters
        The two raters to audit; default: the two raters present other than
        ``consensus_annotator`` (an error if there are not exactly two).
    labels_deg
        The ordered angle vocabulary (the schema's ``turn_angle``); it fixes the linear
        weights and the rows and columns of the confusion matrix.
    consensus_annotator
        The adjudicating rater, never audited by default nor in ``by_rater_pair``.
    min_overlap
        Matching threshold, overlap over the longer duration (ELAN's default, 0.6).
    n_bootstrap, seed
        Percentile bootstrap 95% CI of the kappas over matched pairs; 0 for none.

    Raises
    ------
    TurnbenchError
        A named rater is absent, the two are the same, or there are not exactly two raters
        to choose by default.
    """
    _check_annotations(annotations)
    if not 0.0 < float(min_overlap) <= 1.0:
        raise TurnbenchError(f"--min-overlap must be in (0, 1], not {min_overlap}")
    present = sorted({str(r) for r in annotations["annotator"].dropna().unique()})
    if raters is None:
        rater_a, rater_b = default_raters(annotations, consensus_annotator=consensus_annotator)
    else:
        if len(raters) != 2:
            raise TurnbenchError(f"name exactly two raters, not {len(raters)}")
        rater_a, rater_b = str(raters[0]), str(raters[1])
        if rater_a == rater_b:
            raise TurnbenchError(f"the two raters are the same ({rater_a!r})")
        for r in (rater_a, rater_b):
            if r not in present:
                raise TurnbenchError(
                    f"rater {r!r} has no annotations; raters found: "
                    f"{', '.join(repr(p) for p in present) or 'none'}"
                )

    items, single = pair_items(
        annotations, rater_a=rater_a, rater_b=rater_b, min_overlap=min_overlap
    )
    stats_kw = {"labels_deg": labels_deg, "n_bootstrap": n_bootstrap, "seed": seed}
    overall = pair_stats(items, raters=(rater_a, rater_b), single_annotated=single, **stats_kw)
    by_session = {
        str(session): pair_stats(group, raters=(rater_a, rater_b), **stats_kw)
        for session, group in items.groupby("session", sort=True)
    }
    others = [r for r in present if r.casefold().strip() != consensus_annotator.casefold().strip()]
    pairs = [tuple(p) for p in combinations(sorted(others, key=lambda r: (r.casefold(), r)), 2)]
    if (rater_a, rater_b) not in pairs and (rater_b, rater_a) not in pairs:
        pairs.insert(0, (rater_a, rater_b))
    by_pair: list[PairStats] = []
    for ra, rb in pairs:
        if {ra, rb} == {rater_a, rater_b}:
            # the audited pair, in the order asked for
            by_pair.append(overall)
            continue
        its, sing = pair_items(annotations, rater_a=ra, rater_b=rb, min_overlap=min_overlap)
        by_pair.append(pair_stats(its, raters=(ra, rb), single_annotated=sing, **stats_kw))
    return AgreementAudit(
        overall=overall,
        by_session=by_session,
        by_rater_pair=by_pair,
        items=items,
        disagreements=disagreements(items, rater_a=rater_a, rater_b=rater_b),
        settings={
            "min_overlap": float(min_overlap),
            "bootstrap": int(n_bootstrap),
            "seed": int(seed),
            "ci": "percentile bootstrap over matched pairs, 95%",
            "consensus_annotator": consensus_annotator,
        },
    )


# ---------------------------------------------------------------------------------------
# Markdown


def _pct(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.1f}%"


def _k(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f}"


def _k_ci(value: float | None, ci: tuple[float, float] | None) -> str:
    if value is None:
        return "n/a"
    if ci is None:
        return _k(value)
    return f"{value:.3f} ({ci[0]:.3f} to {ci[1]:.3f})"


def _s(value: float | None) -> str:
    return "n/a" if value is None else f"{value:+.3f}"


def _md_cell(value: Any) -> str:
    # Rater names and session ids come from the files: a "|" would end the cell, a line
    # break the row.
    return " ".join(str(value).split()).replace("|", "\\|")


def _md_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    lines = [
        "| " + " | ".join(_md_cell(h) for h in header) + " |",
        "|" + "|".join("---" for _ in header) + "|",
    ]
    lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in rows]
    return lines


def _stats_row(st: PairStats) -> list[str]:
    a, b = st.raters
    return [
        str(st.annotations[a]),
        str(st.annotations[b]),
        str(st.matched),
        str(st.unmatched[a]),
        str(st.unmatched[b]),
        _pct(st.percent_agreement),
        _k_ci(st.kappa, st.kappa_ci95),
        _k_ci(st.kappa_linear, st.kappa_linear_ci95),
        _k(st.kappa_with_unmatched),
        _s(st.median_start_diff_s),
        _s(st.median_end_diff_s),
    ]


_STATS_HEADER = [
    "turns A",
    "turns B",
    "matched",
    "unmatched A",
    "unmatched B",
    "agreement",
    "kappa (95% CI)",
    "linear kappa (95% CI)",
    "kappa incl. unmatched",
    "median start B-A (s)",
    "median end B-A (s)",
]


def _markdown(audit: AgreementAudit) -> str:
    st = audit.overall
    a, b = st.raters
    s = audit.settings
    lines = [
        f"# Inter-rater agreement: {a} (A) vs {b} (B)",
        "",
        f"Turns of the same participant linked when overlap / longer duration >= "
        f"{s['min_overlap']:g}, greedily (as ELAN); kappa over matched pairs, 95% CI by "
        f"percentile bootstrap ({s['bootstrap']} resamples, seed {s['seed']}).",
        "",
    ]
    lines += _md_table(["", *_STATS_HEADER], [["all", *_stats_row(st)]])
    lines.append("")
    notes = []
    if st.kappa_undefined_reason:
        notes.append(f"Kappa: {st.kappa_undefined_reason}.")
    if st.kappa_with_unmatched_undefined_reason:
        notes.append(f"Kappa incl. unmatched: {st.kappa_with_unmatched_undefined_reason}.")
    if st.bootstrap_undefined:
        notes.append(
            f"{st.bootstrap_undefined} bootstrap resamples had an undefined kappa and were "
            "left out of the interval."
        )
    single = sum(st.single_annotated.values())
    if single:
        notes.append(
            f"Not compared (labelled by one rater only): turns of {a}: "
            f"{st.single_annotated[a]}, of {b}: {st.single_annotated[b]}."
        )
    if notes:
        lines += [*notes, ""]

    lines += ["## Confusion matrix (rows A, columns B)", ""]
    labels = [_fmt_deg(x) + "°" for x in st.labels_deg]
    lines += _md_table(
        [f"{a} \\ {b}", *labels],
        [[labels[i], *(str(int(c)) for c in row)] for i, row in enumerate(st.confusion)],
    )
    lines.append("")
    if audit.by_session:
        lines += ["## Per session", ""]
        lines += _md_table(
            ["session", *_STATS_HEADER],
            [[sess, *_stats_row(x)] for sess, x in audit.by_session.items()],
        )
        lines.append("")
    lines += ["## Per pair of raters", ""]
    lines += _md_table(
        ["A", "B", *_STATS_HEADER],
        [[x.raters[0], x.raters[1], *_stats_row(x)] for x in audit.by_rater_pair],
    )
    lines.append("")
    n_angle = int((audit.disagreements["kind"] == "angle").sum())
    n_un = int((audit.disagreements["kind"] == UNMATCHED).sum())
    lines.append(f"Disagreements to review: {n_angle} with different angles, {n_un} unmatched.")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------
# Figures and review copies


def write_confusion_png(audit: AgreementAudit, path: str | os.PathLike[str]) -> Path:
    """The confusion matrix as a heat map with counts (PNG, reproducible bytes)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    st = audit.overall
    a, b = st.raters
    labels = [_fmt_deg(x) + "°" for x in st.labels_deg]
    conf = st.confusion
    fig = Figure(figsize=(1.0 + 0.6 * len(labels), 0.8 + 0.6 * len(labels)), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(conf, cmap="Blues", vmin=0, vmax=max(1, int(conf.max())))
    ax.set_xticks(range(len(labels)), labels=labels, rotation=45)
    ax.set_yticks(range(len(labels)), labels=labels)
    ax.set_xlabel(f"{b} (B)")
    ax.set_ylabel(f"{a} (A)")
    kappa = "undefined" if st.kappa is None else f"{st.kappa:.3f}"
    ax.set_title(f"matched turns: {st.matched}, kappa {kappa}", fontsize=9)
    half = conf.max() / 2 if conf.size else 0
    for i in range(conf.shape[0]):
        for j in range(conf.shape[1]):
            if conf[i, j]:
                ax.text(
                    j,
                    i,
                    str(int(conf[i, j])),
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="white" if conf[i, j] > half else "black",
                )
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", metadata={"Software": None})
    return Path(path)


_XSI = "http://www.w3.org/2001/XMLSchema-instance"
REVIEW_TIER = "Disagreement"
REVIEW_ANNOTATOR = "turnbench"
#: Header properties that count annotation ids: ELAN writes ``lastUsedAnnotationId``,
#: pympi-ling ``lastUsedAnnotation``. The review copy keeps them past its new ids.
_ID_PROPERTIES = ("lastUsedAnnotationId", "lastUsedAnnotation")
_NEUTRAL_DATE = "1970-01-01T00:00:00+00:00"


def _review_spans(rows: pd.DataFrame, *, rater_a: str, rater_b: str) -> list[tuple[int, int, str]]:
    """(start_ms, end_ms, text) per disagreement of one participant, overlaps merged."""
    spans: list[tuple[int, int, str]] = []
    for r in rows.itertuples(index=False):
        starts = [t for t in (r.start_a_s, r.start_b_s) if np.isfinite(t)]
        ends = [t for t in (r.end_a_s, r.end_b_s) if np.isfinite(t)]
        va = "none" if not np.isfinite(r.angle_a_deg) else _fmt_deg(r.angle_a_deg)
        vb = "none" if not np.isfinite(r.angle_b_deg) else _fmt_deg(r.angle_b_deg)
        text = f"{rater_a}: {va} / {rater_b}: {vb}"
        if r.kind == UNMATCHED:
            text += " (unmatched)"
        spans.append((int(round(min(starts) * 1000)), int(round(max(ends) * 1000)), text))
    spans.sort()
    merged: list[list[Any]] = []
    for s0, s1, text in spans:
        # Annotations on one ELAN tier must not overlap: join overlapping disagreements.
        if merged and s0 < merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], s1)
            merged[-1][2] += "; " + text
        else:
            merged.append([s0, s1, text])
    return [(int(s0), int(s1), str(t)) for s0, s1, t in merged]


def _max_numeric_id(values: Iterable[str | None], prefix: str) -> int:
    best = 0
    for v in values:
        if v and v.startswith(prefix) and v[len(prefix) :].isdigit():
            best = max(best, int(v[len(prefix) :]))
    return best


def write_review_eaf(
    source: str | os.PathLike[str],
    target: str | os.PathLike[str],
    rows: pd.DataFrame,
    *,
    rater_a: str,
    rater_b: str,
    tier_per_participant: bool = False,
    keep_media_paths: bool = False,
) -> Path:
    """Copy an ``.eaf`` with a "Disagreement" tier marking ``rows``, to open in ELAN.

    The copy is the source's XML with added time slots, one linguistic type and one tier
    per participant with disagreements (``Disagreement``, or ``Disagreement <participant>``
    with ``tier_per_participant``; ``PARTICIPANT`` set), whose
    annotations span both raters' intervals and read ``A: 90 / B: 135``. Everything else is
    kept as written (XML is edited directly: pympi-ling would drop ELAN 3.0 ``CVE_REF`` links
    when writing the file back), and ELAN's annotation counter (``lastUsedAnnotationId``) is
    moved past the new ids. Without ``keep_media_paths`` the header goes, as from every
    turnbench output: media and linked-file descriptors, ``MEDIA_FILE``, the author, the
    date (set to 1970-01-01) and every header property but the counter. The source is only
    read.

    Parameters
    ----------
    source, target
        The original ``.eaf`` and the copy to write (atomically).
    rows
        :data:`DISAGREEMENT_COLUMNS` rows of this session.
    rater_a, rater_b
        Names used in the annotation texts.
    tier_per_participant
        Name the tiers after their participant (for sessions with several participants,
        even if only one of them has disagreements, so the names do not depend on that).
    keep_media_paths
        Keep the header as it is (media paths, author, date, properties).
    """
    src = Path(source)
    if Path(target).resolve() == src.resolve():
        raise TurnbenchError("the review copy would overwrite its source", file=str(src))
    try:
        tree = safe_et.parse(str(src), forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except Exception as exc:  # the file was read once already; a change since is the user's
        raise TurnbenchError(
            f"cannot read the file again for the review copy ({exc})", file=str(src)
        ) from None
    root = tree.getroot()
    ET.register_namespace("xsi", _XSI)

    header = root.find("HEADER")
    if not keep_media_paths:
        # What inspect shows only with --keep-media-paths goes: media and linked files, the
        # author, the date, and header properties other than ELAN's annotation counter.
        if header is not None:
            for tag in ("MEDIA_DESCRIPTOR", "LINKED_FILE_DESCRIPTOR"):
                for el in header.findall(tag):
                    header.remove(el)
            for prop in header.findall("PROPERTY"):
                if prop.get("NAME") not in _ID_PROPERTIES:
                    header.remove(prop)
            if header.get("MEDIA_FILE"):
                header.set("MEDIA_FILE", "")
        if "AUTHOR" in root.attrib:
            root.set("AUTHOR", "")
        if "DATE" in root.attrib:
            # ELAN requires a date; a fixed one says nothing about the recording.
            root.set("DATE", _NEUTRAL_DATE)

    time_order = root.find("TIME_ORDER")
    if time_order is None:
        time_order = ET.Element("TIME_ORDER")
        root.insert(1 if header is not None else 0, time_order)
    ts_next = _max_numeric_id((el.get("TIME_SLOT_ID") for el in root.iter("TIME_SLOT")), "ts") + 1
    ann_ids = [
        el.get("ANNOTATION_ID")
        for tag in ("ALIGNABLE_ANNOTATION", "REF_ANNOTATION")
        for el in root.iter(tag)
    ]
    counters = [
        prop
        for prop in (header.findall("PROPERTY") if header is not None else [])
        if prop.get("NAME") in _ID_PROPERTIES
    ]
    # Past every id in the file and past ELAN's counter, so no id is ever given twice.
    aid_next = (
        max(
            [_max_numeric_id(ann_ids, "a")]
            + [int(p.text.strip()) for p in counters if p.text and p.text.strip().isdigit()]
        )
        + 1
    )

    children = list(root)
    tier_ids = {el.get("TIER_ID") for el in root.findall("TIER")}
    lt_ids = {el.get("LINGUISTIC_TYPE_ID") for el in root.findall("LINGUISTIC_TYPE")}
    lt_id = "turnbench-disagreement"
    while lt_id in lt_ids:
        lt_id += "-"
    last_tier = max((children.index(el) for el in root.findall("TIER")), default=None)
    insert_at = (last_tier + 1) if last_tier is not None else children.index(time_order) + 1

    participants = sorted({str(p) for p in rows["participant"]})
    several = tier_per_participant or len(participants) > 1
    new_tiers: list[ET.Element] = []
    for participant in participants:
        name = f"{REVIEW_TIER} {participant}" if several else REVIEW_TIER
        tier_id, k = name, 2
        while tier_id in tier_ids:
            tier_id, k = f"{name} {k}", k + 1
        tier_ids.add(tier_id)
        tier = ET.Element(
            "TIER",
            {
                "TIER_ID": tier_id,
                "LINGUISTIC_TYPE_REF": lt_id,
                "PARTICIPANT": participant,
                "ANNOTATOR": REVIEW_ANNOTATOR,
            },
        )
        spans = _review_spans(
            rows[rows["participant"] == participant], rater_a=rater_a, rater_b=rater_b
        )
        for s0, s1, text in spans:
            ids = []
            for t in (s0, s1):
                slot = ET.SubElement(
                    time_order, "TIME_SLOT", {"TIME_SLOT_ID": f"ts{ts_next}", "TIME_VALUE": str(t)}
                )
                slot.tail = "\n\t\t"
                ids.append(f"ts{ts_next}")
                ts_next += 1
            ann = ET.SubElement(tier, "ANNOTATION")
            al = ET.SubElement(
                ann,
                "ALIGNABLE_ANNOTATION",
                {
                    "ANNOTATION_ID": f"a{aid_next}",
                    "TIME_SLOT_REF1": ids[0],
                    "TIME_SLOT_REF2": ids[1],
                },
            )
            aid_next += 1
            ET.SubElement(al, "ANNOTATION_VALUE").text = text
        new_tiers.append(tier)
    for offset, tier in enumerate(new_tiers):
        ET.indent(tier, space="\t", level=1)  # laid out like ELAN's own files
        tier.tail = "\n\t"
        root.insert(insert_at + offset, tier)

    children = list(root)
    last_lt = max((children.index(el) for el in root.findall("LINGUISTIC_TYPE")), default=None)
    lt = ET.Element(
        "LINGUISTIC_TYPE",
        {"LINGUISTIC_TYPE_ID": lt_id, "TIME_ALIGNABLE": "true", "GRAPHIC_REFERENCES": "false"},
    )
    lt.tail = "\n\t"
    root.insert((last_lt if last_lt is not None else insert_at + len(new_tiers) - 1) + 1, lt)

    for prop in counters:
        # ELAN numbers new annotations after this one.
        prop.text = str(aid_next - 1)

    with atomic_path(target) as tmp:
        tree.write(str(tmp), encoding="UTF-8", xml_declaration=True)
    return Path(target)
