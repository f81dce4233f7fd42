"""Row orders of the event tables: exactly ``numpy.lexsort``'s, found faster when a cheap
guess is right.

``numpy.lexsort`` is a merge sort per key: about 10 ms for 100,000 rows of (unit, time),
more with a third key. The tables it orders are nearly always in order already (files
written unit by unit in time order) or close to the order of one float key, which numpy's
unstable sort finds in a tenth of that. A guess is checked in one pass against the exact
order (every key, then the position, as lexsort is stable) and ``numpy.lexsort`` runs
only when the guess is wrong, so the result is lexsort's either way.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def in_lexsort_order(keys: Sequence[np.ndarray], order: np.ndarray) -> bool:
    """Whether the permutation ``order`` is ``numpy.lexsort(keys)`` (the last key first, ties
    by the key before, ..., last by position)."""
    a, b = order[:-1], order[1:]
    before = a < b
    for key in keys:
        ka, kb = key[a], key[b]
        # NaN compares false both ways: never "in order", so lexsort decides.
        before = (ka < kb) | ((ka == kb) & before)
    return bool(before.all())


def lexsort(keys: Sequence[np.ndarray], guess: np.ndarray) -> np.ndarray:
    """``numpy.lexsort(keys)``; ``guess`` (a permutation of the rows) when it is that order."""
    if in_lexsort_order(keys, guess):
        return guess
    return np.lexsort(tuple(keys))


def unit_time_guess(unit: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """A permutation that is usually the (unit, time) order: an unstable sort of one float
    key that puts the units apart (rounding can misorder near-equal times and ties come in
    any order, which :func:`lexsort`'s check then catches)."""
    if unit.shape[0] == 0:
        return np.arange(0)
    span = float(np.max(time_s)) - float(np.min(time_s)) + 1.0
    return np.argsort(unit * span + time_s)
