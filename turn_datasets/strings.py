"""Vectorised string operations on numpy 2 and numpy 1.26 alike.

numpy 2 has variable-width strings (``np.dtypes.StringDType``) and the ``np.strings``
functions; the readers use them so that one long line does not widen every other one in
memory. The optional ``video`` extra (mediapipe 0.10.21) pins numpy < 2, so the core also
runs on numpy 1.26, where the same operations fall back to object arrays of Python ``str``
and ``str.strip``/``str.count`` element by element: the same results (not numpy 1.26's
fixed-width ``<U`` arrays, which silently drop trailing NUL characters).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = ["HAS_STRING_DTYPE", "count", "strip", "stripped_objects", "text_array"]

#: True on numpy >= 2 (variable-width ``StringDType`` and ``np.strings``).
HAS_STRING_DTYPE = hasattr(np, "strings") and hasattr(np.dtypes, "StringDType")


def text_array(values: Iterable[str] | np.ndarray) -> np.ndarray:
    """``values`` as a numpy array of text: variable-width on numpy 2, ``str`` objects on 1.26."""
    if HAS_STRING_DTYPE:
        return np.asarray(values, dtype=np.dtypes.StringDType())
    items = [str(v) for v in values]
    out = np.empty(len(items), dtype=object)
    out[:] = items
    return out


def strip(text: np.ndarray) -> np.ndarray:
    """Leading and trailing white space removed from every element (``str.strip``)."""
    if HAS_STRING_DTYPE:
        return np.strings.strip(text)
    out = np.empty(len(text), dtype=object)
    out[:] = [str(v).strip() for v in text]
    return out


def count(text: np.ndarray, sub: str) -> np.ndarray:
    """Non-overlapping occurrences of ``sub`` in every element (``str.count``)."""
    if HAS_STRING_DTYPE:
        return np.strings.count(text, sub)
    return np.fromiter((str(v).count(sub) for v in text), dtype=np.int64, count=len(text))


def stripped_objects(values: Iterable[str] | np.ndarray) -> np.ndarray:
    """``values`` stripped, as an object array of Python ``str``."""
    return strip(text_array(values)).astype(object)
