"""Is submission B really better than submission A? Paired tests on the same clips.

In the manner of sacrebleu's ``significance.py``: both submissions are scored on the *same*
bootstrap resamples of the clips, so the noise of which clips happen to be in the set
cancels out of the difference, and a signature line records everything needed to reproduce
the numbers.

Paired bootstrap (Koehn 2004, "Statistical significance tests for machine translation
evaluation"; Efron and Tibshirani 1993, chapters 13 and 16)
    Draw ``n_resamples`` resamples of the ``n`` clips with replacement, compute each metric
    for A and for B on every resample, and take the differences
    ``d*_r = metric_B(r) - metric_A(r)``. The resamples are
    ``numpy.random.default_rng(seed).integers(0, n, (n_resamples, n))``, the draws of
    ``scipy.stats.bootstrap(paired=True)`` and of the confidence intervals of
    ``turn-eval score`` (:func:`turn_eval.scoring.bootstrap.resample_indices`). Reported: the observed
    difference ``d`` on all clips, the mean of ``d*``, and the 95% percentile interval of
    ``d*`` (2.5th and 97.5th percentiles, linear interpolation, as
    ``scipy.stats.bootstrap(method="percentile")``).

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

Metrics (paper Section 5; :mod:`turn_eval.clips.metrics`, the same code as ``turn-eval score``):
``accuracy``, ``mae_deg``, ``wprec`` and, when the reference has durations,
``mae_speed_deg_s`` (equation 4).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import binomtest

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import BIN_WIDTH_DEG
from turn_eval.clips.metrics import (
    METRICS,
    ClipOutcomes,
    clip_outcomes,
    metrics_of,
    pooled_resampler,
)
from turn_eval.scoring.bootstrap import CONFIDENCE, percentile_interval, resample_indices
from turn_eval.scoring.signature import Signature

__all__ = [
    "METRICS",
    "PairedDifference",
    "McNemarResult",
    "Comparison",
    "mcnemar_exact",
    "compare_predictions",
]


@dataclass(frozen=True)
class PairedDifference:
    """One metric of a paired comparison: A, B, the difference B - A and its uncertainty.

    ``ci_low``, ``ci_high`` and ``p_value`` are None when some resample leaves the metric
    undefined (a speed metric on a resample without a clip that has a duration).
    """

    metric: str
    a: float
    b: float
    diff: float
    mean_diff: float
    ci_low: float | None
    ci_high: float | None
    p_value: float | None

    def as_dict(self) -> dict[str, object]:
        ci = None if self.ci_low is None else [self.ci_low, self.ci_high]
        return {
            "a": self.a,
            "b": self.b,
            "diff": self.diff,
            "mean_diff": self.mean_diff,
            "ci95": ci,
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
    def options(self) -> tuple[tuple[str, str], ...]:
        """What pins down the test: clips, bins, resamples, seed and the tests."""
        return (
            ("n", f"{self.n}"),
            ("bin", f"{self.bin_width_deg:g}deg"),
            ("bootstrap", f"paired-percentile-{self.n_resamples}"),
            ("seed", f"{self.seed}"),
            ("p", "shift-two-sided"),
            ("mcnemar", "exact"),
        )

    @property
    def signature(self) -> str:
        """One line that pins down the test (:attr:`options`) and the version."""
        return Signature("compare", self.options, (), self.version).line()

    def signature_of(
        self,
        inputs: Mapping[str, str | os.PathLike[str]],
        digests: Mapping[str, str | None] | None = None,
    ) -> Signature:
        """The signature with the sha256 of the files compared (roles ``reference``, ``a``,
        ``b``), as ``turn-eval compare`` prints it; ``digests`` as
        :meth:`~turn_eval.scoring.signature.Signature.of`."""
        return Signature.of("compare", self.options, inputs, digests)

    def as_dict(self) -> dict[str, object]:
        return {
            "n": self.n,
            "metrics": {name: d.as_dict() for name, d in self.differences.items()},
            "mcnemar": self.mcnemar.as_dict(),
            "settings": {
                "bin_width_deg": self.bin_width_deg,
                "bootstrap": self.n_resamples,
                "seed": self.seed,
                "confidence": CONFIDENCE,
                "version": self.version,
            },
            "signature": self.signature,
        }


def _paired_outcomes(
    pred_a_deg,
    pred_b_deg,
    ref_deg,
    *,
    ref_duration_s,
    pred_a_speed_deg_s,
    pred_b_speed_deg_s,
    bin_width_deg: float,
) -> tuple[ClipOutcomes, ClipOutcomes]:
    sizes = [np.asarray(x).size for x in (pred_a_deg, pred_b_deg, ref_deg)]
    if len(set(sizes)) != 1:
        raise TurnbenchError(
            f"A has {sizes[0]} angles, B {sizes[1]} and the reference {sizes[2]}: "
            "a paired test needs the same clips"
        )
    if sizes[0] == 0:
        raise TurnbenchError("no clips to compare")
    common = {"ref_duration_s": ref_duration_s, "bin_width_deg": bin_width_deg}
    return (
        clip_outcomes(pred_a_deg, ref_deg, pred_speed_deg_s=pred_a_speed_deg_s, **common),
        clip_outcomes(pred_b_deg, ref_deg, pred_speed_deg_s=pred_b_speed_deg_s, **common),
    )


def _differences(
    outcomes_a: ClipOutcomes, outcomes_b: ClipOutcomes, *, n_resamples: int, seed: int
) -> dict[str, np.ndarray]:
    if n_resamples < 1:
        raise TurnbenchError(
            f"the number of bootstrap resamples must be positive, got {n_resamples}"
        )
    parts: dict[str, list[np.ndarray]] = {}
    metrics_a, metrics_b = pooled_resampler(outcomes_a), pooled_resampler(outcomes_b)
    # One index matrix (in chunks) for both submissions: this is what makes the test paired.
    for idx in resample_indices(outcomes_a.n, n_resamples=n_resamples, seed=seed):
        res_a = metrics_a(idx)
        res_b = metrics_b(idx)
        for name in METRICS:
            if name in res_a:
                parts.setdefault(name, []).append(res_b[name] - res_a[name])
    return {name: np.concatenate(values) for name, values in parts.items()}


def _shift_p_value(deltas: np.ndarray, observed: float) -> float:
    """Two-sided bootstrap p-value under the shifted null (see the module docstring)."""
    extreme = np.abs(deltas - observed) >= abs(observed)
    return float((1 + np.count_nonzero(extreme)) / (deltas.size + 1))


def _summarise(
    outcomes_a: ClipOutcomes, outcomes_b: ClipOutcomes, *, n_resamples: int, seed: int
) -> dict[str, PairedDifference]:
    full_a, full_b = metrics_of(outcomes_a), metrics_of(outcomes_b)
    deltas = _differences(outcomes_a, outcomes_b, n_resamples=n_resamples, seed=seed)
    result: dict[str, PairedDifference] = {}
    for name, d in deltas.items():
        a, b = full_a[name], full_b[name]
        if a is None or b is None:  # speed metric without any usable duration
            continue
        observed = float(b) - float(a)
        interval = percentile_interval(d, confidence=CONFIDENCE)
        result[name] = PairedDifference(
            metric=name,
            a=float(a),
            b=float(b),
            diff=observed,
            mean_diff=float(np.nanmean(d)) if np.isfinite(d).any() else float("nan"),
            ci_low=None if interval is None else interval[0],
            ci_high=None if interval is None else interval[1],
            p_value=None if interval is None else _shift_p_value(d, observed),
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
    ref_duration_s=None,
    pred_a_speed_deg_s=None,
    pred_b_speed_deg_s=None,
    n_resamples: int = 1000,
    seed: int = 0,
    bin_width_deg: float = BIN_WIDTH_DEG,
) -> Comparison:
    """Paired bootstrap of the differences B - A in every metric, and the exact McNemar test.

    Parameters
    ----------
    pred_a_deg, pred_b_deg
        Predicted angles (degrees) of submissions A and B, one per clip, in the same clip
        order as ``ref_deg``.
    ref_deg
        Reference angles (degrees) of the same clips.
    ref_duration_s
        Reference durations (seconds), for the speed metric (equation 4); None: no speed.
    pred_a_speed_deg_s, pred_b_speed_deg_s
        Predicted speeds where the submissions give them (NaN or None: angle over duration).
    n_resamples
        Bootstrap resamples (sacrebleu's and this project's default: 1000).
    seed
        Seed of ``numpy.random.default_rng`` for the index matrix.
    bin_width_deg
        Width of the angle bins (the paper's 45°).

    Returns
    -------
    Comparison
        ``differences``: metric name -> :class:`PairedDifference` with A's and B's values on
        all clips (as ``turn-eval score`` computes them), the observed difference, the mean
        resampled difference, the 95% percentile interval and the two-sided p-value (module
        docstring); for the MAEs a negative difference means B is better, for the others a
        positive one. ``mcnemar``: :func:`mcnemar_exact` on per-clip correctness. And the
        settings, for the signature.
    """
    outcomes_a, outcomes_b = _paired_outcomes(
        pred_a_deg,
        pred_b_deg,
        ref_deg,
        ref_duration_s=ref_duration_s,
        pred_a_speed_deg_s=pred_a_speed_deg_s,
        pred_b_speed_deg_s=pred_b_speed_deg_s,
        bin_width_deg=bin_width_deg,
    )
    return Comparison(
        n=outcomes_a.n,
        n_resamples=n_resamples,
        seed=seed,
        bin_width_deg=float(bin_width_deg),
        differences=_summarise(outcomes_a, outcomes_b, n_resamples=n_resamples, seed=seed),
        mcnemar=mcnemar_exact(outcomes_a.correct, outcomes_b.correct),
    )
