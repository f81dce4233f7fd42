"""Groups of scored units as every scorer names, chooses and averages them.

A group's label is its value as text (:func:`group_label`); a unit whose grouping cell is
empty falls in :data:`BLANK_GROUP`. ``--by`` names the groupings, repeated or comma-separated
(``--by cohort,scenario`` is ``--by cohort --by scenario``), matched ignoring case and
surrounding spaces (:func:`split_by`, :func:`check_groupings`). A grouping's ``avg`` is the
paper's "Avg." column: the unweighted mean over its groups (:func:`average`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from turn_datasets.errors import TurnbenchError

__all__ = ["BLANK_GROUP", "group_label", "split_by", "check_groupings", "average"]

#: The group of units whose grouping cell is empty.
BLANK_GROUP = "(blank)"


def group_label(value: object) -> str:
    """The label of a group as the scores print it: bins as ``45``, text as it is."""
    if isinstance(value, (float, np.floating)):
        return f"{float(value):g}"
    return str(value)


def split_by(values: Iterable[str] | None) -> list[str]:
    """``--by`` values, each possibly comma-separated, as one list (empty parts dropped)."""
    return [part.strip() for value in values or () for part in value.split(",") if part.strip()]


def check_groupings(
    by: Iterable[str] | None,
    columns: Sequence[str],
    *,
    default: Sequence[str],
    file: str | None = None,
) -> list[str]:
    """The groupings to report: ``default`` when ``by`` names none, else each column ``by``
    names (:func:`split_by`; matched ignoring case and spaces), once, in the order named.

    Raises
    ------
    TurnbenchError
        A name that is not one of ``columns``, naming the reference ``file`` and listing the
        columns it has.
    """
    names = split_by(by)
    if not names:
        return list(default)
    out: list[str] = []
    for name in names:
        col = name.lower()
        if col not in columns:
            raise TurnbenchError(
                f"--by {name!r}: the reference has no such group column; it has "
                f"{', '.join(columns)}",
                file=file,
            )
        if col not in out:
            out.append(col)
    return out


def average(groups: Iterable[Mapping[str, Any]], keys: Sequence[str]) -> dict[str, Any]:
    """The unweighted mean over groups of each of ``keys``, of the groups where it is
    defined (not None); None where no group defines it."""
    entries = list(groups)
    out: dict[str, Any] = {}
    for key in keys:
        values = [g.get(key) for g in entries]
        defined = [v for v in values if v is not None]
        out[key] = float(np.mean(defined)) if defined else None
    return out
