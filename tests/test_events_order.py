"""The event tables' fast row order is numpy.lexsort's, whatever the guess."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_eval.events.order import in_lexsort_order, lexsort, stable_argsort, unit_time_guess

_TIMES = st.sampled_from([0.0, 0.1, 0.1 + 1e-12, 1.0, 2.5, 1e6, 1e6 + 1e-9, np.nan])


@settings(max_examples=300, deadline=None)
@given(
    rows=st.lists(
        st.tuples(st.integers(0, 4), _TIMES, st.integers(-1, 3)), min_size=0, max_size=25
    ),
    shuffle=st.randoms(use_true_random=False),
)
def test_lexsort_equals_numpys_whatever_the_guess(rows, shuffle):
    unit = np.array([r[0] for r in rows], dtype=np.int64)
    time_s = np.array([r[1] for r in rows], dtype=np.float64)
    third = np.array([r[2] for r in rows], dtype=np.int64)
    for keys in ((time_s, unit), (third, time_s, unit)):
        expected = np.lexsort(keys)
        guesses = [unit_time_guess(unit, time_s), np.arange(len(rows)), expected]
        shuffled = list(range(len(rows)))
        shuffle.shuffle(shuffled)
        guesses.append(np.array(shuffled, dtype=np.int64))
        for guess in guesses:
            got = lexsort(keys, guess)
            assert got.tolist() == expected.tolist()
            right = guess.tolist() == expected.tolist()
            if in_lexsort_order(keys, guess):
                assert right
            elif not np.isnan(time_s).any():
                # Without NaN (which compares false, so lexsort decides) the check is exact.
                assert not right


def test_rows_in_order_are_their_own_guess():
    unit = np.repeat(np.arange(3), 4)
    time_s = np.tile([0.0, 1.5, 3.0, 7.25], 3)
    assert unit_time_guess(unit, time_s).tolist() == list(range(12))


@settings(max_examples=200, deadline=None)
@given(
    values=st.lists(
        st.sampled_from([0.0, 0.001, 0.25, 0.3, 1.0 / 3, 2.0, 1e9]), min_size=0, max_size=30
    ),
    n_groups=st.integers(1, 4),
    data=st.data(),
)
def test_group_medians_are_numpys_median_of_each_group(values, n_groups, data):
    from turn_eval.events.scoring import _group_medians

    v = np.array(values, dtype=np.float64)
    codes = np.array(
        data.draw(
            st.lists(st.integers(0, n_groups - 1), min_size=len(values), max_size=len(values))
        ),
        dtype=np.int64,
    )
    count = np.bincount(codes, minlength=n_groups)
    got = _group_medians(codes, count, v, np.argsort(v))
    for g in range(n_groups):
        if count[g]:
            # Bit for bit, not approximately.
            assert got[g] == float(np.median(v[codes == g]))
        else:
            assert np.isnan(got[g])


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.sampled_from([-1.0, -0.0, 0.0, 0.5, 0.5 + 1e-16, 0.7, np.inf, -np.inf, np.nan]),
        max_size=40,
    )
)
def test_stable_argsort_is_numpys(values):
    v = np.array(values, dtype=np.float64)
    assert stable_argsort(v).tolist() == np.argsort(v, kind="stable").tolist()
