"""The detections contract (DESIGN.md, "Detections"): written by ``turn-eval detect``, read by
``turn-eval score-events``. Declared once here; readers and writers take the columns from it.

One row per detected turn: ``session, subject, start_s, end_s, angle_deg`` and, optionally,
``direction`` (``left``/``right``), ``speed_deg_s`` and ``score`` (a confidence, higher =
surer). Detections of one (session, subject) do not overlap.
"""

from __future__ import annotations

from types import MappingProxyType

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
        "score": "float64",
    }
)
#: The full contract, as ``turn-eval detect`` writes it.
DETECTION_DTYPES = MappingProxyType({**DETECTION_REQUIRED, **DETECTION_OPTIONAL})
