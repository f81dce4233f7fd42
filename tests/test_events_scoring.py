"""score_events (issue 12): metrics by hand, the cluster bootstrap against a plain loop, AP by
hand, grouping of false detections, validation errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from turn_datasets.errors import TurnbenchError
from turn_eval.events import score_events
from turn_eval.events.ap import interpolated_ap
from turn_eval.events.bootstrap import COMPONENTS, cluster_bootstrap
from turn_eval.scoring.bootstrap import resample_indices, unit_sums

REF = pd.DataFrame(
    {
        "session": ["s1", "s1", "s1", "s2", "s2"],
        "subject": ["P1", "P1", "P1", "P2", "P2"],
        "start_s": [0.0, 10.0, 20.0, 0.0, 5.0],
        "end_s": [2.0, 12.0, 22.0, 3.0, 6.0],
        "angle_deg": [90.0, 180.0, 90.0, 135.0, 360.0],
        "cohort": ["PD", "PD", "PD", "HC", "HC"],
        "scenario": ["scripted", "scripted", "free-living", "scripted", "scripted"],
        "location": ["kitchen"] * 3 + ["hall"] * 2,
    }
)
DET = pd.DataFrame(
    {
        "session": ["s1", "s1", "s1", "s2"],
        "subject": ["P1", "P1", "P1", "P2"],
        "start_s": [0.0, 10.5, 30.0, 0.5],
        "end_s": [2.0, 12.0, 31.0, 3.0],
        "angle_deg": [80.0, 200.0, 90.0, 135.0],
        "score": [0.9, 0.8, 0.7, 0.3],
    }
)


def test_counts_and_matched_metrics_by_hand():
    doc = score_events(DET, REF, n_resamples=0).doc
    o = doc["overall"]
    # Matches: [0,2]-[0,2] (IoU 1), [10.5,12]-[10,12] (0.75), [0.5,3]-[0,3] (5/6);
    # [30,31] unmatched (FP); [20,22] and [5,6] unmatched (FN).
    assert (o["tp"], o["fp"], o["fn"]) == (3, 1, 2)
    assert o["precision"] == pytest.approx(3 / 4)
    assert o["recall"] == pytest.approx(3 / 5)
    assert o["f1"] == pytest.approx(6 / 9)
    m = o["matched"]
    # Angle errors 10, 20, 0; bins 90/90, 180/180 (200 -> 180), 135/135: all right.
    assert m["n"] == 3
    assert m["accuracy"] == 1.0
    assert m["mae_deg"] == pytest.approx(10.0)
    assert m["wprec"] == 1.0
    assert m["mae_speed_deg_s"] is None and m["direction_agreement"] is None
    # |dstart| 0, 0.5, 0.5 -> 0.5; |dend| 0, 0, 0 -> 0.
    assert m["median_abs_dstart_s"] == 0.5 and m["median_abs_dend_s"] == 0.0
    assert doc["settings"]["iou"] == 0.5 and doc["settings"]["resamples"] == 0


def test_groups_take_the_reference_row_and_false_detections_are_unknown_without_context():
    doc = score_events(DET, REF, n_resamples=0).doc
    cohort = doc["by"]["cohort"]["groups"]
    assert (cohort["PD"]["tp"], cohort["PD"]["fp"], cohort["PD"]["fn"]) == (2, 1, 1)
    assert (cohort["HC"]["tp"], cohort["HC"]["fp"], cohort["HC"]["fn"]) == (1, 0, 1)
    scenario = doc["by"]["scenario"]["groups"]
    assert list(scenario) == ["free-living", "scripted", "unknown"]
    assert (scenario["unknown"]["tp"], scenario["unknown"]["fp"]) == (0, 1)
    assert scenario["free-living"]["fn"] == 1
    # Avg. is the unweighted mean of the groups' F1 (the undefined ones left out).
    f1 = [g["f1"] for g in cohort.values()]
    assert doc["by"]["cohort"]["avg"]["f1"] == pytest.approx(np.mean(f1))


def test_false_detection_takes_the_context_at_its_midpoint():
    context = pd.DataFrame(
        {
            "session": ["s1", "s1"],
            "subject": ["", "P1"],
            "start_s": [0.0, 29.0],
            "end_s": [100.0, 30.4],
            "scenario": ["scripted", "clinical"],
            "location": ["kitchen", "bedroom"],
        }
    )
    # The FP [30, 31] has midpoint 30.5: the participant's own interval ended at 30.4, so the
    # session's shared one applies.
    doc = score_events(DET, REF, context=context, n_resamples=0).doc
    assert doc["by"]["scenario"]["groups"]["scripted"]["fp"] == 1
    assert "unknown" not in doc["by"]["scenario"]["groups"]
    own = context.assign(end_s=[100.0, 31.0])
    doc = score_events(DET, REF, context=own, n_resamples=0).doc
    assert doc["by"]["scenario"]["groups"]["clinical"]["fp"] == 1
    assert doc["by"]["location"]["groups"]["bedroom"]["fp"] == 1


def test_turns_per_hour():
    sessions = pd.DataFrame(
        {"session": ["s1", "s2"], "subject": ["P1", "P2"], "duration_s": [1800.0, 3600.0]}
    )
    result = score_events(DET, REF, sessions=sessions, n_resamples=0)
    rates = result.doc["overall"]["turns_per_hour"]
    # s1: 3 turns, 3 detections in half an hour -> 6 and 6; s2: 2 turns, 1 detection in 1 h.
    assert rates["reference_per_hour_mean"] == pytest.approx((6 + 2) / 2)
    assert rates["detected_per_hour_mean"] == pytest.approx((6 + 1) / 2)
    assert rates["mean_abs_difference_per_hour"] == pytest.approx((0 + 1) / 2)
    assert result.rates["reference_turns"].tolist() == [3, 2]
    with pytest.raises(TurnbenchError, match="no annotated duration for session 's2'"):
        score_events(DET, REF, sessions=sessions.iloc[:1], n_resamples=0)


def test_average_precision_by_hand():
    doc = score_events(DET, REF, n_resamples=0).doc
    # Ranked: 0.9 TP, 0.8 TP, 0.7 FP, 0.3 TP, over 5 turns. Precision 1, 1, 2/3, 3/4; recall
    # .2, .4, .4, .6. Interpolated: the step to .2 and .4 at precision 1, to .6 at 3/4:
    # AP = .2 + .2 + .2 * .75 = 0.55 (the IoUs, 1, .75, .83, pass every threshold to 0.7).
    for value in doc["overall"]["ap"]["by_iou"].values():
        assert value == pytest.approx(0.55)
    assert doc["overall"]["ap"]["mean"] == pytest.approx(0.55)
    # At 0.8 the second detection (IoU 0.75) is an FP.
    assert interpolated_ap(np.array([1.0, 0.5]), np.array([0.5, 0.5])) == 0.5


def test_interpolation_takes_the_best_precision_to_the_right():
    # P = [1, .5, .667], R = [1/3, 1/3, 2/3]: interpolated at 1/3 is 1, at 2/3 is .667.
    ap = interpolated_ap(np.array([1.0, 0.5, 2 / 3]), np.array([1 / 3, 1 / 3, 2 / 3]))
    assert ap == pytest.approx(1 / 3 * 1 + 1 / 3 * 2 / 3)


def test_greedy_ap_follows_the_confidence():
    # One turn [0, 2]; two detections can match it only one at a time... detections do not
    # overlap, so take [0, 1.5] (IoU .75, score .2) and [1.5, 2.5]... not eligible. Use two
    # turns [0, 2] and [2, 3] and a detection [0, 2.4] (IoU .83 with the first, score .1)
    # plus [2.4, 3] (IoU .6 with the second, score .9).
    ref = pd.DataFrame(
        {
            "session": ["s"] * 2,
            "subject": ["p"] * 2,
            "start_s": [0.0, 2.0],
            "end_s": [2.0, 3.0],
            "angle_deg": [90.0, 90.0],
        }
    )
    det = pd.DataFrame(
        {
            "session": ["s"] * 2,
            "subject": ["p"] * 2,
            "start_s": [0.0, 2.4],
            "end_s": [2.4, 3.0],
            "angle_deg": [90.0, 90.0],
            "score": [0.1, 0.9],
        }
    )
    ap = score_events(det, ref, n_resamples=0).doc["overall"]["ap"]["by_iou"]
    # At 0.5 and 0.6: both TP (ranked .9 then .1): P 1, 1; R .5, 1 -> AP 1.
    assert ap["0.5"] == pytest.approx(1.0) and ap["0.6"] == pytest.approx(1.0)
    # At 0.7: the .9 detection (IoU .6) is an FP, the .1 one a TP: P 0, .5; R 0, .5 -> .25.
    assert ap["0.7"] == pytest.approx(0.25)


def test_cluster_bootstrap_equals_a_plain_loop():
    rng = np.random.default_rng(3)
    n_units, n_groups = 6, 3
    events = 40
    unit = rng.integers(0, n_units, events)
    group = rng.integers(0, n_groups, events)
    kind = rng.integers(0, 3, events)
    correct = (kind == 0) & (rng.random(events) < 0.6)
    error = np.where(kind == 0, rng.random(events) * 30, 0.0)
    values = np.stack([kind == 0, kind == 1, kind == 2, correct, error], axis=1).astype(float)
    sums = {"g": unit_sums(unit, group, values, n_units, n_groups)}
    result = cluster_bootstrap(sums, n_resamples=25, seed=7)["g"]
    (indices,) = list(resample_indices(n_units, n_resamples=25, seed=7, rows_per_chunk=25))
    for r, row in enumerate(indices):
        # The resample: every event of each drawn unit, as often as the unit was drawn.
        picked = np.concatenate([np.flatnonzero(unit == u) for u in row])
        for g in range(n_groups):
            sel = picked[group[picked] == g]
            tp = float((kind[sel] == 0).sum())
            fp = float((kind[sel] == 1).sum())
            fn = float((kind[sel] == 2).sum())
            expect = {
                "precision": tp / (tp + fp) if tp + fp else np.nan,
                "recall": tp / (tp + fn) if tp + fn else np.nan,
                "f1": 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else np.nan,
                "accuracy": correct[sel].sum() / tp if tp else np.nan,
                "mae_deg": error[sel].sum() / tp if tp else np.nan,
            }
            for name, value in expect.items():
                np.testing.assert_allclose(result[name][r, g], value, rtol=1e-12, equal_nan=True)
    assert COMPONENTS == ("tp", "fp", "fn", "correct", "abs_error_deg")


def test_cluster_bootstrap_does_not_depend_on_the_blas_thread_count():
    # OpenBLAS splits a product of this size over its threads in another order of sums than
    # one thread takes: without the bootstrap's own one-thread limit the MAE intervals of
    # score-events differed in their last digits between OPENBLAS_NUM_THREADS=1 and 2.
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(5)
    n_units, n_groups, events = 500, 60, 5000
    unit = rng.integers(0, n_units, events)
    group = rng.integers(0, n_groups, events)
    values = np.stack(
        [
            rng.random(events) < 0.8,
            rng.random(events) < 0.1,
            rng.random(events) < 0.1,
            rng.random(events) < 0.6,
            rng.random(events) * 40.0,
        ],
        axis=1,
    ).astype(float)
    sums = {"g": unit_sums(unit, group, values, n_units, n_groups)}
    results = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads, user_api="blas"):
            results.append(cluster_bootstrap(sums, n_resamples=1000, seed=0)["g"])
    for name in results[0]:
        assert np.array_equal(results[0][name], results[1][name], equal_nan=True), name


def test_bootstrap_is_seeded_and_reproducible():
    a = score_events(DET, REF, n_resamples=200, seed=1).doc
    b = score_events(DET, REF, n_resamples=200, seed=1).doc
    assert a == b
    # Two units: a resample is (s1, s1) (recall 4/6), (s2, s2) (1/2) or one of each (3/5),
    # the first two a quarter of the time each, so the 2.5th and 97.5th percentiles of 200
    # draws are 1/2 and 2/3.
    assert a["overall"]["ci95"]["recall"] == pytest.approx([0.5, 2 / 3])
    low, high = a["overall"]["ci95"]["f1"]
    assert low <= a["overall"]["f1"] <= high


def test_clip_index_reference_makes_the_session_from_action_and_subaction():
    index = pd.DataFrame(
        {
            "clip_id": ["S9_Walking-1_0-100", "S9_Walking_0-100"],
            "subject": ["S9", "S9"],
            "action": ["Walking", "Walking"],
            "subaction": ["1", ""],
            "start_s": [0.0, 0.0],
            "end_s": [2.0, 2.0],
            "angle_deg": [90.0, 180.0],
            "direction": ["left", "right"],
        }
    )
    det = pd.DataFrame(
        {
            "session": ["Walking 1", "Walking"],
            "subject": ["S9", "S9"],
            "start_s": [0.0, 0.1],
            "end_s": [2.0, 2.0],
            "angle_deg": [95.0, 170.0],
            "direction": ["Left", "left"],
        }
    )
    doc = score_events(det, index, n_resamples=0).doc
    assert doc["overall"]["tp"] == 2
    assert doc["overall"]["matched"]["direction_agreement"] == 0.5
    assert list(doc["by"]) == ["subject", "action"]


def _det(**changes):
    frame = DET.copy()
    for col, values in changes.items():
        frame[col] = values
    return frame


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (DET.drop(columns="end_s"), "lacks column 'end_s'"),
        (_det(start_s=[0.0, np.nan, 30.0, 0.5]), "3: start_s is NaN"),
        (_det(start_s=[0.0, -1.0, 30.0, 0.5]), "3: start_s -1 is outside"),
        (_det(end_s=[2.0, 12.0, np.inf, 3.0]), "4: end_s is infinite"),
        (_det(end_s=[2.0, 10.5, 31.0, 3.0]), "3: end_s 10.5 is not after start_s 10.5"),
        (_det(angle_deg=[80.0, 200.0, 5000.0, 135.0]), "4: angle_deg 5000 is outside"),
        (_det(session=["s1", "", "s1", "s2"]), "3: session is empty"),
        (_det(start_s=[0.0, 1.0, 30.0, 0.5]), "lines 2 and 3 overlap"),
        (_det(start_s=[0.0, 0.0, 30.0, 0.5], end_s=[2.0, 2.0, 31.0, 3.0]), "3: duplicate"),
        (_det(session=["s1", "s1", "s9", "s2"]), "4: session 's9', subject 'P1' is not annotated"),
        (_det(direction=["left", "up", "", "right"]), "3: direction 'up'"),
    ],
)
def test_bad_detections_are_one_line_naming_the_row(frame, message):
    with pytest.raises(TurnbenchError, match=message.replace("(", r"\(")):
        score_events(frame, REF, n_resamples=0)


def test_overlapping_reference_turns_are_refused():
    ref = REF.copy()
    ref.loc[1, "start_s"] = 1.0
    with pytest.raises(TurnbenchError, match="reference turns on lines 2 and 3 overlap"):
        score_events(DET, ref, n_resamples=0)


def test_ignore_unknown_drops_and_counts():
    frame = _det(session=["s1", "s1", "s9", "s2"])
    said = []
    doc = score_events(frame, REF, n_resamples=0, ignore_unknown=True, warn=said.append).doc
    assert doc["counts"]["dropped_unknown"] == 1
    assert doc["overall"]["fp"] == 0
    assert "dropped 1 detection" in said[0] and "line 4" in said[0]


def test_vectorised_percentiles_equal_the_harness_interval():
    from turn_eval.events.scoring import _percentiles
    from turn_eval.scoring.bootstrap import percentile_interval

    rng = np.random.default_rng(5)
    values = rng.normal(size=(1000, 7))
    values[rng.random(values.shape) < 0.2] = np.nan
    values[:, 3] = np.nan
    values[:999, 4] = np.nan
    alpha = (1 - 0.95) / 2
    low, high = _percentiles(values, (100 * alpha, 100 * (1 - alpha)))
    for column in range(values.shape[1]):
        expected = percentile_interval(values[:, column])
        got = (low[column], high[column])
        if expected is None:
            assert np.isnan(got).all()
        else:
            assert got == expected


def test_the_callers_frames_are_left_as_they_were():
    det, ref = DET.copy(), REF.copy()
    det["direction"] = ["Left", "right", "", "left"]
    before = (det.copy(), ref.copy())
    score_events(det, ref, n_resamples=10)
    pd.testing.assert_frame_equal(det, before[0])
    pd.testing.assert_frame_equal(ref, before[1])


def test_a_participant_annotated_without_turns_counts_and_takes_its_subjects_cohort():
    # sessions.csv lists (s3, P1), a session where P1 made no turn: a detection there is
    # not unknown but a false positive, of P1's cohort (PD, constant over P1's turns).
    sessions = pd.DataFrame(
        {
            "session": ["s1", "s2", "s3"],
            "subject": ["P1", "P2", "P1"],
            "duration_s": [3600.0, 3600.0, 1800.0],
        }
    )
    extra = pd.DataFrame(
        [{"session": "s3", "subject": "P1", "start_s": 1.0, "end_s": 2.0, "angle_deg": 90.0}]
    )
    det = pd.concat([DET.drop(columns="score"), extra], ignore_index=True)
    result = score_events(det, REF, sessions=sessions, n_resamples=0)
    doc = result.doc
    assert doc["counts"]["units"] == 3
    assert doc["by"]["cohort"]["groups"]["PD"]["fp"] == 2
    assert doc["by"]["subject"]["groups"]["P1"]["fp"] == 2
    # Turns per hour of (s3, P1): 0 reference, 2 detected per hour.
    row = result.rates.set_index(["session", "subject"]).loc[("s3", "P1")]
    assert (row["reference_per_hour"], row["detected_per_hour"]) == (0.0, 2.0)
