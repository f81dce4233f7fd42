"""significance: paired bootstrap and exact McNemar, checked by hand, by scipy and by sklearn."""

from __future__ import annotations

from math import comb

import numpy as np
import pytest
from scipy import stats
from sklearn.metrics import accuracy_score, mean_absolute_error, precision_score

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import quantise_deg
from turn_eval.clips.significance import (
    _differences,
    _paired_outcomes,
    compare_predictions,
    mcnemar_exact,
)


def two_systems(n: int, *, sd_a_deg: float, sd_b_deg: float, seed: int = 7):
    """Reference angles over the benchmark's range and two noisy submissions."""
    rng = np.random.default_rng(seed)
    ref = rng.uniform(40.0, 240.0, n)
    a = np.abs(ref + rng.normal(0.0, sd_a_deg, n))
    b = np.abs(ref + rng.normal(0.0, sd_b_deg, n))
    return a, b, ref


def outcomes(n_both: int, n_a_only: int, n_b_only: int, n_neither: int):
    a = [True] * n_both + [True] * n_a_only + [False] * n_b_only + [False] * n_neither
    b = [True] * n_both + [False] * n_a_only + [True] * n_b_only + [False] * n_neither
    return np.array(a), np.array(b)


# ---------------------------------------------------------------- McNemar, by hand


def test_mcnemar_b1_c9_by_hand():
    a, b = outcomes(n_both=20, n_a_only=1, n_b_only=9, n_neither=5)
    result = mcnemar_exact(a, b)
    assert (result.b, result.c) == (1, 9)
    # Two-sided exact: 2 * P(X <= 1), X ~ Bin(10, 1/2) = 2 * (1 + 10) / 1024 = 0.021484375
    by_hand = 2 * sum(comb(10, k) for k in range(2)) / 2**10
    assert by_hand == 0.021484375
    assert result.p_value == pytest.approx(by_hand, rel=1e-12)


def test_mcnemar_b6_c0_and_balanced_and_no_discordance():
    a, b = outcomes(n_both=3, n_a_only=6, n_b_only=0, n_neither=1)
    result = mcnemar_exact(a, b)
    assert (result.b, result.c) == (6, 0)
    assert result.p_value == pytest.approx(2 / 2**6)  # 2 * P(X = 0), X ~ Bin(6, 1/2)
    # b = c: the observed count is the mode, every outcome is as or less likely: p = 1.
    assert mcnemar_exact(*outcomes(2, 4, 4, 2)).p_value == pytest.approx(1.0)
    none = mcnemar_exact(*outcomes(5, 0, 0, 5))
    assert (none.b, none.c, none.p_value) == (0, 0, 1.0)
    with pytest.raises(TurnbenchError):
        mcnemar_exact([True, False], [True])


# ------------------------------------------- resampled differences vs sklearn


def test_paired_differences_are_sklearn_differences_on_scipys_resamples():
    # Predictions land in bins the reference never has (0°, 270°) and the reference has bins
    # a submission never predicts, so sklearn's zero_division=0 and zero-support cases occur.
    a, b, ref = two_systems(120, sd_a_deg=35.0, sd_b_deg=20.0)
    a[:3] = [5.0, 280.0, 275.0]
    n_resamples = 40
    # the resampled differences behind compare_predictions' intervals and p-values
    outcomes = _paired_outcomes(
        a,
        b,
        ref,
        ref_duration_s=None,
        pred_a_speed_deg_s=None,
        pred_b_speed_deg_s=None,
        bin_width_deg=45.0,
    )
    deltas = _differences(*outcomes, n_resamples=n_resamples, seed=3)
    assert set(deltas) == {"accuracy", "mae_deg", "wprec"}  # no durations, no speed
    # The documented draws (scipy.stats.bootstrap's): one index matrix for both submissions.
    idx = np.random.default_rng(3).integers(0, ref.size, (n_resamples, ref.size))
    ref_bin = quantise_deg(ref)
    for r in (0, 1, 17, 39):
        rows = idx[r]
        y_true = ref_bin[rows]
        pa, pb = quantise_deg(a)[rows], quantise_deg(b)[rows]
        expected = {
            "accuracy": accuracy_score(y_true, pb) - accuracy_score(y_true, pa),
            "mae_deg": mean_absolute_error(ref[rows], b[rows])
            - mean_absolute_error(ref[rows], a[rows]),
            "wprec": precision_score(y_true, pb, average="weighted", zero_division=0)
            - precision_score(y_true, pa, average="weighted", zero_division=0),
        }
        for name, value in expected.items():
            assert deltas[name][r] == pytest.approx(value, abs=1e-12), (name, r)


