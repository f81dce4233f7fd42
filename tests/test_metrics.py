"""The paper's metrics and their bootstrap, against hand-worked cases, scikit-learn and scipy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from sklearn.metrics import cohen_kappa_score, precision_score

from turn_datasets.errors import TurnbenchError
from turn_datasets.geometry import quantise_deg
from turn_eval.clips.metrics import (
    Partition,
    bin_report,
    bootstrap_ci,
    clip_outcomes,
    compute_metrics,
    grouped_bootstrap,
    metrics_of,
    pooled_resampler,
    wprec_from_counts,
)
from turn_eval.scoring.bootstrap import percentile_interval, resample_indices

# Four clips worked by hand (also the CLI tests' example).
REF = [90.0, 180.0, 45.0, 135.0]
PRED = [92.5, 170.0, 40.0, 100.0]
DURATION = [1.0, 2.0, 0.5, 1.5]


def test_hand_worked_metrics():
    m = compute_metrics(PRED, REF, ref_duration_s=DURATION)
    # Bins: ref 90, 180, 45, 135; pred 90, 180, 45, 90 (100/45 + 0.5 = 2.72 -> 2 -> 90).
    assert m["n"] == 4
    assert m["accuracy"] == pytest.approx(3 / 4)
    # |errors| 2.5, 10, 5, 35 -> 52.5 / 4.
    assert m["mae_deg"] == pytest.approx(13.125)
    # Precision per predicted bin: 90 -> 1 of 2, 180 -> 1/1, 45 -> 1/1, 135 never predicted -> 0;
    # each reference bin has one clip, so WPrec = (0.5 + 1 + 1 + 0) / 4.
    assert m["wprec"] == pytest.approx(0.625)
    # Speeds (eq. 4): reference 90/1, 180/2, 45/0.5, 135/1.5 = 90 deg/s each; predicted
    # 92.5, 85, 80, 66.67 -> errors 2.5, 5, 10, 23.33 -> mean 10.2083.
    assert m["mae_speed_deg_s"] == pytest.approx((2.5 + 5 + 10 + 70 / 3) / 4)


def test_speed_given_overrides_and_undefined_durations_are_left_out():
    # Clip 0 gives its speed (100 vs 90 -> 10); clip 1 falls back to 170/2 = 85 (5);
    # clip 2 has a zero duration and clip 3 a NaN one: no speed for either.
    m = compute_metrics(
        PRED,
        REF,
        ref_duration_s=[1.0, 2.0, 0.0, np.nan],
        pred_speed_deg_s=[100.0, np.nan, 50.0, 60.0],
    )
    assert m["mae_speed_deg_s"] == pytest.approx((10 + 5) / 2)
    assert compute_metrics(PRED, REF)["mae_speed_deg_s"] is None


def test_bins_are_the_geometry_quantisation_halves_up():
    # 22.5 is in the 45 bin (floor(0.5 + 0.5) = 1); 22.49 is in the 0 bin; 67.5 -> 90.
    m = compute_metrics([22.5, 22.49, 67.5], [44.0, 44.0, 89.0])
    assert m["accuracy"] == pytest.approx(2 / 3)
    assert quantise_deg(22.5) == 45.0  # the rule the metric relies on


def test_wprec_matches_sklearn_including_bins_only_predicted():
    rng = np.random.default_rng(5)
    ref = rng.uniform(30, 200, 400)
    pred = np.abs(ref + rng.normal(0, 60, 400))  # reaches bins the reference lacks
    m = compute_metrics(pred, ref)
    expected = precision_score(
        quantise_deg(ref), quantise_deg(pred), average="weighted", zero_division=0
    )
    assert m["wprec"] == pytest.approx(expected, abs=1e-12)
    o = clip_outcomes(pred, ref)
    confusion = np.zeros((o.bins_deg.size,) * 2)
    np.add.at(confusion, (o.ref_bin, o.pred_bin), 1)
    # the same from the confusion counts: reference bins (row sums), predicted bins (column
    # sums), and both (the diagonal)
    from_counts = wprec_from_counts(
        confusion.sum(axis=1), confusion.sum(axis=0), np.diag(confusion)
    )
    assert from_counts == pytest.approx(expected, abs=1e-12)


def test_per_bin_precision_recall_by_hand():
    report = bin_report(clip_outcomes(PRED, REF))
    assert list(report["per_bin"]) == ["45", "90", "135", "180"]
    assert report["per_bin"]["90"] == {"n": 1, "n_predicted": 2, "precision": 0.5, "recall": 1.0}
    assert report["per_bin"]["135"] == {"n": 1, "n_predicted": 0, "precision": 0.0, "recall": 0.0}
    assert report["per_bin"]["45"]["precision"] == 1.0


def test_kappa_weighs_bins_by_degrees_even_with_an_empty_bin_between():
    ref = [0.0, 45.0, 180.0, 180.0]
    pred = [45.0, 45.0, 180.0, 0.0]
    # Quadratic weights ((a - b) / 45)^2: observed sum 1 + 16 = 17 over n = 4 -> 4.25;
    # expected sum over marginals ref {0:1, 45:1, 180:2}, pred {0:1, 45:2, 180:1} is
    # (18 + 10 + 68) / 16 = 6; kappa = 1 - 4.25 / 6 = 7/24.
    assert bin_report(clip_outcomes(pred, ref))["kappa"] == pytest.approx(7 / 24)
    # scikit-learn given only the labels present weighs 0 vs 180 as two steps: kappa 0.
    assert cohen_kappa_score(ref, pred, weights="quadratic") == pytest.approx(0.0)


def test_kappa_is_none_when_every_clip_is_in_one_bin():
    assert bin_report(clip_outcomes([90.0, 95.0], [88.0, 91.0]))["kappa"] is None


def test_bad_inputs():
    with pytest.raises(TurnbenchError, match="2 predicted angles for 3"):
        compute_metrics([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(TurnbenchError, match="finite"):
        compute_metrics([np.nan], [1.0])
    with pytest.raises(TurnbenchError, match="no clips"):
        compute_metrics([], [])


# --- bootstrap -----------------------------------------------------------------------------


@pytest.mark.parametrize("rows", [1, 7, 64, None])
def test_resample_indices_are_scipys_draws_in_any_chunking(rows):
    n, b = 101, 64  # odd n: 32-bit draws do not pair up into 64-bit words
    drawn = np.concatenate(list(resample_indices(n, n_resamples=b, seed=3, rows_per_chunk=rows)))
    expected = np.random.default_rng(3).integers(0, n, (b, n))  # scipy's _bootstrap_resample
    assert drawn.shape == (b, n)
    assert np.array_equal(drawn, expected)


def _sample(n=150, seed=11):
    rng = np.random.default_rng(seed)
    ref = rng.uniform(20, 250, n)
    pred = np.abs(ref + rng.normal(0, 35, n))
    duration = rng.uniform(0.8, 4.0, n)
    duration[:7] = np.nan  # some clips without a duration
    speed = np.where(rng.random(n) < 0.3, rng.uniform(10, 120, n), np.nan)
    group = rng.integers(0, 3, n)
    return pred, ref, duration, speed, group


def test_vectorised_group_metrics_equal_sklearn_on_the_same_resamples():
    pred, ref, duration, speed, group = _sample()
    o = clip_outcomes(pred, ref, ref_duration_s=duration, pred_speed_deg_s=speed)
    idx = np.random.default_rng(0).integers(0, o.n, (40, o.n))
    overall, by = grouped_bootstrap(
        o, [Partition.whole(o.n), Partition("g", ("a", "b", "c"), group)], indices=[idx]
    )
    for r in range(idx.shape[0]):
        drawn = idx[r]
        whole = compute_metrics(
            pred[drawn], ref[drawn], ref_duration_s=duration[drawn], pred_speed_deg_s=speed[drawn]
        )
        for name in ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s"):
            assert overall[name][r, 0] == pytest.approx(whole[name], abs=1e-12)
        for g in range(3):
            keep = drawn[group[drawn] == g]
            assert by["n"][r, g] == keep.size
            expected = precision_score(
                quantise_deg(ref[keep]),
                quantise_deg(pred[keep]),
                average="weighted",
                zero_division=0,
            )
            assert by["wprec"][r, g] == pytest.approx(expected, abs=1e-12)
            assert by["mae_deg"][r, g] == pytest.approx(np.abs(pred[keep] - ref[keep]).mean())
    assert pooled_resampler(o)(idx)["wprec"] == pytest.approx(overall["wprec"][:, 0])


def test_overall_ci_equals_scipy_bootstrap_percentile():
    pred, ref, duration, _, _ = _sample(n=120)
    n_resamples, seed = 300, 4
    ci = bootstrap_ci(
        clip_outcomes(pred, ref, ref_duration_s=np.full(ref.shape, 2.0)),
        n_resamples=n_resamples,
        seed=seed,
    )

    def accuracy(p, r, axis=-1):
        return np.mean(quantise_deg(p) == quantise_deg(r), axis=axis)

    def mae(p, r, axis=-1):
        return np.mean(np.abs(p - r), axis=axis)

    def wprec(p, r):
        return precision_score(
            quantise_deg(r), quantise_deg(p), average="weighted", zero_division=0
        )

    def speed(p, r, axis=-1):
        return np.mean(np.abs(p / 2.0 - r / 2.0), axis=axis)

    for name, statistic, vectorized in [
        ("accuracy", accuracy, True),
        ("mae_deg", mae, True),
        ("wprec", wprec, False),
        ("mae_speed_deg_s", speed, True),
    ]:
        res = stats.bootstrap(
            (pred, ref),
            statistic,
            paired=True,
            vectorized=vectorized,
            n_resamples=n_resamples,
            method="percentile",
            rng=seed,
        )
        low, high = res.confidence_interval
        # Same draws, same percentiles: equal up to floating-point summation order.
        assert ci[name] == pytest.approx((low, high), rel=1e-9, abs=1e-12), name


def test_group_ci_equals_scipy_bootstrap_on_all_clips_keeping_the_group():
    pred, ref, _, _, group = _sample(n=180)
    o = clip_outcomes(pred, ref)
    n_resamples, seed = 300, 9
    _, by = grouped_bootstrap(
        o,
        [Partition.whole(o.n), Partition("g", ("a", "b", "c"), group)],
        n_resamples=n_resamples,
        seed=seed,
    )
    # ~60 clips per group: a resample without any clip of a group has probability ~e^-60.
    assert np.isfinite(by["accuracy"]).all()

    def accuracy_in(g):
        def statistic(p, r, grp, axis=-1):
            keep = grp == g
            return np.sum((quantise_deg(p) == quantise_deg(r)) & keep, axis=axis) / np.sum(
                keep, axis=axis
            )

        return statistic

    for g in range(3):
        res = stats.bootstrap(
            (pred, ref, group),
            accuracy_in(g),
            paired=True,
            vectorized=True,
            n_resamples=n_resamples,
            method="percentile",
            rng=seed,
        )
        expected = tuple(res.confidence_interval)
        assert percentile_interval(by["accuracy"][:, g]) == pytest.approx(expected, rel=1e-12)


def test_percentile_interval_leaves_out_undefined_resamples():
    values = np.array([np.nan, *np.arange(1.0, 102.0)])
    # 101 defined values 1..101: the 2.5th percentile by linear interpolation is 1 + 2.5 = 3.5.
    assert percentile_interval(values) == pytest.approx((3.5, 98.5))
    assert percentile_interval(np.array([np.nan])) is None


def test_a_group_missing_from_a_resample_is_nan_not_zero():
    # Clip 2 alone is group "b"; the first resample never draws it.
    o = clip_outcomes([90.0, 90.0, 10.0], [90.0, 90.0, 90.0])
    idx = np.array([[0, 1, 0], [2, 2, 2]])
    _, by = grouped_bootstrap(
        o, [Partition.whole(3), Partition("g", ("a", "b"), np.array([0, 0, 1]))], indices=[idx]
    )
    assert by["n"][:, 1].tolist() == [0, 3]
    assert math.isnan(by["accuracy"][0, 1]) and by["accuracy"][1, 1] == 0.0
    assert math.isnan(by["wprec"][0, 1]) and by["mae_deg"][1, 1] == 80.0


def test_resampling_refuses_nonsense():
    with pytest.raises(TurnbenchError):
        next(resample_indices(0))
    o = clip_outcomes(PRED, REF)
    with pytest.raises(TurnbenchError, match="does not label every clip"):
        grouped_bootstrap(o, [Partition("g", ("a",), np.array([0, 0, 1, 0]))], n_resamples=2)
    assert metrics_of(o)["n"] == 4


def test_observed_group_metrics_equal_sklearn_per_group():
    from turn_eval.clips.metrics import grouped_metrics

    pred, ref, duration, speed, group = _sample(n=90)
    o = clip_outcomes(pred, ref, ref_duration_s=duration, pred_speed_deg_s=speed)
    overall, by = grouped_metrics(o, [Partition.whole(o.n), Partition("g", ("a", "b", "c"), group)])
    assert overall["n"].tolist() == [90]
    for g in range(3):
        keep = group == g
        expected = compute_metrics(
            pred[keep], ref[keep], ref_duration_s=duration[keep], pred_speed_deg_s=speed[keep]
        )
        assert by["n"][g] == keep.sum()
        assert metrics_of(o.subset(keep)) == pytest.approx(expected, abs=1e-12)
        for name in ("accuracy", "mae_deg", "wprec", "mae_speed_deg_s"):
            assert by[name][g] == pytest.approx(expected[name], abs=1e-12), name


# --- predictions spread over many bins (a submission in the wrong unit) --------------------


def test_quadratic_kappa_equals_sklearn_on_the_step_grid():
    # scikit-learn's own formula on integer steps with every step in between as a label is
    # the oracle; the closed form must agree whatever the bins present.
    from turn_eval.clips.metrics import quadratic_kappa

    rng = np.random.default_rng(8)
    for spread in (30.0, 90.0, 400.0):
        ref = rng.uniform(0, 360, 300)
        pred = np.abs(ref + rng.normal(0, spread, 300))
        o = clip_outcomes(pred, ref)
        ref_step = np.rint(quantise_deg(ref) / 45).astype(int)
        pred_step = np.rint(quantise_deg(pred) / 45).astype(int)
        grid = np.arange(max(ref_step.max(), pred_step.max()) + 1)
        expected = cohen_kappa_score(ref_step, pred_step, labels=grid, weights="quadratic")
        assert quadratic_kappa(o) == pytest.approx(expected, rel=1e-12), spread
        assert bin_report(o)["kappa"] == pytest.approx(expected, rel=1e-12)


def test_wprec_from_counts_is_sklearns_weighted_precision():
    # Reference bins 0,0,1,2 and predictions 0,1,1,1: true (2,1,1), predicted (1,3,0),
    # right (1,1,0) -> (2 * 1/1 + 1 * 1/3 + 1 * 0) / 4 = 7/12.
    from turn_eval.clips.metrics import wprec_from_counts

    assert wprec_from_counts([2, 1, 1], [1, 3, 0], [1, 1, 0]) == pytest.approx(7 / 12)
    assert precision_score([0, 0, 1, 2], [0, 1, 1, 1], average="weighted", zero_division=0) == (
        pytest.approx(7 / 12)
    )


def test_hundreds_of_bins_score_like_sklearn_per_group_and_resample():
    # Predictions in centidegrees: hundreds of distinct bins. Every group metric on every resample
    # must still equal scikit-learn on that resample's clips of the group, and a chunk larger
    # than the engine's memory bound is evaluated in passes with the same numbers.
    from turn_eval.clips.metrics import _Engine

    rng = np.random.default_rng(3)
    n = 400
    ref = rng.uniform(45, 360, n)
    pred = ref * 100
    pred[:40] = ref[:40]  # a few right, so precision is not zero everywhere
    group = rng.integers(0, 4, n)
    o = clip_outcomes(pred, ref)
    assert o.bins_deg.size > 200  # a 200 x 200 confusion per group the engine never builds
    partitions = [Partition.whole(n), Partition("g", ("a", "b", "c", "d"), group)]
    idx = np.random.default_rng(1).integers(0, n, (12, n))
    overall, by = grouped_bootstrap(o, partitions, indices=[idx])
    for r in (0, 5, 11):
        drawn = idx[r]
        assert overall["wprec"][r, 0] == pytest.approx(
            compute_metrics(pred[drawn], ref[drawn])["wprec"], abs=1e-12
        )
        for g in range(4):
            keep = drawn[group[drawn] == g]
            expected = compute_metrics(pred[keep], ref[keep])
            for name in ("accuracy", "wprec"):
                assert by[name][r, g] == pytest.approx(expected[name], abs=1e-12), (name, r, g)
            # Errors of thousands of degrees: equal up to the order of summation.
            assert by["mae_deg"][r, g] == pytest.approx(expected["mae_deg"], rel=1e-12)
    engine = _Engine(o, partitions)
    object.__setattr__(engine, "rows_per_pass", 5)  # 12 rows -> passes of 5, 5 and 2
    split = engine.evaluate(idx)
    for whole, parts in zip((overall, by), split, strict=True):
        for name in whole:
            assert np.array_equal(whole[name], parts[name], equal_nan=True), name


def test_a_huge_finite_angle_is_scored_not_crashed():
    # 1e300 degrees is finite and non-negative, so it passes validation; bins that large
    # must not reach scikit-learn as floats (it calls them continuous) nor overflow kappa.
    o = clip_outcomes([1e300, 90.0, 180.0], [90.0, 90.0, 180.0])
    m = metrics_of(o)
    # Bins: ref 90, 90, 180; pred 1e300-ish, 90, 180. Precision: 90 -> 1/1, 180 -> 1/1,
    # huge -> 0 of 0 reference clips; WPrec = (2 * 1 + 1 * 1) / 3 = 1.
    assert m["accuracy"] == pytest.approx(2 / 3) and m["wprec"] == pytest.approx(1.0)
    report = bin_report(o)
    assert report["per_bin"]["90"] == {"n": 2, "n_predicted": 1, "precision": 1.0, "recall": 0.5}
    assert report["kappa"] is not None and -1.0 <= report["kappa"] <= 1.0


@pytest.mark.parametrize("seed", range(5))
def test_segments_are_numpys_unique_rows(seed):
    # The distinct rows' first indices and every row's id, as np.unique(axis=0) gives them.
    from turn_eval.clips.metrics import _segments

    rng = np.random.default_rng(seed)
    sizes = [3, 5, 2]
    columns = [rng.integers(0, size, 200) for size in sizes]
    first, seg = _segments(columns, sizes)
    _, first_np, seg_np = np.unique(
        np.stack(columns, axis=1), axis=0, return_index=True, return_inverse=True
    )
    assert first.tolist() == first_np.tolist()
    assert seg.tolist() == seg_np.reshape(-1).tolist()


def _bench_score():
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_score.py"
    spec = importlib.util.spec_from_file_location("bench_score_module", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_generic_engine_scores_clips_as_the_sparse_path_and_sklearn():
    # The benchmark's comparison is of equal work: the clips through the generic engine
    # (components per clip, one combine) give every metric of every group on every resample
    # that the sparse path and scikit-learn give.
    bench = _bench_score()
    pred, ref, duration, speed, group = _sample(n=90, seed=5)
    o = clip_outcomes(pred, ref, ref_duration_s=duration, pred_speed_deg_s=speed)
    partitions = [Partition.whole(o.n), Partition("g", ("a", "b", "c"), group)]
    chunks = [np.random.default_rng(2).integers(0, o.n, (25, o.n))]
    generic = bench.generic_bootstrap(o, partitions, chunks)
    sparse = grouped_bootstrap(o, partitions, indices=chunks)
    for a, b in zip(sparse, generic, strict=True):
        assert set(a) == set(b)
        for name in a:
            assert np.allclose(a[name], b[name], rtol=1e-12, atol=0.0, equal_nan=True), name
    for r in (0, 13, 24):
        drawn = chunks[0][r]
        for g in range(3):
            keep = drawn[group[drawn] == g]
            expected = precision_score(
                quantise_deg(ref[keep]),
                quantise_deg(pred[keep]),
                average="weighted",
                zero_division=0,
            )
            assert generic[1]["wprec"][r, g] == pytest.approx(expected, abs=1e-12)
            assert generic[1]["n"][r, g] == keep.size
            assert generic[1]["mae_deg"][r, g] == pytest.approx(
                np.abs(pred[keep] - ref[keep]).mean()
            )
    ratio = bench.sparse_over_generic(o, partitions, n_resamples=20, repeats=1)
    assert np.isfinite(ratio) and ratio > 0
