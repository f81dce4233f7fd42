"""Matching detected turns to reference turns in untrimmed sessions.

The rule (DESIGN.md, "Detections"; sed_eval and ActivityNet state theirs as exactly):

* Matching is done per (session, subject) unit, one-to-one: a detection matches at most one
  reference turn and a reference turn at most one detection.
* A (detection, reference) pair is *eligible* when its temporal IoU, ``|D ∩ R| / |D ∪ R|``
  with intervals ``[start_s, end_s]``, is at least the threshold ``iou`` (default 0.5; the
  comparison is ``>=`` on the floating-point quotient).
* Among all one-to-one matchings of eligible pairs, the one with the **most pairs**, and among
  those the **largest total IoU**, is taken. Matched pairs are true positives (TP), unmatched
  detections false positives (FP), unmatched reference turns false negatives (FN).

How it is computed. Eligible pairs are found by a sweep (both sides sorted by unit and start;
detections of one unit do not overlap, nor do reference turns, so each detection's
overlapping turns are one contiguous run). The eligible pairs form a bipartite graph; each
connected component is matched on its own. A component of one pair is that pair. A larger
one is solved with ``scipy.sparse.csgraph.min_weight_full_bipartite_matching`` (LAPJVsp, on
the eligible pairs alone, so memory grows linearly with them) maximising the weight
``M + IoU`` of eligible pairs with ``M = min(rows, columns) + 1``: a
matching of ``k`` eligible pairs weighs between ``k M`` and ``k M + k``, and
``(k + 1) M > k M + k`` because ``M > k``, so a heaviest matching has the most pairs, and
among those the largest total IoU (lexicographic, not a plain maximum of total IoU, which
can prefer one pair of IoU 0.9 to two of 0.5). Ties between equally good matchings are
broken by the solver on the component's rows and columns in row order: deterministic for
the same input. Total IoUs closer than about
``1e-13`` of each other count as equal (floating point).

The functions return DataFrames (mobgap's ``categorize_intervals`` /
``get_matching_intervals``), so the matching is inspectable before any metric is computed.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.sparse import coo_array, csr_array
from scipy.sparse.csgraph import connected_components, min_weight_full_bipartite_matching

from turn_eval.events._order import lexsort, unit_time_guess

__all__ = [
    "EVENT_COLUMNS",
    "temporal_iou",
    "overlapping_pairs",
    "eligible_pairs",
    "match_pairs",
    "categorize_events",
]

#: The categorised events: one row per TP pair, FP detection and FN reference turn, ordered by
#: unit and time. ``det_row``/``ref_row`` index the detections/reference (-1 where absent).
EVENT_COLUMNS = {
    "unit": "int64",
    "kind": "str",
    "det_row": "int64",
    "ref_row": "int64",
    "iou": "float64",
}


def temporal_iou(start_a, end_a, start_b, end_b) -> np.ndarray:
    """Intersection over union of intervals ``[start_a, end_a]`` and ``[start_b, end_b]``
    (element-wise; 0 where they do not overlap)."""
    start_a, end_a = np.asarray(start_a, dtype=np.float64), np.asarray(end_a, dtype=np.float64)
    start_b, end_b = np.asarray(start_b, dtype=np.float64), np.asarray(end_b, dtype=np.float64)
    inter = np.clip(np.minimum(end_a, end_b) - np.maximum(start_a, start_b), 0.0, None)
    union = np.maximum(end_a, end_b) - np.minimum(start_a, start_b)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(inter > 0, inter / union, 0.0)


def _overlapping(
    det_unit: np.ndarray,
    det_start: np.ndarray,
    det_end: np.ndarray,
    ref_unit: np.ndarray,
    ref_start: np.ndarray,
    ref_end: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Every (detection, reference) pair of one unit whose intervals overlap (positive length).

    Both sides are searched on (unit, time) keys as complex numbers, which numpy orders
    lexicographically (real part first), so one ``searchsorted`` spans every unit.
    """
    order = lexsort((ref_start, ref_unit), unit_time_guess(ref_unit, ref_start))
    ru = ref_unit[order].astype(np.float64)
    # Reference turns of a unit do not overlap, so in start order their ends are sorted too.
    lo = np.searchsorted(ru + 1j * ref_end[order], det_unit + 1j * det_start, side="right")
    hi = np.searchsorted(ru + 1j * ref_start[order], det_unit + 1j * det_end, side="left")
    count = np.maximum(hi - lo, 0)
    det = np.repeat(np.arange(det_unit.shape[0]), count)
    first = np.repeat(lo - np.cumsum(count) + count, count)
    ref = order[first + np.arange(det.shape[0])]
    return det, ref


