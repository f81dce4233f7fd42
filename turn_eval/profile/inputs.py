"""Read and cross-check what ``turn-eval profile`` reads: detections, sessions, participants.

The detections and ``sessions.csv`` are read by the event scorer's readers
(:func:`turn_eval.events.reading.read_detections`, :func:`~turn_eval.events.reading.read_sessions`:
header names matched ignoring case, each row's own line kept). On top of their checks, a profile
needs every detection to lie in a recorded session and every participant in a group, so these
are refused, each one :class:`TurnbenchError` naming the file and line (line 1 is the header):

- a detection whose (session, subject) is not in ``sessions.csv`` (turns per hour would divide by
  a recording time nobody stated);
- a detection ending after its session's ``duration_s`` (the session was shorter than the
  detections say: the wrong sessions file, or a duration in minutes);
- a participant of ``sessions.csv`` without a group in the participants table (or with an empty
  one), and a grouping column with other than two values (a contrast compares two groups);
- a ``start_time`` that is not ISO 8601 with a UTC offset (``2024-03-05T09:30:00+01:00``, or
  ``Z`` for UTC): without its offset a time is not a local hour anywhere in particular.

An empty ``start_time`` means the start is not known: the session counts in the profile but not
in ``by_hour.csv`` nor in the across-day variation (which needs local dates). A session is taken
as recorded from its ``start_time`` (time 0 of its detections) for ``duration_s``: a sessions
table whose durations are an annotated stretch starting later (``remap labels``' from the first
context annotation) places its hours as if it started at 0.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.remap.participants import COHORTS
from turn_datasets.render.order import natural_key
from turn_eval.events.reading import Pairs, read_detections_pairs, read_sessions

__all__ = ["ProfileInputs", "read_inputs", "local_start_s", "read_groups"]

#: The default grouping: the participants table's cohort, PD against HC.
DEFAULT_BY = "cohort"


@dataclass(frozen=True)
class ProfileInputs:
    """What a profile is computed from, checked against each other.

    Attributes
    ----------
    detections
        The detections (:mod:`turn_eval.events.contract`) plus ``unit``, the row number of their
        session in ``sessions``; ``attrs`` as read (``path``, ``lines``, ``sha256``).
    sessions
        ``session, subject, duration_s`` plus ``local_start_s``: the session's start in local
        wall-clock seconds since 1970-01-01 (UTC seconds plus the start's offset), NaN where
        ``start_time`` is empty or absent; ``attrs`` as read.
    subjects
        Every participant of ``sessions``, in natural order.
    groups
        Each of ``subjects``' group (the ``by`` column's value).
    levels
        The two groups: the first is reported in the ``pd`` columns, the second in ``hc``.
    by
        The grouping column.
    """

    detections: pd.DataFrame
    sessions: pd.DataFrame
    subjects: list[str]
    groups: list[str]
    levels: tuple[str, str]
    by: str


def _line(frame: pd.DataFrame, i: int) -> int:
    lines = frame.attrs.get("lines")
    return int(lines[i]) if lines is not None and len(lines) == frame.shape[0] else i + 2


def _parse_time(text: str) -> datetime | None:
    """An ISO 8601 time with its UTC offset, or None when it is not one."""
    try:
        # "Z" is UTC; Python 3.10's parser knows only "+00:00".
        value = datetime.fromisoformat(text[:-1] + "+00:00" if text.endswith("Z") else text)
    except ValueError:
        return None
    return value if value.utcoffset() is not None else None


def local_start_s(sessions: pd.DataFrame) -> np.ndarray:
    """Each session's ``start_time`` as local wall-clock seconds since 1970-01-01.

    Local seconds are UTC epoch seconds plus the start's UTC offset, so ``// 86400`` is the
    local date and ``// 3600 % 24`` the local hour. A session keeps its start's offset
    throughout (a session that crosses a daylight-saving change is counted in its starting
    offset). NaN where ``start_time`` is empty or the column is absent.
    """
    out = np.full(sessions.shape[0], np.nan)
    if "start_time" not in sessions.columns:
        return out
    texts = sessions["start_time"].to_numpy(dtype=object)
    path = str(sessions.attrs.get("path", "sessions"))
    for i, text in enumerate(texts):
        if text == "":
            continue
        value = _parse_time(str(text))
        if value is None:
            raise TurnbenchError(
                f"start_time {text!r} is not an ISO 8601 time with its UTC offset "
                "(e.g. 2024-03-05T09:30:00+01:00)",
                file=path,
                row=_line(sessions, i),
            )
        offset = value.utcoffset()
        assert offset is not None  # _parse_time returns only times with an offset
        out[i] = value.timestamp() + offset.total_seconds()
    return out


def read_groups(path: str | os.PathLike[str], by: str = DEFAULT_BY) -> dict[str, str]:
    """Each participant's group: the participants table's ``by`` column.

    Only ``subject`` and ``by`` are needed (the full participants contract of
    :mod:`turn_datasets.remap.participants` also qualifies). ``cohort`` must be PD or HC (any
    case); any other column is read as text. An empty value or a repeated subject is an error
    naming its line.
    """
    file = os.fspath(path)
    try:
        with open(file, encoding="utf-8-sig", newline="") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as exc:
        raise TurnbenchError(f"cannot read the participants table: {exc}", file=file) from None
    if not rows:
        raise TurnbenchError("empty participants table", file=file)
    header = [h.strip().lower() for h in rows[0]]
    require_columns(header, ["subject", by], what="participants table", file=file, row=1)
    s, g = header.index("subject"), header.index(by)
    out: dict[str, str] = {}
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        subject = row[s].strip() if s < len(row) else ""
        value = row[g].strip() if g < len(row) else ""
        if not subject or not value:
            what = "subject" if not subject else by
            raise TurnbenchError(f"{what} is empty", file=file, row=line)
        if by == DEFAULT_BY:
            value = value.upper()
            if value not in COHORTS:
                raise TurnbenchError(
                    f"cohort {row[g].strip()!r} is not one of {', '.join(COHORTS)}",
                    file=file,
                    row=line,
                )
        if subject in out:
            raise TurnbenchError(f"subject {subject!r} is listed twice", file=file, row=line)
        out[subject] = value
    return out


def _levels(values: Sequence[str], by: str, file: str) -> tuple[str, str]:
    """The two groups compared: PD then HC for ``cohort``, else the two values in natural
    order."""
    found = sorted(set(values), key=natural_key)
    if by == DEFAULT_BY:
        return COHORTS[0], COHORTS[1]
    if len(found) != 2:
        raise TurnbenchError(
            f"{by} has {len(found)} distinct values among the recorded participants "
            f"({', '.join(map(repr, found[:5]))}); a contrast needs exactly two",
            file=file,
        )
    return found[0], found[1]


def _check_inside(detections: pd.DataFrame, sessions: pd.DataFrame, unit: np.ndarray) -> None:
    """Refuse detections of unrecorded sessions and detections past their session's end."""
    path = str(detections.attrs.get("path", "detections"))
    missing = np.flatnonzero(unit < 0)
    if missing.size:
        i = int(missing[0])
        more = f" ({missing.size - 1} more rows like it)" if missing.size > 1 else ""
        raise TurnbenchError(
            f"session {detections['session'].iat[i]!r}, subject "
            f"{detections['subject'].iat[i]!r} is not in the sessions table{more}",
            file=path,
            row=_line(detections, i),
        )
    duration = sessions["duration_s"].to_numpy(dtype=np.float64)[unit]
    end = detections["end_s"].to_numpy(dtype=np.float64)
    late = np.flatnonzero(end > duration)
    if late.size:
        i = int(late[0])
        more = f" ({late.size - 1} more rows like it)" if late.size > 1 else ""
        raise TurnbenchError(
            f"the detection ends at {end[i]:g} s, after its session's duration_s "
            f"{duration[i]:g} (sessions table line {_line(sessions, int(unit[i]))}){more}",
            file=path,
            row=_line(detections, i),
        )


