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
    from confusion counts (:func:`wprec_from_confusion`), tested equal to it.
``mae_speed_deg_s``
    Mean absolute error of the angular speed, equation 4 (:func:`angular_speed_deg_s`): the
    predicted ``speed_deg_s`` where the submission gives one, else the predicted angle over
    the reference duration, against the reference angle over the reference duration.
    ``None`` when no clip has a positive reference duration.

Also, for the whole set: each bin's precision and recall (scikit-learn's
``precision_recall_fscore_support``) and Cohen's kappa between predicted and reference bins
with quadratic weights (scikit-learn's ``cohen_kappa_score``). The kappa is given every bin
between the smallest and the largest as a label, so a disagreement of two bins weighs as two
bins even when the bin between them is empty (scikit-learn weighs by label position).

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
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from sklearn.metrics import cohen_kappa_score, precision_recall_fscore_support, precision_score

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import angular_speed_deg_s, quantise_deg

__all__ = [
    "METRICS",
    "CONFIDENCE",
    "KAPPA_WEIGHTS",
    "ClipOutcomes",
    "clip_outcomes",
    "compute_metrics",
    "metrics_of",
    "bin_report",
    "Partition",
    "chunk_rows",
    "resample_indices",
    "grouped_bootstrap",
    "grouped_metrics",
    "resampled_metrics",
    "bootstrap_distribution",
    "percentile_interval",
    "bootstrap_ci",
    "wprec_from_confusion",
]

#: The aggregate metrics, in the paper's row order.
METRICS = ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s")
#: Two-sided confidence level of every interval.
CONFIDENCE = 0.95
#: Weighting of Cohen's kappa between bins (ordinal classes: far misses weigh more).
KAPPA_WEIGHTS = "quadratic"
#: Index-matrix cells per chunk of resamples: a few arrays of this many 4- or 8-byte values.
_CHUNK_CELLS = 1 << 21


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
        pred_speed = np.asarray(
            angular_speed_deg_s(pred, duration), dtype=np.float64
        ).reshape(-1)
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
    ref_bins = outcomes.bins_deg[outcomes.ref_bin]
    pred_bins = outcomes.bins_deg[outcomes.pred_bin]
    return {
        "n": outcomes.n,
        "accuracy": float(np.mean(outcomes.correct)),
        "mae_deg": float(np.mean(outcomes.abs_error_deg)),
        "wprec": float(
            precision_score(ref_bins, pred_bins, average="weighted", zero_division=0)
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
    ref_bins = outcomes.bins_deg[outcomes.ref_bin]
    pred_bins = outcomes.bins_deg[outcomes.pred_bin]
    labels = outcomes.bins_deg
    precision, recall, _, support = precision_recall_fscore_support(
        ref_bins, pred_bins, labels=labels, zero_division=0
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
    if labels.shape[0] < 2:
        kappa = None
    else:
        # Bins as their step number from the lowest, with every step in between as a label,
        # so the quadratic weights count bins, not labels present (and scikit-learn takes
        # its fast path for labels 0..k-1).
        ref_step = np.rint((ref_bins - labels[0]) / bin_width_deg).astype(np.int64)
        pred_step = np.rint((pred_bins - labels[0]) / bin_width_deg).astype(np.int64)
        grid = np.arange(int(max(ref_step.max(), pred_step.max())) + 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            value = cohen_kappa_score(ref_step, pred_step, labels=grid, weights=KAPPA_WEIGHTS)
        kappa = float(value) if np.isfinite(value) else None
    return {"per_bin": per_bin, "kappa": kappa}


def chunk_rows(n: int) -> int:
    """Resamples drawn and evaluated together for ``n`` clips: bounds memory to a few arrays
    of :data:`_CHUNK_CELLS` values whatever ``n``."""
    return max(1, _CHUNK_CELLS // max(n, 1))


def resample_indices(
    n: int, *, n_resamples: int = 1000, seed: int = 0, rows_per_chunk: int | None = None
) -> Iterator[np.ndarray]:
    """The bootstrap index matrix of ``scipy.stats.bootstrap``, in chunks of rows.

    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))`` is what scipy draws
    for one sample, or for paired samples (whose common index it resamples); drawing it a
    chunk of rows at a time takes the same values from the generator's stream. The values are
    ``uint32``: for any ``n`` below 2**32 the generator draws 32-bit values whatever the
    requested type, so they equal scipy's ``int64`` draws (tested).

    Yields
    ------
    ndarray
        ``(rows, n)`` chunks, ``n_resamples`` rows in all.
    """
    if n < 1:
        raise TurnbenchError("cannot resample an empty set of clips")
    if n >= 2**32:
        raise TurnbenchError(f"too many clips to resample ({n})")
    if n_resamples < 0:
        raise TurnbenchError(f"the number of resamples must be 0 or more, got {n_resamples}")
    rows = rows_per_chunk if rows_per_chunk is not None else chunk_rows(n)
    rng = np.random.default_rng(seed)
    for start in range(0, n_resamples, rows):
        count = min(rows, n_resamples - start)
        yield rng.integers(0, n, (count, n), dtype=np.uint32)


def wprec_from_confusion(confusion: np.ndarray) -> np.ndarray:
    """Weighted precision from confusion counts ``(..., ref bin, predicted bin)``.

    ``sum_k true_k * tp_k / pred_k / n`` with ``tp_k / pred_k = 0`` where ``pred_k = 0``:
    scikit-learn's ``average="weighted", zero_division=0``. NaN where ``n = 0``.
    """
    counts = np.asarray(confusion, dtype=np.float64)
    tp = np.diagonal(counts, axis1=-2, axis2=-1)
    true = counts.sum(axis=-1)
    pred = counts.sum(axis=-2)
    n = true.sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = np.where(pred > 0, tp / np.where(pred > 0, pred, 1.0), 0.0)
        return (true * precision).sum(axis=-1) / n


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
        _, first, seg = np.unique(key, return_index=True, return_inverse=True)
    else:
        _, first, seg = np.unique(
            np.stack(columns, axis=1), axis=0, return_index=True, return_inverse=True
        )
    return first, seg.reshape(-1)


class _Engine:
    """Every metric of every group of every partition, on many resamples at once.

    The clips are first pooled into *segments*: clips that share their group in every
    partition, their (reference bin, predicted bin) cell and whether they have a speed error
    are interchangeable for the counts. A resample is a vector ``w`` of how often it drew
    each clip (``np.bincount`` of its row of the index matrix); one sparse product turns it
    into, per segment, the number of clips drawn and the sums of their absolute angle and
    speed errors; a second sparse product turns those into, per group, the confusion counts
    and the error sums. The metrics follow from those with array arithmetic. No step costs
    more than one pass over a resample's clips, whatever the number of groups.
    """

    def __init__(self, outcomes: ClipOutcomes, partitions: Sequence[Partition]) -> None:
        n = outcomes.n
        k = outcomes.bins_deg.shape[0]
        self.n, self.k = n, k
        n_cells = k * k
        cell = outcomes.ref_bin.astype(np.int64) * k + outcomes.pred_bin
        speed = outcomes.abs_error_speed_deg_s
        self.has_speed = speed is not None
        ok = np.isfinite(speed) if speed is not None else np.zeros(n, dtype=bool)
        keys = [np.asarray(p.codes, dtype=np.int64) for p in partitions]
        for p, codes in zip(partitions, keys, strict=True):
            if codes.shape != (n,) or (n and (codes.min() < 0 or codes.max() >= len(p.labels))):
                raise TurnbenchError(f"grouping {p.name!r} does not label every clip")
        first, seg = _segments([*keys, cell, ok.astype(np.int64)], [
            *(len(p.labels) for p in partitions), n_cells, 2
        ])
        n_seg = first.shape[0]
        clips = np.arange(n)
        blocks = 3 if self.has_speed else 2
        data = [np.ones(n), outcomes.abs_error_deg]
        if speed is not None:
            data.append(np.where(ok, speed, 0.0))
        # Per segment: [drawn clips; sum of |angle error|; sum of |speed error|].
        self.per_segment = sparse.csr_array(
            (
                np.concatenate(data),
                (np.concatenate([seg + b * n_seg for b in range(blocks)]), np.tile(clips, blocks)),
            ),
            shape=(blocks * n_seg, n),
        ).tocsc()  # column by column: reads the draw counts in order (cache-friendly)
        seg_cell, seg_ok = cell[first], ok[first]
        rows, cols, vals = [], [], []
        self.layout: list[tuple[Partition, int]] = []
        offset = 0
        for p, codes in zip(partitions, keys, strict=True):
            g = codes[first]
            n_groups = len(p.labels)
            segments = np.arange(n_seg)
            # Confusion cells per group from the drawn counts.
            rows.append(offset + g * n_cells + seg_cell)
            cols.append(segments)
            vals.append(np.ones(n_seg))
            base = offset + n_groups * n_cells
            # Sum of |angle error| per group.
            rows.append(base + g)
            cols.append(n_seg + segments)
            vals.append(np.ones(n_seg))
            if self.has_speed:
                # Sum of |speed error| and the number of clips that have one, per group.
                rows.append(base + n_groups + g)
                cols.append(2 * n_seg + segments)
                vals.append(np.ones(n_seg))
                rows.append(base + 2 * n_groups + g)
                cols.append(segments)
                vals.append(seg_ok.astype(np.float64))
            self.layout.append((p, offset))
            offset = base + (3 if self.has_speed else 1) * n_groups
        self.per_group = sparse.csr_array(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(offset, blocks * n_seg),
        )

    def evaluate(self, indices: np.ndarray) -> list[dict[str, np.ndarray]]:
        """Per partition, each metric (and ``n``) as ``(rows, groups)`` for a chunk of rows."""
        idx = np.asarray(indices)
        if idx.ndim != 2 or idx.shape[1] != self.n:
            raise TurnbenchError(
                f"an index matrix for {self.n} clips must have shape (rows, {self.n}), "
                f"got {idx.shape}"
            )
        n_rows = idx.shape[0]
        # How often each resample drew each clip, laid out clip-major (n, rows) so that one
        # sparse product with several vectors gives every resample's per-segment sums: the
        # column-stored matrix then walks each clip's row of counts contiguously (measured
        # 1.5x faster than one matrix-vector product per resample).
        drawn = np.empty((self.n, n_rows), dtype=np.float64)
        for r in range(n_rows):
            drawn[:, r] = np.bincount(idx[r], minlength=self.n)
        per_segment = self.per_segment @ drawn
        totals = self.per_group @ per_segment
        k, n_cells = self.k, self.k * self.k
        out = []
        with np.errstate(divide="ignore", invalid="ignore"):
            for p, offset in self.layout:
                n_groups = len(p.labels)
                confusion = totals[offset : offset + n_groups * n_cells].reshape(
                    n_groups, k, k, n_rows
                )
                confusion = np.moveaxis(confusion, -1, 0)
                count = confusion.sum(axis=(-2, -1))
                base = offset + n_groups * n_cells
                result = {
                    "n": count,
                    "accuracy": np.trace(confusion, axis1=-2, axis2=-1) / count,
                    "mae_deg": totals[base : base + n_groups].T / count,
                    "wprec": wprec_from_confusion(confusion),
                }
                if self.has_speed:
                    sums = totals[base + n_groups : base + 2 * n_groups].T
                    have = totals[base + 2 * n_groups : base + 3 * n_groups].T
                    result["mae_speed_deg_s"] = sums / have
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
        {name: np.concatenate(values, axis=0) for name, values in store.items()}
        if store
        else {}
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


def resampled_metrics(outcomes: ClipOutcomes, indices: np.ndarray) -> dict[str, np.ndarray]:
    """Every metric of the pooled clips on each row of an index matrix (one value per row)."""
    (result,) = grouped_bootstrap(
        outcomes, [Partition.whole(outcomes.n)], indices=[np.asarray(indices)]
    )
    return {name: values[:, 0] for name, values in result.items() if name != "n"}


def bootstrap_distribution(
    outcomes: ClipOutcomes, *, n_resamples: int = 1000, seed: int = 0
) -> dict[str, np.ndarray]:
    """Each metric on ``n_resamples`` bootstrap resamples of the clips (scipy's draws)."""
    (result,) = grouped_bootstrap(
        outcomes, [Partition.whole(outcomes.n)], n_resamples=n_resamples, seed=seed
    )
    return {name: values[:, 0] for name, values in result.items() if name != "n"}


def percentile_interval(
    values: np.ndarray, *, confidence: float = CONFIDENCE
) -> tuple[float, float] | None:
    """The percentile interval of a bootstrap distribution (linear interpolation, as scipy).

    Undefined (NaN) resamples are left out; None when none is defined.
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    alpha = (1 - confidence) / 2
    low, high = np.percentile(v, [100 * alpha, 100 * (1 - alpha)])
    return float(low), float(high)


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