def test_speed_difference_by_hand():
    # Durations of 2 s: speed errors are angle errors / 2 (equation 4). A is off by 20° on
    # every clip -> 10 °/s; B gives its own speeds, off by 4 °/s on every clip -> B - A = -6.
    ref = np.array([90.0, 180.0, 45.0, 135.0])
    a = ref + 20.0
    b_speed = ref / 2.0 + 4.0
    result = compare_predictions(
        a,
        ref,
        ref,
        ref_duration_s=np.full(4, 2.0),
        pred_b_speed_deg_s=b_speed,
        n_resamples=50,
        seed=0,
    ).differences
    speed = result["mae_speed_deg_s"]
    assert (speed.a, speed.b, speed.diff) == pytest.approx((10.0, 4.0, -6.0))
    # Every clip has the same errors, so every resample has the same difference.
    assert (speed.ci_low, speed.ci_high) == pytest.approx((-6.0, -6.0))


# ------------------------------------------------------------- paired bootstrap


def test_accuracy_difference_ci_agrees_with_scipy_paired_percentile():
    a, b, ref = two_systems(300, sd_a_deg=25.0, sd_b_deg=15.0)
    n_resamples = 5000
    ours = compare_predictions(a, b, ref, n_resamples=n_resamples, seed=0).differences["accuracy"]
    correct_a = quantise_deg(a) == quantise_deg(ref)
    correct_b = quantise_deg(b) == quantise_deg(ref)

    def accuracy_difference(ca, cb, axis=-1):
        return cb.mean(axis=axis) - ca.mean(axis=axis)

    theirs = stats.bootstrap(
        (correct_a.astype(float), correct_b.astype(float)),
        accuracy_difference,
        paired=True,
        vectorized=True,
        n_resamples=n_resamples,
        confidence_level=0.95,
        method="percentile",
        rng=np.random.default_rng(1),  # an independent stream: agreement is not by construction
    )
    sd = theirs.standard_error
    # Each 2.5% / 97.5% percentile from B = 5000 draws has Monte Carlo standard error about
    # sqrt(0.025 * 0.975 / B) / phi(1.96) * sd = 0.038 sd; two independent estimates differ by
    # about 0.054 sd, so 0.25 sd is more than four standard errors (here 0.25 sd ~ 0.006,
    # two steps of the accuracy's 1/300 grid).
    tolerance = 0.25 * sd
    assert ours.ci_low == pytest.approx(theirs.confidence_interval.low, abs=tolerance)
    assert ours.ci_high == pytest.approx(theirs.confidence_interval.high, abs=tolerance)
    assert ours.diff == pytest.approx(correct_b.mean() - correct_a.mean(), abs=1e-12)
    assert ours.mean_diff == pytest.approx(ours.diff, abs=tolerance)


def test_identical_submissions_give_zero_difference_and_p_one():
    a, _, ref = two_systems(80, sd_a_deg=30.0, sd_b_deg=1.0)
    duration = np.full(ref.size, 1.5)
    result = compare_predictions(a, a.copy(), ref, ref_duration_s=duration, n_resamples=300, seed=0)
    assert list(result.differences) == ["accuracy", "mae_deg", "wprec", "mae_speed_deg_s"]
    for metric in result.differences:
        d = result.differences[metric]
        assert d.a == d.b
        assert (d.diff, d.mean_diff, d.ci_low, d.ci_high, d.p_value) == (0.0, 0.0, 0.0, 0.0, 1.0)
    assert (result.mcnemar.b, result.mcnemar.c, result.mcnemar.p_value) == (0, 0, 1.0)


def test_clearly_better_b_has_a_ci_excluding_zero():
    a, b, ref = two_systems(200, sd_a_deg=40.0, sd_b_deg=3.0)
    n_resamples = 999
    result = compare_predictions(a, b, ref, n_resamples=n_resamples, seed=0).differences
    assert result["accuracy"].ci_low > 0.0
    assert result["wprec"].ci_low > 0.0
    assert result["mae_deg"].ci_high < 0.0  # lower error: B better
    for d in result.values():
        # Not one resample is as far from the observed difference as zero is: the smallest
        # p-value the +1 rule allows, 1 / (B + 1).
        assert d.p_value == pytest.approx(1 / (n_resamples + 1))


def test_p_value_of_a_single_discordant_clip_by_hand():
    # B is right on one clip where A is wrong; elsewhere they agree. The resampled accuracy
    # difference is k / n with k ~ Binomial(n, 1/n) copies of that clip, the observed one 1/n,
    # so |d* - d| >= |d| unless k = 1: p = 1 - (1 - 1/n)^(n-1), for n = 10: 1 - 0.9^9 = 0.6126.
    n = 10
    ref = np.full(n, 90.0)
    a = ref.copy()
    b = ref.copy()
    a[0] = 150.0  # bin 135 != 90: wrong; 60° off
    b[0] = 100.0  # bin 90: right; 10° off
    n_resamples = 4000
    d = compare_predictions(a, b, ref, n_resamples=n_resamples, seed=0).differences["accuracy"]
    assert d.diff == pytest.approx(0.1)
    by_hand = 1 - 0.9**9
    # Monte Carlo standard error sqrt(0.61 * 0.39 / 4000) = 0.0077; allow four of them.
    assert d.p_value == pytest.approx(by_hand, abs=0.031)
    # McNemar on the same data: b = 0, c = 1; P = 2 * min(1/2, 1) capped at 1.
    assert mcnemar_exact(quantise_deg(a) == 90, quantise_deg(b) == 90).p_value == 1.0


