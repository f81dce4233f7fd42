"""Is submission B really better than submission A? Paired tests on the same clips.

In the manner of sacrebleu's ``significance.py``: both submissions are scored on the *same*
bootstrap resamples of the clips, so the noise of which clips happen to be in the set
cancels out of the difference, and a signature line records everything needed to reproduce
the numbers.

Paired bootstrap (Koehn 2004, "Statistical significance tests for machine translation
evaluation"; Efron and Tibshirani 1993, chapters 13 and 16)
    Draw ``n_resamples`` resamples of the ``n`` clips with replacement (one index matrix,
    seeded), compute each metric for A and for B on every resample, and take the differences
    ``d*_r = metric_B(r) - metric_A(r)``. Reported: the observed difference ``d`` on all clips,
    the mean of ``d*``, and the 95% percentile interval of ``d*`` (2.5th and 97.5th
    percentiles, linear interpolation, as ``scipy.stats.bootstrap(method="percentile")``).

Two-sided p-value
    The bootstrap distribution shifted to the null hypothesis of no difference (Efron and
    Tibshirani 1993, section 16.4; the centring that Berg-Kirkpatrick et al. 2012 point out
    Koehn's test needs):

        ``p = (1 + #{r : |d*_r - d| >= |d|}) / (n_resamples + 1)``

    This is sacrebleu's paired bootstrap test (``_paired_bs_test`` with
    ``_compute_p_value``, after Clark et al. 2011's MultEval) with two differences: the
    signed differences are centred on the observed difference (sacrebleu centres the absolute
    differences on their own mean), and ties count (``>=``, sacrebleu has ``>``), so two
    identical submissions get ``p = 1`` rather than ``1 / (n_resamples + 1)``. The ``+ 1``
    keeps the test's false-rejection rate at or below its level (sacrebleu's reason too), so
    the smallest reportable p is ``1 / (n_resamples + 1)``.

Exact McNemar test
    On bin correctness (the accuracy metric's per-clip outcome): ``b`` clips A gets right and
    B wrong, ``c`` clips A gets wrong and B right. Under the null each discordant clip is a
    fair coin, so ``p = binomtest(c, b + c, 0.5)`` two-sided (``scipy.stats.binomtest``);
    with no discordant clip, ``p = 1``.

Metrics (paper Section 5; DESIGN.md): ``accuracy`` (predicted and reference angles in the
same 45° bin), ``mae_deg`` and ``wprec`` (scikit-learn's weighted precision over bins with
``zero_division=0``, computed here for every resample at once from per-bin counts).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import binomtest

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import quantise_deg

__all__ = [
    "METRICS",
    "PairedDifference",
    "McNemarResult",
    "Comparison",
    "per_clip_outcomes",
    "resample_indices",
    "resampled_metrics",
    "paired_bootstrap",
    "mcnemar_exact",
    "compare_predictions",
]

#: The metrics compared, in the order they are reported.
METRICS = ("accuracy", "mae_deg", "wprec")
#: Index-matrix cells per chunk of resamples: bounds memory (a few arrays of this many
#: int64, tens of MB) whatever the number of clips; 1000 resamples of 2000 clips is one chunk.
_CHUNK_CELLS = 2_000_000


@dataclass(frozen=True)
class PairedDifference:
    """One metric of a paired comparison: A, B, the difference B - A and its uncertainty."""

    metric: str
    a: float
    b: float
    diff: float
    mean_diff: float
    ci_low: float
    ci_high: float
    p_value: float

    def as_dict(self) -> dict[str, object]:
        return {
            "a": self.a,
            "b": self.b,
            "diff": self.diff,
            "mean_diff": self.mean_diff,
            "ci95": [self.ci_low, self.ci_high],
            "p_value": self.p_value,
        }


@dataclass(frozen=True)
class McNemarResult:
    """Exact McNemar test: ``b`` = A right and B wrong, ``c`` = A wrong and B right."""

    b: int
    c: int
    p_value: float

    def as_dict(self) -> dict[str, object]:
        return {"b": self.b, "c": self.c, "n_discordant": self.b + self.c, "p_value": self.p_value}


@dataclass(frozen=True)
class Comparison:
    """Everything ``turn-eval compare`` reports, and the signature to reproduce it."""

    n: int
    n_resamples: int
    seed: int
    bin_width_deg: float
    differences: Mapping[str, PairedDifference]
    mcnemar: McNemarResult
    version: str = field(default=__version__)

    @property
    def signature(self) -> str:
        """One line that pins down the test: clips, bins, resamples, seed, tests, version."""
        return (
            f"turnbench-compare|n:{self.n}|bin:{self.bin_width_deg:g}deg"
            f"|bootstrap:paired-percentile-{self.n_resamples}|seed:{self.seed}"
            f"|p:shift-two-sided|mcnemar:exact|version:{self.version}"
        )

    def as_dict(self) -> dict[str, object]:
        return {
            "n": self.n,
            "metrics": {name: d.as_dict() for name, d in self.differences.items()},
            "mcnemar": self.mcnemar.as_dict(),
            "settings": {
                "bin_width_deg": self.bin_width_deg,
                "bootstrap": self.n_resamples,
                "seed": self.seed,
                "confidence": 0.95,
                "version": self.version,
            },
            "signature": self.signature,
        }


def _as_angles(values, name: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise TurnbenchError(f"{name} must be one angle per clip, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise TurnbenchError(f"{name} holds NaN or infinite angles")
    return arr


@dataclass(frozen=True)
class _Outcomes:
    """Per-clip ingredients of every metric, for one submission against the reference."""

    correct: np.ndarray  # bool, predicted bin == reference bin
    abs_error_deg: np.ndarray  # |pred - ref|
    pred_code: np.ndarray  # bin as an index into the shared label set
    ref_code: np.ndarray
    n_labels: int


def per_clip_outcomes(pred_deg, ref_deg, *, bin_width_deg: float = 45.0) -> dict[str, np.ndarray]:
    """Per-clip bin correctness and absolute error, the ingredients of accuracy and MAE.

    Returns ``{"correct": bool array, "abs_error_deg": float array, "pred_bin_deg",
    "ref_bin_deg"}``; bins are ``quantise_deg`` (nearest multiple of ``bin_width_deg``).
    """
    pred = _as_angles(pred_deg, "predicted angles")
    ref = _as_angles(ref_deg, "reference angles")
    if pred.shape != ref.shape:
        raise TurnbenchError(f"{pred.size} predictions for {ref.size} reference clips")
    pred_bin = quantise_deg(pred, bin_width_deg)
    ref_bin = quantise_deg(ref, bin_width_deg)
    return {
        "correct": pred_bin == ref_bin,
        "abs_error_deg": np.abs(pred - ref),
        "pred_bin_deg": pred_bin,
        "ref_bin_deg": ref_bin,
    }


def _outcomes(
    pred: np.ndarray, ref_bin: np.ndarray, ref: np.ndarray, labels: np.ndarray, bin_width_deg: float
) -> _Outcomes:
    pred_bin = quantise_deg(pred, bin_width_deg)
    return _Outcomes(
        correct=pred_bin == ref_bin,
        abs_error_deg=np.abs(pred - ref),
        pred_code=np.searchsorted(labels, pred_bin),
        ref_code=np.searchsorted(labels, ref_bin),
        n_labels=labels.size,
    )


def resample_indices(n: int, *, n_resamples: int, seed: int) -> np.ndarray:
    """The bootstrap index matrix ``(n_resamples, n)``: clips drawn with replacement.

    Drawn as ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))``, the same
    call ``scipy.stats.bootstrap`` makes, so the resamples are documented and reproducible.
    :func:`paired_bootstrap` draws the same rows in chunks (see :func:`_index_chunks`).
    """
    _check_resampling(n, n_resamples)
    return np.random.default_rng(seed).integers(0, n, size=(n_resamples, n))


def _check_resampling(n: int, n_resamples: int) -> None:
    if n < 1:
        raise TurnbenchError("no clips to compare")
    if n_resamples < 1:
        raise TurnbenchError(
            f"the number of bootstrap resamples must be positive, got {n_resamples}"
        )


def _metrics_on(idx: np.ndarray, out: _Outcomes) -> dict[str, np.ndarray]:
    """Every metric on each row of an index matrix ``(r, n)``; arrays of length ``r``."""
    r, n = idx.shape
    k = out.n_labels
    accuracy = out.correct[idx].mean(axis=1)
    mae = out.abs_error_deg[idx].mean(axis=1)
    # Weighted precision (sklearn, average="weighted", zero_division=0) is
    # sum_l support_l / n * TP_l / predicted_l; labels never predicted count 0 and labels
    # without support weigh 0, so one shared label set serves every resample. Per-resample
    # counts come from one bincount over (row, label) cells.
    offset = (np.arange(r) * k)[:, None]
    ref_cells = out.ref_code[idx] + offset
    pred_cells = out.pred_code[idx] + offset
    support = np.bincount(ref_cells.ravel(), minlength=r * k).reshape(r, k)
    predicted = np.bincount(pred_cells.ravel(), minlength=r * k).reshape(r, k)
    hits = np.bincount(ref_cells[out.correct[idx]], minlength=r * k).reshape(r, k)
    with np.errstate(divide="ignore", invalid="ignore"):
        precision = np.where(predicted > 0, hits / np.maximum(predicted, 1), 0.0)
    wprec = (support * precision).sum(axis=1) / n
    return {"accuracy": accuracy, "mae_deg": mae, "wprec": wprec}


def _chunks(n_resamples: int, n: int):
    step = max(1, _CHUNK_CELLS // max(n, 1))
    for start in range(0, n_resamples, step):
        yield start, min(start + step, n_resamples)


def _index_chunks(n: int, *, n_resamples: int, seed: int):
    """The rows of :func:`resample_indices`, drawn chunk by chunk from one generator.

    NumPy draws bounded integers one after another from the stream, so consecutive chunks
    are the rows of the whole matrix (tests check this), without holding it in memory.
    """
    _check_resampling(n, n_resamples)
    rng = np.random.default_rng(seed)
    for start, stop in _chunks(n_resamples, n):
        yield start, stop, rng.integers(0, n, size=(stop - start, n))


def resampled_metrics(
    pred_deg, ref_deg, idx: np.ndarray, *, bin_width_deg: float = 45.0
) -> dict[str, np.ndarray]:
    """Accuracy, MAE and WPrec of one submission on each resample (row) of ``idx``.

    ``idx`` of shape ``(r, n)`` indexes the clips; the identity row ``arange(n)`` gives the
    metrics on the whole set.
    """
    pred = _as_angles(pred_deg, "predicted angles")
    ref = _as_angles(ref_deg, "reference angles")
    ref_bin = quantise_deg(ref, bin_width_deg)
    labels = np.unique(np.concatenate([ref_bin, quantise_deg(pred, bin_width_deg)]))
    out = _outcomes(pred, ref_bin, ref, labels, bin_width_deg)
    idx = np.atleast_2d(np.asarray(idx))
    parts = [_metrics_on(idx[a:b], out) for a, b in _chunks(idx.shape[0], idx.shape[1])]
    return {m: np.concatenate([p[m] for p in parts]) for m in METRICS}


def _shift_p_value(deltas: np.ndarray, observed: float) -> float:
    """Two-sided bootstrap p-value under the shifted null (see the module docstring)."""
    extreme = np.abs(deltas - observed) >= abs(observed)
    return float((1 + np.count_nonzero(extreme)) / (deltas.size + 1))


def paired_bootstrap(
    pred_a_deg,
    pred_b_deg,
    ref_deg,
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    bin_width_deg: float = 45.0,
) -> dict[str, PairedDifference]:
    """Paired bootstrap of the differences B - A in accuracy, MAE and WPrec.

    Parameters
    ----------
    pred_a_deg, pred_b_deg
        Predicted angles (degrees) of submissions A and B, one per clip, same clip order.
    ref_deg
        Reference angles (degrees) of the same clips.
    n_resamples
        Bootstrap resamples (sacrebleu's and this project's default: 1000).
    seed
        Seed of ``numpy.random.default_rng`` for the index matrix.
    bin_width_deg
        Width of the angle bins (the paper's 45°).

    Returns
    -------
    dict
        Metric name -> :class:`PairedDifference` with A's and B's values on all clips, the
        observed difference, the mean resampled difference, the 95% percentile interval and
        the two-sided p-value (module docstring). For ``mae_deg`` a negative difference means
        B is better; for the others a positive one.
    """
    pred_a = _as_angles(pred_a_deg, "A's angles")
    pred_b = _as_angles(pred_b_deg, "B's angles")
    ref = _as_angles(ref_deg, "reference angles")
    if not (pred_a.size == pred_b.size == ref.size):
        raise TurnbenchError(
            f"A has {pred_a.size} angles, B {pred_b.size} and the reference {ref.size}: "
            "a paired test needs the same clips"
        )
    _check_resampling(ref.size, n_resamples)
    ref_bin = quantise_deg(ref, bin_width_deg)
    # One label set for A, B and the reference, so per-bin counts line up in every resample.
    labels = np.unique(
        np.concatenate(
            [ref_bin, quantise_deg(pred_a, bin_width_deg), quantise_deg(pred_b, bin_width_deg)]
        )
    )
    out_a = _outcomes(pred_a, ref_bin, ref, labels, bin_width_deg)
    out_b = _outcomes(pred_b, ref_bin, ref, labels, bin_width_deg)
    whole = np.arange(ref.size)[None, :]
    full_a, full_b = _metrics_on(whole, out_a), _metrics_on(whole, out_b)

    deltas = {m: np.empty(n_resamples) for m in METRICS}
    for start, stop, idx in _index_chunks(ref.size, n_resamples=n_resamples, seed=seed):
        res_a, res_b = _metrics_on(idx, out_a), _metrics_on(idx, out_b)
        for m in METRICS:
            deltas[m][start:stop] = res_b[m] - res_a[m]

    result: dict[str, PairedDifference] = {}
    for m in METRICS:
        a, b = float(full_a[m][0]), float(full_b[m][0])
        observed = b - a
        low, high = np.percentile(deltas[m], [2.5, 97.5])
        result[m] = PairedDifference(
            metric=m,
            a=a,
            b=b,
            diff=observed,
            mean_diff=float(deltas[m].mean()),
            ci_low=float(low),
            ci_high=float(high),
            p_value=_shift_p_value(deltas[m], observed),
        )
    return result


def mcnemar_exact(correct_a, correct_b) -> McNemarResult:
    """Exact McNemar test on paired per-clip correctness (``scipy.stats.binomtest``).

    Parameters
    ----------
    correct_a, correct_b
        Boolean per clip: did A (B) put the clip in the reference's bin?

    Returns
    -------
    McNemarResult
        ``b`` (A right, B wrong), ``c`` (A wrong, B right) and the two-sided exact p-value
        ``binomtest(c, b + c, 0.5)``; ``p = 1`` when no clip is discordant.
    """
    a = np.asarray(correct_a, dtype=bool)
    b_ = np.asarray(correct_b, dtype=bool)
    if a.shape != b_.shape:
        raise TurnbenchError(f"{a.size} outcomes for A but {b_.size} for B")
    b = int(np.count_nonzero(a & ~b_))
    c = int(np.count_nonzero(~a & b_))
    p = 1.0 if b + c == 0 else float(binomtest(c, b + c, 0.5, alternative="two-sided").pvalue)
    return McNemarResult(b=b, c=c, p_value=p)


def compare_predictions(
    pred_a_deg,
    pred_b_deg,
    ref_deg,
    *,
    n_resamples: int = 1000,
    seed: int = 0,
    bin_width_deg: float = 45.0,
) -> Comparison:
    """Paired bootstrap of every metric and the exact McNemar test, with a signature.

    Parameters are as in :func:`paired_bootstrap`; the clips must be in the same order in
    all three arrays.
    """
    differences = paired_bootstrap(
        pred_a_deg,
        pred_b_deg,
        ref_deg,
        n_resamples=n_resamples,
        seed=seed,
        bin_width_deg=bin_width_deg,
    )
    outcome_a = per_clip_outcomes(pred_a_deg, ref_deg, bin_width_deg=bin_width_deg)
    outcome_b = per_clip_outcomes(pred_b_deg, ref_deg, bin_width_deg=bin_width_deg)
    return Comparison(
        n=int(np.asarray(ref_deg).size),
        n_resamples=n_resamples,
        seed=seed,
        bin_width_deg=float(bin_width_deg),
        differences=differences,
        mcnemar=mcnemar_exact(outcome_a["correct"], outcome_b["correct"]),
    )
