"""Reading a Turn-H3.6M clip index back (``turn-datasets h36m mine``'s CSV), checked row by row.

The index's columns are DESIGN.md's contract (:data:`turn_datasets.h36m.miner.CLIP_INDEX_DTYPES`).
A command reads the columns it needs and nothing else, so an index with extra columns, or
from another corpus, is read as long as those columns are right. Every problem names the
file and its CSV line (1 = the header).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.geometry import quantise_deg
from turn_datasets.limits import MAX_ANGLE_DEG
from turn_datasets.mocap.h36m import parse_h36m_action

__all__ = ["read_clip_index"]

#: Checked as a column, all rows at once: finite numbers, then each rule in order.
_NUMERIC = ("angle_deg", "duration_s", "bin_deg", "hip_rotation_deg")


def _read(p: Path, columns: Sequence[str]) -> pd.DataFrame:
    if not p.is_file():
        raise TurnbenchError("no such file", file=p)
    try:
        frame = pd.read_csv(p, dtype=str, keep_default_na=False, encoding="utf-8")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the clip index: {exc}", file=p) from None
    require_columns(frame.columns, columns, what="the clip index", file=p)
    return frame


def _check_rows(frame: pd.DataFrame, p: Path, *, h36m_actions: bool) -> pd.DataFrame:
    """clip_id unique and not empty, canonical actions, whole frames in order, fps > 0."""
    has = set(frame.columns)
    seen: dict[str, int] = {}
    for i, rec in enumerate(frame.to_dict("records")):
        line = i + 2
        if "clip_id" in has:
            clip_id = rec["clip_id"].strip()
            if not clip_id:
                raise TurnbenchError("empty clip_id", file=p, row=line)
            if clip_id in seen:
                raise TurnbenchError(
                    f"clip_id {clip_id!r} repeats row {seen[clip_id]}", file=p, row=line
                )
            seen[clip_id] = line
        if h36m_actions:
            try:
                parse_h36m_action(rec["action"])
            except TurnbenchError as exc:
                raise TurnbenchError(exc.message, file=p, row=line) from None
        if {"start_frame", "end_frame"} <= has:
            try:
                start, end = int(rec["start_frame"]), int(rec["end_frame"])
            except ValueError:
                raise TurnbenchError(
                    f"start_frame {rec['start_frame']!r} / end_frame {rec['end_frame']!r} are "
                    "not whole numbers",
                    file=p,
                    row=line,
                ) from None
            if not 0 <= start < end:
                raise TurnbenchError(
                    f"frames must satisfy 0 <= start_frame < end_frame, got {start} and {end}",
                    file=p,
                    row=line,
                )
        if "fps" in has:
            try:
                fps = float(rec["fps"])
            except ValueError:
                fps = float("nan")
            if not fps > 0:
                raise TurnbenchError(f"fps must be positive, got {rec['fps']!r}", file=p, row=line)
    out = frame.copy()
    if "clip_id" in has:
        out["clip_id"] = out["clip_id"].str.strip()
    if h36m_actions:
        out["action"] = [parse_h36m_action(a)[0] for a in out["action"]]
    for col in ("subject", "subaction"):
        if h36m_actions and col in has:
            out[col] = out[col].str.strip()
    for col, dtype in (("start_frame", "int64"), ("end_frame", "int64"), ("fps", "float64")):
        if col in has:
            out[col] = out[col].astype(float).astype(dtype) if len(out) else out[col].astype(dtype)
    return out


def _check_angles(frame: pd.DataFrame, p: Path) -> pd.DataFrame:
    """Finite angles, durations and bins; angles >= 0, durations > 0, bins as quantised."""
    cols = [c for c in _NUMERIC if c in frame.columns]
    for col in cols:
        values = pd.to_numeric(frame[col], errors="coerce")
        bad = ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise TurnbenchError(
                f"{col} {frame[col].iloc[i]!r} is not a finite number", file=p, row=i + 2
            )
        frame[col] = values.astype(float)
    checks = []
    if "angle_deg" in cols:
        checks.append(
            (frame["angle_deg"] < 0, "angle_deg {} is negative (it is a magnitude)", "angle_deg")
        )
        checks.append(
            (
                frame["angle_deg"] > MAX_ANGLE_DEG,
                f"angle_deg {{}} is beyond the plausible {MAX_ANGLE_DEG:g} (see the README)",
                "angle_deg",
            )
        )
    if "duration_s" in cols:
        checks.append((frame["duration_s"] <= 0, "duration_s {} is not positive", "duration_s"))
    if "hip_rotation_deg" in cols:
        checks.append(
            (
                frame["hip_rotation_deg"] < 0,
                "hip_rotation_deg {} is negative (it is a magnitude)",
                "hip_rotation_deg",
            )
        )
    if {"angle_deg", "bin_deg"} <= set(cols):
        # a bin that is not the angle's nearest multiple of 45 (an angle edited by hand, a
        # column shifted) would put a clip in the wrong row of Table 3 unnoticed
        checks.append(
            (
                frame["bin_deg"] != quantise_deg(frame["angle_deg"].to_numpy()),
                "bin_deg {} is not the nearest multiple of 45 to angle_deg",
                "bin_deg",
            )
        )
    for bad, message, col in checks:
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise TurnbenchError(message.format(f"{frame[col].iloc[i]:g}"), file=p, row=i + 2)
    return frame


def read_clip_index(
    path: str | os.PathLike[str],
    columns: Sequence[str],
    *,
    h36m_actions: bool = False,
    optional: Sequence[str] = (),
) -> pd.DataFrame:
    """The ``columns`` of a clip index CSV, checked, plus ``row`` (its CSV line number).

    Parameters
    ----------
    path
        The index (``turn-datasets h36m mine``'s ``--out``).
    columns
        The columns the caller needs, in the order returned. Of these, ``clip_id`` must be
        non-empty and unique; ``start_frame``/``end_frame`` whole numbers with
        ``0 <= start_frame < end_frame`` (int64); ``fps`` positive (float64);
        ``angle_deg``, ``duration_s`` and ``bin_deg`` finite (float64), the angle not
        negative (a magnitude) nor beyond :data:`turn_datasets.limits.MAX_ANGLE_DEG`, the duration positive and the bin
        :func:`turn_datasets.geometry.quantise_deg` of the angle. Other columns are text
        (an empty cell is ``""``).
    optional
        Columns read (after ``columns``) and checked the same way when the file has them,
        such as ``hip_rotation_deg`` (finite, not negative), which indexes mined before
        issue 11 lack.
    h36m_actions
        ``action`` must be a Human3.6M action (any spelling of
        :func:`turn_datasets.mocap.h36m.parse_h36m_action`) and is returned canonical;
        ``subject`` and ``subaction`` are returned stripped of spaces.

    Raises
    ------
    TurnbenchError
        A missing or unreadable file, a missing column, or the first bad row, naming its
        line.
    """
    p = Path(path)
    frame = _read(p, columns)
    frame = frame.loc[:, list(columns) + [c for c in optional if c in frame.columns]]
    frame = _check_rows(frame, p, h36m_actions=h36m_actions)
    frame = _check_angles(frame, p)
    frame["row"] = np.arange(2, len(frame) + 2, dtype=np.int64)
    return frame.reset_index(drop=True)
