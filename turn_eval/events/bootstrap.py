"""Cluster bootstrap over (session, subject) units for the event metrics.

Events of one session are not independent (one person, one home, one detector run), so the
unit of resampling is the (session, subject), not the event: a resample draws as many units
as there are, with replacement, and takes every event of each drawn unit (as often as it was
drawn). The index matrix is scipy's (:func:`turn_eval.metrics.resample_indices`:
``numpy.random.default_rng(seed).integers(0, units, (n_resamples, units))``), so the draws
are seeded and reproducible; the intervals are percentile intervals
(:func:`turn_eval.metrics.percentile_interval`), as every interval of the harness.

Every metric here is a ratio of sums of per-event components (pyannote.metrics' model):
TP, FP, FN, matched-correct and matched absolute error per unit and group. A resample's sums
are its unit draw counts times the per-unit sums, one matrix product for all resamples of a
chunk; the metrics follow with array arithmetic (:func:`event_metrics`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from functools import cache

import numpy as np
from threadpoolctl import ThreadpoolController

from turn_eval.metrics import chunk_rows, resample_indices

__all__ = ["COMPONENTS", "CI_METRICS", "event_metrics", "unit_sums", "cluster_bootstrap"]

#: The additive per-event components, in this order along the last axis.
COMPONENTS = ("tp", "fp", "fn", "correct", "abs_error_deg")
#: The metrics with bootstrap intervals (issue 12).
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


def unit_sums(
    unit: np.ndarray, group: np.ndarray, values: np.ndarray, n_units: int, n_groups: int
) -> np.ndarray:
    """Per (unit, group) sums of per-event components: ``(n_units, n_groups, components)``.

    ``unit`` and ``group`` give each event's unit and group number; ``values`` its
    components (``(events, components)``).
    """
    k = values.shape[1]
    cell = unit * n_groups + group
    size = n_units * n_groups
    out = np.empty((size, k))
    # One bincount per component (each adds its events in order, as one over every
    # component would): reads a column-stored ``values`` in order.
    for j in range(k):
        out[:, j] = np.bincount(cell, weights=values[:, j], minlength=size)
    return out.reshape(n_units, n_groups, k)


@cache
def _blas() -> ThreadpoolController:
    """The BLAS libraries numpy and scipy loaded (found once: the search reads every one)."""
    return ThreadpoolController()


def cluster_bootstrap(
    sums: Mapping[str, np.ndarray],
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    indices: Iterable[np.ndarray] | None = None,
    progress: Callable[[Iterable[np.ndarray], int], Iterable[np.ndarray]] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Every metric of every group on every cluster-bootstrap resample of the units.

    Parameters
    ----------
    sums
        Per grouping, the per-unit sums of :func:`unit_sums` (``(units, groups, components)``;
        the same units in every grouping).
    n_resamples, seed
        As :func:`turn_eval.metrics.resample_indices` over the units.
    indices
        Chunks of a unit index matrix to use instead (tests).
    progress
        Wraps the chunks (and their number) to show progress.

    Returns
    -------
    dict
        Per grouping, each of :data:`CI_METRICS` as ``(n_resamples, groups)``.
    """
    names = list(sums)
    n_units = next(iter(sums.values())).shape[0]
    flat = np.concatenate([sums[n].reshape(n_units, -1) for n in names], axis=1)
    widths = [sums[n].shape[1] * sums[n].shape[2] for n in names]
    if indices is None:
        chunks: Iterable[np.ndarray] = resample_indices(n_units, n_resamples=n_resamples, seed=seed)
        if progress is not None:
            chunks = progress(chunks, -(-n_resamples // chunk_rows(n_units)))
    else:
        chunks = indices
    totals = []
    # One BLAS thread: a chunk's product is a few tens of milliseconds, and OpenBLAS's other
    # threads spin for as long again after it, busy on a core for nothing (measured: a
    # quarter of score-events' CPU time). Nor do the sums then depend on the thread count.
    with _blas().limit(limits=1, user_api="blas"):
        for chunk in chunks:
            # How often each resample drew each unit: one bincount over the whole chunk, each
            # row's draws offset into its own block of n_units counts.
            rows = chunk.shape[0]
            cells = chunk.astype(np.int64) + (np.arange(rows, dtype=np.int64) * n_units)[:, None]
            counts = np.bincount(cells.ravel(), minlength=rows * n_units).reshape(rows, n_units)
            totals.append(counts.astype(np.float64) @ flat)
    drawn = np.concatenate(totals, axis=0) if totals else np.zeros((0, flat.shape[1]))
    out: dict[str, dict[str, np.ndarray]] = {}
    start = 0
    for name, width in zip(names, widths, strict=True):
        block = drawn[:, start : start + width].reshape(drawn.shape[0], *sums[name].shape[1:])
        out[name] = event_metrics(block)
        start += width
    return out
