"""Vectorised string operations on numpy 2 and numpy 1.26 alike.

numpy 2 has variable-width strings (``np.dtypes.StringDType``) and the ``np.strings``
functions; the readers use them so that one long line does not widen every other one in
memory. The optional ``video`` extra (mediapipe 0.10.21) pins numpy < 2, so the core also
runs on numpy 1.26, where the same operations fall back to fixed-width unicode arrays and
``np.char`` (element by element ``str.strip``/``str.count``: the same results, more memory).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = ["HAS_STRING_DTYPE", "count", "strip", "stripped_objects", "text_array"]

#: True on numpy >= 2 (variable-width ``StringDType`` and ``np.strings``).
HAS_STRING_DTYPE = hasattr(np, "strings") and hasattr(np.dtypes, "StringDType")


def text_array(values: Iterable[str] | np.ndarray) -> np.ndarray:
    """``values`` as a numpy array of text: variable-width on numpy 2, ``<U`` on 1.26."""
    if HAS_STRING_DTYPE:
        return np.asarray(values, dtype=np.dtypes.StringDType())
    values = values if isinstance(values, np.ndarray) else list(values)
    return np.asarray(values, dtype=str)


def strip(text: np.ndarray) -> np.ndarray:
    """Leading and trailing white space removed from every element (``str.strip``)."""
    return np.strings.strip(text) if HAS_STRING_DTYPE else np.char.strip(text)


def count(text: np.ndarray, sub: str) -> np.ndarray:
    """Non-overlapping occurrences of ``sub`` in every element (``str.count``)."""
    return np.strings.count(text, sub) if HAS_STRING_DTYPE else np.char.count(text, sub)


def stripped_objects(values: Iterable[str] | np.ndarray) -> np.ndarray:
    """``values`` stripped, as an object array of Python ``str``."""
    return strip(text_array(values)).astype(object)
