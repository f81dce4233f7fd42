"""PD-versus-control contrasts of the profile's measures, with bootstrap intervals.

For each measure, over the participants with a value (not suppressed, not NaN):

- the two groups' means and their ``difference`` (first group minus second: PD - HC);
- Hedges' g: the difference over the pooled standard deviation
  ``sqrt(((n1 - 1) s1^2 + (n2 - 1) s2^2) / (n1 + n2 - 2))`` (``s`` with ddof=1), times the
  small-sample factor ``J = 1 - 3 / (4 (n1 + n2) - 9)`` (Hedges 1981; Hedges & Olkin 1985,
  eq. 5.10's approximation); undefined below two participants in a group or at zero spread;
- the AUC of the measure for telling the first group from the second: the Mann-Whitney
  ``U / (n1 n2)``, the probability that a random PD participant's value exceeds a random
  control's, ties counting one half (what ``sklearn.metrics.roc_auc_score`` gives with PD as the
  positive class). Below 0.5 the measure is lower in PD (Shah et al. 2020 report
  ``max(AUC, 1 - AUC)``: a smaller turn angle in PD there is an AUC of 0.90).

Intervals are 95% percentile intervals of a stratified bootstrap: each resample draws, with
replacement, as many PD participants as there are from the PD participants and as many
controls from the controls (the groups' sizes are the design's, so each is kept), and
recomputes every statistic. The draws are ``numpy.random.default_rng(seed)``'s: one
``integers(0, n1, (resamples, n1))`` matrix for the first group, then one for the second. A
resample's statistics are weighted sums with each participant's draw count as its weight, so
all resamples of all measures are a few matrix products; the AUC's pairwise comparison becomes
a cumulative sum over the measure's sorted values.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_eval.scoring.bootstrap import percentile_interval

__all__ = ["CONTRAST_COLUMNS", "GroupStats", "group_stats", "contrasts_table", "draw_counts"]

#: ``contrasts.csv``.
CONTRAST_COLUMNS = {
    "measure": "str",
    "n_pd": "int64",
    "n_hc": "int64",
    "pd_mean": "float64",
    "hc_mean": "float64",
    "difference": "float64",
    "difference_lo": "float64",
    "difference_hi": "float64",
    "hedges_g": "float64",
    "hedges_g_lo": "float64",
    "hedges_g_hi": "float64",
    "auc": "float64",
    "auc_lo": "float64",
    "auc_hi": "float64",
}
_WITH_INTERVALS = ("difference", "hedges_g", "auc")


@dataclass(frozen=True)
class GroupStats:
    """Each statistic as ``(resamples, measures)``."""

    n_pd: np.ndarray
    n_hc: np.ndarray
    pd_mean: np.ndarray
    hc_mean: np.ndarray
    difference: np.ndarray
    hedges_g: np.ndarray
    auc: np.ndarray


def _moments(weights: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted count, mean and variance (ddof=1 on the count) of each measure.

    ``weights`` ``(resamples, participants)``; ``values`` ``(participants, measures)`` with NaN
    where a participant has no value. Values are centred on their column mean first, so the
    variance from sums of squares does not cancel.
    """
    ok = np.isfinite(values)
    centre = np.zeros(values.shape[1])
    has = ok.any(axis=0)
    centre[has] = np.nanmean(values[:, has], axis=0)
    v = np.where(ok, values - centre, 0.0)
    count = weights @ ok.astype(np.float64)
    s1 = weights @ v
    s2 = weights @ (v * v)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = s1 / count
        var = (s2 - count * mean * mean) / (count - 1)
    var = np.where(count >= 2, np.maximum(var, 0.0), np.nan)
    return count, np.where(count > 0, mean + centre, np.nan), var


