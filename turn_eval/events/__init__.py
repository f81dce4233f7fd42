"""Untrimmed sessions: the detections contract, event matching and ``turn-eval score-events``.

The library face of ``score-events``: :func:`score_events` scores a detections table against
time-stamped reference turns and returns :class:`EventScores` (``.doc`` is the JSON
document); the matching is inspectable on its own (:func:`categorize_events`).
"""

from __future__ import annotations

from turn_eval.events.ap import AP_IOUS, average_precision, interpolated_ap
from turn_eval.events.contract import (
    DETECTION_DTYPES,
    DETECTION_OPTIONAL,
    DETECTION_REQUIRED,
)
from turn_eval.events.matching import categorize_events, eligible_pairs, match_pairs, temporal_iou
from turn_eval.events.reading import (
    check_detections,
    read_context,
    read_detections,
    read_event_reference,
    read_sessions,
)
from turn_eval.events.scoring import DEFAULT_BY, UNKNOWN_GROUP, EventScores, score_events
from turn_eval.events.tables import events_frame, events_markdown

__all__ = [
    "AP_IOUS",
    "DEFAULT_BY",
    "DETECTION_DTYPES",
    "DETECTION_OPTIONAL",
    "DETECTION_REQUIRED",
    "UNKNOWN_GROUP",
    "EventScores",
    "average_precision",
    "categorize_events",
    "check_detections",
    "eligible_pairs",
    "events_frame",
    "events_markdown",
    "interpolated_ap",
    "match_pairs",
    "read_context",
    "read_detections",
    "read_event_reference",
    "read_sessions",
    "score_events",
    "temporal_iou",
]