def overlapping_pairs(
    detections: pd.DataFrame,
    det_unit: np.ndarray,
    reference: pd.DataFrame,
    ref_unit: np.ndarray,
) -> pd.DataFrame:
    """Every (detection, reference turn) pair of one unit that overlaps, with its IoU.

    Returns
    -------
    DataFrame
        ``det_row, ref_row, unit, iou`` (rows of the two frames), in detection order.
    """
    ds = detections["start_s"].to_numpy(dtype=np.float64)
    de = detections["end_s"].to_numpy(dtype=np.float64)
    rs = reference["start_s"].to_numpy(dtype=np.float64)
    re_ = reference["end_s"].to_numpy(dtype=np.float64)
    du = np.asarray(det_unit, dtype=np.int64)
    ru = np.asarray(ref_unit, dtype=np.int64)
    det, ref = _overlapping(du, ds, de, ru, rs, re_)
    values = temporal_iou(ds[det], de[det], rs[ref], re_[ref])
    keep = values > 0
    return pd.DataFrame(
        {"det_row": det[keep], "ref_row": ref[keep], "unit": du[det[keep]], "iou": values[keep]}
    )


def eligible_pairs(overlaps: pd.DataFrame, *, iou: float = 0.5) -> pd.DataFrame:
    """The pairs of :func:`overlapping_pairs` whose temporal IoU is at least ``iou``.

    One sweep serves every threshold (AP tries five).

    Returns
    -------
    DataFrame
        ``det_row, ref_row, unit, iou`` (rows of the two frames), in detection order.
    """
    if not 0.0 < iou <= 1.0:
        raise ValueError(f"iou must be in (0, 1], got {iou}")
    keep = overlaps["iou"].to_numpy() >= iou
    return overlaps.loc[keep].reset_index(drop=True)


