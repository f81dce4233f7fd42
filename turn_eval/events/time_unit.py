"""Detections in the wrong time unit: milliseconds read as seconds.

A detector that writes times in milliseconds gives ``start_s`` a thousand times too large:
no detection overlaps a reference turn, F1 is 0.0, and nothing else says why. With
``sessions.csv`` the annotated duration bounds every detection of its session, so a
detection past its session's end is refused; without it, detections far beyond every
reference turn are warned about.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_eval.events.reading import Units

__all__ = ["END_SLACK_FRACTION", "END_SLACK_S", "FAR_FACTOR", "check_time_unit"]

#: How far past its session's annotated end a detection may run before it is refused: 1 s
#: plus half the duration. A stream often runs on a little past the annotated part (such a
#: detection is warned about); a unit 1000 times too small runs far past.
END_SLACK_S = 1.0
END_SLACK_FRACTION = 0.5

#: A detection starting past this multiple of the last reference turn's end (over the whole
#: reference) is far beyond anything annotated: the mark of a unit 1000 times too small.
FAR_FACTOR = 100.0


def _line(frame: pd.DataFrame, i: int) -> int:
    lines = frame.attrs.get("lines")
    return int(lines[i]) if lines is not None and len(lines) == frame.shape[0] else i + 2


def _unit_hint(end_s: float, duration_s: float) -> str:
    ratio = end_s / duration_s if duration_s > 0 else np.inf
    if ratio > 100:
        return "times in milliseconds? divide start_s and end_s by 1000"
    return "the wrong session, or times counted from another origin?"


def check_time_unit(
    det: pd.DataFrame,
    det_unit: np.ndarray,
    ref: pd.DataFrame,
    units: Units,
    sessions: pd.DataFrame | None,
    *,
    warn: Callable[[str], None] | None = None,
) -> None:
    """Refuse detections far past their session's end, and warn about those a little past
    it (with ``sessions``); else warn about detections far past every reference turn.

    Parameters
    ----------
    det, det_unit
        The detections (after unknown units are dropped) and each row's unit number.
    ref
        The reference turns.
    units
        The annotated (session, subject) units.
    sessions
        ``sessions.csv`` (``session, subject, duration_s``), or None.
    warn
        Called with the one-line warning (without ``sessions``).

    Raises
    ------
    TurnbenchError
        With ``sessions``: a detection ending more than :data:`END_SLACK_S` plus
        :data:`END_SLACK_FRACTION` of the duration past its session's annotated duration (the first one, the count, and the likely unit).
    """
    if det.shape[0] == 0:
        return
    end = det["end_s"].to_numpy(dtype=np.float64)
    if sessions is not None:
        duration = np.full(len(units), np.nan)
        codes = units.codes(sessions)
        known = codes >= 0
        duration[codes[known]] = sessions["duration_s"].to_numpy(dtype=np.float64)[known]
        session_end = duration[det_unit]
        limit = session_end * (1.0 + END_SLACK_FRACTION) + END_SLACK_S
        past = np.flatnonzero(end > limit)  # NaN (no duration) compares False: said elsewhere
        over = np.flatnonzero((end > session_end) & ~(end > limit))
        if over.size and warn is not None and not past.size:
            i = int(over[0])
            warn(
                f"{over.size} of {det.shape[0]} detections end past their session's annotated "
                f"duration (first: line {_line(det, i)}, {end[i]:g} s in session "
                f"{units.sessions[int(det_unit[i])]!r} of {session_end[i]:g} s in sessions.csv)"
            )
        if past.size:
            i = int(past[0])
            u = int(det_unit[i])
            more = f"; {past.size} of {det.shape[0]} detections are past their session's end"
            raise TurnbenchError(
                f"a detection ends at {end[i]:g} s, past the end of session "
                f"{units.sessions[u]!r} ({duration[u]:g} s in sessions.csv){more}",
                file=str(det.attrs.get("path", "detections")),
                row=_line(det, i),
                hint=_unit_hint(end[i], duration[u]),
            )
        return
    if warn is None or ref.shape[0] == 0:
        return
    last_ref = float(np.nanmax(ref["end_s"].to_numpy(dtype=np.float64)))
    far = np.flatnonzero(det["start_s"].to_numpy(dtype=np.float64) > FAR_FACTOR * last_ref)
    if far.size:
        i = int(far[0])
        warn(
            f"{far.size} of {det.shape[0]} detections start past {FAR_FACTOR:g} x the last "
            f"reference turn's end ({last_ref:g} s; first: line {_line(det, i)}, "
            f"start_s {det['start_s'].iloc[i]:g}): {_unit_hint(end[i], last_ref)} "
            "(--sessions checks each against its session's duration)"
        )