def test_swapping_a_and_b_negates_the_difference():
    a, b, ref = two_systems(90, sd_a_deg=30.0, sd_b_deg=22.0)
    ab = compare_predictions(a, b, ref, n_resamples=400, seed=2).differences
    ba = compare_predictions(b, a, ref, n_resamples=400, seed=2).differences
    for metric in ab:
        assert ba[metric].diff == pytest.approx(-ab[metric].diff, abs=1e-12)
        assert ba[metric].ci_low == pytest.approx(-ab[metric].ci_high, abs=1e-9)
        assert ba[metric].ci_high == pytest.approx(-ab[metric].ci_low, abs=1e-9)
        assert ba[metric].p_value == ab[metric].p_value


def test_same_seed_same_numbers_other_seed_other_draws():
    a, b, ref = two_systems(60, sd_a_deg=30.0, sd_b_deg=25.0)
    first = compare_predictions(a, b, ref, n_resamples=200, seed=11)
    assert compare_predictions(a, b, ref, n_resamples=200, seed=11) == first
    other = compare_predictions(a, b, ref, n_resamples=200, seed=12)
    assert other.differences["mae_deg"].mean_diff != first.differences["mae_deg"].mean_diff


def test_signature_and_dict_carry_what_reproduces_the_claim():
    a, b, ref = two_systems(40, sd_a_deg=30.0, sd_b_deg=25.0)
    result = compare_predictions(a, b, ref, n_resamples=250, seed=9)
    sig = result.signature
    for part in ("n:40", "bootstrap:paired-percentile-250", "seed:9", f"version:{__version__}"):
        assert part in sig.split("|")
    doc = result.as_dict()
    assert list(doc) == ["n", "metrics", "mcnemar", "settings", "signature"]
    assert list(doc["metrics"]) == ["accuracy", "mae_deg", "wprec"]
    assert list(doc["metrics"]["accuracy"]) == ["a", "b", "diff", "mean_diff", "ci95", "p_value"]
    assert doc["settings"]["bootstrap"] == 250 and doc["settings"]["seed"] == 9
    assert doc["mcnemar"]["n_discordant"] == result.mcnemar.b + result.mcnemar.c


@pytest.mark.parametrize(
    "a, b, ref, n_resamples",
    [
        ([10.0, 20.0], [10.0], [10.0, 20.0], 10),
        ([10.0, np.nan], [10.0, 20.0], [10.0, 20.0], 10),
        ([], [], [], 10),
        ([10.0], [10.0], [10.0], 0),
    ],
)
def test_bad_arrays_are_refused(a, b, ref, n_resamples):
    with pytest.raises(TurnbenchError):
        compare_predictions(a, b, ref, n_resamples=n_resamples, seed=0)


def test_difference_intervals_equal_scipy_paired_bootstrap_on_the_same_seed():
    # The documented draws are scipy.stats.bootstrap's: with the same seed, the paired
    # intervals of B - A are scipy's percentile intervals up to summation order.
    a, b, ref = two_systems(150, sd_a_deg=30.0, sd_b_deg=20.0, seed=4)
    n_resamples, seed = 300, 5
    ours = compare_predictions(a, b, ref, n_resamples=n_resamples, seed=seed).differences

    def accuracy(pa, pb, r, axis=-1):
        return np.mean(quantise_deg(pb) == quantise_deg(r), axis=axis) - np.mean(
            quantise_deg(pa) == quantise_deg(r), axis=axis
        )

    def mae(pa, pb, r, axis=-1):
        return np.mean(np.abs(pb - r), axis=axis) - np.mean(np.abs(pa - r), axis=axis)

    def wprec(pa, pb, r):
        def one(p):
            return precision_score(
                quantise_deg(r), quantise_deg(p), average="weighted", zero_division=0
            )

        return one(pb) - one(pa)

    for name, statistic, vectorized in [
        ("accuracy", accuracy, True),
        ("mae_deg", mae, True),
        ("wprec", wprec, False),
    ]:
        res = stats.bootstrap(
            (a, b, ref),
            statistic,
            paired=True,
            vectorized=vectorized,
            n_resamples=n_resamples,
            method="percentile",
            rng=seed,
        )
        low, high = res.confidence_interval
        assert (ours[name].ci_low, ours[name].ci_high) == pytest.approx(
            (low, high), rel=1e-9, abs=1e-12
        ), name