def _components(det: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The connected component of each pair in the bipartite graph of the pairs."""
    d_ids, d = np.unique(det, return_inverse=True)
    _, r = np.unique(ref, return_inverse=True)
    n = d_ids.shape[0] + int(r.max(initial=-1)) + 1
    graph = coo_array(
        (np.ones(det.shape[0]), (d.reshape(-1), d_ids.shape[0] + r.reshape(-1))), shape=(n, n)
    )
    _, label = connected_components(graph, directed=False)
    return label[d.reshape(-1)]


def _solve(rows: np.ndarray, cols: np.ndarray, iou: np.ndarray) -> np.ndarray:
    """Indices of the pairs of one component in its best matching (module docstring).

    Sparse: memory grows with the number of pairs, not with rows x columns (a dense matrix
    of a component of 24,000 overlapping intervals needs several GB). Each row also gets a
    column of its own, of weight 1, so that a matching covering every row exists (the
    solver needs one); the eligible pairs weigh ``M + IoU + 1``. That adds 1 per row to
    every candidate matching, which leaves the best one unchanged.
    """
    r_ids, r = np.unique(rows, return_inverse=True)
    c_ids, c = np.unique(cols, return_inverse=True)
    n_r, n_c = r_ids.shape[0], c_ids.shape[0]
    r, c = r.reshape(-1), c.reshape(-1)
    big = min(n_r, n_c) + 1.0
    weight = csr_array(
        (
            np.concatenate([big + 1.0 + iou, np.ones(n_r)]),
            (np.concatenate([r, np.arange(n_r)]), np.concatenate([c, n_c + np.arange(n_r)])),
        ),
        shape=(n_r, n_c + n_r),
    )
    a, b = min_weight_full_bipartite_matching(weight, maximize=True)
    real = b < n_c
    # Each (row, column) is one pair: find the chosen ones among the pairs' sorted keys.
    key = r.astype(np.int64) * n_c + c
    order = np.argsort(key, kind="stable")
    found = np.searchsorted(key[order], a[real].astype(np.int64) * n_c + b[real])
    return np.sort(order[found])


def match_pairs(pairs: pd.DataFrame) -> pd.DataFrame:
    """The best one-to-one matching of eligible pairs (most pairs, then largest total IoU).

    Parameters
    ----------
    pairs
        From :func:`eligible_pairs`: ``det_row, ref_row, unit, iou``.

    Returns
    -------
    DataFrame
        The matched pairs, same columns, ordered by detection.
    """
    det = pairs["det_row"].to_numpy(dtype=np.int64)
    ref = pairs["ref_row"].to_numpy(dtype=np.int64)
    if det.shape[0] == 0:
        return pairs.iloc[:0].reset_index(drop=True)
    # A pair whose detection and turn have no other eligible partner is its own component
    # (nearly every pair at IoU >= 0.5): taken without a solver.
    d_count = np.bincount(det)[det]
    r_count = np.bincount(ref)[ref]
    alone = (d_count == 1) & (r_count == 1)
    chosen = [np.flatnonzero(alone)]
    rest = np.flatnonzero(~alone)
    if rest.size:
        label = _components(det[rest], ref[rest])
        order = np.argsort(label, kind="stable")
        bounds = np.flatnonzero(np.diff(label[order])) + 1
        values = pairs["iou"].to_numpy(dtype=np.float64)
        for group in np.split(rest[order], bounds):
            chosen.append(group[_solve(det[group], ref[group], values[group])])
    keep = np.sort(np.concatenate(chosen))
    return pairs.iloc[keep].reset_index(drop=True)


def categorize_events(
    detections: pd.DataFrame,
    det_unit: np.ndarray,
    reference: pd.DataFrame,
    ref_unit: np.ndarray,
    *,
    iou: float = 0.5,
    overlaps: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Every detection and reference turn as TP, FP or FN under the matching rule.

    Parameters
    ----------
    detections, reference
        Frames with ``start_s`` and ``end_s`` (validated: no overlaps within a unit).
    det_unit, ref_unit
        Each row's (session, subject) unit number.
    iou
        The IoU threshold of an eligible pair.
    overlaps
        :func:`overlapping_pairs` of the same frames, if already computed.

    Returns
    -------
    DataFrame
        :data:`EVENT_COLUMNS`: a TP row per matched pair (both rows, its IoU), an FP row per
        unmatched detection, an FN row per unmatched turn (``iou`` NaN for both), ordered by
        unit, then by the start of the reference turn or else of the detection.
    """
    if overlaps is None:
        overlaps = overlapping_pairs(detections, det_unit, reference, ref_unit)
    pairs = match_pairs(eligible_pairs(overlaps, iou=iou))
    n_det, n_ref = detections.shape[0], reference.shape[0]
    det_used = np.zeros(n_det, dtype=bool)
    ref_used = np.zeros(n_ref, dtype=bool)
    det_used[pairs["det_row"].to_numpy()] = True
    ref_used[pairs["ref_row"].to_numpy()] = True
    fp = np.flatnonzero(~det_used)
    fn = np.flatnonzero(~ref_used)
    det_unit = np.asarray(det_unit, dtype=np.int64)
    ref_unit = np.asarray(ref_unit, dtype=np.int64)
    n_tp = pairs.shape[0]
    kind = np.repeat(np.array(["TP", "FP", "FN"], dtype=object), [n_tp, fp.size, fn.size])
    det_row = np.concatenate([pairs["det_row"].to_numpy(), fp, np.full(fn.size, -1)])
    ref_row = np.concatenate([pairs["ref_row"].to_numpy(), np.full(fp.size, -1), fn])
    unit = np.concatenate([pairs["unit"].to_numpy(dtype=np.int64), det_unit[fp], ref_unit[fn]])
    values = np.concatenate([pairs["iou"].to_numpy(), np.full(fp.size + fn.size, np.nan)])
    ds = detections["start_s"].to_numpy(dtype=np.float64)
    rs = reference["start_s"].to_numpy(dtype=np.float64)
    start = np.empty(ref_row.shape[0])
    has_ref = ref_row >= 0
    start[has_ref] = rs[ref_row[has_ref]]
    start[~has_ref] = ds[det_row[~has_ref]]
    order = lexsort((det_row, start, unit), unit_time_guess(unit, start))
    return pd.DataFrame(
        {
            "unit": unit[order],
            "kind": kind[order],
            "det_row": det_row[order].astype(np.int64),
            "ref_row": ref_row[order].astype(np.int64),
            "iou": values[order],
        }
    )
