"""The paper's metrics, per clip and aggregated, and their bootstrap confidence intervals.

Cheng et al., "Your Turn", Section 5 (Evaluation metrics), as DESIGN.md fixes them:

``accuracy``
    The fraction of clips whose predicted and reference angles fall in the same bin, both
    quantised to the nearest multiple of 45° by :func:`turn_datasets.geometry.quantise_deg`
    (``45 * floor(angle / 45 + 0.5)``).
``mae_deg``
    Mean absolute error of the predicted angle against the reference's continuous angle.
``wprec``
    scikit-learn's ``precision_score(ref_bins, pred_bins, average="weighted",
    zero_division=0)``: each bin's precision weighted by its number of reference clips.
    :func:`metrics_of` calls scikit-learn; the grouped and resampled paths compute the same
    from per-bin counts of reference, predicted and right clips
    (:func:`wprec_from_counts`), tested equal to it.
``mae_speed_deg_s``
    Mean absolute error of the angular speed, equation 4 (:func:`angular_speed_deg_s`): the
    predicted ``speed_deg_s`` where the submission gives one, else the predicted angle over
    the reference duration, against the reference angle over the reference duration.
    ``None`` when no clip has a positive reference duration.

Also, for the whole set: each bin's precision and recall (scikit-learn's
``precision_recall_fscore_support``) and Cohen's kappa between predicted and reference bins
with quadratic weights (:func:`quadratic_kappa`: scikit-learn's ``cohen_kappa_score`` with
every bin between the smallest and the largest as a label, so a disagreement of two bins
weighs as two bins even when the bin between them is empty).

Bootstrap
    Percentile intervals over clips, as ``scipy.stats.bootstrap(method="percentile")``
    computes them, with the same draws: the resample index matrix of ``n_resamples`` rows is
    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))``, drawn in chunks of
    rows (the generator's stream is the same) to bound memory; the bounds are the 2.5th and
    97.5th percentiles of the resampled statistic (linear interpolation). One index matrix
    resamples all the clips, and each group's metric on a resample is computed on that group's
    clips in it, so a reader reproduces any interval with scipy on the same clips and seed
    (paired, with a statistic that keeps the group's clips). The metrics of all groups on all
    resamples come from per-resample draw counts (``np.bincount``) and two sparse products
    (:class:`_Engine`), never from a call to scikit-learn per resample.

From a notebook or another tool, :func:`compute_metrics` gives the metrics of one set of
predictions (plain arrays in, a dict out) and :func:`bootstrap_ci` their pooled intervals;
``turn-eval score`` uses the grouped functions (:func:`grouped_metrics`,
:func:`grouped_bootstrap`) that compute every group at once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from sklearn.metrics import precision_recall_fscore_support, precision_score

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import angular_speed_deg_s, quantise_deg
from turn_eval.scoring.bootstrap import (
    CHUNK_CELLS,
    CONFIDENCE,
    percentile_interval,
    resample_indices,
)

__all__ = [
    "METRICS",
    "KAPPA_WEIGHTS",
    "ClipOutcomes",
    "clip_outcomes",
    "compute_metrics",
    "metrics_of",
    "bin_report",
    "quadratic_kappa",
    "Partition",
    "grouped_bootstrap",
    "grouped_metrics",
    "pooled_resampler",
    "bootstrap_distribution",
    "bootstrap_ci",
    "wprec_from_counts",
]

#: The aggregate metrics, in the paper's row order.
METRICS = ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s")
#: Weighting of Cohen's kappa between bins (ordinal classes: far misses weigh more).
KAPPA_WEIGHTS = "quadratic"


@dataclass(frozen=True)
class ClipOutcomes:
    """What every metric needs, per clip, computed once and subset per group.

    Attributes
    ----------
    bins_deg
        The bin labels (degrees) that occur in the reference or the predictions, sorted.
    ref_bin, pred_bin
        Each clip's reference and predicted bin as an index into ``bins_deg``.
    abs_error_deg
        ``|pred - ref|`` in degrees.
    abs_error_speed_deg_s
        ``|pred speed - ref speed|`` (equation 4), NaN where the reference has no positive
        duration; None when no reference duration was given at all.
    """

    bins_deg: np.ndarray
    ref_bin: np.ndarray
    pred_bin: np.ndarray
    abs_error_deg: np.ndarray
    abs_error_speed_deg_s: np.ndarray | None

    @property
    def n(self) -> int:
        return int(self.ref_bin.shape[0])

    @property
    def correct(self) -> np.ndarray:
        """Whether each clip's predicted bin is its reference bin."""
        return self.ref_bin == self.pred_bin

    def subset(self, mask: np.ndarray) -> ClipOutcomes:
        """The outcomes of the clips where ``mask`` is true (or at the given indices)."""
        speed = self.abs_error_speed_deg_s
        return ClipOutcomes(
            bins_deg=self.bins_deg,
            ref_bin=self.ref_bin[mask],
            pred_bin=self.pred_bin[mask],
            abs_error_deg=self.abs_error_deg[mask],
            abs_error_speed_deg_s=None if speed is None else speed[mask],
        )


