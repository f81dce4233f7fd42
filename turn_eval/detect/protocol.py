"""The detector contract: any algorithm that finds turns in one person's skeleton stream.

Modelled on mobgap's ``BaseTurnDetector.detect(data, sampling_rate_hz)``: one call per
stream, plain arrays in, a DataFrame of turns out. The built-in rule
(:class:`turn_eval.detect.rule.MinerRule`) implements it first; a learned detector or an
IMU method implements the same method and runs through ``turn-eval detect --detector``,
its manifest and ``score-events`` unchanged.

A detector receives ``positions`` ``(frames, joints, 3)`` float32 or float64 (as the file
stores them; a day at 30 fps is half the memory in float32), **z up** (DESIGN.md's
frame; the stream reader has converted the file's axes), in the file's own length unit,
NaN where the person is not seen; ``fps_hz``; and the joint ``layout``. It returns one row
per turn with the columns of :data:`TURN_DTYPES` (the detections contract without
``session`` and ``subject``, which the caller adds): ``start_s`` and ``end_s`` from the
stream's first frame, ``angle_deg`` (magnitude), ``direction`` (``left`` = counter-clockwise
from above), ``speed_deg_s`` and ``score`` (higher = surer; NaN when the detector has none).
"""

from __future__ import annotations

import functools
from typing import Protocol, runtime_checkable

import numpy as np
import pandas as pd

from turn_datasets import limits
from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import typed_frame
from turn_datasets.skeleton import Layout
from turn_eval.events.contract import DETECTION_DTYPES

__all__ = ["TURN_DTYPES", "TurnDetector", "checked_turns", "empty_turns"]

#: What :meth:`TurnDetector.detect` returns: the detections contract less session and subject.
TURN_DTYPES = {k: v for k, v in DETECTION_DTYPES.items() if k not in ("session", "subject")}


@runtime_checkable
class TurnDetector(Protocol):
    """Finds turns in one person's stream (module docstring)."""

    #: A short name, recorded in the manifest.
    name: str

    def detect(self, positions: np.ndarray, fps_hz: float, layout: Layout) -> pd.DataFrame:
        """The turns of one stream, :data:`TURN_DTYPES` columns, in time order."""
        ...


def empty_turns() -> pd.DataFrame:
    """No turns, with the contract's columns and dtypes."""
    return typed_frame(pd.DataFrame({c: [] for c in TURN_DTYPES}), TURN_DTYPES)


@functools.cache
def _contract_dtypes() -> pd.Series:
    """The dtypes :func:`typed_frame` gives the contract's columns (whatever this pandas
    makes of "str"), found once: every stream's result is checked against them."""
    return empty_turns().dtypes


def _typed(table: pd.DataFrame) -> bool:
    """Whether ``table`` has exactly the contract's columns, in order, of its dtypes."""
    if list(table.columns) != list(TURN_DTYPES):
        return False
    want = _contract_dtypes()
    return all(table[col].dtype == want[col] for col in TURN_DTYPES)


def _text(value: object) -> str:
    """A cell of a text column: missing (None, NA, NaN) is empty, anything else its str."""
    missing = value is None or value is pd.NA or (isinstance(value, float) and value != value)
    return "" if missing else str(value)


def _as_contract(table: pd.DataFrame, detector: str) -> pd.DataFrame:
    """The detector's table with exactly the contract's columns and dtypes (missing optional
    columns empty), or one :class:`TurnbenchError` saying what does not fit."""
    duplicated = sorted(set(table.columns[table.columns.duplicated()].map(str)))
    if duplicated:
        raise TurnbenchError(
            f"detector {detector!r} returned the column(s) {', '.join(duplicated)} twice"
        )
    missing = [c for c in ("start_s", "end_s", "angle_deg") if c not in table.columns]
    if missing:
        raise TurnbenchError(f"detector {detector!r} returned no {', '.join(missing)} column")
    if _typed(table):
        return table  # already the contract (the built-in rule's output): nothing to convert
    t = table.copy()
    for col in TURN_DTYPES:
        if col not in t.columns:
            t[col] = "" if TURN_DTYPES[col] == "str" else np.nan
    for col, dtype in TURN_DTYPES.items():
        if dtype == "str":
            continue
        try:
            t[col] = pd.to_numeric(t[col], errors="raise").astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise TurnbenchError(
                f"detector {detector!r} returned a {col} column that is not numbers "
                f"({' '.join(str(exc).split())[:120]})"
            ) from None
    for col, dtype in TURN_DTYPES.items():
        if dtype == "str":
            t[col] = t[col].map(_text)
    return typed_frame(t[list(TURN_DTYPES)], TURN_DTYPES)


