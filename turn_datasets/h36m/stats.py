"""The statistics of a clip index: the paper's Table 3 (clips per 45° bin), and per subject and action.

Minimum, maximum and mean angle in degrees and mean duration in seconds, printed with one and
two decimals, rounded as every table of turnbench (:mod:`turn_datasets.render.numbers`).
When the index has ``hip_rotation_deg`` (older indexes lack it), Table 3 is also given over
that column, binned by it (the paper's own quantity: the hip's net rotation between the
boundaries), with the distribution of ``hip_rotation_deg - angle_deg``: what the step's
pelvic rotation adds to the heading change.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame
from turn_datasets.geometry import quantise_deg
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
    "STATS_OPTIONAL_COLUMNS",
    "hip_minus_angle",
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
#: Read when present: the paper's hip rotation, beside the heading change.
STATS_OPTIONAL_COLUMNS = ("hip_rotation_deg",)
_HIP = "hip_rotation_deg"


def clip_stats(index: pd.DataFrame, by: str, angle: str = "angle_deg") -> pd.DataFrame:
    """Clips, min, max and mean of the ``angle`` column and mean duration per value of ``by``.

    Groups are sorted (bins numerically, subjects S2 before S11, others by name); the index
    of the result is the group value as text. ``by="bin_deg"`` with another ``angle`` bins
    that column (nearest multiple of 45, :func:`turn_datasets.geometry.quantise_deg`).
    """
    if index.empty:
        return typed_frame(pd.DataFrame({c: [] for c in STATS_COLUMNS}), STATS_COLUMNS)
    if by == "bin_deg":
        bins = index[by] if angle == "angle_deg" else quantise_deg(index[angle].to_numpy())
        keys = pd.Series(np.asarray(bins).astype(int), index=index.index)
    else:
        keys = index[by].astype(str)
    grouped = index.groupby(keys, sort=False)
    frame = pd.DataFrame(
        {
            "clips": grouped.size(),
            "min_deg": grouped[angle].min(),
            "max_deg": grouped[angle].max(),
            "mean_deg": grouped[angle].mean(),
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


def table3(index: pd.DataFrame, angle: str = "angle_deg") -> pd.DataFrame:
    """The paper's Table 3: per 45° bin, clips, min/max/mean angle and mean duration, + Total.

    ``angle`` is the column binned and summarised (``hip_rotation_deg`` for the paper's own
    quantity).
    """
    per_bin = clip_stats(index, "bin_deg", angle)
    total = pd.DataFrame(
        {
            "clips": [len(index)],
            "min_deg": [index[angle].min() if len(index) else np.nan],
            "max_deg": [index[angle].max() if len(index) else np.nan],
            "mean_deg": [index[angle].mean() if len(index) else np.nan],
            "mean_duration_s": [index["duration_s"].mean() if len(index) else np.nan],
        },
        index=pd.Index(["Total"], name="bin_deg"),
    )
    out = pd.concat(
        [per_bin, typed_frame(total.reset_index(drop=True), STATS_COLUMNS).set_axis(total.index)]
    )
    out.index.name = "bin_deg"
    return out


def hip_minus_angle(index: pd.DataFrame) -> dict[str, float]:
    """Median and quartiles of ``hip_rotation_deg - angle_deg`` over the clips (degrees)."""
    diff = (index[_HIP] - index["angle_deg"]).to_numpy(dtype=float)
    if not diff.size:
        return {"median_deg": np.nan, "q25_deg": np.nan, "q75_deg": np.nan}
    q25, median, q75 = np.percentile(diff, [25, 50, 75])
    return {"median_deg": float(median), "q25_deg": float(q25), "q75_deg": float(q75)}


def _tables(index: pd.DataFrame) -> list[tuple[str, str, pd.DataFrame]]:
    """``(key, Markdown title, table)`` of every table the statistics print, in order."""
    out = [
        ("table3", "## Table 3: clips per angle bin", table3(index)),
        ("subject", "## Clips per subject", clip_stats(index, "subject")),
        ("action", "## Clips per action", clip_stats(index, "action")),
    ]
    if _HIP in index.columns:
        title = "## Table 3 by the hip rotation (hip_rotation_deg, binned by it)"
        out.append(("table3_hip_rotation", title, table3(index, _HIP)))
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
    """Table 3, then the same figures per subject and per action, as Markdown; with the hip
    rotation, Table 3 over it and its difference to the angle."""
    lines: list[str] = []
    for key, title, frame in _tables(index):
        first = {"subject": "Subject", "action": "Action"}.get(key, "Bin (°)")
        lines += ([""] if lines else []) + [title, ""] + _md_table(first, frame)
    if _HIP in index.columns:
        d = hip_minus_angle(index)
        lines += [
            "",
            f"hip_rotation_deg - angle_deg over {len(index)} clips: median "
            f"{_fmt(d['median_deg'], 1)}°, interquartile {_fmt(d['q25_deg'], 1)}° to "
            f"{_fmt(d['q75_deg'], 1)}° (the step's pelvic rotation in the hip's angle; "
            "submissions are scored against angle_deg).",
        ]
    return "\n".join(lines) + "\n"


_CSV_NAMES = {"table3": "bin", "table3_hip_rotation": "hip_rotation_bin"}


def _long(index: pd.DataFrame) -> pd.DataFrame:
    parts = []
    for key, _, frame in _tables(index):
        part = frame.reset_index(names="group")
        part.insert(0, "table", _CSV_NAMES.get(key, key))
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def stats_csv(index: pd.DataFrame) -> str:
    """The tables as one CSV: ``table`` (bin, subject, action, and hip_rotation_bin when the
    index has the hip rotation), ``group``, the figures."""
    return _long(index).to_csv(index=False, lineterminator="\n")


def stats_dict(index: pd.DataFrame) -> dict[str, Any]:
    """The tables as JSON-ready dicts (NaN becomes null when written); with the hip rotation,
    also ``table3_hip_rotation`` and ``hip_minus_angle`` (median and quartiles)."""
    out: dict[str, Any] = {}
    for name, _, frame in _tables(index):
        out[name] = {
            str(g): {k: (int(v) if k == "clips" else float(v)) for k, v in row.items()}
            for g, row in frame.iterrows()
        }
    if _HIP in index.columns:
        out["hip_minus_angle"] = hip_minus_angle(index)
    return out