def _as_float(values, name: str) -> np.ndarray:
    out = np.asarray(values, dtype=np.float64).reshape(-1)
    if not np.isfinite(out).all():
        raise TurnbenchError(f"{name} must be finite numbers")
    return out


def clip_outcomes(
    pred_deg,
    ref_deg,
    *,
    ref_duration_s=None,
    pred_speed_deg_s=None,
    bin_width_deg: float = 45.0,
) -> ClipOutcomes:
    """Per-clip outcomes of a submission against the reference.

    Parameters
    ----------
    pred_deg, ref_deg
        Predicted and reference turning angles (degrees), one per clip, same order.
    ref_duration_s
        Reference turn durations (seconds); None when the reference has none. Zero, negative
        or NaN durations leave that clip out of the speed metric.
    pred_speed_deg_s
        Predicted angular speeds (degrees per second); NaN (or None for all) where the
        submission gives none, which then uses the predicted angle over the reference
        duration (equation 4).
    bin_width_deg
        Bin width for the quantisation (the paper's 45°).
    """
    pred = _as_float(pred_deg, "predicted angles")
    ref = _as_float(ref_deg, "reference angles")
    if pred.shape != ref.shape:
        raise TurnbenchError(
            f"{pred.shape[0]} predicted angles for {ref.shape[0]} reference angles"
        )
    pred_q = np.asarray(quantise_deg(pred, bin_width_deg), dtype=np.float64).reshape(-1)
    ref_q = np.asarray(quantise_deg(ref, bin_width_deg), dtype=np.float64).reshape(-1)
    bins, inverse = np.unique(np.concatenate([ref_q, pred_q]), return_inverse=True)
    inverse = inverse.reshape(-1).astype(np.int32)
    speed_error = None
    if ref_duration_s is not None:
        duration = np.asarray(ref_duration_s, dtype=np.float64).reshape(-1)
        ref_speed = np.asarray(angular_speed_deg_s(ref, duration), dtype=np.float64).reshape(-1)
        pred_speed = np.asarray(angular_speed_deg_s(pred, duration), dtype=np.float64).reshape(-1)
        if pred_speed_deg_s is not None:
            given = np.asarray(pred_speed_deg_s, dtype=np.float64).reshape(-1)
            pred_speed = np.where(np.isfinite(given), given, pred_speed)
        speed_error = np.abs(pred_speed - ref_speed)
        speed_error[~np.isfinite(ref_speed)] = np.nan
    return ClipOutcomes(
        bins_deg=bins,
        ref_bin=inverse[: ref.shape[0]],
        pred_bin=inverse[ref.shape[0] :],
        abs_error_deg=np.abs(pred - ref),
        abs_error_speed_deg_s=speed_error,
    )


def _mean_or_none(values: np.ndarray | None) -> float | None:
    if values is None:
        return None
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if finite.size else None


