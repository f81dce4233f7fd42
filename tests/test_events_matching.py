"""Event matching (issue 12): hand-worked cases and a brute-force check of the rule."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_eval.events.matching import (
    categorize_events,
    eligible_pairs,
    match_pairs,
    overlapping_pairs,
    temporal_iou,
)


def _frame(intervals, unit=None):
    starts = [a for a, _ in intervals]
    ends = [b for _, b in intervals]
    return pd.DataFrame({"start_s": starts, "end_s": ends}, dtype=np.float64), np.asarray(
        unit if unit is not None else [0] * len(intervals), dtype=np.int64
    )


def _categorize(dets, refs, iou=0.5, det_unit=None, ref_unit=None):
    d, du = _frame(dets, det_unit)
    r, ru = _frame(refs, ref_unit)
    return categorize_events(d, du, r, ru, iou=iou)


def _kinds(events):
    return events["kind"].value_counts().reindex(["TP", "FP", "FN"], fill_value=0).tolist()


def test_iou_by_hand():
    # [0, 2] and [1, 3]: intersection 1, union 3.
    assert temporal_iou([0.0], [2.0], [1.0], [3.0])[0] == pytest.approx(1 / 3)
    # Touching intervals do not overlap.
    assert temporal_iou([0.0], [1.0], [1.0], [2.0])[0] == 0.0
    # Nested: [1, 2] inside [0, 4]: 1 / 4.
    assert temporal_iou([1.0], [2.0], [0.0], [4.0])[0] == 0.25


def test_iou_exactly_at_the_threshold_is_eligible():
    # [0, 1] against [0, 2]: IoU 1/2 exactly (binary fractions); >= 0.5 matches.
    events = _categorize([(0.0, 1.0)], [(0.0, 2.0)], iou=0.5)
    assert _kinds(events) == [1, 0, 0]
    assert events["iou"].iloc[0] == 0.5
    # Just above the threshold it does not.
    assert _kinds(_categorize([(0.0, 1.0)], [(0.0, 2.0)], iou=0.5000001)) == [0, 1, 1]


def test_one_detection_spanning_two_turns_matches_at_most_one():
    # [0, 2] against [0, 1] and [1, 2]: both IoU 1/2; one-to-one, so one TP and one FN.
    events = _categorize([(0.0, 2.0)], [(0.0, 1.0), (1.0, 2.0)], iou=0.5)
    assert _kinds(events) == [1, 0, 1]
    tp = events[events["kind"] == "TP"]
    assert tp["iou"].tolist() == [0.5]
    # Above 1/2 neither is eligible.
    assert _kinds(_categorize([(0.0, 2.0)], [(0.0, 1.0), (1.0, 2.0)], iou=0.6)) == [0, 1, 2]


def test_ties_give_one_pair_per_turn_and_the_most_pairs():
    # Turns [0, 2] and [2, 4]; detections [0, 1] (IoU 0.5 with the first) and [1, 3]
    # (1/3 with each). At IoU 0.3 the detection [1, 3] is eligible for both turns; the
    # first turn is also wanted by [0, 1]. The largest matching has two pairs: [0, 1] with
    # [0, 2] (0.5) and [1, 3] with [2, 4] (1/3), total 5/6.
    events = _categorize([(0.0, 1.0), (1.0, 3.0)], [(0.0, 2.0), (2.0, 4.0)], iou=0.3)
    assert _kinds(events) == [2, 0, 0]
    tp = events[events["kind"] == "TP"].sort_values("det_row")
    assert tp["ref_row"].tolist() == [0, 1]
    assert tp["iou"].sum() == pytest.approx(0.5 + 1 / 3)


def test_most_pairs_before_largest_total_iou():
    # (The matching itself needs only the reference side free of overlaps.)
    # Turns A=[0, 4], B=[4, 5]; detections d1=[0, 5] (IoU 0.8 with A, 0.2 with B) and
    # d2=[1.5, 4.5] (IoU 2.5/4.5 = 0.556 with A; 0.5/3.5 = 0.143 with B, ineligible at 0.2).
    # Pairs at IoU >= 0.2: d1-A 0.8, d1-B 0.2, d2-A 0.556. Max total IoU alone: d1-A (0.8),
    # then d2 has nothing: one pair. Most pairs: d1-B + d2-A (0.756), two pairs.
    events = _categorize([(0.0, 5.0), (1.5, 4.5)], [(0.0, 4.0), (4.0, 5.0)], iou=0.2)
    assert _kinds(events) == [2, 0, 0]
    tp = events[events["kind"] == "TP"].sort_values("det_row")
    assert tp["ref_row"].tolist() == [1, 0]


def test_nested_intervals():
    # A detection [1, 2] inside the turn [0, 4]: IoU 0.25: a match at 0.25, not at 0.3.
    assert _kinds(_categorize([(1.0, 2.0)], [(0.0, 4.0)], iou=0.25)) == [1, 0, 0]
    assert _kinds(_categorize([(1.0, 2.0)], [(0.0, 4.0)], iou=0.3)) == [0, 1, 1]
    # A turn nested inside a detection: the same, symmetric.
    assert _kinds(_categorize([(0.0, 4.0)], [(1.0, 2.0)], iou=0.25)) == [1, 0, 0]


def test_empty_sessions_and_units_are_kept_apart():
    # No detections: every turn an FN. No turns: every detection an FP.
    assert _kinds(_categorize([], [(0.0, 1.0), (2.0, 3.0)])) == [0, 0, 2]
    assert _kinds(_categorize([(0.0, 1.0)], [])) == [0, 1, 0]
    assert _kinds(_categorize([], [])) == [0, 0, 0]
    # The same times in two units never match across units.
    events = _categorize([(0.0, 1.0)], [(0.0, 1.0)], det_unit=[1], ref_unit=[0])
    assert _kinds(events) == [0, 1, 1]
    events = _categorize(
        [(0.0, 1.0), (0.0, 1.0)], [(0.0, 1.0), (0.0, 1.0)], det_unit=[0, 1], ref_unit=[1, 0]
    )
    assert _kinds(events) == [2, 0, 0]
    tp = events.sort_values("det_row")
    assert tp["ref_row"].tolist() == [1, 0]


def _brute_force(dets, refs, iou):
    """The best matching over every one-to-one assignment: (pairs, total IoU)."""
    values = np.array(
        [[temporal_iou([a], [b], [c], [d])[0] for c, d in refs] for a, b in dets]
    ).reshape(len(dets), len(refs))
    best = (0, 0.0)
    for k in range(min(len(dets), len(refs)), 0, -1):
        for rows in itertools.combinations(range(len(dets)), k):
            for cols in itertools.permutations(range(len(refs)), k):
                v = values[list(rows), list(cols)]
                if (v >= iou).all():
                    best = max(best, (k, float(v.sum())))
        if best[0] == k:
            break
    return best


def _disjoint(draw_cuts):
    """Non-overlapping intervals from sorted cut points (pairs of consecutive cuts)."""
    cuts = sorted(set(draw_cuts))
    return [(cuts[i], cuts[i + 1]) for i in range(0, len(cuts) - 1, 2)]


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(0, 24), min_size=0, max_size=10),
    st.lists(st.integers(0, 24), min_size=0, max_size=10),
    st.sampled_from([0.1, 0.25, 0.3, 0.5, 0.7]),
)
def test_matching_equals_brute_force(det_cuts, ref_cuts, iou):
    # Half-second grid: many exact ties and IoUs exactly at the threshold.
    dets = [(a / 2, b / 2) for a, b in _disjoint(det_cuts)]
    refs = [(a / 2, b / 2) for a, b in _disjoint(ref_cuts)]
    events = _categorize(dets, refs, iou=iou)
    tp = events[events["kind"] == "TP"]
    k, total = _brute_force(dets, refs, iou)
    assert tp.shape[0] == k
    assert tp["iou"].sum() == pytest.approx(total, abs=1e-12)
    # One-to-one, and every pair eligible.
    assert tp["det_row"].is_unique and tp["ref_row"].is_unique
    assert (tp["iou"] >= iou).all()
    assert _kinds(events) == [k, len(dets) - k, len(refs) - k]


def test_eligible_pairs_and_match_pairs_are_frames():
    d, du = _frame([(0.0, 2.0), (3.0, 4.0)])
    r, ru = _frame([(0.0, 1.0), (1.0, 2.0), (3.0, 4.5)])
    pairs = eligible_pairs(overlapping_pairs(d, du, r, ru), iou=0.5)
    assert pairs.columns.tolist() == ["det_row", "ref_row", "unit", "iou"]
    assert sorted(zip(pairs["det_row"], pairs["ref_row"], strict=True)) == [(0, 0), (0, 1), (1, 2)]
    matched = match_pairs(pairs)
    assert matched.shape[0] == 2
    assert matched["iou"].tolist()[-1] == pytest.approx(1 / 1.5)
