"""Untrimmed sessions: the detections contract, event matching and ``turn-eval score-events``."""

from __future__ import annotations

from turn_eval.events.contract import (
    DETECTION_DTYPES,
    DETECTION_OPTIONAL,
    DETECTION_REQUIRED,
)

__all__ = ["DETECTION_DTYPES", "DETECTION_OPTIONAL", "DETECTION_REQUIRED"]