def metrics_of(outcomes: ClipOutcomes) -> dict[str, float | int | None]:
    """``n`` and the :data:`METRICS` of a set of clips (scikit-learn for WPrec)."""
    if outcomes.n == 0:
        raise TurnbenchError("no clips to score")
    return {
        "n": outcomes.n,
        "accuracy": float(np.mean(outcomes.correct)),
        "mae_deg": float(np.mean(outcomes.abs_error_deg)),
        # The bins as their positions in the sorted bin list: the same classes in the same
        # order, so the same WPrec, and integer labels, which scikit-learn never mistakes for
        # continuous targets (a float bin beyond 2**63 would be).
        "wprec": float(
            precision_score(
                outcomes.ref_bin, outcomes.pred_bin, average="weighted", zero_division=0
            )
        ),
        "mae_speed_deg_s": _mean_or_none(outcomes.abs_error_speed_deg_s),
    }


def compute_metrics(
    pred_deg,
    ref_deg,
    *,
    ref_duration_s=None,
    pred_speed_deg_s=None,
    bin_width_deg: float = 45.0,
) -> dict[str, float | int | None]:
    """The paper's metrics of one set of predictions (see the module docstring).

    Returns
    -------
    dict
        ``n``, ``accuracy`` and ``wprec`` (fractions), ``mae_deg`` (degrees),
        ``mae_speed_deg_s`` (degrees per second, None without durations).
    """
    return metrics_of(
        clip_outcomes(
            pred_deg,
            ref_deg,
            ref_duration_s=ref_duration_s,
            pred_speed_deg_s=pred_speed_deg_s,
            bin_width_deg=bin_width_deg,
        )
    )


def bin_report(outcomes: ClipOutcomes, *, bin_width_deg: float = 45.0) -> dict[str, object]:
    """Per-bin precision and recall, and the weighted kappa between predicted and reference bins.

    Returns
    -------
    dict
        ``per_bin``: for every bin (label ``"45"``, ...) ``n`` (reference clips in it),
        ``n_predicted``, ``precision`` and ``recall`` (zero where undefined, as WPrec);
        ``kappa``: Cohen's kappa with :data:`KAPPA_WEIGHTS` weights, None when undefined
        (every clip in one bin on both sides).
    """
    labels = outcomes.bins_deg
    positions = np.arange(labels.shape[0])
    precision, recall, _, support = precision_recall_fscore_support(
        outcomes.ref_bin, outcomes.pred_bin, labels=positions, zero_division=0
    )
    n_predicted = np.bincount(outcomes.pred_bin, minlength=labels.shape[0])
    per_bin = {
        f"{label:g}": {
            "n": int(support[k]),
            "n_predicted": int(n_predicted[k]),
            "precision": float(precision[k]),
            "recall": float(recall[k]),
        }
        for k, label in enumerate(labels)
    }
    return {"per_bin": per_bin, "kappa": quadratic_kappa(outcomes, bin_width_deg=bin_width_deg)}


def quadratic_kappa(outcomes: ClipOutcomes, *, bin_width_deg: float = 45.0) -> float | None:
    """Cohen's kappa between reference and predicted bins with quadratic weights in bin steps.

    scikit-learn's ``cohen_kappa_score(weights="quadratic")`` is ``1 - sum(w O) / sum(w E)``
    with ``O`` the confusion counts, ``E`` the outer product of their marginals over ``n``
    and ``w = (i - j)**2`` for label positions ``i, j``. Given every bin step between the
    lowest and the highest bin as a label, a disagreement of two bins weighs as two bins
    even when the bin between them is empty. With ``x`` and ``y`` each clip's reference and
    predicted step, the two sums are ``n`` times ``mean((x - y)**2)`` and
    ``var(x) + var(y) + (mean(x) - mean(y))**2`` (population variances), so the same kappa
    needs no ``steps x steps`` matrix, however far a prediction strays (tested equal to
    scikit-learn's on the step grid). The steps are scaled by their span first, which
    leaves the ratio unchanged and keeps huge angles from overflowing.

    Returns
    -------
    float or None
        The kappa; None when undefined (every clip in one bin on both sides).
    """
    bins = outcomes.bins_deg
    steps = (bins - bins[0]) / bin_width_deg
    span = float(steps[-1])
    if span == 0.0:
        return None
    x = steps[outcomes.ref_bin] / span
    y = steps[outcomes.pred_bin] / span
    chance = x.var() + y.var() + (x.mean() - y.mean()) ** 2
    if not chance > 0.0:
        return None
    return float(1.0 - np.mean((x - y) ** 2) / chance)


