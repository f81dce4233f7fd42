"""Turns in long skeleton streams: the miner's rule with the preprocessing estimator output
needs, a detector protocol any algorithm can implement, and the mapping over many files
(serial or Dask). ``turn-eval detect`` is the command; see :mod:`turn_eval.detect.rule`."""

from __future__ import annotations

from turn_eval.detect.mapping import DetectRun, FileResult, detect_file, detect_files
from turn_eval.detect.protocol import TURN_DTYPES, TurnDetector, checked_turns, empty_turns
from turn_eval.detect.rule import DetectParams, MinerRule
from turn_eval.detect.streams import Stream, read_streams, stream_files, stream_names

__all__ = [
    "TURN_DTYPES",
    "DetectParams",
    "DetectRun",
    "FileResult",
    "MinerRule",
    "Stream",
    "TurnDetector",
    "checked_turns",
    "detect_file",
    "detect_files",
    "empty_turns",
    "read_streams",
    "stream_files",
    "stream_names",
]