def _check_plausible(t: pd.DataFrame, detector: str) -> None:
    """Refuse a turn no person makes, by the bounds every reader applies
    (:mod:`turn_datasets.limits`): an angle above ``MAX_ANGLE_DEG``, a speed (given, or the
    angle over the duration) negative or above ``MAX_SPEED_DEG_S``, a score that is infinite.
    An optional column may be empty (NaN); ``score-events`` reads what passes."""
    angle = t["angle_deg"].to_numpy(dtype=float)
    duration = (t["end_s"] - t["start_s"]).to_numpy(dtype=float)
    speed = t["speed_deg_s"].to_numpy(dtype=float)
    score = t["score"].to_numpy(dtype=float)
    checks = (
        (angle > limits.MAX_ANGLE_DEG, "angle_deg", angle, f"at most {limits.MAX_ANGLE_DEG:g}"),
        (
            ~np.isnan(speed) & ~((speed >= 0) & (speed <= limits.MAX_SPEED_DEG_S)),
            "speed_deg_s",
            speed,
            f"in [0, {limits.MAX_SPEED_DEG_S:g}]",
        ),
        (
            angle / duration > limits.MAX_SPEED_DEG_S,
            "angle_deg / (end_s - start_s)",
            angle / duration,
            f"at most {limits.MAX_SPEED_DEG_S:g} deg/s",
        ),
        (np.isinf(score), "score", score, "finite (or empty)"),
    )
    for bad, what, values, bound in checks:
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            more = int(bad.sum()) - 1
            raise TurnbenchError(
                f"detector {detector!r} returned an implausible turn (row {i}: {what} "
                f"{values[i]:g}, plausible: {bound}"
                + (f"; {more} more row(s) like it)" if more else ")"),
                hint="the bounds are turnbench's for every reader (README, errors section)",
            )


def checked_turns(
    table: pd.DataFrame, *, detector: str, n_frames: int, fps_hz: float
) -> pd.DataFrame:
    """A detector's result, checked against the contract and put in time order.

    Raises
    ------
    TurnbenchError
        A missing, duplicated or non-numeric column, a time outside the stream or an
        interval that ends before it starts, an angle that is not a positive finite number,
        a direction other than left/right, a value outside the plausibility bounds of
        :mod:`turn_datasets.limits`, or two turns that overlap: naming the detector.
    """
    t = _as_contract(table, detector)
    start, end, angle = (t[c].to_numpy(dtype=float) for c in ("start_s", "end_s", "angle_deg"))
    length_s = n_frames / fps_hz
    bad = ~(np.isfinite(start) & np.isfinite(end) & (start >= 0) & (end > start))
    bad |= end > length_s + 1e-6
    bad |= ~(np.isfinite(angle) & (angle > 0))
    bad |= ~t["direction"].isin(["left", "right", ""]).to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TurnbenchError(
            f"detector {detector!r} returned an impossible turn (row {i}: start {start[i]}, "
            f"end {end[i]}, angle {angle[i]}, direction {t['direction'].iloc[i]!r}; the "
            f"stream lasts {length_s:.3f} s)"
        )
    _check_plausible(t, detector)
    # in time order (by start, then end; stable): a detector's turns mostly come so already
    order = np.lexsort((end, start))
    if (order != np.arange(order.shape[0])).any():
        t, start, end = t.iloc[order], start[order], end[order]
    t = t.reset_index(drop=True)
    s, e = start, end
    if (s[1:] < e[:-1] - 1e-9).any():
        i = int(np.flatnonzero(s[1:] < e[:-1] - 1e-9)[0])
        raise TurnbenchError(
            f"detector {detector!r} returned overlapping turns ({s[i]:.3f}-{e[i]:.3f} s and "
            f"{s[i + 1]:.3f}-{e[i + 1]:.3f} s)"
        )
    return t
