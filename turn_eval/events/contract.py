"""The detections contract (DESIGN.md, "Detections"): written by ``turn-eval detect``, read by
``turn-eval score-events``. Declared once here; readers and writers take the columns from it.

One row per detected turn: ``session, subject, start_s, end_s, angle_deg`` and, optionally,
``direction`` (``left``/``right``), ``speed_deg_s``, ``peak_speed_deg_s`` (the largest heading
rate during the turn), ``steps`` (foot contacts during the turn), ``turn_type`` (``pivot`` or
``step``, REMAP's raters' classes) and ``score`` (a confidence, higher = surer). Detections of one
(session, subject) do not overlap.
"""

from __future__ import annotations

from types import MappingProxyType

from turn_datasets import limits
from turn_datasets.remap import context as remap_context
from turn_datasets.remap import open_sheet

#: Columns every detections file has, in this order, with these dtypes.
DETECTION_REQUIRED = MappingProxyType(
    {
        "session": "str",
        "subject": "str",
        "start_s": "float64",
        "end_s": "float64",
        "angle_deg": "float64",
    }
)
#: Columns a detections file may have; a writer that has them puts them after the required ones.
DETECTION_OPTIONAL = MappingProxyType(
    {
        "direction": "str",
        "speed_deg_s": "float64",
        "peak_speed_deg_s": "float64",
        "steps": "float64",
        "turn_type": "str",
        "score": "float64",
    }
)
#: The full contract, as ``turn-eval detect`` writes it.
DETECTION_DTYPES = MappingProxyType({**DETECTION_REQUIRED, **DETECTION_OPTIONAL})

#: The reference columns scoring needs (a ``remap labels`` CSV). A Turn-H3.6M clip index has
#: no ``session``: its sequence within a subject, ``action`` and ``subaction``, is the session
#: (:data:`CLIP_INDEX_SESSION`).
REFERENCE_REQUIRED = ("session", "subject", "start_s", "end_s", "angle_deg")
#: The columns of a clip index that name a session: ``"{action} {subaction}"`` (or the action
#: alone when the subaction is empty), the miner's own name of a sequence within a subject.
CLIP_INDEX_SESSION = ("action", "subaction")

#: ``context.csv`` and ``sessions.csv`` beside the labels: declared where ``remap labels``
#: writes them (:mod:`turn_datasets.remap.context`). In ``context.csv``, ``subject`` may be
#: empty (or absent) for context shared by every participant of the session.
CONTEXT_COLUMNS = remap_context.CONTEXT_COLUMNS
#: The context columns a false detection takes from the context at its midpoint.
CONTEXT_GROUPS = ("scenario", "location")

SESSIONS_COLUMNS = remap_context.SESSIONS_COLUMNS
SESSIONS_OPTIONAL = remap_context.SESSIONS_OPTIONAL

#: The plausible bounds of an angle and a speed are the harness's (one place for all readers).
MAX_ANGLE_DEG = limits.MAX_ANGLE_DEG
MAX_SPEED_DEG_S = limits.MAX_SPEED_DEG_S
#: The most foot contacts one turn of at most 10 s can plausibly hold (a step every 0.25 s:
#: faster than the fastest cadence reported in gait, about 3.5 steps/s).
MAX_STEPS = 40.0
#: The two directions (DESIGN.md: ``left`` = counter-clockwise seen from above).
DIRECTIONS = ("left", "right")
#: The two turn types REMAP's raters use, in turnbench's words: a pivot turn (one or both feet
#: swivel in place) and a step turn (three steps or more without pivoting); declared where the
#: release's spreadsheet is read (:data:`turn_datasets.remap.open_sheet.TURN_TYPES`).
TURN_TYPES = tuple(v for v in open_sheet.TURN_TYPES.values() if v)
