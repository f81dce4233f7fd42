"""Agreement audit: matching as ELAN's reliability check, kappa, the report."""

from __future__ import annotations

import pandas as pd
import pytest

from turn_datasets.agreement import MATCH_COLUMNS, match_annotations


def _ann(rows, index=None):
    return pd.DataFrame(rows, columns=["session", "participant", "start_s", "end_s"], index=index)


def test_match_links_by_ratio_to_longer_duration():
    a = _ann([("s1", "P1", 0.0, 2.0), ("s1", "P1", 10.0, 11.0)])
    # b0 overlaps a0 by 1.5 s; longer is a0 (2.0 s): ratio 0.75 -> linked.
    # b1 overlaps a1 by 0.5 s; both last 1.0 s: ratio 0.5 < 0.6 -> not linked.
    b = _ann([("s1", "P1", 0.5, 2.5), ("s1", "P1", 10.5, 11.5)])
    m = match_annotations(a, b)
    assert list(m.columns) == list(MATCH_COLUMNS)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.75])
    # with a lower threshold the second pair is linked at 0.5
    m = match_annotations(a, b, min_overlap=0.5)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0], [1, 1]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.75, 0.5])


def test_match_ratio_uses_longer_not_shorter():
    # b lies inside a: overlap 1.0 s = all of b, but a lasts 2.0 s: ratio 0.5, not 1.0.
    a = _ann([("s1", "P1", 0.0, 2.0)])
    b = _ann([("s1", "P1", 0.5, 1.5)])
    assert match_annotations(a, b).empty
    assert match_annotations(a, b, min_overlap=0.5)["overlap_ratio"].tolist() == [0.5]


def test_match_threshold_inclusive_despite_float_rounding():
    # overlap 0.6 of 1.0 s: 0.6 >= 0.6 must link although 10.6 - 10.0 != 0.6 exactly.
    a = _ann([("s1", "P1", 10.0, 11.0)])
    b = _ann([("s1", "P1", 9.6, 10.6)])
    m = match_annotations(a, b)
    assert len(m) == 1 and m["overlap_ratio"].iloc[0] == pytest.approx(0.6)


def test_match_only_same_session_and_participant():
    a = _ann([("s1", "P1", 0.0, 1.0), ("s1", "P2", 0.0, 1.0), ("s2", "P1", 0.0, 1.0)])
    b = _ann([("s2", "P2", 0.0, 1.0), ("s1", "P2", 0.0, 1.0), ("s2", "P1", 0.0, 1.0)])
    m = match_annotations(a, b)
    # a1 <-> b1 (s1, P2) and a2 <-> b2 (s2, P1); a0 (s1, P1) and b0 (s2, P2) have no partner.
    assert m[["index_a", "index_b"]].values.tolist() == [[1, 1], [2, 2]]


def test_match_greedy_highest_ratio_first():
    # a0 = [0, 2], a1 = [1.2, 3.2]; b0 = [0.2, 2.2], b1 = [1.0, 3.0].
    # ratios (all durations 2 s): a0-b0 1.8/2 = 0.9, a0-b1 1.0/2 = 0.5,
    #                             a1-b0 1.0/2 = 0.5, a1-b1 1.8/2 = 0.9.
    a = _ann([("s", "P", 0.0, 2.0), ("s", "P", 1.2, 3.2)])
    b = _ann([("s", "P", 0.2, 2.2), ("s", "P", 1.0, 3.0)])
    m = match_annotations(a, b, min_overlap=0.4)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0], [1, 1]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.9, 0.9])

    # Two candidates for one b: a0 = [0, 2] with b0 = [0.1, 2.1] overlaps 1.9 of 2.0 s (0.95),
    # a1 = [0.3, 2.5] overlaps 1.8 of its 2.2 s (0.818); the higher ratio wins, a1 stays alone.
    a = _ann([("s", "P", 0.0, 2.0), ("s", "P", 0.3, 2.5)])
    b = _ann([("s", "P", 0.1, 2.1)])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    assert m["overlap_ratio"].tolist() == pytest.approx([0.95])


def test_match_greedy_can_leave_a_feasible_pair_unlinked():
    # a0 = [0, 10], a1 = [2, 10]; b0 = [1, 10], b1 = [0, 6].
    # a0-b0: 9/10 = 0.9, a0-b1: 6/10 = 0.6, a1-b0: 8/9 = 0.889, a1-b1: 4/8 = 0.5.
    # Greedy takes a0-b0 (0.9); a1 is left with b1 at 0.5 < 0.6: one link only, as ELAN does
    # (an optimal assignment would have linked a0-b1 and a1-b0).
    a = _ann([("s", "P", 0.0, 10.0), ("s", "P", 2.0, 10.0)])
    b = _ann([("s", "P", 1.0, 10.0), ("s", "P", 0.0, 6.0)])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[0, 0]]


def test_match_tie_break_is_deterministic():
    # a0 = [0, 2] is equally good (ratio 0.75) with b0 = [0.5, 2.5] and b1 = [-0.5, 1.5];
    # equal start gaps (0.5 s), so the earlier row of b wins: b0.
    a = _ann([("s", "P", 0.0, 2.0)])
    b = _ann([("s", "P", 0.5, 2.5), ("s", "P", -0.5, 1.5)])
    assert match_annotations(a, b)[["index_a", "index_b"]].values.tolist() == [[0, 0]]
    # reversed order of b: the earlier row is now the other one.
    b2 = b.iloc[::-1]
    assert match_annotations(a, b2)[["index_a", "index_b"]].values.tolist() == [[0, 1]]


def test_match_keeps_index_labels_and_skips_zero_durations():
    a = _ann([("s", "P", 5.0, 5.0), ("s", "P", 0.0, 1.0)], index=[40, 41])
    b = _ann([("s", "P", 0.0, 1.0), ("s", "P", 5.0, 5.0)], index=[7, 8])
    m = match_annotations(a, b)
    assert m[["index_a", "index_b"]].values.tolist() == [[41, 7]]
    assert m.dtypes.astype(str).to_dict() == MATCH_COLUMNS


def test_match_empty_and_bad_arguments():
    empty = _ann([])
    m = match_annotations(empty, empty)
    assert m.empty and list(m.columns) == list(MATCH_COLUMNS)
    with pytest.raises(ValueError):
        match_annotations(empty, empty, min_overlap=0.0)
    with pytest.raises(ValueError):
        match_annotations(empty.drop(columns="participant"), empty)
