"""``context.csv`` and ``sessions.csv``: what untrimmed scoring needs beside the labels.

A labels row carries the scenario and location of its turn, but a false detection has no
labels row: ``turn-eval score-events`` groups it by the context in force at its midpoint,
read from ``context.csv``. Turns per hour need how long each participant was annotated:
``sessions.csv``. Both are written by ``turn-datasets remap labels`` beside the labels
(DESIGN.md, "Labels").

``context.csv`` (:data:`CONTEXT_COLUMNS`)
    Per session and participant, the time line cut where any context annotation starts or
    ends, each piece with the scenario and location that the labels would give a turn there
    (:func:`turn_datasets.remap.eaf` rule: the participant's own context tiers before the
    shared ones; among annotations covering the piece, the earlier). Pieces without either
    are left out; neighbouring pieces with the same values are merged. The contract's
    ``subject`` column is filled (the pieces are per participant); a reader also takes a file
    without it as shared by every participant of the session.
``sessions.csv`` (:data:`SESSIONS_COLUMNS`)
    Per session and participant with turn annotations, the annotated duration in seconds:
    from the first start to the last end of the context annotations that apply to the
    participant, or, without any, from 0 to the file's last time slot; and, when any file
    records it (its header's ``start_time`` property:
    :data:`turn_datasets.remap.eaf.START_TIME_PROPERTY`), ``start_time`` (empty for files
    that do not).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from turn_datasets.fileio import typed_frame

if TYPE_CHECKING:  # the ELAN reader (pympi) is not needed to read the contracts
    from turn_datasets.remap.eaf import FileContext

__all__ = [
    "CONTEXT_COLUMNS",
    "SESSIONS_COLUMNS",
    "SESSIONS_OPTIONAL",
    "context_table",
    "sessions_table",
]

#: ``context.csv``: the context tiers' intervals, per session and participant.
CONTEXT_COLUMNS: Mapping[str, str] = MappingProxyType(
    {
        "session": "str",
        "subject": "str",
        "start_s": "float64",
        "end_s": "float64",
        "scenario": "str",
        "location": "str",
    }
)
#: ``sessions.csv``: how long each participant's session was annotated.
SESSIONS_COLUMNS: Mapping[str, str] = MappingProxyType(
    {"session": "str", "subject": "str", "duration_s": "float64"}
)
#: ``sessions.csv``'s optional column: when the session started, ISO 8601 with its UTC offset
#: (``2024-03-05T09:30:00+00:00``), written where the source knows it; hour-of-day profiles
#: (``turn-eval profile``) read the local time from it.
SESSIONS_OPTIONAL: Mapping[str, str] = MappingProxyType({"start_time": "str"})
_ROLES = ("scenario", "location")


def _applicable(file: FileContext, participant: str, role: str):
    """The participant's own annotations of a role, then the shared ones (each in time order)."""
    pool = file.contexts[role]
    return [c for c in pool if c.participant == participant] + [
        c for c in pool if not c.participant
    ]


def _pieces(file: FileContext, participant: str) -> list[dict[str, Any]]:
    """The participant's context time line, cut at every boundary, merged where equal."""
    per_role = {role: _applicable(file, participant, role) for role in _ROLES}
    bounds = np.unique(
        [t for pool in per_role.values() for c in pool for t in (c.start_ms, c.end_ms)]
    )
    if bounds.size < 2:
        return []
    values: dict[str, np.ndarray] = {}
    for role, pool in per_role.items():
        value = np.full(bounds.size - 1, "", dtype=object)
        taken = np.zeros(bounds.size - 1, dtype=bool)
        # Own annotations first, then shared; within each, time order: the first to cover
        # a piece gives its value (every annotation covering a piece overlaps it wholly, so
        # this is the labels' "overlapping most, the earlier on a tie").
        for c in pool:
            lo, hi = np.searchsorted(bounds, [c.start_ms, c.end_ms])
            free = ~taken[lo:hi]
            value[lo:hi][free] = c.value
            taken[lo:hi] = True
        values[role] = value
    rows: list[dict[str, Any]] = []
    for k in range(bounds.size - 1):
        scenario, location = values["scenario"][k], values["location"][k]
        if not scenario and not location:
            continue
        last = rows[-1] if rows else None
        if (
            last is not None
            and last["end_ms"] == bounds[k]
            and (last["scenario"], last["location"]) == (scenario, location)
        ):
            last["end_ms"] = int(bounds[k + 1])
            continue
        rows.append(
            {
                "start_ms": int(bounds[k]),
                "end_ms": int(bounds[k + 1]),
                "scenario": scenario,
                "location": location,
            }
        )
    return rows


def context_table(files: Iterable[FileContext]) -> pd.DataFrame:
    """``context.csv`` from the files' contexts (module docstring), by session, subject, time."""
    rows = []
    for file in files:
        for participant in file.participants:
            for piece in _pieces(file, participant):
                rows.append(
                    {
                        "session": file.session,
                        "subject": participant,
                        "start_s": piece["start_ms"] / 1000,
                        "end_s": piece["end_ms"] / 1000,
                        "scenario": piece["scenario"],
                        "location": piece["location"],
                    }
                )
    frame = pd.DataFrame(rows, columns=list(CONTEXT_COLUMNS))
    frame = frame.sort_values(["session", "subject", "start_s"], kind="mergesort")
    return typed_frame(frame, CONTEXT_COLUMNS)


def sessions_table(files: Iterable[FileContext]) -> pd.DataFrame:
    """``sessions.csv`` from the files' contexts (module docstring), by session and subject."""
    rows = []
    for file in files:
        for participant in file.participants:
            pool = [c for role in _ROLES for c in _applicable(file, participant, role)]
            if pool:
                duration_ms = max(c.end_ms for c in pool) - min(c.start_ms for c in pool)
            else:
                duration_ms = file.last_time_ms
            rows.append(
                {
                    "session": file.session,
                    "subject": participant,
                    "duration_s": duration_ms / 1000,
                    "start_time": file.start_time,
                }
            )
    columns = dict(SESSIONS_COLUMNS)
    if any(row["start_time"] for row in rows):
        columns.update(SESSIONS_OPTIONAL)
    frame = pd.DataFrame(rows, columns=[*SESSIONS_COLUMNS, *SESSIONS_OPTIONAL])
    frame = frame.sort_values(["session", "subject"], kind="mergesort")
    return typed_frame(frame, columns)