def _units(pairs: Pairs, sessions: pd.DataFrame) -> np.ndarray:
    """Each detection's row in ``sessions``, -1 where its (session, subject) is not there.

    Only the detections' distinct pairs (the reader's factorisation) are looked up among the
    sessions, then spread to their rows."""
    keys = pd.MultiIndex.from_arrays([sessions["session"], sessions["subject"]])
    wanted = pd.MultiIndex.from_arrays([pairs.sessions, pairs.subjects])
    found = np.asarray(keys.get_indexer(wanted), dtype=np.int64)
    return found[pairs.code]


def read_inputs(
    detections: str | os.PathLike[str] | pd.DataFrame,
    sessions: str | os.PathLike[str],
    participants: str | os.PathLike[str],
    *,
    by: str = DEFAULT_BY,
) -> ProfileInputs:
    """Read the three inputs and check them against each other (module docstring)."""
    by = by.strip().lower()
    table = read_sessions(sessions)
    local = local_start_s(table)
    groups_of = read_groups(participants, by)
    if isinstance(detections, pd.DataFrame):
        det, pairs = detections, Pairs.of(detections)
    else:
        det, pairs = read_detections_pairs(detections)
    unit = _units(pairs, table)
    _check_inside(det, table, unit)
    subject_col = table["subject"].to_numpy(dtype=object)
    ungrouped = np.flatnonzero([s not in groups_of for s in subject_col])
    if ungrouped.size:
        i = int(ungrouped[0])
        raise TurnbenchError(
            f"subject {subject_col[i]!r} has no {by} in the participants table "
            f"{os.fspath(participants)}",
            file=str(table.attrs.get("path", sessions)),
            row=_line(table, i),
        )
    subjects = sorted(set(subject_col), key=natural_key)
    groups = [groups_of[s] for s in subjects]
    levels = _levels(groups, by, os.fspath(participants))
    frame = det.copy(deep=False)
    frame["unit"] = unit
    frame.attrs = dict(det.attrs)
    out_sessions = table.loc[:, ["session", "subject", "duration_s"]].copy()
    out_sessions["local_start_s"] = local
    out_sessions.attrs = dict(table.attrs)
    return ProfileInputs(
        detections=frame,
        sessions=out_sessions,
        subjects=subjects,
        groups=groups,
        levels=levels,
        by=by,
    )
