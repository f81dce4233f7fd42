"""The CSV table every scorer writes: one row per group of every grouping.

A scores document (``score``'s or ``score-events``') has an ``overall`` entry and, per
grouping, its groups and their ``avg``; its CSV is the overall row (grouping ``overall``,
group ``all``), then each grouping's groups and its ``avg`` row, each row the entry's values
and the bounds of its 95% intervals (``<metric>_ci_low``, ``<metric>_ci_high``), empty where
undefined (:func:`grouped_frame`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame

__all__ = ["csv_row", "grouped_frame"]


def csv_row(
    grouping: str,
    group: str,
    values: Mapping[str, Any],
    ci: Mapping[str, Sequence[float] | None] | None,
    ci_metrics: Sequence[str],
) -> dict[str, Any]:
    """One row: ``grouping``, ``group``, the values (None as NaN), then the low and high
    bound of each of ``ci_metrics``' intervals in ``ci`` (NaN where there is none)."""
    row: dict[str, Any] = {"grouping": grouping, "group": group}
    row.update({key: np.nan if value is None else value for key, value in values.items()})
    ci = ci or {}
    for m in ci_metrics:
        bounds = ci.get(m)
        row[f"{m}_ci_low"] = np.nan if bounds is None else bounds[0]
        row[f"{m}_ci_high"] = np.nan if bounds is None else bounds[1]
    return row


def grouped_frame(
    doc: Mapping[str, Any],
    row: Callable[[str, str, Mapping[str, Any]], dict[str, Any]],
    columns: Mapping[str, str],
) -> pd.DataFrame:
    """The overall row, then every group of every grouping and its ``avg``, each made by
    ``row(grouping, group, entry)``, as a frame of exactly ``columns`` (names and dtypes)."""
    rows = [row("overall", "all", doc["overall"])]
    for col, block in doc.get("by", {}).items():
        for label, entry in block["groups"].items():
            rows.append(row(col, label, entry))
        rows.append(row(col, "avg", block["avg"]))
    return typed_frame(pd.DataFrame(rows), columns)