def _precision_terms(true, predicted, true_positive) -> np.ndarray:
    """Each bin's ``true * tp / predicted``, zero where nothing was predicted in the bin."""
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = np.where(
            predicted > 0, true_positive / np.where(predicted > 0, predicted, 1.0), 0.0
        )
    return true * precision


def wprec_from_counts(true, predicted, true_positive) -> np.ndarray:
    """Weighted precision from per-bin counts along the last axis.

    ``sum_k true_k * tp_k / pred_k / n`` with ``tp_k / pred_k = 0`` where ``pred_k = 0`` and
    ``n = sum_k true_k``: scikit-learn's ``average="weighted", zero_division=0``, with
    ``true_k`` the reference clips in bin ``k``, ``pred_k`` the clips predicted in it and
    ``tp_k`` those in it on both sides. NaN where ``n = 0``.
    """
    true = np.asarray(true, dtype=np.float64)
    terms = _precision_terms(
        true, np.asarray(predicted, dtype=np.float64), np.asarray(true_positive, dtype=np.float64)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        return terms.sum(axis=-1) / true.sum(axis=-1)


@dataclass(frozen=True)
class Partition:
    """A grouping of the clips: each clip's group as an index into ``labels``."""

    name: str
    labels: tuple[str, ...]
    codes: np.ndarray

    @classmethod
    def whole(cls, n: int, *, name: str = "overall", label: str = "all") -> Partition:
        """Every clip in one group."""
        return cls(name=name, labels=(label,), codes=np.zeros(n, dtype=np.int64))


def _segments(columns: Sequence[np.ndarray], sizes: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Ids of the distinct rows of integer columns (each in ``[0, size)``): the first row of
    each and every row's id, as ``np.unique(axis=0)`` gives them but on one int64 key when
    the sizes' product fits (a 1-D sort instead of a row-wise one)."""
    if math.prod(sizes) < 2**62:
        key = np.zeros(columns[0].shape[0], dtype=np.int64)
        for column, size in zip(columns, sizes, strict=True):
            key = key * size + column
        # np.unique's first indices, without the stable sort it uses to find them (the
        # first index of each value is its smallest).
        uniq, seg = np.unique(key, return_inverse=True)
        first = np.full(uniq.shape[0], key.shape[0], dtype=np.int64)
        np.minimum.at(first, seg.reshape(-1), np.arange(key.shape[0]))
    else:
        _, first, seg = np.unique(
            np.stack(columns, axis=1), axis=0, return_index=True, return_inverse=True
        )
    return first, seg.reshape(-1)


@dataclass
class _Rows:
    """Where one partition's sums sit in the rows of :attr:`_Engine.per_group`.

    Per group: ``abs_error`` (sum of the drawn clips' angle errors) and, with durations,
    ``speed_sum`` and, unless every clip has a speed error, ``speed_count`` (empty slices
    where absent). Per (group, reference bin) pair that occurs:
    ``true`` (drawn clips with that reference bin) and ``true_right`` (those also predicted
    in it); per (group, predicted bin) pair: ``predicted``. ``twin`` is each reference
    pair's predicted pair with the same group and bin (valid where ``has_twin``);
    ``group_of_pairs`` sums the reference pairs of each group (a ``groups x pairs`` matrix
    of ones): the clips drawn and those in their reference bin.
    """

    partition: Partition
    abs_error: slice
    speed_sum: slice
    speed_count: slice
    true: slice
    true_right: slice
    predicted: slice
    group_of_pairs: sparse.csr_array
    twin: np.ndarray
    has_twin: np.ndarray


class _Engine:
    """Every metric of every group of every partition, on many resamples at once.

    The clips are first pooled into *segments*: clips that share their group in every
    partition, their reference and predicted bins and whether they have a speed error are
    interchangeable for the counts. A resample is a vector ``w`` of how often it drew each
    clip (``np.bincount`` of its row of the index matrix); one sparse product turns it into,
    per segment, the number of clips drawn and the sums of their absolute angle and speed
    errors; a second sparse product turns those into the sums of :class:`_Rows`: per group
    the error sums, and per (group, bin) pair that occurs the clips drawn, predicted and
    right, from which follow each group's clips, accuracy and WPrec
    (:func:`wprec_from_counts`). Counting per
    occurring pair, not per cell of a bins x bins confusion matrix, keeps memory linear in
    the clips however widely the predictions spread (a submission in the wrong unit reaches
    hundreds of bins). The metrics follow with array arithmetic. No step costs more than one
    pass over a resample's clips, whatever the number of groups.
    """

    def __init__(self, outcomes: ClipOutcomes, partitions: Sequence[Partition]) -> None:
        n = outcomes.n
        k = int(outcomes.bins_deg.shape[0])
        self.n = n
        speed = outcomes.abs_error_speed_deg_s
        self.has_speed = speed is not None
        ok = np.isfinite(speed) if speed is not None else np.zeros(n, dtype=bool)
        keys = [np.asarray(p.codes, dtype=np.int64) for p in partitions]
        for p, codes in zip(partitions, keys, strict=True):
            if codes.shape != (n,) or (n and (codes.min() < 0 or codes.max() >= len(p.labels))):
                raise TurnbenchError(f"grouping {p.name!r} does not label every clip")
        ref_bin = outcomes.ref_bin.astype(np.int64)
        pred_bin = outcomes.pred_bin.astype(np.int64)
        first, seg = _segments(
            [*keys, ref_bin, pred_bin, ok.astype(np.int64)],
            [*(len(p.labels) for p in partitions), k, k, 2],
        )
        n_seg = first.shape[0]
        clips = np.arange(n)
        blocks = 3 if self.has_speed else 2
        data = [np.ones(n), outcomes.abs_error_deg]
        if speed is not None:
            data.append(np.where(ok, speed, 0.0))
        # Per segment, in adjacent rows: drawn clips, sum of |angle error|, sum of |speed
        # error| (adjacent, so a clip's updates and a group's reads share cache lines).
        self.per_segment = sparse.csr_array(
            (
                np.concatenate(data),
                (np.concatenate([blocks * seg + b for b in range(blocks)]), np.tile(clips, blocks)),
            ),
            shape=(blocks * n_seg, n),
        ).tocsc()  # column by column: reads the draw counts in order (cache-friendly)
        seg_ref, seg_pred, seg_ok = ref_bin[first], pred_bin[first], ok[first]
        segments = np.arange(n_seg)
        right = segments[seg_ref == seg_pred]
        # The columns of the segment sums: drawn clips, angle errors, speed errors.
        drawn, abs_error, *speed_error = (blocks * segments + b for b in range(blocks))
        # With a speed error for every clip, a group's clips with one are all its clips.
        self.speed_everywhere = bool(ok.all())
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []

        def add(where: slice, row: np.ndarray, col: np.ndarray, val=None) -> None:
            rows.append(where.start + row)
            cols.append(col)
            vals.append(np.ones(row.shape[0]) if val is None else val)

        self.layout: list[_Rows] = []
        offset = 0
        for p, codes in zip(partitions, keys, strict=True):
            g = codes[first]
            n_groups = len(p.labels)
            # The (group, bin) pairs that occur, numbered in (group, bin) order.
            ref_keys, ref_pair = np.unique(g * k + seg_ref, return_inverse=True)
            pred_keys, pred_pair = np.unique(g * k + seg_pred, return_inverse=True)
            ref_pair, pred_pair = ref_pair.reshape(-1), pred_pair.reshape(-1)
            twin = np.minimum(np.searchsorted(pred_keys, ref_keys), pred_keys.shape[0] - 1)
            own_speed_count = self.has_speed and not self.speed_everywhere
            sizes = [n_groups] * (1 + self.has_speed + own_speed_count)
            sizes += [ref_keys.shape[0], ref_keys.shape[0], pred_keys.shape[0]]
            bounds = offset + np.concatenate([[0], np.cumsum(sizes)])
            where = [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
            if not self.has_speed:
                where[1:1] = [slice(0, 0)]
            if not own_speed_count:
                where[2:2] = [slice(0, 0)]
            at_abs, at_speed_sum, at_speed_count, at_true, at_true_right, at_predicted = where
            layout = _Rows(
                p,
                at_abs,
                at_speed_sum,
                at_speed_count,
                at_true,
                at_true_right,
                at_predicted,
                group_of_pairs=sparse.csr_array(
                    (np.ones(ref_keys.shape[0]), (ref_keys // k, np.arange(ref_keys.shape[0]))),
                    shape=(n_groups, ref_keys.shape[0]),
                ),
                twin=twin,
                has_twin=pred_keys[twin] == ref_keys,
            )
            add(layout.abs_error, g, abs_error)
            if self.has_speed:
                add(layout.speed_sum, g, speed_error[0])
            if own_speed_count:
                add(layout.speed_count, g, drawn, seg_ok.astype(np.float64))
            add(layout.true, ref_pair, drawn)
            add(layout.true_right, ref_pair[right], drawn[right])
            add(layout.predicted, pred_pair, drawn)
            self.layout.append(layout)
            offset = int(bounds[-1])
        # Column-stored too: the product then reads the segment sums once, in order, and
        # adds into the group sums, which fit in cache (measured 1.6x faster than by rows;
        # each sum still adds its terms in column order, so the numbers are the same).
        self.per_group = sparse.csr_array(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(offset, blocks * n_seg),
        ).tocsc()
        # Resamples evaluated in one pass: bounds the dense intermediates (draw counts,
        # segment sums, group sums) to a few arrays of CHUNK_CELLS values, however many
        # rows a chunk has and however many groups and bins there are.
        self.rows_per_pass = max(1, CHUNK_CELLS // max(n, blocks * n_seg, offset))

    def evaluate(self, indices: np.ndarray) -> list[dict[str, np.ndarray]]:
        """Per partition, each metric (and ``n``) as ``(rows, groups)`` for a chunk of rows."""
        idx = np.asarray(indices)
        if idx.ndim != 2 or idx.shape[1] != self.n:
            raise TurnbenchError(
                f"an index matrix for {self.n} clips must have shape (rows, {self.n}), "
                f"got {idx.shape}"
            )
        step = self.rows_per_pass
        if idx.shape[0] <= step:
            return self._evaluate(idx)
        passes = [self._evaluate(idx[i : i + step]) for i in range(0, idx.shape[0], step)]
        return [
            {name: np.concatenate([p[part][name] for p in passes]) for name in passes[0][part]}
            for part in range(len(self.layout))
        ]

    def _evaluate(self, idx: np.ndarray) -> list[dict[str, np.ndarray]]:
        n_rows = idx.shape[0]
        # How often each resample drew each clip, one bincount per resample into a row, then
        # one transposing copy to the clip-major (n, rows) layout: one sparse product with
        # several vectors then gives every resample's per-segment sums, the column-stored
        # matrix walking each clip's row of counts contiguously (measured 1.5x faster than
        # one matrix-vector product per resample). Writing each bincount straight into a
        # column of that layout costs a cache miss per clip and resample instead.
        counts = np.empty((n_rows, self.n), dtype=np.int64)
        for r in range(n_rows):
            counts[r] = np.bincount(idx[r], minlength=self.n)
        drawn = np.array(counts.T, dtype=np.float64, order="C")
        totals = self.per_group @ (self.per_segment @ drawn)
        out = []
        with np.errstate(divide="ignore", invalid="ignore"):
            for rows in self.layout:
                true, true_right = totals[rows.true], totals[rows.true_right]
                count = rows.group_of_pairs @ true
                predicted = np.where(rows.has_twin[:, None], totals[rows.predicted][rows.twin], 0.0)
                terms = _precision_terms(true, predicted, true_right)
                result = {
                    "n": count.T,
                    "accuracy": ((rows.group_of_pairs @ true_right) / count).T,
                    "mae_deg": (totals[rows.abs_error] / count).T,
                    # A group's WPrec sums its pairs' terms (the bins of wprec_from_counts).
                    "wprec": ((rows.group_of_pairs @ terms) / count).T,
                }
                if self.has_speed:
                    have = count if self.speed_everywhere else totals[rows.speed_count]
                    result["mae_speed_deg_s"] = (totals[rows.speed_sum] / have).T
                out.append(result)
        return out


def grouped_bootstrap(
    outcomes: ClipOutcomes,
    partitions: Sequence[Partition],
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    indices: Iterable[np.ndarray] | None = None,
) -> list[dict[str, np.ndarray]]:
    """Every metric of every group on every bootstrap resample of the clips.

    One index matrix (:func:`resample_indices`, scipy's draws) resamples all the clips;
    each group's metric on a resample is computed on the clips of that group the resample
    drew. So every number shares the same resamples (the groups of a grouping are resampled
    jointly, which is what makes an interval for their average meaningful), and a reader
    reproduces a group's interval with ``scipy.stats.bootstrap`` on all the clips, paired,
    with a statistic that keeps the group's clips. A resample that drew no clip of a group
    gives NaN for that group (:func:`percentile_interval` leaves it out).

    Parameters
    ----------
    outcomes
        The clips' outcomes.
    partitions
        Groupings of the clips; use :meth:`Partition.whole` for the pooled set.
    n_resamples, seed
        The resampling, as :func:`resample_indices`.
    indices
        Chunks of an index matrix to use instead of drawing one (tests, paired designs).

    Returns
    -------
    list of dict
        Per partition, ``n`` and each metric as an ``(n_resamples, n_groups)`` array
        (``mae_speed_deg_s`` only with durations).
    """
    engine = _Engine(outcomes, partitions)
    chunks = (
        indices
        if indices is not None
        else resample_indices(outcomes.n, n_resamples=n_resamples, seed=seed)
    )
    parts: list[dict[str, list[np.ndarray]]] = [{} for _ in partitions]
    for chunk in chunks:
        for store, result in zip(parts, engine.evaluate(chunk), strict=True):
            for name, values in result.items():
                store.setdefault(name, []).append(values)
    return [
        {name: np.concatenate(values, axis=0) for name, values in store.items()} if store else {}
        for store in parts
    ]


def grouped_metrics(
    outcomes: ClipOutcomes, partitions: Sequence[Partition]
) -> list[dict[str, np.ndarray]]:
    """``n`` and every metric of every group, on the clips as they are (no resampling).

    The same computation as :func:`grouped_bootstrap` on the one "resample" that draws every
    clip once, so the observed values and their intervals come from one code path; it equals
    :func:`metrics_of` (scikit-learn's WPrec) on each group's clips (tested). A group with
    no clip that has a speed gets NaN for ``mae_speed_deg_s``.

    Returns
    -------
    list of dict
        Per partition, ``n`` and each metric as an array with one value per group.
    """
    observed = grouped_bootstrap(
        outcomes, partitions, indices=[np.arange(outcomes.n, dtype=np.int64)[None, :]]
    )
    return [{name: values[0] for name, values in result.items()} for result in observed]


def pooled_resampler(outcomes: ClipOutcomes) -> Callable[[np.ndarray], dict[str, np.ndarray]]:
    """A function giving every metric of the pooled clips on each row of an index matrix.

    The set-up (segments, sparse matrices) is done once here, so a caller that evaluates
    many chunks of resamples (the paired comparison) pays it once.
    """
    engine = _Engine(outcomes, [Partition.whole(outcomes.n)])

    def evaluate(indices: np.ndarray) -> dict[str, np.ndarray]:
        (result,) = engine.evaluate(indices)
        return {name: values[:, 0] for name, values in result.items() if name != "n"}

    return evaluate


def bootstrap_distribution(
    outcomes: ClipOutcomes, *, n_resamples: int = 1000, seed: int = 0
) -> dict[str, np.ndarray]:
    """Each metric on ``n_resamples`` bootstrap resamples of the clips (scipy's draws)."""
    (result,) = grouped_bootstrap(
        outcomes, [Partition.whole(outcomes.n)], n_resamples=n_resamples, seed=seed
    )
    return {name: values[:, 0] for name, values in result.items() if name != "n"}


def bootstrap_ci(
    outcomes: ClipOutcomes,
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    confidence: float = CONFIDENCE,
) -> dict[str, tuple[float, float] | None]:
    """Percentile bootstrap intervals of every metric of the pooled clips."""
    distribution = bootstrap_distribution(outcomes, n_resamples=n_resamples, seed=seed)
    return {
        name: percentile_interval(values, confidence=confidence)
        for name, values in distribution.items()
    }
