"""Groups of scored units as every scorer names them.

A group's label is its value as text (:func:`group_label`); a unit whose grouping cell is
empty falls in :data:`BLANK_GROUP`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BLANK_GROUP", "group_label"]

#: The group of units whose grouping cell is empty.
BLANK_GROUP = "(blank)"


def group_label(value: object) -> str:
    """The label of a group as the scores print it: bins as ``45``, text as it is."""
    if isinstance(value, (float, np.floating)):
        return f"{float(value):g}"
    return str(value)
