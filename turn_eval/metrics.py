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
    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))``, drawn here in chunks
    of rows (the generator's stream is the same) to bound memory; the bounds are the 2.5th
    and 97.5th percentiles of the resampled statistic (linear interpolation). A reader can
    therefore reproduce any interval with scipy on the same clips and seed. All metrics of a
    resample come from one gather per clip and one ``np.bincount`` of confusion cells per
    chunk, never from a call to scikit-learn per resample.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np
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
    "resample_indices",
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
    # Every bin between the extremes, so that the quadratic weights count bins, not labels.
    grid = np.arange(labels[0], labels[-1] + bin_width_deg / 2, bin_width_deg)
    if labels.shape[0] < 2:
        kappa = None
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            value = cohen_kappa_score(ref_bins, pred_bins, labels=grid, weights=KAPPA_WEIGHTS)
        kappa = float(value) if np.isfinite(value) else None
    return {"per_bin": per_bin, "kappa": kappa}


def resample_indices(
    n: int, *, n_resamples: int = 1000, seed: int = 0, chunk_rows: int | None = None
) -> Iterator[np.ndarray]:
    """The bootstrap index matrix of ``scipy.stats.bootstrap``, in chunks of rows.

    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))`` is what scipy draws
    for one sample (or for paired samples, whose index it resamples); drawing it a chunk of
    rows at a time takes the same values from the generator's stream. The values are
    returned as ``uint32`` (the generator draws 32-bit values for any ``n`` below 2**32, so
    they equal the ``int64`` draws; tested).

    Yields
    ------
    ndarray
        ``(rows, n)`` chunks, ``n_resamples`` rows in all.
    """
    if n < 1:
        raise TurnbenchError("cannot resample an empty set of clips")
    if n >= 2**32:
        raise TurnbenchError(f"too many clips to resample ({n})")
    rows = chunk_rows if chunk_rows is not None else max(1, _CHUNK_CELLS // n)
    rng = np.random.default_rng(seed)
    for start in range(0, n_resamples, rows):
        count = min(rows, n_resamples - start)
        yield rng.integers(0, n, (count, n), dtype=np.uint32)


def wprec_from_confusion(confusion: np.ndarray) -> np.ndarray:
    """Weighted precision from confusion counts ``(..., ref bin, predicted bin)``.

    ``sum_k true_k * tp_k / pred_k / n`` with ``tp_k / pred_k = 0`` where ``pred_k = 0``:
    scikit-learn's ``average="weighted", zero_division=0``.
    """
    counts = np.asarray(confusion, dtype=np.float64)
    tp = np.diagonal(counts, axis1=-2, axis2=-1)
    true = counts.sum(axis=-1)
    pred = counts.sum(axis=-2)
    n = true.sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = np.where(pred > 0, tp / np.where(pred > 0, pred, 1.0), 0.0)
    return (true * precision).sum(axis=-1) / n


def resampled_metrics(outcomes: ClipOutcomes, indices: np.ndarray) -> dict[str, np.ndarray]:
    """Every metric on every resample of an index matrix, vectorised.

    Parameters
    ----------
    outcomes
        The clips' outcomes.
    indices
        ``(n_resamples, n)`` indices into the clips (each row one resample).

    Returns
    -------
    dict
        For each of :data:`METRICS`, an array of ``n_resamples`` values (``mae_speed_deg_s``
        absent without durations; NaN in a resample with no clip that has a speed).
    """
    idx = np.asarray(indices)
    if idx.ndim != 2:
        raise TurnbenchError(f"an index matrix must be 2-D, got shape {idx.shape}")
    rows, n = idx.shape
    k = outcomes.bins_deg.shape[0]
    cell = (outcomes.ref_bin * k + outcomes.pred_bin).astype(np.int32)
    offsets = (np.arange(rows, dtype=np.int32) * (k * k))[:, None]
    confusion = np.bincount(
        (cell[idx] + offsets).reshape(-1), minlength=rows * k * k
    ).reshape(rows, k, k)
    out: dict[str, np.ndarray] = {
        "accuracy": np.trace(confusion, axis1=1, axis2=2) / n,
        "mae_deg": outcomes.abs_error_deg[idx].sum(axis=1) / n,
        "wprec": wprec_from_confusion(confusion),
    }
    speed = outcomes.abs_error_speed_deg_s
    if speed is not None:
        finite = np.isfinite(speed)
        if finite.all():
            out["mae_speed_deg_s"] = speed[idx].sum(axis=1) / n
        else:
            counts = finite[idx].sum(axis=1)
            sums = np.where(finite, speed, 0.0)[idx].sum(axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                out["mae_speed_deg_s"] = np.where(counts > 0, sums / counts, np.nan)
    return out


def bootstrap_distribution(
    outcomes: ClipOutcomes, *, n_resamples: int = 1000, seed: int = 0
) -> dict[str, np.ndarray]:
    """Each metric on ``n_resamples`` bootstrap resamples of the clips (scipy's draws)."""
    parts: dict[str, list[np.ndarray]] = {}
    for chunk in resample_indices(outcomes.n, n_resamples=n_resamples, seed=seed):
        for name, values in resampled_metrics(outcomes, chunk).items():
            parts.setdefault(name, []).append(values)
    return {name: np.concatenate(values) for name, values in parts.items()}


def percentile_interval(
    values: np.ndarray, *, confidence: float = CONFIDENCE
) -> tuple[float, float] | None:
    """The percentile interval of a bootstrap distribution (linear interpolation, as scipy).

    None when any resample's value is undefined (NaN).
    """
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0 or not np.isfinite(v).all():
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
    """Percentile bootstrap intervals of every metric (:func:`bootstrap_distribution`)."""
    distribution = bootstrap_distribution(outcomes, n_resamples=n_resamples, seed=seed)
    out: Mapping[str, np.ndarray] = distribution
    return {name: percentile_interval(values, confidence=confidence) for name, values in out.items()}
