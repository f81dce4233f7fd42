"""Cluster bootstrap over (session, subject) units for the event metrics.

Events of one session are not independent (one person, one home, one detector run), so the
unit of resampling is the (session, subject), not the event: a resample draws as many units
as there are, with replacement, and takes every event of each drawn unit (as often as it was
drawn). The draws and the percentile intervals are the harness's
(:mod:`turn_eval.scoring.bootstrap`), so they are seeded, reproducible and scipy's.

Every metric here is a ratio of sums of per-event components (pyannote.metrics' model):
TP, FP, FN, matched-correct and matched absolute error per unit and group
(:data:`COMPONENTS`), combined by :func:`event_metrics`; the resampling is the core's
:func:`turn_eval.scoring.bootstrap.unit_bootstrap`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping

import numpy as np

from turn_eval.scoring.bootstrap import unit_bootstrap

__all__ = ["COMPONENTS", "CI_METRICS", "event_metrics", "cluster_bootstrap"]

#: The additive per-event components, in this order along the last axis.
COMPONENTS = ("tp", "fp", "fn", "correct", "abs_error_deg")
#: The metrics with bootstrap intervals.
CI_METRICS = ("precision", "recall", "f1", "accuracy", "mae_deg")


def event_metrics(sums: np.ndarray) -> dict[str, np.ndarray]:
    """Precision, recall, F1, matched accuracy and MAE from summed components.

    ``sums[..., k]`` is the sum of :data:`COMPONENTS` ``[k]``. Precision = TP/(TP+FP),
    recall = TP/(TP+FN), F1 = 2TP/(2TP+FP+FN), accuracy = correct/TP, MAE = |error|/TP;
    NaN where undefined (a zero denominator).
    """
    s = np.asarray(sums, dtype=np.float64)
    tp, fp, fn, correct, error = (s[..., k] for k in range(len(COMPONENTS)))
    with np.errstate(divide="ignore", invalid="ignore"):
        return {
            "precision": np.where(tp + fp > 0, tp / (tp + fp), np.nan),
            "recall": np.where(tp + fn > 0, tp / (tp + fn), np.nan),
            "f1": np.where(2 * tp + fp + fn > 0, 2 * tp / (2 * tp + fp + fn), np.nan),
            "accuracy": np.where(tp > 0, correct / tp, np.nan),
            "mae_deg": np.where(tp > 0, error / tp, np.nan),
        }


def cluster_bootstrap(
    sums: Mapping[str, np.ndarray],
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    indices: Iterable[np.ndarray] | None = None,
    progress: Callable[[Iterable[np.ndarray], int], Iterable[np.ndarray]] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Every event metric of every group on every cluster-bootstrap resample of the units.

    :func:`turn_eval.scoring.bootstrap.unit_bootstrap` with :func:`event_metrics` as the
    combining function; the arguments are its own.

    Returns
    -------
    dict
        Per grouping, each of :data:`CI_METRICS` as ``(n_resamples, groups)``.
    """
    return unit_bootstrap(
        sums, event_metrics, n_resamples=n_resamples, seed=seed, indices=indices, progress=progress
    )
