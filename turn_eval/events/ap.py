"""Average precision of scored detections at temporal IoU thresholds (ActivityNet's protocol).

Caba Heilbron et al., "ActivityNet: A Large-Scale Video Benchmark for Human Activity
Understanding" (CVPR 2015), and its evaluation code (``Evaluation/eval_detection.py``:
``compute_average_precision_detection`` and ``interpolated_prec_rec``), as THUMOS'14 scores
temporal detections:

* Detections are ranked by ``score``, highest first (ties kept in file order: a stable sort,
  where ActivityNet's ``argsort`` leaves their order unspecified).
* Going down the ranking, a detection is a true positive when some reference turn of its
  (session, subject) not yet taken has IoU >= the threshold with it; it takes the one of
  highest IoU among those. Otherwise it is a false positive. (This greedy, confidence-first
  assignment is AP's own; the F1 of :mod:`turn_eval.events.matching` uses the maximum
  matching instead, which does not depend on scores.)
* Precision and recall after each detection (recall over all reference turns); AP is the
  area under the interpolated curve: precision made non-increasing from the right, summed
  over the recall steps, ``sum (r_i - r_{i-1}) * p_interp(r_i)``.

Eligible pairs of a detection that competes with no other detection for its turns (nearly all
of them) are decided without the loop; only connected groups of detections sharing eligible
turns are walked in score order, which is exactly the greedy order restricted to them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from turn_eval.events.matching import eligible_pairs, overlapping_pairs
from turn_eval.events.order import stable_argsort

__all__ = ["AP_IOUS", "interpolated_ap", "greedy_true_positives", "average_precision"]

#: The IoU thresholds of the AP table (ActivityNet's 0.5:0.95 is for actions; a turn's
#: boundaries are vaguer, so the THUMOS-like 0.3 to 0.7).
AP_IOUS = (0.3, 0.4, 0.5, 0.6, 0.7)


def interpolated_ap(precision: np.ndarray, recall: np.ndarray) -> float:
    """ActivityNet's ``interpolated_prec_rec``: area under the interpolated PR curve.

    ``precision`` and ``recall`` after each ranked detection.
    """
    mprec = np.concatenate([[0.0], np.asarray(precision, dtype=np.float64), [0.0]])
    mrec = np.concatenate([[0.0], np.asarray(recall, dtype=np.float64), [1.0]])
    mprec = np.maximum.accumulate(mprec[::-1])[::-1]
    steps = np.flatnonzero(mrec[1:] != mrec[:-1]) + 1
    return float(np.sum((mrec[steps] - mrec[steps - 1]) * mprec[steps]))


def greedy_true_positives(pairs: pd.DataFrame, rank: np.ndarray, n_det: int) -> np.ndarray:
    """Whether each detection is a TP under the confidence-first greedy assignment.

    Parameters
    ----------
    pairs
        Eligible pairs (:func:`turn_eval.events.matching.eligible_pairs`).
    rank
        Each detection's position in the ranking (0 = highest score).
    n_det
        Number of detections.
    """
    tp = np.zeros(n_det, dtype=bool)
    det = pairs["det_row"].to_numpy(dtype=np.int64)
    ref = pairs["ref_row"].to_numpy(dtype=np.int64)
    iou = pairs["iou"].to_numpy(dtype=np.float64)
    if det.size == 0:
        return tp
    # A turn eligible for a single detection goes to it; a detection whose eligible turns
    # are all such is a TP whatever the order.
    ref_count = np.bincount(ref)[ref]
    contested = np.zeros(n_det, dtype=bool)
    contested[det[ref_count > 1]] = True
    simple = ~contested[det]
    tp[det[simple]] = True
    hard = np.flatnonzero(~simple)
    if hard.size:
        # Walk the contested detections in rank order, each pair list by IoU descending
        # (ties: the earlier turn, as a stable sort over the reference order).
        order = np.lexsort((ref[hard], -iou[hard], rank[det[hard]]))
        taken: set[int] = set()
        decided: set[int] = set()
        for k in hard[order]:
            d = int(det[k])
            if d in decided:
                continue
            r = int(ref[k])
            if r not in taken:
                taken.add(r)
                decided.add(d)
                tp[d] = True
    return tp


def average_precision(
    detections: pd.DataFrame,
    det_unit: np.ndarray,
    reference: pd.DataFrame,
    ref_unit: np.ndarray,
    *,
    ious: Sequence[float] = AP_IOUS,
    overlaps: pd.DataFrame | None = None,
) -> dict[str, Any]:
    """AP at each IoU threshold, their mean, and the PR curve at each threshold.

    ``overlaps`` (:func:`turn_eval.events.matching.overlapping_pairs`) saves the sweep.

    Returns
    -------
    dict
        ``by_iou`` (``{"0.3": ap, ...}``), ``mean`` (over the thresholds), ``curves``
        (per threshold, ``precision`` and ``recall`` after each ranked detection, as arrays).
    """
    score = detections["score"].to_numpy(dtype=np.float64)
    n_det = score.shape[0]
    n_ref = reference.shape[0]
    ranking = stable_argsort(-score)  # np.argsort(-score, kind="stable"), faster
    rank = np.empty(n_det, dtype=np.int64)
    rank[ranking] = np.arange(n_det)
    if overlaps is None:
        overlaps = overlapping_pairs(detections, det_unit, reference, ref_unit)
    by_iou: dict[str, float | None] = {}
    curves: dict[str, dict[str, np.ndarray]] = {}
    for threshold in ious:
        pairs = eligible_pairs(overlaps, iou=threshold)
        tp = greedy_true_positives(pairs, rank, n_det)[ranking]
        cum_tp = np.cumsum(tp)
        precision = cum_tp / np.arange(1, n_det + 1)
        recall = cum_tp / n_ref if n_ref else np.zeros(n_det)
        key = f"{threshold:g}"
        by_iou[key] = interpolated_ap(precision, recall) if n_ref else None
        curves[key] = {"precision": precision, "recall": recall}
    defined = [v for v in by_iou.values() if v is not None]
    return {
        "by_iou": by_iou,
        "mean": float(np.mean(defined)) if defined else None,
        "curves": curves,
    }