def _auc(w_pd: np.ndarray, w_hc: np.ndarray, x_pd: np.ndarray, x_hc: np.ndarray) -> np.ndarray:
    """The Mann-Whitney AUC of one measure for each row of weights (NaN values left out).

    With the second group sorted by value and its weights summed cumulatively (``C``), a
    first-group value ``v`` beats the weight below it and ties with the weight equal to it,
    counted half: ``(C[left(v)] + C[right(v)]) / 2`` (``searchsorted`` positions). Weights
    are draw counts, so the sums are whole or half numbers, exact in float32 (which halves
    the memory traffic of the ``(resamples, participants)`` arrays): ``w_pd`` and ``w_hc``
    come as float32, converted once for every measure.
    """
    ok_pd, ok_hc = np.isfinite(x_pd), np.isfinite(x_hc)
    a, b = x_pd[ok_pd], x_hc[ok_hc]
    if a.size == 0 or b.size == 0:
        return np.full(w_pd.shape[0], np.nan)
    wa = w_pd if ok_pd.all() else w_pd[:, ok_pd]
    order = np.argsort(b, kind="stable")
    b_sorted = b[order]
    wb = w_hc[:, np.flatnonzero(ok_hc)[order]]
    cum = np.zeros((wb.shape[0], b.size + 1), dtype=np.float32)
    np.cumsum(wb, axis=1, out=cum[:, 1:])
    left = np.searchsorted(b_sorted, a, side="left")
    right = np.searchsorted(b_sorted, a, side="right")
    score = cum[:, left]
    if (right != left).any():
        score += cum[:, right]
        score *= 0.5
    won = np.einsum("ij,ij->i", wa, score, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return won / (wa.sum(axis=1, dtype=np.float64) * wb.sum(axis=1, dtype=np.float64))


def group_stats(
    w_pd: np.ndarray, w_hc: np.ndarray, values_pd: np.ndarray, values_hc: np.ndarray
) -> GroupStats:
    """Every statistic of every measure, for each row of participant weights.

    ``w_pd`` ``(resamples, n1)`` and ``w_hc`` ``(resamples, n2)`` are how often each
    participant counts (all ones: the sample itself); ``values_*`` ``(n, measures)``.
    """
    n1, m1, v1 = _moments(w_pd, values_pd)
    n2, m2, v2 = _moments(w_hc, values_hc)
    with np.errstate(invalid="ignore", divide="ignore"):
        pooled = np.sqrt(((n1 - 1) * v1 + (n2 - 1) * v2) / (n1 + n2 - 2))
        factor = 1.0 - 3.0 / (4.0 * (n1 + n2) - 9.0)
        g = np.where((n1 >= 2) & (n2 >= 2) & (pooled > 0), (m1 - m2) / pooled * factor, np.nan)
    w_pd32, w_hc32 = w_pd.astype(np.float32), w_hc.astype(np.float32)
    auc = np.column_stack(
        [_auc(w_pd32, w_hc32, values_pd[:, k], values_hc[:, k]) for k in range(values_pd.shape[1])]
    )
    return GroupStats(n1, n2, m1, m2, m1 - m2, g, auc.reshape(w_pd.shape[0], -1))


def draw_counts(rng: np.random.Generator, n: int, n_resamples: int) -> np.ndarray:
    """How often each of ``n`` participants is drawn in each resample: ``(n_resamples, n)``
    counts of ``rng.integers(0, n, (n_resamples, n))``'s rows."""
    if n == 0:
        return np.zeros((n_resamples, 0))
    draws = rng.integers(0, n, (n_resamples, n)).astype(np.int64)
    cells = draws + (np.arange(n_resamples, dtype=np.int64) * n)[:, None]
    counts = np.bincount(cells.ravel(), minlength=n_resamples * n)
    return counts.reshape(n_resamples, n).astype(np.float64)


def contrasts_table(
    profile: pd.DataFrame,
    measures: Sequence[str],
    *,
    by: str,
    levels: tuple[str, str],
    n_resamples: int = 1000,
    seed: int = 0,
    chunk: int = 1000,
    progress: Callable[[Iterable[int], int], Iterable[int]] | None = None,
) -> pd.DataFrame:
    """``contrasts.csv``: one row per measure (module docstring).

    ``profile`` is :func:`turn_eval.profile.measures.profile_table`'s rows of the participants
    compared (the suppressed ones left out: they are not resampled); ``levels[0]`` is reported
    in the ``pd`` columns. Resamples are evaluated ``chunk`` at a time (memory: a chunk of weights).
    """
    group = profile[by].to_numpy(dtype=object)
    values = profile.loc[:, list(measures)].to_numpy(dtype=np.float64)
    x_pd, x_hc = values[group == levels[0]], values[group == levels[1]]
    point = group_stats(np.ones((1, x_pd.shape[0])), np.ones((1, x_hc.shape[0])), x_pd, x_hc)
    rng = np.random.default_rng(seed)
    w_pd_all = draw_counts(rng, x_pd.shape[0], n_resamples)
    w_hc_all = draw_counts(rng, x_hc.shape[0], n_resamples)
    starts: Iterable[int] = range(0, n_resamples, chunk)
    if progress is not None:
        starts = progress(starts, -(-n_resamples // chunk))
    parts = [
        group_stats(w_pd_all[s : s + chunk], w_hc_all[s : s + chunk], x_pd, x_hc) for s in starts
    ]
    rows: dict[str, list[object]] = {c: [] for c in CONTRAST_COLUMNS}
    for k, measure in enumerate(measures):
        rows["measure"].append(measure)
        rows["n_pd"].append(int(point.n_pd[0, k]))
        rows["n_hc"].append(int(point.n_hc[0, k]))
        rows["pd_mean"].append(point.pd_mean[0, k])
        rows["hc_mean"].append(point.hc_mean[0, k])
        for name in _WITH_INTERVALS:
            rows[name].append(getattr(point, name)[0, k])
            drawn = [getattr(p, name)[:, k] for p in parts]
            interval = percentile_interval(np.concatenate(drawn)) if drawn else None
            low, high = interval if interval is not None else (np.nan, np.nan)
            rows[f"{name}_lo"].append(low)
            rows[f"{name}_hi"].append(high)
    return typed_frame(pd.DataFrame(rows), CONTRAST_COLUMNS)
