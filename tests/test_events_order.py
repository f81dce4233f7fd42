"""The event tables' fast row order is numpy.lexsort's, whatever the guess."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from turn_eval.events._order import in_lexsort_order, lexsort, unit_time_guess

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
