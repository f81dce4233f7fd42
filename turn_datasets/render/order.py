"""The one sort order of names in turnbench's outputs: natural order ("S2" before "S11")."""

from __future__ import annotations

import re
from decimal import Decimal

__all__ = ["natural_key"]

_NUMBER = re.compile(r"(\d+(?:\.\d+)?)")


def natural_key(text: str) -> tuple:
    """Sort key putting "S2" before "S11" and bin "45" before "135".

    Runs of digits (with a decimal part: "22.5") compare as numbers, the rest as text, by
    code point (so upper case sorts before lower case, as the file listings of a dataset
    root always have in the clip index and the manifest); names that tie so (``"1"`` and
    ``"01"``) are then ordered by their exact text, so the order never depends on the
    input's. The one ordering
    of subjects, actions, groups and file paths in indexes, manifests, scores and statistics.
    """
    text = str(text)
    parts = _NUMBER.split(text)
    key = tuple(
        (0, int(p) if p.isdigit() else Decimal(p), "") if i % 2 else (1, 0, p)
        for i, p in enumerate(parts)
    )
    return (key, text)
