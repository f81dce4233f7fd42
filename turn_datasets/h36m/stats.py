"""The statistics of a clip index: the paper's Table 3 (clips per 45° bin), and per subject and action.

Minimum, maximum and mean angle in degrees and mean duration in seconds, printed with one and
two decimals, rounded as every table of turnbench (:mod:`turn_datasets.render.numbers`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_datasets.render.markdown import markdown_table
from turn_datasets.render.numbers import MISSING, fixed
from turn_datasets.render.order import natural_key

__all__ = [
    "STATS_COLUMNS",
    "clip_stats",
    "table3",
    "stats_markdown",
    "stats_csv",
    "stats_dict",
    "STATS_INDEX_COLUMNS",
]


#: The figures of each row of the statistics, with their dtypes.
STATS_COLUMNS = {
    "clips": "int64",
    "min_deg": "float64",
    "max_deg": "float64",
    "mean_deg": "float64",
    "mean_duration_s": "float64",
}


#: The columns of a clip index the statistics read
#: (:func:`turn_datasets.h36m.clip_index.read_clip_index`).
STATS_INDEX_COLUMNS = ("subject", "action", "angle_deg", "duration_s", "bin_deg")


def clip_stats(index: pd.DataFrame, by: str) -> pd.DataFrame:
    """Clips, min, max and mean angle and mean duration per value of column ``by``.

    Groups are sorted (bins numerically, subjects S2 before S11, others by name); the index
    of the result is the group value as text.
    """
    if index.empty:
        return typed_frame(pd.DataFrame({c: [] for c in STATS_COLUMNS}), STATS_COLUMNS)
    keys = index[by].astype(int) if by == "bin_deg" else index[by].astype(str)
    grouped = index.groupby(keys, sort=False)
    frame = pd.DataFrame(
        {
            "clips": grouped.size(),
            "min_deg": grouped["angle_deg"].min(),
            "max_deg": grouped["angle_deg"].max(),
            "mean_deg": grouped["angle_deg"].mean(),
            "mean_duration_s": grouped["duration_s"].mean(),
        }
    )
    order = sorted(
        frame.index, key=(lambda v: v) if by == "bin_deg" else (lambda v: natural_key(str(v)))
    )
    frame = frame.loc[order]
    names = [str(v) for v in frame.index]
    out = typed_frame(frame.reset_index(drop=True), STATS_COLUMNS)
    out.index = pd.Index(names, name=by)
    return out


def table3(index: pd.DataFrame) -> pd.DataFrame:
    """The paper's Table 3: per 45° bin, clips, min/max/mean angle and mean duration, + Total."""
    per_bin = clip_stats(index, "bin_deg")
    total = pd.DataFrame(
        {
            "clips": [len(index)],
            "min_deg": [index["angle_deg"].min() if len(index) else np.nan],
            "max_deg": [index["angle_deg"].max() if len(index) else np.nan],
            "mean_deg": [index["angle_deg"].mean() if len(index) else np.nan],
            "mean_duration_s": [index["duration_s"].mean() if len(index) else np.nan],
        },
        index=pd.Index(["Total"], name="bin_deg"),
    )
    out = pd.concat(
        [per_bin, typed_frame(total.reset_index(drop=True), STATS_COLUMNS).set_axis(total.index)]
    )
    out.index.name = "bin_deg"
    return out


def _fmt(value: float, digits: int) -> str:
    return MISSING if value is None or not np.isfinite(value) else fixed(value, digits)


def _md_table(first: str, frame: pd.DataFrame) -> list[str]:
    header = [first, "Clips", "Min (°)", "Max (°)", "Mean (°)", "Mean duration (s)"]
    rows = []
    for name, r in frame.iterrows():
        label = f"**{name}**" if name == "Total" else str(name)
        cells = [
            label,
            str(int(r["clips"])),
            _fmt(r["min_deg"], 1),
            _fmt(r["max_deg"], 1),
            _fmt(r["mean_deg"], 1),
            _fmt(r["mean_duration_s"], 2),
        ]
        rows.append(cells)
    return markdown_table(header, rows, align="lrrrrr")


def stats_markdown(index: pd.DataFrame) -> str:
    """Table 3, then the same figures per subject and per action, as Markdown."""
    lines = ["## Table 3: clips per angle bin", ""]
    lines += _md_table("Bin (°)", table3(index))
    lines += ["", "## Clips per subject", ""]
    lines += _md_table("Subject", clip_stats(index, "subject"))
    lines += ["", "## Clips per action", ""]
    lines += _md_table("Action", clip_stats(index, "action"))
    return "\n".join(lines) + "\n"


def _long(index: pd.DataFrame) -> pd.DataFrame:
    parts = []
    for name, frame in (
        ("bin", table3(index)),
        ("subject", clip_stats(index, "subject")),
        ("action", clip_stats(index, "action")),
    ):
        part = frame.reset_index(names="group")
        part.insert(0, "table", name)
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def stats_csv(index: pd.DataFrame) -> str:
    """The three tables as one CSV: ``table`` (bin, subject, action), ``group``, the figures."""
    return _long(index).to_csv(index=False, lineterminator="\n")


def stats_dict(index: pd.DataFrame) -> dict[str, Any]:
    """The three tables as JSON-ready dicts (NaN becomes null when written)."""
    out: dict[str, Any] = {}
    for name, frame in (
        ("table3", table3(index)),
        ("subject", clip_stats(index, "subject")),
        ("action", clip_stats(index, "action")),
    ):
        out[name] = {
            str(g): {k: (int(v) if k == "clips" else float(v)) for k, v in row.items()}
            for g, row in frame.iterrows()
        }
    return out
